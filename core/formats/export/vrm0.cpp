// VRM 0.x out (format=vrm0), for the apps that read only 0.x (VSeeFace among them): the rig turned
// to face -z as 0.x avatars do, the glb as for 1.0, and the "VRM" extension: meta in 0.x's terms,
// the humanoid's bone list, blendShapeMaster (weights in percent, by mesh; material colours as
// materialValues), firstPerson with the look-at, secondaryAnimation's springs and colliders, and
// MToon as materialProperties.
#include <algorithm>
#include <cmath>

#include "common/vrm_presets.h"
#include "common/vrm_terms.h"
#include "export/vrm_parts.h"
#include "export/writers.h"
#include "facespace/engine/face.h"
#include "facespace/engine/weights.h"

namespace facespace::formats::writers {

namespace {

void Turn3(float* v) { v[0] = -v[0], v[2] = -v[2]; }
void TurnAll(std::vector<float>& v, size_t stride) {
  for (size_t i = 0; i + 2 < v.size(); i += stride) Turn3(&v[i]);
}
void TurnQuaternion(std::array<float, 4>& q) {
  q[0] = -q[0], q[2] = -q[2];
}  // Ry(180) q Ry(180)^-1.
void TurnMatrix(float* m) {  // F m F, F = diag(-1, 1, -1, 1): negate where exactly one of row and
                             // column is x or z.
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) {
      if (((c == 0 || c == 2) ? 1 : 0) != ((r == 0 || r == 2) ? 1 : 0))
        m[4 * c + r] = -m[4 * c + r];
    }
  }
}

// 0.x's name of a 1.0 bone: 0.x's thumb is proximal, intermediate, distal where 1.0's is
// metacarpal, proximal, distal.
std::string Bone0(std::string name) {
  if (name.find("ThumbMetacarpal") != std::string::npos)
    return name.replace(name.find("Metacarpal"), 10, "Proximal");
  if (name.find("ThumbProximal") != std::string::npos)
    return name.replace(name.find("Proximal"), 8, "Intermediate");
  return name;
}

// 0.x's preset names for 1.0's (the others are custom: "unknown").
const char* Preset0(const std::string& name) {
  for (const auto& [one, zero] : vrm_presets::kPresets) {
    if (name == one) return zero;
  }
  return "unknown";
}

ordered_json BlendShapeGroups(const Rig& rig, const ordered_json& materials) {
  ordered_json groups = ordered_json::array();
  for (const Expression& e : VrmExpressions(rig)) {
    ordered_json binds = ordered_json::array(), values = ordered_json::array();
    for (const auto& [shape, weight] : e.binds) {
      for (const auto& [mesh, t] : TargetsOf(rig, shape))
        binds.push_back({{"mesh", mesh},
                         {"index", t},
                         {"weight", Num(100.0f * std::clamp(weight, 0.0f, 1.0f))}});
    }
    for (const ordered_json& c : MaterialColorBinds(rig, e)) {
      const size_t m = c["material"].get<size_t>();
      values.push_back({{"materialName", materials[m].value("name", rig.materials[m].name)},
                        {"propertyName", "_Color"},
                        {"targetValue", c["targetValue"]}});
    }
    groups.push_back({{"name", e.name},
                      {"presetName", Preset0(e.name)},
                      {"binds", binds},
                      {"materialValues", values},
                      {"isBinary", e.binary}});
  }
  return groups;
}

ordered_json Curve(const Rig& rig, const RangeMap& m) {
  return {{"curve", {0, 0, 0, 1, 1, 1, 1, 0}},
          {"xRange", Num(WholeAngle(rig.gaze, m))},
          {"yRange", Num(m.output_scale)}};
}

ordered_json FirstPerson(const Rig& rig, int head) {
  const GazeSetup& g = rig.gaze;
  const std::array<float, 3> offset = EyesFromHead(rig, head);
  ordered_json annotations = ordered_json::array();
  for (size_t m = 0; m < rig.meshes.size(); ++m)
    annotations.push_back({{"mesh", m}, {"firstPersonFlag", "Auto"}});
  ordered_json o = {{"firstPersonBone", head},
                    {"firstPersonBoneOffset",
                     {{"x", Num(offset[0])}, {"y", Num(offset[1])}, {"z", Num(offset[2])}}},
                    {"meshAnnotations", annotations},
                    {"lookAtTypeName", g.kind == GazeSetup::Kind::kBones ? "Bone" : "BlendShape"}};
  if (g.kind == GazeSetup::Kind::kNone) return o;
  o["lookAtHorizontalInner"] = Curve(rig, g.horizontal_inner);
  o["lookAtHorizontalOuter"] = Curve(rig, g.horizontal_outer);
  o["lookAtVerticalDown"] = Curve(rig, g.vertical_down);
  o["lookAtVerticalUp"] = Curve(rig, g.vertical_up);
  return o;
}

