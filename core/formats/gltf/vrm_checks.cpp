// A VRM's extensions are outside input: every index they hold (nodes, meshes, targets, materials,
// colliders, collider groups) is checked against the file, and every member we read has its type,
// before anything of it is applied. The first fault is the file's: InvalidArgument "invalid-vrm"
// naming the member's pointer.
#include <nlohmann/json.hpp>
#include <string>

#include "gltf/gltf_common.h"

namespace facespace::formats {

namespace {

using nlohmann::json;

struct Checker {
  const tinygltf::Model& model;
  Status bad = Status::Ok();

  bool Fail(const std::string& ptr, const std::string& message) {
    if (bad.ok()) bad = WithReason(InvalidField(ptr, message), "invalid-vrm");
    return false;
  }
  // v an index below `size` (of `what`).
  bool IndexValue(const json& v, size_t size, const char* what, const std::string& ptr) {
    if (!v.is_number_integer() || v.get<int64_t>() < 0 ||
        static_cast<uint64_t>(v.get<int64_t>()) >= size) {
      return Fail(ptr, std::string("must be an index into ") + what + " (0 to " +
                           std::to_string(size) + ", exclusive)");
    }
    return true;
  }
  // o[key] an index below `size`; absent is fine unless required.
  bool Index(const json& o, const char* key, size_t size, const char* what, const std::string& ptr,
             bool required = true) {
    if (!o.is_object()) return Fail(ptr, "must be an object");
    if (!o.contains(key))
      return !required || Fail(ptr + "/" + key, std::string("is required: an index into ") + what);
    return IndexValue(o[key], size, what, ptr + "/" + key);
  }
  // o[key], when present, an array of `n` finite numbers (n 0: any length) or, with `one`, a finite
  // number.
  bool Numbers(const json& o, const char* key, size_t n, const std::string& ptr, bool one = false) {
    if (!o.is_object() || !o.contains(key)) return true;
    const json& v = o[key];
    auto finite = [](const json& x) { return x.is_number() && std::isfinite(x.get<double>()); };
    if (one) return finite(v) || Fail(ptr + "/" + key, "must be a finite number");
    bool ok = v.is_array() && (n == 0 || v.size() == n);
    for (size_t i = 0; ok && i < v.size(); ++i) ok = finite(v[i]);
    return ok ||
           Fail(ptr + "/" + key, n ? "must be an array of " + std::to_string(n) + " finite numbers"
                                   : "must be an array of finite numbers");
  }
  bool Type(const json& o, const char* key, bool (json::*is)() const noexcept, const char* what,
            const std::string& ptr) {
    return !o.is_object() || !o.contains(key) || (o[key].*is)() ||
           Fail(ptr + "/" + key, std::string("must be ") + what);
  }
  template <typename F>
  bool Each(const json& o, const char* key, const std::string& ptr, F&& f) {
    if (!o.is_object() || !o.contains(key)) return true;
    const json& a = o[key];
    if (!a.is_array()) return Fail(ptr + "/" + key, "must be an array");
    for (size_t i = 0; i < a.size(); ++i) {
      if (!f(a[i], ptr + "/" + key + "/" + std::to_string(i))) return false;
    }
    return true;
  }

