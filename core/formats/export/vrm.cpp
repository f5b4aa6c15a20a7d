// VRM 1.0 out: the rig as a glb (its base, targets and skin, ExportGlb's keep_targets) with
// VRMC_vrm (meta from the rig's credit, licence and terms, the humanoid's bones by their MMD,
// VRoid, Mixamo or VRM names, the expressions as morph target and material colour binds, the
// look-at from the rig's gaze, a thumbnail), VRMC_springBone from MMD's physics,
// VRMC_node_constraint from its grants and VRMC_materials_mtoon for its toon materials
// (vrm_parts.h). Also the pieces vrm0.cpp shares.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "common/vrm_terms.h"
#include "export/vrm_parts.h"
#include "export/writers.h"
#include "facespace/engine/face.h"
#include "facespace/engine/weights.h"
#include "gltf/gltf_common.h"

namespace facespace::formats::writers {

namespace {

using nlohmann::ordered_json;

// VRM 1.0's human bones: name, required, and the node names that may be it ("a|b|c", the first the
// rig has wins): MMD's standard bones (D bones before the ones they follow: they carry the skin),
// VRoid's, Mixamo's, and VRM's own. Right-side rows are made from the left's (AvatarBones).
struct HumanBone {
  const char* name;
  bool required;
  const char* candidates;
};
constexpr HumanBone kCentre[] = {
    {"hips", true, "腰|グルーブ|センター|Hips|hips|J_Bip_C_Hips|mixamorig:Hips"},
    {"spine", true, "上半身|Spine|spine|J_Bip_C_Spine|mixamorig:Spine"},
    {"chest", false, "上半身2|Chest|chest|J_Bip_C_Chest|mixamorig:Spine1"},
    {"upperChest", false, "上半身3|UpperChest|upperChest|J_Bip_C_UpperChest|mixamorig:Spine2"},
    {"neck", false, "首|Neck|neck|J_Bip_C_Neck|mixamorig:Neck"},
    {"head", true, "頭|Head|head|J_Bip_C_Head|mixamorig:Head"},
};
constexpr HumanBone kLeft[] = {
    {"leftEye", false, "左目|LeftEye|leftEye|J_Adj_L_FaceEye|mixamorig:LeftEye"},
    {"leftShoulder", false,
     "左肩|LeftShoulder|leftShoulder|J_Bip_L_Shoulder|mixamorig:LeftShoulder"},
    {"leftUpperArm", true,
     "左腕|LeftUpperArm|leftUpperArm|LeftArm|J_Bip_L_UpperArm|mixamorig:LeftArm"},
    {"leftLowerArm", true,
     "左ひじ|LeftLowerArm|leftLowerArm|LeftForeArm|J_Bip_L_LowerArm|mixamorig:LeftForeArm"},
    {"leftHand", true, "左手首|LeftHand|leftHand|J_Bip_L_Hand|mixamorig:LeftHand"},
    {"leftUpperLeg", true,
     "左足D|左足|LeftUpperLeg|leftUpperLeg|LeftUpLeg|J_Bip_L_UpperLeg|mixamorig:LeftUpLeg"},
    {"leftLowerLeg", true,
     "左ひざD|左ひざ|LeftLowerLeg|leftLowerLeg|LeftLeg|J_Bip_L_LowerLeg|mixamorig:LeftLeg"},
    {"leftFoot", true, "左足首D|左足首|LeftFoot|leftFoot|J_Bip_L_Foot|mixamorig:LeftFoot"},
    {"leftToes", false,
     "左足先EX|左つま先|LeftToes|leftToes|J_Bip_L_ToeBase|mixamorig:LeftToeBase"},
    {"leftThumbMetacarpal", false,
     "左親指０|LeftThumbMetacarpal|J_Bip_L_Thumb1|mixamorig:LeftHandThumb1"},
    {"leftThumbProximal", false,
     "左親指１|LeftThumbProximal|J_Bip_L_Thumb2|mixamorig:LeftHandThumb2"},
    {"leftThumbDistal", false, "左親指２|LeftThumbDistal|J_Bip_L_Thumb3|mixamorig:LeftHandThumb3"},
    {"leftIndexProximal", false,
     "左人指１|LeftIndexProximal|J_Bip_L_Index1|mixamorig:LeftHandIndex1"},
    {"leftIndexIntermediate", false,
     "左人指２|LeftIndexIntermediate|J_Bip_L_Index2|mixamorig:LeftHandIndex2"},
    {"leftIndexDistal", false, "左人指３|LeftIndexDistal|J_Bip_L_Index3|mixamorig:LeftHandIndex3"},
    {"leftMiddleProximal", false,
     "左中指１|LeftMiddleProximal|J_Bip_L_Middle1|mixamorig:LeftHandMiddle1"},
    {"leftMiddleIntermediate", false,
     "左中指２|LeftMiddleIntermediate|J_Bip_L_Middle2|mixamorig:LeftHandMiddle2"},
    {"leftMiddleDistal", false,
     "左中指３|LeftMiddleDistal|J_Bip_L_Middle3|mixamorig:LeftHandMiddle3"},
    {"leftRingProximal", false, "左薬指１|LeftRingProximal|J_Bip_L_Ring1|mixamorig:LeftHandRing1"},
    {"leftRingIntermediate", false,
     "左薬指２|LeftRingIntermediate|J_Bip_L_Ring2|mixamorig:LeftHandRing2"},
    {"leftRingDistal", false, "左薬指３|LeftRingDistal|J_Bip_L_Ring3|mixamorig:LeftHandRing3"},
    {"leftLittleProximal", false,
     "左小指１|LeftLittleProximal|J_Bip_L_Little1|mixamorig:LeftHandPinky1"},
    {"leftLittleIntermediate", false,
     "左小指２|LeftLittleIntermediate|J_Bip_L_Little2|mixamorig:LeftHandPinky2"},
    {"leftLittleDistal", false,
     "左小指３|LeftLittleDistal|J_Bip_L_Little3|mixamorig:LeftHandPinky3"},
};

void ReplaceAll(std::string& s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
    s.replace(at, from.size(), to);
}

// The right side's row from the left's.
std::string Mirrored(std::string s) {
  for (const auto& [l, r] : {std::pair{"左", "右"}, std::pair{"Left", "Right"},
                             std::pair{"left", "right"}, std::pair{"_L_", "_R_"}})
    ReplaceAll(s, l, r);
  return s;
}

}  // namespace

double Num(float x) { return std::stod(FormatNumber(x)); }

Result<std::vector<std::pair<std::string, int>>> AvatarBones(const Rig& rig) {
  std::vector<std::pair<std::string, int>> out;
  std::vector<std::string> missing;
  auto add = [&](const std::string& name, bool required, const std::string& candidates) {
    const int n = FirstNodeOf(rig, candidates);
    if (n < 0 ||
        std::any_of(out.begin(), out.end(), [n](const auto& b) { return b.second == n; })) {
      if (required)
        missing.push_back(name + " (" + candidates.substr(0, candidates.find('|')) + ")");
      return;
    }
    out.emplace_back(name, n);
  };
  for (const HumanBone& b : kCentre) add(b.name, b.required, b.candidates);
  for (const HumanBone& b : kLeft) add(b.name, b.required, b.candidates);
  for (const HumanBone& b : kLeft) add(Mirrored(b.name), b.required, Mirrored(b.candidates));
  if (missing.empty()) {
    if (rig.license_url.empty()) {
      Status s = InvalidArgument("a VRM's meta needs the rig's licence, and '" + rig.name +
                                 "' has none: set \"license_url\" in its manifest");
      s.fields.push_back({"/format", "the rig has no licence URL (manifest \"license_url\")"});
      return s;
    }
    return out;
  }
  std::string list;
  for (size_t i = 0; i < missing.size(); ++i) list += (i ? ", " : "") + missing[i];
  Status s =
      InvalidArgument("a VRM needs a humanoid skeleton, and '" + rig.name + "' has no bone for " +
                      list + (rig.skins.empty() ? " (it has no skeleton)" : "") +
                      "; bones are found by MMD's standard names, VRoid's, Mixamo's or VRM's own");
  s.fields.push_back({"/format", "this rig cannot be a VRM humanoid: no bone for " + list});
  return s;
}

std::vector<Expression> VrmExpressions(const Rig& rig) {
  std::vector<Expression> out = rig.expressions;
  for (Expression& e : AppExpressions(rig)) {
    if (FindExpression(rig, e.name) < 0) out.push_back(std::move(e));
  }
  return out;
}

std::vector<std::pair<size_t, size_t>> TargetsOf(const Rig& rig, uint32_t shape) {
  std::vector<std::pair<size_t, size_t>> out;
  for (size_t mi = 0; mi < rig.meshes.size(); ++mi) {
    const auto& shapes = rig.meshes[mi].target_shapes;
    for (size_t t = 0; t < shapes.size(); ++t) {
      if (shapes[t] == shape) out.emplace_back(mi, t);
    }
  }
  return out;
}

std::array<float, 3> EyesFromHead(const Rig& rig, int head) {
  const auto world = NodeWorldMatrices(rig);
  const auto& o = rig.gaze.origin;
  return {o[0] - world[head][12], o[1] - world[head][13], o[2] - world[head][14]};
}

float WholeAngle(const GazeSetup& g, const RangeMap& m) {
  const float share = g.kind == GazeSetup::Kind::kBones ? g.head_share + g.neck_share : 0.0f;
  return m.input_max / std::max(1e-3f, 1.0f - share);
}

std::vector<int> MeshNodes(const Rig& rig) {
  std::vector<int> out(rig.meshes.size(), -1);
  for (size_t n = rig.nodes.size(); n-- > 0;) {
    const int m = rig.nodes[n].mesh;
    if (m >= 0 && static_cast<size_t>(m) < out.size()) out[m] = static_cast<int>(n);
  }
  return out;
}

Result<GlbParts> RestGlbParts(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings) {
  BlendedRig rest = blended;  // A VRM's rest is its bind pose: the weights as its meshes' defaults.
  rest.posed = false;
  std::vector<Warning> said(warnings.begin(), warnings.end());
  if (blended.posed)
    said.push_back({"pose_not_exported",
                    "a VRM is written at rest: the request's pose is not in it", "", 0.0, false});
  ExportOptions options;
  options.keep_targets = true;
  options.clips = false;
  auto glb = ExportGlb(rig, rest, weights, said, options);
  if (!glb.ok()) return glb.status();
  std::string text;
  std::span<const unsigned char> bin;
  if (Status s =
          SplitGlb({reinterpret_cast<const unsigned char*>(glb->data()), glb->size()}, text, bin);
      !s.ok())
    return Internal("our glb: " + s.message);
  GlbParts g;
  g.json = ordered_json::parse(text, nullptr, false);
  if (g.json.is_discarded()) return Internal("our glb's JSON does not parse");
  g.bin.assign(bin.begin(), bin.end());
  return g;
}

std::string PackGlb(const GlbParts& g) {
  const std::vector<unsigned char> out =
      MakeGlb(g.json.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), g.bin);
  return std::string(out.begin(), out.end());
}

