#include "facespace/evaluator/store.h"

#include <cinttypes>
#include <cstdio>
#include <nlohmann/json.hpp>

namespace facespace::evaluator {

bool IsValidRigId(const std::string& id) {
  if (id.empty() || id.size() > 64) return false;
  auto lower_digit = [](char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'); };
  if (!lower_digit(id[0])) return false;
  for (char c : id) {
    if (!lower_digit(c) && c != '_' && c != '-') return false;
  }
  return true;
}

Result<Rig> LoadUpload(const std::string& id, std::span<const unsigned char> bytes,
                       formats::RigFormat format, const std::string& manifest) {
  auto rig = LoadRigMemory(bytes, format, id);
  if (!rig.ok()) return rig;
  rig->name = id;
  if (manifest.empty()) return rig;
  if (Status s = formats::ApplyManifest(rig.value(), manifest); !s.ok()) {
    for (FieldError& f : s.fields) f.pointer = "/manifest" + f.pointer;
    if (s.fields.empty()) s.fields.push_back({"/manifest", s.message});
    return WithInputReason(s, "invalid-manifest");
  }
  // A file on disk may name shapes its rig lacks (a load warning); an upload is a client's
  // request, refused at the first unknown name like any other.
  for (const Warning& w : rig->load_warnings) {
    if (w.code == "manifest_unknown_material") {
      Status s = InvalidArgument("manifest: /materials/" + JsonPointerEscape(w.shape) +
                                 ": the rig has no material '" + w.shape + "'");
      s.fields.push_back({"/manifest/materials/" + JsonPointerEscape(w.shape),
                          "unknown material '" + w.shape + "'"});
      return WithReason(s, "invalid-manifest");
    }
    if (w.code != "manifest_unknown_shape") continue;
    std::vector<std::string_view> names;
    for (const Shape& shape : rig->shapes) names.push_back(shape.name);
    const auto shapes =
        nlohmann::json::parse(manifest, nullptr, false).value("shapes", nlohmann::json::object());
    const bool in_shapes = shapes.is_object() && shapes.contains(w.shape);
    const std::string pointer =
        in_shapes ? "/manifest/shapes/" + JsonPointerEscape(w.shape) : "/manifest/groups";
    Status s = InvalidArgument("manifest: " + pointer.substr(9) + ": the rig has no shape '" +
                               w.shape + "'" + DidYouMean(w.shape, names));
    s.fields.push_back({pointer, "unknown shape '" + w.shape + "'"});
    return WithReason(s, "invalid-manifest");
  }
  return rig;
}

std::string RigVersion(std::span<const unsigned char> bytes, const std::string& manifest) {
  uint64_t h = 1469598103934665603ull;  // FNV-1a over both.
  auto mix = [&h](unsigned char c) {
    h ^= c;
    h *= 1099511628211ull;
  };
  for (unsigned char c : bytes) mix(c);
  for (char c : manifest) mix(static_cast<unsigned char>(c));
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016" PRIx64, h);
  return buf;
}

}  // namespace facespace::evaluator
