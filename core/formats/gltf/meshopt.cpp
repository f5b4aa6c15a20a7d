// EXT_meshopt_compression, decoded with meshoptimizer before tinygltf (2.7, which does not know
// the extension) sees the file.
#include <meshoptimizer.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include "facespace/formats/io.h"
#include "gltf/gltf_common.h"

namespace facespace::formats {

using nlohmann::json;

bool ListHas(const json& j, const char* key, const std::string& value) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_array()) return false;
  for (const json& e : *it) {
    if (e.is_string() && e.get<std::string>() == value) return true;
  }
  return false;
}

// Splits a GLB into its JSON text and binary chunk, checking every length.
Status SplitGlb(std::span<const unsigned char> bytes, std::string& json_text,
                std::span<const unsigned char>& bin) {
  if (bytes.size() < 20) return InvalidArgument("truncated glb: shorter than its header");
  if (ReadU32(&bytes[4]) != 2)
    return InvalidArgument("unsupported glb version " + std::to_string(ReadU32(&bytes[4])));
  const uint32_t total = ReadU32(&bytes[8]);
  if (total < 20)
    return InvalidArgument("truncated glb: header says " + std::to_string(total) +
                           " bytes, less than the header");
  if (total > bytes.size()) {
    return InvalidArgument("truncated glb: header says " + std::to_string(total) +
                           " bytes, file has " + std::to_string(bytes.size()));
  }
  const uint32_t json_len = ReadU32(&bytes[12]);
  if (ReadU32(&bytes[16]) != 0x4E4F534Au) return InvalidArgument("glb: first chunk is not JSON");
  if (json_len > total - 20) return InvalidArgument("truncated glb: JSON chunk beyond the file");
  json_text.assign(reinterpret_cast<const char*>(&bytes[20]), json_len);
  bin = {};
  size_t pos = 20 + static_cast<size_t>(json_len);
  pos = (pos + 3) & ~size_t{3};
  if (pos + 8 <= total) {
    const uint32_t bin_len = ReadU32(&bytes[pos]);
    if (ReadU32(&bytes[pos + 4]) == 0x004E4942u) {
      if (bin_len > total - pos - 8)
        return InvalidArgument("truncated glb: BIN chunk beyond the file");
      bin = bytes.subspan(pos + 8, bin_len);
    }
  }
  return Status::Ok();
}