std::pair<int, int> AddImage(GlbParts& g, std::span<const unsigned char> bytes,
                             const std::string& mime_type, const std::string& name) {
  while (g.bin.size() % 4) g.bin.push_back(0);
  ordered_json& j = g.json;
  for (const char* key : {"bufferViews", "images", "textures", "samplers"}) {
    if (!j.contains(key)) j[key] = ordered_json::array();
  }
  j["bufferViews"].push_back(
      {{"buffer", 0}, {"byteOffset", g.bin.size()}, {"byteLength", bytes.size()}});
  g.bin.insert(g.bin.end(), bytes.begin(), bytes.end());
  if (!j.contains("buffers") || j["buffers"].empty())
    j["buffers"] = ordered_json::array({ordered_json::object()});
  j["buffers"][0]["byteLength"] = g.bin.size();
  const int image = static_cast<int>(j["images"].size());
  j["images"].push_back(
      {{"name", name}, {"mimeType", mime_type}, {"bufferView", j["bufferViews"].size() - 1}});
  j["samplers"].push_back({{"magFilter", 9729}, {"minFilter", 9729}});
  const int texture = static_cast<int>(j["textures"].size());
  j["textures"].push_back({{"sampler", j["samplers"].size() - 1}, {"source", image}});
  return {image, texture};
}

