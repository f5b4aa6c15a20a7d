// What the glTF importer checks of a file's JSON before tinygltf reads it (gltf_common.h):
// tinygltf 2.x follows what the JSON says without checking all of it.
#include "gltf/gltf_common.h"

namespace facespace::formats {

using nlohmann::json;

// Refuses buffers and images that point outside the file (anything but a data: URI).
Status CheckEmbedded(const json& j) {
  for (const char* list : {"buffers", "images"}) {
    auto it = j.find(list);
    if (it == j.end() || !it->is_array()) continue;
    for (const json& e : *it) {
      if (!e.is_object() || !e.contains("uri")) continue;
      if (!e["uri"].is_string())
        return InvalidArgument(std::string(list) + ": uri must be a string");
      const std::string uri = e["uri"].get<std::string>();
      if (uri.rfind("data:", 0) != 0) {
        return InvalidArgument(
            "external file '" + uri.substr(0, 200) +
            "' refused: uploaded glTF must embed its buffers and images (.glb or data: URIs)");
      }
    }
  }
  return Status::Ok();
}

namespace {

size_t SizeMember(const json& o, const char* key) {
  auto it = o.find(key);
  return it != o.end() && it->is_number_unsigned() ? it->get<size_t>() : 0;
}

}  // namespace

Status CheckImageViews(const json& j) {
  const json none = json::array();
  const json& images = j.contains("images") && j["images"].is_array() ? j["images"] : none;
  const json& views =
      j.contains("bufferViews") && j["bufferViews"].is_array() ? j["bufferViews"] : none;
  const json& buffers = j.contains("buffers") && j["buffers"].is_array() ? j["buffers"] : none;
  for (size_t i = 0; i < images.size(); ++i) {
    if (!images[i].is_object() || !images[i].contains("bufferView")) continue;
    const json& v = images[i]["bufferView"];
    const std::string where = "images[" + std::to_string(i) + "].bufferView";
    if (!v.is_number_unsigned() || v.get<size_t>() >= views.size() ||
        !views[v.get<size_t>()].is_object())
      return InvalidArgument(where + ": no such bufferView");
    const json& view = views[v.get<size_t>()];
    const size_t buffer = SizeMember(view, "buffer"), offset = SizeMember(view, "byteOffset"),
                 length = SizeMember(view, "byteLength");
    if (buffer >= buffers.size() || !buffers[buffer].is_object())
      return InvalidArgument(where + ": its buffer does not exist");
    const size_t size = SizeMember(buffers[buffer], "byteLength");
    if (offset > size || length > size - offset) {
      return InvalidArgument(where + ": bytes " + std::to_string(offset) + " to " +
                             std::to_string(offset + length) + " run past its buffer of " +
                             std::to_string(size));
    }
  }
  return Status::Ok();
}

}  // namespace facespace::formats