namespace {

// ---- EXT_meshopt_compression --------------------------------------------------------------

// Decodes one compressed bufferView into `out`.
Status DecodeMeshoptView(const json& ext, std::span<const unsigned char> bin,
                         std::vector<unsigned char>& out) {
  if (!ext.is_object()) return InvalidArgument("EXT_meshopt_compression: not an object");
  const auto num = [&](const char* key, size_t def, bool required) -> long long {
    auto it = ext.find(key);
    if (it == ext.end()) return required ? -1 : static_cast<long long>(def);
    if (!it->is_number_unsigned()) return -1;
    return static_cast<long long>(it->get<uint64_t>() > (uint64_t{1} << 40) ? (uint64_t{1} << 40)
                                                                            : it->get<uint64_t>());
  };
  const long long buffer = num("buffer", 0, true), offset = num("byteOffset", 0, false),
                  length = num("byteLength", 0, true), stride = num("byteStride", 0, true),
                  count = num("count", 0, true);
  if (buffer < 0 || offset < 0 || length < 0 || stride <= 0 || count < 0) {
    return InvalidArgument(
        "EXT_meshopt_compression: missing or invalid buffer/byteLength/byteStride/count");
  }
  if (buffer != 0)
    return InvalidArgument(
        "EXT_meshopt_compression: only the GLB binary chunk is supported as source");
  if (static_cast<unsigned long long>(offset) + static_cast<unsigned long long>(length) >
      bin.size()) {
    return InvalidArgument("EXT_meshopt_compression: compressed data beyond the binary chunk");
  }
  if (static_cast<size_t>(count) > kMaxElements ||
      static_cast<size_t>(count) * stride > (size_t{1} << 31)) {
    return InvalidArgument("EXT_meshopt_compression: decoded size too large");
  }
  const std::string mode = ext.value("mode", std::string());
  const std::string filter = ext.contains("filter") && ext["filter"].is_string()
                                 ? ext["filter"].get<std::string>()
                                 : "NONE";
  out.assign(static_cast<size_t>(count) * stride, 0);
  const unsigned char* src = bin.data() + offset;
  int rc = -1;
  if (mode == "ATTRIBUTES") {
    if (stride % 4 != 0 || stride > 256)
      return InvalidArgument("EXT_meshopt_compression: bad attribute byteStride");
    rc = meshopt_decodeVertexBuffer(out.data(), count, stride, src, length);
  } else if (mode == "TRIANGLES") {
    if ((stride != 2 && stride != 4) || count % 3 != 0)
      return InvalidArgument("EXT_meshopt_compression: bad triangle index layout");
    rc = meshopt_decodeIndexBuffer(out.data(), count, stride, src, length);
  } else if (mode == "INDICES") {
    if (stride != 2 && stride != 4)
      return InvalidArgument("EXT_meshopt_compression: bad index byteStride");
    rc = meshopt_decodeIndexSequence(out.data(), count, stride, src, length);
  } else {
    return InvalidArgument("EXT_meshopt_compression: unknown mode '" + mode + "'");
  }
  if (rc != 0) return InvalidArgument("EXT_meshopt_compression: corrupt compressed data");
  if (filter == "OCTAHEDRAL") {
    if (mode != "ATTRIBUTES" || (stride != 4 && stride != 8))
      return InvalidArgument("EXT_meshopt_compression: bad OCTAHEDRAL stride");
    meshopt_decodeFilterOct(out.data(), count, stride);
  } else if (filter == "QUATERNION") {
    if (mode != "ATTRIBUTES" || stride != 8)
      return InvalidArgument("EXT_meshopt_compression: bad QUATERNION stride");
    meshopt_decodeFilterQuat(out.data(), count, stride);
  } else if (filter == "EXPONENTIAL") {
    if (mode != "ATTRIBUTES" || stride % 4 != 0)
      return InvalidArgument("EXT_meshopt_compression: bad EXPONENTIAL stride");
    meshopt_decodeFilterExp(out.data(), count, stride);
  } else if (filter != "NONE") {
    return InvalidArgument("EXT_meshopt_compression: unknown filter '" + filter + "'");
  }
  return Status::Ok();
}

void ListRemove(json& j, const char* key, const std::string& value) {
  auto it = j.find(key);
  if (it == j.end() || !it->is_array()) return;
  json kept = json::array();
  for (const json& e : *it) {
    if (!(e.is_string() && e.get<std::string>() == value)) kept.push_back(e);
  }
  if (kept.empty()) {
    j.erase(key);
  } else {
    *it = kept;
  }
}

}  // namespace

std::vector<unsigned char> MakeGlb(const std::string& json_text,
                                   std::span<const unsigned char> bin) {
  std::string j = json_text;
  while (j.size() % 4) j.push_back(' ');
  const size_t bin_padded = (bin.size() + 3) & ~size_t{3};
  const size_t total = 12 + 8 + j.size() + (bin.empty() ? 0 : 8 + bin_padded);
  std::vector<unsigned char> out;
  out.reserve(total);
  auto u32 = [&](uint32_t v) {
    unsigned char b[4];
    std::memcpy(b, &v, 4);
    out.insert(out.end(), b, b + 4);
  };
  u32(0x46546C67u);
  u32(2);
  u32(static_cast<uint32_t>(total));
  u32(static_cast<uint32_t>(j.size()));
  u32(0x4E4F534Au);
  out.insert(out.end(), j.begin(), j.end());
  if (!bin.empty()) {
    u32(static_cast<uint32_t>(bin_padded));
    u32(0x004E4942u);
    out.insert(out.end(), bin.begin(), bin.end());
    out.resize(total, 0);
  }
  return out;
}