void UseExtension(GlbParts& g, const std::string& name) {
  ordered_json& used = g.json["extensionsUsed"];
  if (!used.is_array()) used = ordered_json::array();
  if (std::find(used.begin(), used.end(), name) == used.end()) used.push_back(name);
}

namespace {

// An expression's shapes as VRM's morph target binds: each target of each mesh that carries the
// shape, on the first node showing that mesh.
ordered_json MorphTargetBinds(const Rig& rig, const Expression& e) {
  ordered_json binds = ordered_json::array();
  const std::vector<int> nodes = MeshNodes(rig);
  for (const auto& [shape, weight] : e.binds) {
    for (const auto& [mesh, t] : TargetsOf(rig, shape)) {
      if (nodes[mesh] >= 0)
        binds.push_back(
            {{"node", nodes[mesh]}, {"index", t}, {"weight", Num(std::clamp(weight, 0.0f, 1.0f))}});
    }
  }
  return binds;
}

ordered_json RangeMapJson(const Rig& rig, const RangeMap& m) {
  return {{"inputMaxValue", Num(WholeAngle(rig.gaze, m))}, {"outputScale", Num(m.output_scale)}};
}

// VRM 1.0's meta: VRM's licence (licenseUrl is always VRM's own), the rig's own in otherLicenseUrl,
// and the terms its authors allow (UsageTerms: VRM's most restrictive values when nothing is
// known).
ordered_json Meta(const Rig& rig, int thumbnail) {
  ordered_json meta = {
      {"name", rig.name.empty() ? "facespace rig" : rig.name},
      {"authors", ordered_json::array({rig.credit.empty() ? rig.name : rig.credit})},
      {"licenseUrl", "https://vrm.dev/licenses/1.0/"},
      {"otherLicenseUrl", rig.license_url}};
  if (!rig.credit.empty()) meta["copyrightInformation"] = rig.credit;
  if (thumbnail >= 0) meta["thumbnailImage"] = thumbnail;
  meta.update(vrm_terms::Meta1(rig.terms));
  meta["extras"] = {{"termsSource", rig.terms.source.empty()
                                        ? "none known: VRM's most restrictive terms"
                                        : rig.terms.source}};
  return meta;
}

ordered_json Expressions(const Rig& rig) {
  ordered_json preset = ordered_json::object(), custom = ordered_json::object();
  for (const Expression& e : VrmExpressions(rig)) {
    ordered_json x = {{"morphTargetBinds", MorphTargetBinds(rig, e)},
                      {"isBinary", e.binary},
                      {"overrideBlink", ExpressionOverrideName(e.blink)},
                      {"overrideLookAt", ExpressionOverrideName(e.look_at)},
                      {"overrideMouth", ExpressionOverrideName(e.mouth)}};
    if (ordered_json colours = MaterialColorBinds(rig, e); !colours.empty())
      x["materialColorBinds"] = std::move(colours);
    (IsExpressionPreset(e.name) ? preset : custom)[e.name] = std::move(x);
  }
  ordered_json out = {{"preset", preset}};
  if (!custom.empty()) out["custom"] = custom;
  return out;
}

ordered_json LookAt(const Rig& rig, int head) {
  const GazeSetup& g = rig.gaze;
  const std::array<float, 3> offset = EyesFromHead(rig, head);
  return {{"offsetFromHeadBone", {Num(offset[0]), Num(offset[1]), Num(offset[2])}},
          {"type", g.kind == GazeSetup::Kind::kBones ? "bone" : "expression"},
          {"rangeMapHorizontalInner", RangeMapJson(rig, g.horizontal_inner)},
          {"rangeMapHorizontalOuter", RangeMapJson(rig, g.horizontal_outer)},
          {"rangeMapVerticalDown", RangeMapJson(rig, g.vertical_down)},
          {"rangeMapVerticalUp", RangeMapJson(rig, g.vertical_up)}};
}

// Springs, node constraints and MToon onto the glb; grants VRM cannot say are a warning in
// asset.extras.
void AddSecondaryAndLooks(const Rig& rig, const SpringSetup& springs,
                          const Constrained& constrained, GlbParts& g) {
  if (!springs.empty()) {
    g.json["extensions"]["VRMC_springBone"] = SpringBone1(springs);
    UseExtension(g, "VRMC_springBone");
  }
  for (const auto& [node, constraint] : constrained.constraints) {
    g.json["nodes"][node]["extensions"]["VRMC_node_constraint"] = constraint;
    UseExtension(g, "VRMC_node_constraint");
  }
  if (constrained.dropped > 0) {
    g.json["asset"]["extras"]["warnings"].push_back(
        {{"code", "vrm_constraints_dropped"},
         {"message", std::to_string(constrained.dropped) +
                         " MMD grants VRM's node constraints cannot say (of translation, with a "
                         "ratio outside [0, 1], or onto a swinging bone) are left out"}});
  }
  ordered_json& materials = g.json["materials"];
  for (size_t m = 0; m < rig.materials.size() && m < materials.size(); ++m) {
    if (ordered_json mtoon = MToon1(rig.materials[m], materials[m]); !mtoon.is_null()) {
      materials[m]["extensions"]["VRMC_materials_mtoon"] = std::move(mtoon);
      UseExtension(g, "VRMC_materials_mtoon");
    }
  }
}

}  // namespace

