// Rig files: picking the importer, and the manifest that carries what glTF drops.
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "facespace/core/io.h"

namespace facespace {

namespace {

using nlohmann::json;

bool EndsWith(const std::string& s, const std::string& t) {
  if (s.size() < t.size()) return false;
  for (size_t i = 0; i < t.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(s[s.size() - t.size() + i])) != t[i]) return false;
  }
  return true;
}

std::string JsonPointerEscape(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '~') r += "~0";
    else if (c == '/') r += "~1";
    else r += c;
  }
  return r;
}

}  // namespace

Status ApplyManifest(Rig& rig, const std::string& text) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidArgument("manifest: not valid JSON");
  if (!j.is_object()) return InvalidArgument("manifest: must be a JSON object");
  auto bad = [](const std::string& pointer, const std::string& msg) {
    Status s = InvalidArgument("manifest: " + pointer + ": " + msg);
    s.fields.push_back({pointer, msg});
    return s;
  };
  if (j.contains("name")) {
    if (!j["name"].is_string()) return bad("/name", "must be a string");
    rig.name = j["name"].get<std::string>();
  }
  if (j.contains("groups")) {
    if (!j["groups"].is_object()) return bad("/groups", "must be an object of group -> [shape names]");
    for (auto it = j["groups"].begin(); it != j["groups"].end(); ++it) {
      const std::string ptr = "/groups/" + JsonPointerEscape(it.key());
      if (!it->is_array()) return bad(ptr, "must be an array of shape names");
      for (const json& name : *it) {
        if (!name.is_string()) return bad(ptr, "must hold strings");
        const int s = FindShape(rig, name.get<std::string>());
        if (s < 0) {
          rig.load_warnings.push_back({"manifest_unknown_shape", "manifest names unknown shape '" + name.get<std::string>() + "'",
                                       name.get<std::string>(), 0.0, false});
          continue;
        }
        rig.shapes[s].group = it.key();
      }
    }
  }
  if (j.contains("shapes")) {
    if (!j["shapes"].is_object()) return bad("/shapes", "must be an object of shape name -> properties");
    for (auto it = j["shapes"].begin(); it != j["shapes"].end(); ++it) {
      const std::string ptr = "/shapes/" + JsonPointerEscape(it.key());
      if (!it->is_object()) return bad(ptr, "must be an object");
      const int s = FindShape(rig, it.key());
      if (s < 0) {
        rig.load_warnings.push_back({"manifest_unknown_shape", "manifest names unknown shape '" + it.key() + "'", it.key(), 0.0, false});
        continue;
      }
      Shape& shape = rig.shapes[s];
      const json& o = *it;
      for (const char* key : {"min", "max", "default"}) {
        if (!o.contains(key)) continue;
        if (!o[key].is_number()) return bad(ptr + "/" + key, "must be a number");
        const float v = o[key].get<float>();
        (std::string(key) == "min" ? shape.min : std::string(key) == "max" ? shape.max : shape.default_weight) = v;
      }
      if (shape.min > shape.max) return bad(ptr, "min is greater than max");
      if (o.contains("group")) {
        if (!o["group"].is_string()) return bad(ptr + "/group", "must be a string");
        shape.group = o["group"].get<std::string>();
      }
      if (o.contains("aliases")) {
        if (!o["aliases"].is_array()) return bad(ptr + "/aliases", "must be an array of strings");
        for (const json& a : o["aliases"]) {
          if (!a.is_string()) return bad(ptr + "/aliases", "must be an array of strings");
          const int other = FindShape(rig, a.get<std::string>());
          if (other >= 0 && other != s) return bad(ptr + "/aliases", "'" + a.get<std::string>() + "' already names another shape");
          shape.aliases.push_back(a.get<std::string>());
        }
      }
      if (o.contains("partner")) {
        if (o["partner"].is_null()) {
          if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
          shape.partner = -1;
          continue;
        }
        if (!o["partner"].is_string()) return bad(ptr + "/partner", "must be a shape name or null");
        const int p = FindShape(rig, o["partner"].get<std::string>());
        if (p < 0 || p == s) return bad(ptr + "/partner", "unknown partner shape '" + o["partner"].get<std::string>() + "'");
        if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
        if (rig.shapes[p].partner >= 0) rig.shapes[rig.shapes[p].partner].partner = -1;
        shape.partner = p;
        rig.shapes[p].partner = s;
      }
    }
  }
  return Status::Ok();
}

Result<Rig> LoadRigFile(const std::string& path, const LoadOptions& options) {
  Result<Rig> rig = EndsWith(path, ".obj") ? LoadObjSequence(std::span<const std::string>(&path, 1))
                                           : LoadGltfFile(path, options);
  if (!rig.ok()) return rig;
  if (rig->name.empty()) {
    const size_t slash = path.find_last_of('/');
    std::string stem = slash == std::string::npos ? path : path.substr(slash + 1);
    rig->name = stem.substr(0, stem.rfind('.'));
  }
  if (options.read_manifest) {
    const size_t dot = path.rfind('.');
    const std::string manifest = (dot == std::string::npos ? path : path.substr(0, dot)) + ".manifest.json";
    std::ifstream f(manifest, std::ios::binary);
    if (f) {
      std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
      if (Status s = ApplyManifest(rig.value(), text); !s.ok()) {
        return Status{s.code, manifest + ": " + s.message, s.fields};
      }
    }
  }
  return rig;
}

}  // namespace facespace