namespace {

// A glb's JSON chunk parsed (an object) and its binary chunk.
Status ReadGlb(std::span<const unsigned char> bytes, json& j, std::span<const unsigned char>& bin) {
  std::string text;
  if (Status s = SplitGlb(bytes, text, bin); !s.ok()) return s;
  j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    return InvalidArgument("glb: JSON chunk is not valid JSON");
  return Status::Ok();
}

}  // namespace

// Rewrites a GLB that uses EXT_meshopt_compression into a plain one: decoded views are
// appended to the binary chunk and the fallback buffers are removed. Other files are
// returned unchanged (out empty).
Status DecodeMeshoptGlb(std::span<const unsigned char> bytes, std::vector<unsigned char>& out) {
  out.clear();
  json j;
  std::span<const unsigned char> bin;
  if (Status s = ReadGlb(bytes, j, bin); !s.ok()) return s;
  if (!ListHas(j, "extensionsUsed", "EXT_meshopt_compression")) return Status::Ok();
  std::vector<unsigned char> newbin(bin.begin(), bin.end());
  json& views = j["bufferViews"];
  json& buffers = j["buffers"];
  if (!views.is_array() || !buffers.is_array() || buffers.empty())
    return InvalidArgument("glb: bufferViews/buffers missing");
  for (json& view : views) {
    if (!view.is_object() || !view.contains("extensions") || !view["extensions"].is_object())
      continue;
    json& exts = view["extensions"];
    if (!exts.contains("EXT_meshopt_compression")) continue;
    std::vector<unsigned char> decoded;
    if (Status s = DecodeMeshoptView(exts["EXT_meshopt_compression"], bin, decoded); !s.ok())
      return s;
    while (newbin.size() % 4) newbin.push_back(0);
    view["buffer"] = 0;
    view["byteOffset"] = newbin.size();
    view["byteLength"] = decoded.size();
    newbin.insert(newbin.end(), decoded.begin(), decoded.end());
    exts.erase("EXT_meshopt_compression");
    if (exts.empty()) view.erase("extensions");
  }
  // Drop the fallback buffers; renumber the views' buffer references.
  std::vector<int> remap(buffers.size(), -1);
  json kept = json::array();
  for (size_t b = 0; b < buffers.size(); ++b) {
    const json& buf = buffers[b];
    const bool fallback = buf.is_object() && buf.contains("extensions") &&
                          buf["extensions"].is_object() &&
                          buf["extensions"].contains("EXT_meshopt_compression");
    if (fallback && b != 0) continue;
    remap[b] = static_cast<int>(kept.size());
    kept.push_back(buf);
  }
  for (json& view : views) {
    if (!view.is_object() || !view.contains("buffer") || !view["buffer"].is_number_unsigned())
      continue;
    const uint64_t b = view["buffer"].get<uint64_t>();
    if (b >= remap.size() || remap[b] < 0) {
      return InvalidArgument(
          "glb: a bufferView reads a meshopt fallback buffer that holds no data");
    }
    view["buffer"] = remap[b];
  }
  kept[0]["byteLength"] = newbin.size();
  if (kept[0].is_object() && kept[0].contains("extensions")) kept[0].erase("extensions");
  buffers = kept;
  ListRemove(j, "extensionsUsed", "EXT_meshopt_compression");
  ListRemove(j, "extensionsRequired", "EXT_meshopt_compression");
  out = MakeGlb(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), newbin);
  return Status::Ok();
}