Result<std::string> ExportVrm(const Rig& rig, const BlendedRig& blended,
                              std::span<const float> weights, std::span<const Warning> warnings,
                              const ExportOptions& options) {
  auto bones = AvatarBones(rig);
  if (!bones.ok()) return bones.status();
  std::vector<int> humanoid_nodes;
  for (const auto& bone : bones.value()) humanoid_nodes.push_back(bone.second);
  const SpringSetup springs = SpringsOf(rig);
  const Constrained constrained = WithNodeConstraints(rig, humanoid_nodes, springs);
  auto glb = RestGlbParts(constrained.rig, blended, weights, warnings);
  if (!glb.ok()) return glb.status();
  GlbParts& g = glb.value();
  const int thumbnail = options.thumbnail_png.empty()
                            ? -1
                            : AddImage(g, options.thumbnail_png, "image/png", "thumbnail").first;
  ordered_json humanoid = ordered_json::object();
  for (const auto& [name, node] : bones.value()) humanoid[name] = {{"node", node}};
  ordered_json vrm = {{"specVersion", "1.0"},
                      {"meta", Meta(rig, thumbnail)},
                      {"humanoid", {{"humanBones", humanoid}}},
                      {"expressions", Expressions(rig)}};
  if (rig.gaze.kind != GazeSetup::Kind::kNone)
    vrm["lookAt"] = LookAt(rig, humanoid["head"]["node"].get<int>());
  UseExtension(g, "VRMC_vrm");
  g.json["extensions"]["VRMC_vrm"] = std::move(vrm);
  AddSecondaryAndLooks(rig, springs, constrained, g);
  return PackGlb(g);
}

}  // namespace facespace::formats::writers