  // A morph target bind of 1.0 (by node) or 0.x (by mesh, weight in percent).
  bool MorphBind(const json& b, const std::string& ptr, bool v0) {
    const size_t targets_of = [&] {
      int mesh = -1;
      if (v0)
        mesh = b.is_object() && b.contains("mesh") && b["mesh"].is_number_integer()
                   ? b["mesh"].get<int>()
                   : -1;
      else if (b.is_object() && b.contains("node") && b["node"].is_number_integer() &&
               b["node"].get<int64_t>() >= 0 &&
               static_cast<size_t>(b["node"].get<int64_t>()) < model.nodes.size())
        mesh = model.nodes[b["node"].get<int>()].mesh;
      if (mesh < 0 || static_cast<size_t>(mesh) >= model.meshes.size() ||
          model.meshes[mesh].primitives.empty())
        return size_t{0};
      return model.meshes[mesh].primitives[0].targets.size();
    }();
    if (!(v0 ? Index(b, "mesh", model.meshes.size(), "meshes", ptr)
             : Index(b, "node", model.nodes.size(), "nodes", ptr)))
      return false;
    return Index(b, "index", targets_of, "the morph targets of its mesh", ptr) &&
           Numbers(b, "weight", 0, ptr, true);
  }
  bool Expression1(const json& x, const std::string& ptr) {
    if (!x.is_object()) return Fail(ptr, "must be an object");
    const size_t materials = model.materials.size();
    return Type(x, "isBinary", &json::is_boolean, "true or false", ptr) &&
           Each(x, "morphTargetBinds", ptr,
                [&](const json& b, const std::string& p) { return MorphBind(b, p, false); }) &&
           Each(x, "materialColorBinds", ptr,
                [&](const json& b, const std::string& p) {
                  return Index(b, "material", materials, "materials", p) &&
                         Type(b, "type", &json::is_string, "a string", p) &&
                         Numbers(b, "targetValue", 0, p);
                }) &&
           Each(x, "textureTransformBinds", ptr, [&](const json& b, const std::string& p) {
             return Index(b, "material", materials, "materials", p) && Numbers(b, "scale", 2, p) &&
                    Numbers(b, "offset", 2, p);
           });
  }
  bool Expressions1(const json& vrm, const std::string& root) {
    if (!vrm.contains("expressions")) return true;
    const json& ex = vrm["expressions"];
    if (!ex.is_object()) return Fail(root + "/expressions", "must be an object");
    for (const char* group : {"preset", "custom"}) {
      if (!ex.contains(group)) continue;
      if (!ex[group].is_object()) return Fail(root + "/expressions/" + group, "must be an object");
      for (auto it = ex[group].begin(); it != ex[group].end(); ++it) {
        if (!Expression1(it.value(),
                         root + "/expressions/" + group + "/" + JsonPointerEscape(it.key())))
          return false;
      }
    }
    return true;
  }
  bool Groups0(const json& vrm, const std::string& root) {
    if (!vrm.contains("blendShapeMaster")) return true;
    return Each(
        vrm["blendShapeMaster"], "blendShapeGroups", root + "/blendShapeMaster",
        [&](const json& g, const std::string& p) {
          return Type(g, "isBinary", &json::is_boolean, "true or false", p) &&
                 Type(g, "name", &json::is_string, "a string", p) &&
                 Each(g, "binds", p,
                      [&](const json& b, const std::string& q) { return MorphBind(b, q, true); }) &&
                 Each(g, "materialValues", p, [&](const json& v, const std::string& q) {
                   return Type(v, "materialName", &json::is_string, "a string", q) &&
                          Numbers(v, "targetValue", 0, q);
                 });
        });
  }
  bool Collider(const json& c, const std::string& p) {
    if (!Index(c, "node", model.nodes.size(), "nodes", p)) return false;
    if (!c.contains("shape")) return true;
    const json& s = c["shape"];
    if (!s.is_object())
      return Fail(p + "/shape", "must be an object: {\"sphere\": ...} or {\"capsule\": ...}");
    for (const char* kind : {"sphere", "capsule"}) {
      if (s.contains(kind) && !(Numbers(s[kind], "offset", 3, p + "/shape/" + kind) &&
                                Numbers(s[kind], "radius", 0, p + "/shape/" + kind, true) &&
                                Numbers(s[kind], "tail", 3, p + "/shape/" + kind)))
        return false;
    }
    return true;
  }
  bool SpringBone(const json& sb, const std::string& root) {
    const size_t colliders =
        sb.contains("colliders") && sb["colliders"].is_array() ? sb["colliders"].size() : 0;
    const size_t groups = sb.contains("colliderGroups") && sb["colliderGroups"].is_array()
                              ? sb["colliderGroups"].size()
                              : 0;
    auto in = [this](size_t size, const char* what) {
      return [this, size, what](const json& i, const std::string& p) {
        return IndexValue(i, size, what, p);
      };
    };
    return Each(sb, "colliders", root,
                [&](const json& c, const std::string& p) { return Collider(c, p); }) &&
           Each(sb, "colliderGroups", root,
                [&](const json& g, const std::string& p) {
                  return Each(g, "colliders", p, in(colliders, "colliders"));
                }) &&
           Each(sb, "springs", root, [&](const json& s, const std::string& p) {
             return Each(s, "colliderGroups", p, in(groups, "colliderGroups")) &&
                    Index(s, "center", model.nodes.size(), "nodes", p, false) &&
                    Each(s, "joints", p, [&](const json& j, const std::string& q) {
                      bool ok = Index(j, "node", model.nodes.size(), "nodes", q);
                      for (const char* k : {"hitRadius", "stiffness", "gravityPower", "dragForce"})
                        ok = ok && Numbers(j, k, 0, q, true);
                      return ok && Numbers(j, "gravityDir", 3, q);
                    });
           });
  }
  bool Secondary0(const json& vrm, const std::string& root) {
    if (!vrm.contains("secondaryAnimation")) return true;
    const std::string p = root + "/secondaryAnimation";
    const json& s = vrm["secondaryAnimation"];
    return Each(s, "colliderGroups", p,
                [&](const json& g, const std::string& q) {
                  return Index(g, "node", model.nodes.size(), "nodes", q);
                }) &&
           Each(s, "boneGroups", p, [&](const json& g, const std::string& q) {
             return Each(g, "bones", q, [&](const json& b, const std::string& r) {
               return IndexValue(b, model.nodes.size(), "nodes", r);
             });
           });
  }
  bool Constraint(const json& c, const std::string& p) {
    if (!c.is_object() || !c.contains("constraint") || !c["constraint"].is_object())
      return Fail(p + "/constraint",
                  "is required: {\"rotation\" | \"roll\" | \"aim\": {\"source\": NODE, ...}}");
    for (auto it = c["constraint"].begin(); it != c["constraint"].end(); ++it) {
      const std::string q = p + "/constraint/" + JsonPointerEscape(it.key());
      if (!Index(it.value(), "source", model.nodes.size(), "nodes", q) ||
          !Numbers(it.value(), "weight", 0, q, true))
        return false;
    }
    return true;
  }
};

json ToJson(const tinygltf::Value& v, int depth = 0) {
  if (depth > 32) return nullptr;
  if (v.IsBool()) return v.Get<bool>();
  if (v.IsInt()) return v.Get<int>();
  if (v.IsNumber()) return v.GetNumberAsDouble();
  if (v.IsString()) return v.Get<std::string>();
  if (v.IsArray()) {
    json a = json::array();
    for (size_t i = 0; i < v.ArrayLen(); ++i)
      a.push_back(ToJson(v.Get(static_cast<int>(i)), depth + 1));
    return a;
  }
  if (v.IsObject()) {
    json o = json::object();
    for (const std::string& k : v.Keys()) o[k] = ToJson(v.Get(k), depth + 1);
    return o;
  }
  return nullptr;
}

}  // namespace

json VrmJson(const tinygltf::Value& v) { return ToJson(v); }

Status CheckVrmExtensions(const tinygltf::Model& model) {
  Checker c{model};
  if (auto v1 = model.extensions.find("VRMC_vrm"); v1 != model.extensions.end()) {
    const json vrm = ToJson(v1->second);
    if (!vrm.is_object())
      return WithReason(InvalidField("/extensions/VRMC_vrm", "must be an object"), "invalid-vrm");
    c.Expressions1(vrm, "/extensions/VRMC_vrm");
  } else if (auto v0 = model.extensions.find("VRM"); v0 != model.extensions.end()) {
    const json vrm = ToJson(v0->second);
    if (!vrm.is_object())
      return WithReason(InvalidField("/extensions/VRM", "must be an object"), "invalid-vrm");
    c.Groups0(vrm, "/extensions/VRM") && c.Secondary0(vrm, "/extensions/VRM");
  }
  if (auto sb = model.extensions.find("VRMC_springBone");
      c.bad.ok() && sb != model.extensions.end()) {
    const json j = ToJson(sb->second);
    if (!j.is_object())
      return WithReason(InvalidField("/extensions/VRMC_springBone", "must be an object"),
                        "invalid-vrm");
    c.SpringBone(j, "/extensions/VRMC_springBone");
  }
  for (size_t n = 0; n < model.nodes.size() && c.bad.ok(); ++n) {
    if (auto nc = model.nodes[n].extensions.find("VRMC_node_constraint");
        nc != model.nodes[n].extensions.end()) {
      c.Constraint(ToJson(nc->second),
                   "/nodes/" + std::to_string(n) + "/extensions/VRMC_node_constraint");
    }
  }
  return c.bad;
}

}  // namespace facespace::formats