namespace {

size_t Components(const std::string& type) {
  return type == "SCALAR"                   ? 1
         : type == "VEC2"                   ? 2
         : type == "VEC3"                   ? 3
         : type == "VEC4" || type == "MAT2" ? 4
         : type == "MAT3"                   ? 9
         : type == "MAT4"                   ? 16
                                            : 0;
}

// How one bufferView may be encoded: its elements' stride and count and the codec's mode, from
// the one accessor (or sparse part) that reads it whole; "" when it is not to be encoded.
struct ViewUse {
  int users = 0;
  std::string mode;  // ATTRIBUTES, TRIANGLES or INDICES.
  size_t stride = 0, count = 0;
};

// How each buffer view is used: by one accessor (or sparse part) as a whole, in which mode.
std::vector<ViewUse> ViewUses(const json& j, size_t view_count) {
  std::vector<ViewUse> use(view_count);
  auto note = [&](const json& bv, const json& offset, const std::string& mode, size_t stride,
                  size_t count) {
    if (!bv.is_number_unsigned() || bv.get<size_t>() >= use.size()) return;
    ViewUse& u = use[bv.get<size_t>()];
    ++u.users;
    const bool whole = !offset.is_number() || offset.get<double>() == 0;
    u.mode = whole ? mode : "";
    u.stride = stride;
    u.count = count;
  };
  std::vector<uint8_t> is_index(j.contains("accessors") ? j["accessors"].size() : 0, 0);
  for (const json& mesh : j.value("meshes", json::array())) {
    for (const json& prim : mesh.value("primitives", json::array())) {
      const json idx = prim.value("indices", json());
      if (idx.is_number_unsigned() && idx.get<size_t>() < is_index.size() &&
          prim.value("mode", 4) == 4)
        is_index[idx.get<size_t>()] = 1;
    }
  }
  const json& accessors = j.value("accessors", json::array());
  for (size_t a = 0; a < accessors.size(); ++a) {
    const json& acc = accessors[a];
    const size_t comp = static_cast<size_t>(ComponentSize(acc.value("componentType", 0))),
                 n = Components(acc.value("type", std::string())),
                 count = acc.value("count", size_t{0});
    if (acc.contains("bufferView")) {
      const bool triangles = is_index[a] && acc.value("type", std::string()) == "SCALAR" &&
                             (comp == 2 || comp == 4) && count % 3 == 0;
      note(acc["bufferView"], acc.value("byteOffset", json()),
           triangles ? "TRIANGLES" : "ATTRIBUTES", triangles ? comp : comp * n, count);
    }
    if (acc.contains("sparse") && acc["sparse"].is_object()) {
      const json& sp = acc["sparse"];
      const size_t scount = sp.value("count", size_t{0});
      if (sp.contains("indices")) {
        const size_t icomp =
            static_cast<size_t>(ComponentSize(sp["indices"].value("componentType", 0)));
        note(sp["indices"].value("bufferView", json()), sp["indices"].value("byteOffset", json()),
             icomp == 2 || icomp == 4 ? "INDICES" : "", icomp, scount);
      }
      if (sp.contains("values"))
        note(sp["values"].value("bufferView", json()), sp["values"].value("byteOffset", json()),
             "ATTRIBUTES", comp * n, scount);
    }
  }
  return use;
}

// A view's bytes in EXT_meshopt_compression's codec for its mode; empty when it cannot be encoded.
std::vector<unsigned char> EncodeView(const ViewUse& u, const unsigned char* data, size_t length,
                                      std::vector<unsigned int>& indices) {
  std::vector<unsigned char> encoded;
  const bool stride_ok = u.mode == "ATTRIBUTES"
                             ? u.stride % 4 == 0 && u.stride <= 256 && u.stride > 0
                             : u.stride == 2 || u.stride == 4;
  if (u.users == 1 && !u.mode.empty() && stride_ok && u.count > 0 && u.stride * u.count == length) {
    if (u.mode == "ATTRIBUTES") {
      encoded.resize(meshopt_encodeVertexBufferBound(u.count, u.stride));
      encoded.resize(
          meshopt_encodeVertexBuffer(encoded.data(), encoded.size(), data, u.count, u.stride));
    } else {
      indices.resize(u.count);
      for (size_t i = 0; i < u.count; ++i) {
        if (u.stride == 2) {
          uint16_t x;
          std::memcpy(&x, data + 2 * i, 2);
          indices[i] = x;
        } else {
          std::memcpy(&indices[i], data + 4 * i, 4);
        }
      }
      const bool tri = u.mode == "TRIANGLES";
      encoded.resize(tri ? meshopt_encodeIndexBufferBound(u.count, u.count)
                         : meshopt_encodeIndexSequenceBound(u.count, u.count));
      encoded.resize(
          tri ? meshopt_encodeIndexBuffer(encoded.data(), encoded.size(), indices.data(), u.count)
              : meshopt_encodeIndexSequence(encoded.data(), encoded.size(), indices.data(),
                                            u.count));
    }
  }
  return encoded;
}

}  // namespace

