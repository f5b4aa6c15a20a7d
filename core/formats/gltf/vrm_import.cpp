// VRM in: a VRM's expressions (1.0's VRMC_vrm, 0.x's blendShapeMaster) and look-at become the rig's
// expressions and gaze, as its manifest would set them; its meta gives the rig's name, credit and
// licence. The extension is outside input: every index is checked, and what does not fit is a load
// warning.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "common/vrm_presets.h"
#include "common/vrm_terms.h"
#include "facespace/engine/face.h"
#include "gltf/gltf_common.h"

namespace facespace::formats {

namespace {

using nlohmann::json;

double Number(const json& o, const char* key, double fallback) {
  return o.is_object() && o.contains(key) && o[key].is_number() &&
                 std::isfinite(o[key].get<double>())
             ? o[key].get<double>()
             : fallback;
}

int Index(const json& o, const char* key) {
  return o.is_object() && o.contains(key) && o[key].is_number_integer() ? o[key].get<int>() : -1;
}

ExpressionOverride OverrideOf(const json& o, const char* key) {
  const json v = o.is_object() && o.contains(key) ? o[key] : json();
  return v == "block"   ? ExpressionOverride::kBlock
         : v == "blend" ? ExpressionOverride::kBlend
                        : ExpressionOverride::kNone;
}

// The shape of target `index` of glTF mesh `mesh`, or -1.
int ShapeOf(const Rig& rig, int mesh, int index) {
  if (mesh < 0 || static_cast<size_t>(mesh) >= rig.meshes.size()) return -1;
  const auto& shapes = rig.meshes[mesh].target_shapes;
  return index >= 0 && static_cast<size_t>(index) < shapes.size() ? static_cast<int>(shapes[index])
                                                                  : -1;
}

void SetExpression(Rig& rig, Expression e) {
  const int at = FindExpression(rig, e.name);
  if (at >= 0)
    rig.expressions[at] = std::move(e);
  else
    rig.expressions.push_back(std::move(e));
}

RangeMap MapOf(const json& m, const char* in, const char* out, RangeMap fallback) {
  if (!m.is_object()) return fallback;
  const double input = Number(m, in, fallback.input_max),
               output = Number(m, out, fallback.output_scale);
  if (!(input > 0) || input > 360 || !(output >= 0) || output > 360) return fallback;
  return {static_cast<float>(input), static_cast<float>(output)};
}

// ApplyVrm's work: members of the wrong type throw (nlohmann's value() and get()).
bool NodeOk(const Rig& rig, int n) { return n >= 0 && static_cast<size_t>(n) < rig.nodes.size(); }

// The terms a VRM's meta states (1.0's members, 0.x's *UssageName and allowedUserName), each as
// restrictive as VRM's default where the meta does not say it or says something we do not know.
void ApplyTerms(const json& meta, UsageTerms& t) {
  t = UsageTerms{};
  t.source = "the VRM's meta";
  auto text = [&](const char* key) {
    return meta.contains(key) && meta[key].is_string() ? meta[key].get<std::string>()
                                                       : std::string();
  };
  // 1.0's member, else 0.x's (the tables take 0.x's words as aliases: "Everyone", "Allow",
  // "Disallow").
  if (!ParseEnum(vrm_terms::kAvatar, text("avatarPermission"), &t.avatar))
    ParseEnum(vrm_terms::kAvatar, text("allowedUserName"), &t.avatar);
  if (!ParseEnum(vrm_terms::kCommercial, text("commercialUsage"), &t.commercial))
    ParseEnum(vrm_terms::kCommercial, text("commercialUssageName"), &t.commercial);
  ParseEnum(vrm_terms::kModification, text("modification"), &t.modification);
  for (const vrm_terms::Flag& f : vrm_terms::kFlags)
    t.*f.member = meta.contains(f.name) && meta[f.name] == true;
  t.violent = t.violent || text("violentUssageName") == "Allow";
  t.sexual = t.sexual || text("sexualUssageName") == "Allow";
  t.credit_required = text("creditNotation") != "unnecessary";
}

// The rig's name, credit and licence from VRM's meta.
void ApplyMeta(const json& meta, Rig& rig) {
  if (!meta.is_object()) return;
  const std::string name = meta.value("name", meta.value("title", std::string()));
  if (!name.empty()) rig.name = name;
  if (rig.credit.empty()) {
    if (meta.contains("authors") && meta["authors"].is_array() && !meta["authors"].empty() &&
        meta["authors"][0].is_string())
      rig.credit = meta["authors"][0];
    else if (meta.contains("author") && meta["author"].is_string())
      rig.credit = meta["author"];
  }
  const std::string other = meta.value("otherLicenseUrl", std::string());
  rig.license_url = !other.empty() ? other : meta.value("licenseUrl", std::string());
  ApplyTerms(meta, rig.terms);
}

// The humanoid's eyes and head (1.0: humanBones by name; 0.x: a list of {bone, node}).
struct HumanoidBones {
  int left = -1, right = -1, head = -1;
};
HumanoidBones FindHumanoidBones(const json& humanoid, bool one) {
  HumanoidBones h;
  if (one && humanoid.contains("humanBones") && humanoid["humanBones"].is_object()) {
    const json& b = humanoid["humanBones"];
    h.left = Index(b.value("leftEye", json()), "node");
    h.right = Index(b.value("rightEye", json()), "node");
    h.head = Index(b.value("head", json()), "node");
  } else if (!one && humanoid.contains("humanBones") && humanoid["humanBones"].is_array()) {
    for (const json& b : humanoid["humanBones"]) {
      if (!b.is_object() || !b.contains("bone")) continue;
      const int n = Index(b, "node");
      if (b["bone"] == "leftEye") h.left = n;
      if (b["bone"] == "rightEye") h.right = n;
      if (b["bone"] == "head") h.head = n;
    }
  }
  return h;
}

// A shape of an expression's own, named after it, for what its binds do beyond morph targets.
uint32_t LookShape(Rig& rig, const std::string& expression) {
  std::string name = expression + " (VRM binds)";
  while (FindShape(rig, name) >= 0) name += "'";
  Shape shape;
  shape.name = name;
  shape.group = "expression";
  rig.shapes.push_back(std::move(shape));
  return static_cast<uint32_t>(rig.shapes.size() - 1);
}

// A material colour bind as a material morph: the base colour moves linearly to `target` with the
// weight.
void AddColourBind(Rig& rig, uint32_t shape, int material, const json& target) {
  MaterialMorph m;
  m.material = material;
  m.add = true;
  const auto& base = rig.materials[material].base_color_factor;
  for (int c = 0; c < 4; ++c)
    m.diffuse[c] =
        (c < static_cast<int>(target.size()) ? target[c].get<float>() : base[c]) - base[c];
  for (float& t : m.texture_tint) t = 0.0f;
  rig.shapes[shape].material_morphs.push_back(m);
}

// A texture transform bind (uv * scale + offset at weight 1) as UV deltas of every vertex drawn
// with the material: (scale - 1) uv + offset, linear in the weight as VRM's lerp of scale and
// offset.
void AddUvBind(Rig& rig, uint32_t shape, int material, std::array<float, 2> scale,
               std::array<float, 2> offset) {
  for (Mesh& mesh : rig.meshes) {
    bool uses = false;
    for (int pi : mesh.primitives)
      uses = uses ||
             (rig.primitives[pi].material == material && !rig.primitives[pi].texcoords.empty());
    if (!uses) continue;
    auto at = std::find(mesh.target_shapes.begin(), mesh.target_shapes.end(), shape);
    const size_t t = static_cast<size_t>(at - mesh.target_shapes.begin());
    if (at == mesh.target_shapes.end()) mesh.target_shapes.push_back(shape);
    for (int pi : mesh.primitives) {
      Primitive& p = rig.primitives[pi];
      p.targets.resize(mesh.target_shapes.size());
      if (p.material != material || p.texcoords.empty()) continue;
      SparseTarget& st = p.targets[t];
      st.texcoord_indices.resize(p.vertex_count());
      st.texcoord_deltas.resize(2 * p.vertex_count());
      for (uint32_t v = 0; v < p.vertex_count(); ++v) {
        st.texcoord_indices[v] = v;
        for (int k = 0; k < 2; ++k)
          st.texcoord_deltas[2 * v + k] = (scale[k] - 1.0f) * p.texcoords[2 * v + k] + offset[k];
      }
      FinalizeTarget(st);
    }
  }
}

// An expression's material colour and texture transform binds (1.0's, or 0.x's materialValues:
// "_Color" and
// "_MainTex_ST") on a shape of its own, bound at weight 1; the kinds we do not draw (emission,
// shade, rim, outline, matcap colours) counted in `dropped`. Indices were checked
// (CheckVrmExtensions).
void AddLookBinds(Rig& rig, const json& x, bool v0, Expression& e, size_t& dropped) {
  int shape = -1;
  auto own = [&] {
    return static_cast<uint32_t>(shape < 0 ? (shape = static_cast<int>(LookShape(rig, e.name)))
                                           : shape);
  };
  auto material_named = [&](const json& v) {
    for (size_t m = 0; m < rig.materials.size(); ++m)
      if (rig.materials[m].name == v.value("materialName", std::string()))
        return static_cast<int>(m);
    return -1;
  };
  for (const json& b : x.value(v0 ? "materialValues" : "materialColorBinds", json::array())) {
    const int m = v0 ? material_named(b) : b.value("material", -1);
    const std::string kind = b.value(v0 ? "propertyName" : "type", std::string());
    const json target = b.value("targetValue", json::array());
    if (m >= 0 && (kind == "color" || kind == "_Color") && target.size() >= 3)
      AddColourBind(rig, own(), m, target);
    else if (m >= 0 && kind == "_MainTex_ST" && target.size() == 4) {
      const float sy = target[1].get<float>();
      AddUvBind(rig, own(), m, {target[0].get<float>(), sy},
                {target[2].get<float>(), 1.0f - target[3].get<float>() - sy});
    } else
      ++dropped;
  }
  for (const json& b : v0 ? json::array() : x.value("textureTransformBinds", json::array())) {
    const json sc = b.value("scale", json::array({1, 1})),
               of = b.value("offset", json::array({0, 0}));
    AddUvBind(rig, own(), b["material"].get<int>(), {sc[0].get<float>(), sc[1].get<float>()},
              {of[0].get<float>(), of[1].get<float>()});
  }
  if (shape >= 0) e.binds.emplace_back(static_cast<uint32_t>(shape), 1.0f);
}

// One expression onto the rig: its morph binds (0.x: "binds", weights in percent and by mesh; 1.0:
// "morphTargetBinds" by node), its material colour and texture transform binds, its overrides.
void AddExpression(const std::string& name, const json& x, bool v0_binds, Rig& rig,
                   size_t& dropped) {
  if (name.empty() || name.size() > 64 || !x.is_object()) return;
  Expression e;
  e.name = name;
  e.binary = x.value("isBinary", false);
  e.blink = OverrideOf(x, "overrideBlink");
  e.look_at = OverrideOf(x, "overrideLookAt");
  e.mouth = OverrideOf(x, "overrideMouth");
  const json binds = x.value(v0_binds ? "binds" : "morphTargetBinds", json::array());
  for (const json& b : binds.is_array() ? binds : json::array()) {
    const int node = Index(b, "node");
    const int mesh = v0_binds ? Index(b, "mesh") : NodeOk(rig, node) ? rig.nodes[node].mesh : -1;
    const int shape = ShapeOf(rig, mesh, Index(b, "index"));
    const double w = Number(b, "weight", v0_binds ? 100.0 : 1.0) / (v0_binds ? 100.0 : 1.0);
    if (shape < 0 || !std::isfinite(w)) {
      ++dropped;
      continue;
    }
    auto same = std::find_if(e.binds.begin(), e.binds.end(), [&](const auto& p) {
      return p.first == static_cast<uint32_t>(shape);
    });
    if (same == e.binds.end())
      e.binds.emplace_back(static_cast<uint32_t>(shape), static_cast<float>(w));
  }
  AddLookBinds(rig, x, v0_binds, e, dropped);
  SetExpression(rig, std::move(e));
}

// 1.0's preset and custom expressions; 0.x's blend shape groups, their preset names in 1.0's words.
void ApplyExpressions(const json& vrm, bool one, Rig& rig, size_t& dropped) {
  if (one) {
    const json ex = vrm.value("expressions", json::object());
    for (const char* group : {"preset", "custom"}) {
      if (!ex.is_object() || !ex.contains(group) || !ex[group].is_object()) continue;
      for (auto it = ex[group].begin(); it != ex[group].end(); ++it)
        AddExpression(it.key(), it.value(), false, rig, dropped);
    }
    return;
  }
  const json groups =
      vrm.value("blendShapeMaster", json::object()).value("blendShapeGroups", json::array());
  for (const json& g : groups.is_array() ? groups : json::array()) {
    if (!g.is_object()) continue;
    const std::string preset = g.value("presetName", std::string());
    std::string name = g.value("name", std::string());
    for (const vrm_presets::PresetName& p : vrm_presets::kPresets) {
      if (preset == p.zero) name = p.one;
    }
    if (preset == "surprised")
      name = preset;  // Not one of 0.x's presets, but written by exporters that know 1.0's.
    AddExpression(name, g, true, rig, dropped);
  }
}

// Look-at (1.0's lookAt, 0.x's firstPerson): bones or what DeriveGaze finds (shapes, look
// expressions), the range maps, and the eyes' origin from the head (or first-person bone) and
// offset.
void ApplyLookAt(const json& look, bool one, const HumanoidBones& h, Rig& rig) {
  if (!look.is_object()) return;
  GazeSetup& gaze = rig.gaze;
  gaze = GazeSetup{};
  gaze.from_manifest = true;
  gaze.faces_minus_z = !one;
  if (NodeOk(rig, h.head)) gaze.head = h.head;
  const std::string type =
      one ? look.value("type", std::string()) : look.value("lookAtTypeName", std::string());
  if ((type == "bone" || type == "Bone") && NodeOk(rig, h.left) && NodeOk(rig, h.right)) {
    gaze.kind = GazeSetup::Kind::kBones;
    gaze.eyes = {h.left, h.right};
  }
  DeriveGaze(
      rig);  // The kind when not bones (shapes or look expressions), the origin, default maps.
  const char* in = one ? "inputMaxValue" : "xRange";
  const char* out = one ? "outputScale" : "yRange";
  gaze.horizontal_inner =
      MapOf(look.value(one ? "rangeMapHorizontalInner" : "lookAtHorizontalInner", json()), in, out,
            gaze.horizontal_inner);
  gaze.horizontal_outer =
      MapOf(look.value(one ? "rangeMapHorizontalOuter" : "lookAtHorizontalOuter", json()), in, out,
            gaze.horizontal_outer);
  gaze.vertical_down =
      MapOf(look.value(one ? "rangeMapVerticalDown" : "lookAtVerticalDown", json()), in, out,
            gaze.vertical_down);
  gaze.vertical_up = MapOf(look.value(one ? "rangeMapVerticalUp" : "lookAtVerticalUp", json()), in,
                           out, gaze.vertical_up);
  const json offset =
      one ? look.value("offsetFromHeadBone", json()) : look.value("firstPersonBoneOffset", json());
  const int from = one ? h.head : Index(look, "firstPersonBone");
  if (!NodeOk(rig, from)) return;
  const auto world = NodeWorldMatrices(rig);
  float o[3] = {0, 0, 0};
  if (offset.is_array() && offset.size() == 3) {
    for (int k = 0; k < 3; ++k) o[k] = offset[k].is_number() ? offset[k].get<float>() : 0.0f;
  } else if (offset.is_object()) {
    o[0] = static_cast<float>(Number(offset, "x", 0)),
    o[1] = static_cast<float>(Number(offset, "y", 0)),
    o[2] = static_cast<float>(Number(offset, "z", 0));
  }
  if (gaze.kind != GazeSetup::Kind::kBones) {
    for (int k = 0; k < 3; ++k) gaze.origin[k] = world[from][12 + k] + o[k];
  }
}

void ApplyVrmMembers(const tinygltf::Model& model, Rig& rig) {
  const auto v1 = model.extensions.find("VRMC_vrm");
  const auto v0 = model.extensions.find("VRM");
  if (v1 == model.extensions.end() && v0 == model.extensions.end()) return;
  const bool one = v1 != model.extensions.end();
  const json vrm = VrmJson(one ? v1->second : v0->second);
  if (!vrm.is_object()) return;
  ApplyMeta(vrm.value("meta", json::object()), rig);
  const HumanoidBones humanoid = FindHumanoidBones(vrm.value("humanoid", json::object()), one);
  size_t dropped = 0;  // Binds naming no target, colours we do not draw.
  ApplyExpressions(vrm, one, rig, dropped);
  ApplyLookAt(one ? vrm.value("lookAt", json()) : vrm.value("firstPerson", json()), one, humanoid,
              rig);
  if (dropped > 0) {
    rig.load_warnings.push_back(CountWarning(
        "vrm_binds_not_applied", dropped,
        "VRM expression binds are not applied: colours we do not draw (emission, shade, rim, "
        "outline, matcap), or morph binds naming no target"));
  }
}

}  // namespace

Status ApplyVrm(const tinygltf::Model& model, Rig& rig) {
  if (Status s = CheckVrmExtensions(model); !s.ok()) return s;
  try {
    ApplyVrmMembers(model, rig);
  } catch (const json::exception& e) {
    const char* where =
        model.extensions.count("VRMC_vrm") ? "/extensions/VRMC_vrm" : "/extensions/VRM";
    return WithReason(
        InvalidField(where, std::string("a member has the wrong type (") + e.what() + ")"),
        "invalid-vrm");
  }
  CountMovedVertices(rig);  // The binds' shapes.
  return ValidateRig(rig);
}

}  // namespace facespace::formats