// 0.x's licence names for the Creative Commons licences it knows; others are "Other", by URL.
const char* LicenseName0(const std::string& url) {
  if (url.find("creativecommons.org/publicdomain/zero/") != std::string::npos) return "CC0";
  if (url.find("creativecommons.org/licenses/by/") != std::string::npos) return "CC_BY";
  if (url.find("creativecommons.org/licenses/by-sa/") != std::string::npos) return "CC_BY_SA";
  if (url.find("creativecommons.org/licenses/by-nc/") != std::string::npos) return "CC_BY_NC";
  return "Other";
}

ordered_json Meta0(const Rig& rig, int thumbnail_texture) {
  ordered_json meta = {{"title", rig.name.empty() ? "facespace rig" : rig.name},
                       {"version", ""},
                       {"author", rig.credit.empty() ? rig.name : rig.credit},
                       {"contactInformation", ""},
                       {"reference", rig.terms.source},
                       {"texture", thumbnail_texture}};
  meta.update(vrm_terms::Meta0(rig.terms));
  meta["otherPermissionUrl"] = "";
  meta["licenseName"] = LicenseName0(rig.license_url);
  meta["otherLicenseUrl"] = rig.license_url;
  return meta;
}

}  // namespace

Rig TurnedHalfRound(const Rig& rig) {
  Rig r = rig;
  for (Primitive& p : r.primitives) {
    TurnAll(p.positions, 3);
    TurnAll(p.normals, 3);
    TurnAll(p.base_smooth_normals, 3);
    TurnAll(p.tangents, 4);
    for (SparseTarget& t : p.targets) {
      TurnAll(t.position_deltas, 3);
      TurnAll(t.normal_deltas, 3);
      TurnAll(t.tangent_deltas, 3);
    }
  }
  for (Node& n : r.nodes) {
    Turn3(n.translation.data());
    TurnQuaternion(n.rotation);
    TurnMatrix(n.matrix.data());
  }
  for (Skin& s : r.skins) {
    for (size_t j = 0; j + 16 <= s.inverse_bind.size(); j += 16) TurnMatrix(&s.inverse_bind[j]);
  }
  for (Shape& s : r.shapes) {
    for (BoneMorph& b : s.bone_morphs) Turn3(b.translation.data()), TurnQuaternion(b.rotation);
  }
  for (RigidBody& b : r.physics.bodies) Turn3(b.position.data()), TurnQuaternion(b.rotation);
  for (PhysicsJoint& j : r.physics.joints) Turn3(j.position.data()), TurnQuaternion(j.rotation);
  Turn3(r.gaze.origin.data());
  r.gaze.faces_minus_z = true;
  r.animations.clear();  // A VRM carries no clips.
  return r;
}

Result<std::string> ExportVrm0(const Rig& source, const BlendedRig& blended,
                               std::span<const float> weights, std::span<const Warning> warnings,
                               const ExportOptions& options) {
  auto bones = AvatarBones(source);
  if (!bones.ok()) return bones.status();
  const Rig rig = TurnedHalfRound(source);
  auto glb = RestGlbParts(rig, blended, weights, warnings);
  if (!glb.ok()) return glb.status();
  GlbParts& g = glb.value();
  const int thumbnail = options.thumbnail_png.empty()
                            ? -1
                            : AddImage(g, options.thumbnail_png, "image/png", "thumbnail").second;
  ordered_json human = ordered_json::array();
  int head = -1;
  for (const auto& [name, node] : bones.value()) {
    human.push_back({{"bone", Bone0(name)}, {"node", node}, {"useDefaultValues", true}});
    if (name == "head") head = node;
  }
  ordered_json& materials = g.json["materials"];
  ordered_json properties = ordered_json::array();
  for (size_t m = 0; m < materials.size() && m < rig.materials.size(); ++m)
    properties.push_back(MaterialProperties0(rig.materials[m], materials[m]));
  ordered_json vrm = {
      {"exporterVersion", "facespace"},
      {"specVersion", "0.0"},
      {"meta", Meta0(rig, thumbnail)},
      {"humanoid", {{"humanBones", human}}},
      {"firstPerson", FirstPerson(rig, head)},
      {"blendShapeMaster", {{"blendShapeGroups", BlendShapeGroups(rig, materials)}}},
      {"secondaryAnimation", SecondaryAnimation0(SpringsOf(rig))},
      {"materialProperties", properties}};
  UseExtension(g, "VRM");
  g.json["extensions"]["VRM"] = std::move(vrm);
  return PackGlb(g);
}

}  // namespace facespace::formats::writers
