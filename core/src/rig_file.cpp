// Rig files: picking the importer, and the manifest that carries what glTF drops.
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "facespace/core/io.h"
#include "facespace/core/shape_tools.h"

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
  if (j.contains("derived")) {
    // New shapes first, so that the rest of the manifest can describe them too.
    if (!j["derived"].is_object()) return bad("/derived", "must be an object of new shape -> {\"from\", \"mirror\", \"mask\"}");
    for (auto it = j["derived"].begin(); it != j["derived"].end(); ++it) {
      const std::string ptr = "/derived/" + JsonPointerEscape(it.key());
      const json& o = *it;
      if (!o.is_object() || !o.contains("from") || !o["from"].is_string()) return bad(ptr, "must be an object with \"from\": a shape name");
      DeriveOptions d;
      auto axis_of = [](const std::string& a) { return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1; };
      if (o.contains("mirror")) {
        if (!o["mirror"].is_string() || axis_of(o["mirror"].get<std::string>()) < 0) return bad(ptr + "/mirror", "must be \"x\", \"y\" or \"z\" (the axis across which to reflect)");
        d.mirror = true;
        d.axis = axis_of(o["mirror"].get<std::string>());
      }
      if (o.contains("tolerance")) {
        if (!o["tolerance"].is_number() || o["tolerance"].get<double>() <= 0) return bad(ptr + "/tolerance", "must be a positive number");
        d.tolerance = o["tolerance"].get<float>();
      }
      if (o.contains("mask")) {
        const json& m = o["mask"];
        if (!m.is_object()) return bad(ptr + "/mask", "must be an object {\"side\", \"falloff\", \"vertices\"}");
        d.masked = true;
        if (m.contains("side")) {
          const std::string side = m["side"].is_string() ? m["side"].get<std::string>() : "";
          if (side.size() != 2 || (side[0] != '+' && side[0] != '-') || axis_of(side.substr(1)) < 0) {
            return bad(ptr + "/mask/side", "must be \"+x\", \"-x\", \"+y\", \"-y\", \"+z\" or \"-z\"");
          }
          d.mask.side = side[0] == '+' ? 1 : -1;
          d.mask.axis = axis_of(side.substr(1));
        }
        if (m.contains("falloff")) {
          if (!m["falloff"].is_number() || m["falloff"].get<double>() < 0) return bad(ptr + "/mask/falloff", "must be a number >= 0 (mesh units)");
          d.mask.falloff = m["falloff"].get<float>();
        }
        if (m.contains("vertices")) {
          if (!m["vertices"].is_array()) return bad(ptr + "/mask/vertices", "must be an array of vertex indices");
          for (const json& v : m["vertices"]) {
            if (!v.is_number_unsigned()) return bad(ptr + "/mask/vertices", "must be an array of vertex indices");
            d.mask.vertices.push_back(v.get<uint32_t>());
          }
        }
      }
      if (!d.mirror && !d.masked) return bad(ptr, "needs \"mirror\" or \"mask\" (or both)");
      auto r = DeriveShape(rig, it.key(), o["from"].get<std::string>(), d);
      if (!r.ok()) return bad(ptr, r.status().message);
      if (r->unmatched > 0) {
        rig.load_warnings.push_back({"mirror_unmatched", std::to_string(r->unmatched) + " moved vertices of '" + o["from"].get<std::string>() +
                                                             "' have no mirror image; '" + it.key() + "' leaves them still",
                                     it.key(), static_cast<double>(r->unmatched), true});
      }
    }
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