Result<std::vector<unsigned char>> EncodeMeshoptGlb(std::span<const unsigned char> bytes) {
  json j;
  std::span<const unsigned char> bin;
  if (Status s = ReadGlb(bytes, j, bin); !s.ok()) return s;
  if (ListHas(j, "extensionsUsed", "EXT_meshopt_compression"))
    return std::vector<unsigned char>(bytes.begin(), bytes.end());
  json& views = j["bufferViews"];
  json& buffers = j["buffers"];
  if (!views.is_array() || !buffers.is_array() || buffers.size() != 1)
    return std::vector<unsigned char>(bytes.begin(), bytes.end());
  const std::vector<ViewUse> use = ViewUses(j, views.size());
  std::vector<unsigned char> packed, fallback_size_only;
  size_t fallback = 0;
  auto align = [](std::vector<unsigned char>& v) {
    while (v.size() % 4) v.push_back(0);
  };
  meshopt_encodeVertexVersion(0);  // The versions EXT_meshopt_compression defines.
  meshopt_encodeIndexVersion(1);
  std::vector<unsigned int> indices;
  for (size_t v = 0; v < views.size(); ++v) {
    json& view = views[v];
    const size_t offset = view.value("byteOffset", size_t{0}),
                 length = view.value("byteLength", size_t{0});
    if (offset > bin.size() || length > bin.size() - offset)
      return InvalidArgument("glb: bufferView " + std::to_string(v) + " beyond the binary chunk");
    const unsigned char* data = bin.data() + offset;
    const ViewUse& u = use[v];
    const std::vector<unsigned char> encoded = view.contains("byteStride")
                                                   ? std::vector<unsigned char>()
                                                   : EncodeView(u, data, length, indices);
    align(packed);
    if (!encoded.empty() && encoded.size() < length) {
      view["extensions"]["EXT_meshopt_compression"] = {{"buffer", 0},
                                                       {"byteOffset", packed.size()},
                                                       {"byteLength", encoded.size()},
                                                       {"byteStride", u.stride},
                                                       {"count", u.count},
                                                       {"mode", u.mode}};
      packed.insert(packed.end(), encoded.begin(), encoded.end());
      fallback = (fallback + 3) & ~size_t{3};
      view["buffer"] = 1;
      view["byteOffset"] = fallback;
      fallback += length;
    } else {
      view["byteOffset"] = packed.size();
      packed.insert(packed.end(), data, data + length);
    }
  }
  if (fallback == 0)
    return std::vector<unsigned char>(bytes.begin(), bytes.end());  // Nothing smaller.
  buffers[0]["byteLength"] = packed.size();
  buffers.push_back({{"byteLength", fallback},
                     {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}});
  for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
    if (!j.contains(key)) j[key] = json::array();
    j[key].push_back("EXT_meshopt_compression");
  }
  return MakeGlb(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), packed);
}

}  // namespace facespace::formats
