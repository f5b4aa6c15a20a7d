// VRM 1.0 out: the rig as a glb (its base, targets, skin and clips, ExportGlb's keep_targets) with the
// VRMC_vrm extension: meta from the rig's credit and licence, the humanoid's bones by their MMD, VRM or
// Mixamo names, the expressions as morph target binds, and the look-at from the rig's gaze.
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "export/writers.h"
#include "facespace/core/face.h"
#include "facespace/core/weights.h"
#include "gltf/gltf_common.h"

namespace facespace::writers {

namespace {

using nlohmann::ordered_json;

// VRM 1.0's human bones: name, required, and the node names that may be it ("a|b|c", the first the rig
// has wins): MMD's standard bones (D bones before the ones they follow: they carry the skin), VRoid's,
// Mixamo's, and VRM's own. Right-side rows are made from the left's (HumanBones).
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
    {"leftShoulder", false, "左肩|LeftShoulder|leftShoulder|J_Bip_L_Shoulder|mixamorig:LeftShoulder"},
    {"leftUpperArm", true, "左腕|LeftUpperArm|leftUpperArm|LeftArm|J_Bip_L_UpperArm|mixamorig:LeftArm"},
    {"leftLowerArm", true, "左ひじ|LeftLowerArm|leftLowerArm|LeftForeArm|J_Bip_L_LowerArm|mixamorig:LeftForeArm"},
    {"leftHand", true, "左手首|LeftHand|leftHand|J_Bip_L_Hand|mixamorig:LeftHand"},
    {"leftUpperLeg", true, "左足D|左足|LeftUpperLeg|leftUpperLeg|LeftUpLeg|J_Bip_L_UpperLeg|mixamorig:LeftUpLeg"},
    {"leftLowerLeg", true, "左ひざD|左ひざ|LeftLowerLeg|leftLowerLeg|LeftLeg|J_Bip_L_LowerLeg|mixamorig:LeftLeg"},
    {"leftFoot", true, "左足首D|左足首|LeftFoot|leftFoot|J_Bip_L_Foot|mixamorig:LeftFoot"},
    {"leftToes", false, "左足先EX|左つま先|LeftToes|leftToes|J_Bip_L_ToeBase|mixamorig:LeftToeBase"},
    {"leftThumbMetacarpal", false, "左親指０|LeftThumbMetacarpal|J_Bip_L_Thumb1|mixamorig:LeftHandThumb1"},
    {"leftThumbProximal", false, "左親指１|LeftThumbProximal|J_Bip_L_Thumb2|mixamorig:LeftHandThumb2"},
    {"leftThumbDistal", false, "左親指２|LeftThumbDistal|J_Bip_L_Thumb3|mixamorig:LeftHandThumb3"},
    {"leftIndexProximal", false, "左人指１|LeftIndexProximal|J_Bip_L_Index1|mixamorig:LeftHandIndex1"},
    {"leftIndexIntermediate", false, "左人指２|LeftIndexIntermediate|J_Bip_L_Index2|mixamorig:LeftHandIndex2"},
    {"leftIndexDistal", false, "左人指３|LeftIndexDistal|J_Bip_L_Index3|mixamorig:LeftHandIndex3"},
    {"leftMiddleProximal", false, "左中指１|LeftMiddleProximal|J_Bip_L_Middle1|mixamorig:LeftHandMiddle1"},
    {"leftMiddleIntermediate", false, "左中指２|LeftMiddleIntermediate|J_Bip_L_Middle2|mixamorig:LeftHandMiddle2"},
    {"leftMiddleDistal", false, "左中指３|LeftMiddleDistal|J_Bip_L_Middle3|mixamorig:LeftHandMiddle3"},
    {"leftRingProximal", false, "左薬指１|LeftRingProximal|J_Bip_L_Ring1|mixamorig:LeftHandRing1"},
    {"leftRingIntermediate", false, "左薬指２|LeftRingIntermediate|J_Bip_L_Ring2|mixamorig:LeftHandRing2"},
    {"leftRingDistal", false, "左薬指３|LeftRingDistal|J_Bip_L_Ring3|mixamorig:LeftHandRing3"},
    {"leftLittleProximal", false, "左小指１|LeftLittleProximal|J_Bip_L_Little1|mixamorig:LeftHandPinky1"},
    {"leftLittleIntermediate", false, "左小指２|LeftLittleIntermediate|J_Bip_L_Little2|mixamorig:LeftHandPinky2"},
    {"leftLittleDistal", false, "左小指３|LeftLittleDistal|J_Bip_L_Little3|mixamorig:LeftHandPinky3"},
};

void ReplaceAll(std::string& s, const std::string& from, const std::string& to) {
  for (size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size())) s.replace(at, from.size(), to);
}

// The right side's row from the left's.
std::string Mirrored(std::string s) {
  for (const auto& [l, r] : {std::pair{"左", "右"}, std::pair{"Left", "Right"}, std::pair{"left", "right"}, std::pair{"_L_", "_R_"}}) ReplaceAll(s, l, r);
  return s;
}

// The humanoid's bones, or what is missing.
Status HumanBones(const Rig& rig, ordered_json& out) {
  std::vector<std::string> missing;
  std::vector<int> used;
  auto add = [&](const std::string& name, bool required, const std::string& candidates) {
    const int n = FirstNodeOf(rig, candidates);
    if (n < 0 || std::find(used.begin(), used.end(), n) != used.end()) {
      if (required) missing.push_back(name + " (" + candidates.substr(0, candidates.find('|')) + ")");
      return;
    }
    used.push_back(n);
    out[name] = {{"node", n}};
  };
  for (const HumanBone& b : kCentre) add(b.name, b.required, b.candidates);
  for (const HumanBone& b : kLeft) add(b.name, b.required, b.candidates);
  for (const HumanBone& b : kLeft) add(Mirrored(b.name), b.required, Mirrored(b.candidates));
  if (missing.empty()) return Status::Ok();
  std::string list;
  for (size_t i = 0; i < missing.size(); ++i) list += (i ? ", " : "") + missing[i];
  Status s = InvalidArgument("a VRM needs a humanoid skeleton, and '" + rig.name + "' has no bone for " + list +
                             (rig.skins.empty() ? " (it has no skeleton)" : "") +
                             "; bones are found by MMD's standard names, VRoid's, Mixamo's or VRM's own");
  s.fields.push_back({"/format", "this rig cannot be a VRM humanoid: no bone for " + list});
  return s;
}

double Num(float x) { return std::stod(FormatNumber(x)); }

// An expression's shapes as VRM's morph target binds: each target of each mesh that carries the shape,
// on the first node showing that mesh.
ordered_json MorphTargetBinds(const Rig& rig, const Expression& e) {
  ordered_json binds = ordered_json::array();
  for (const auto& [shape, weight] : e.binds) {
    for (size_t mi = 0; mi < rig.meshes.size(); ++mi) {
      const Mesh& mesh = rig.meshes[mi];
      for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
        if (mesh.target_shapes[t] != shape) continue;
        for (size_t n = 0; n < rig.nodes.size(); ++n) {
          if (rig.nodes[n].mesh != static_cast<int>(mi)) continue;
          binds.push_back({{"node", n}, {"index", t}, {"weight", Num(std::clamp(weight, 0.0f, 1.0f))}});
          break;
        }
      }
    }
  }
  return binds;
}

ordered_json RangeMapJson(const RangeMap& m, float share) {
  // VRM turns the eyes by the whole angle: our head's and neck's shares fold into the input's range.
  const float keep = std::max(1e-3f, 1.0f - share);
  return {{"inputMaxValue", Num(m.input_max / keep)}, {"outputScale", Num(m.output_scale)}};
}

}  // namespace

Result<std::string> ExportVrm(const Rig& rig, const BlendedRig& blended, std::span<const float> weights, std::span<const Warning> warnings) {
  ordered_json humanoid = ordered_json::object();
  if (Status s = HumanBones(rig, humanoid); !s.ok()) return s;
  if (rig.license_url.empty()) {
    Status s = InvalidArgument("a VRM's meta needs the rig's licence, and '" + rig.name + "' has none: set \"license_url\" in its manifest");
    s.fields.push_back({"/format", "the rig has no licence URL (manifest \"license_url\")"});
    return s;
  }
  // The rig at rest (a VRM's rest is its bind pose) with these weights as its meshes' defaults.
  BlendedRig rest = blended;
  rest.posed = false;
  std::vector<Warning> said(warnings.begin(), warnings.end());
  if (blended.posed) said.push_back({"pose_not_exported", "a VRM is written at rest: the request's pose is not in it", "", 0.0, false});
  ExportOptions options;
  options.keep_targets = true;
  options.clips = false;
  auto glb = ExportGlb(rig, rest, weights, said, options);
  if (!glb.ok()) return glb.status();
  std::string text;
  std::span<const unsigned char> bin;
  const auto* bytes = reinterpret_cast<const unsigned char*>(glb->data());
  if (Status s = SplitGlb({bytes, glb->size()}, text, bin); !s.ok()) return Internal("our glb: " + s.message);
  ordered_json j = ordered_json::parse(text, nullptr, false);
  if (j.is_discarded()) return Internal("our glb's JSON does not parse");

  // VRM 1.0's meta is itself a licence (licenseUrl is always VRM's): the rig's own goes in otherLicenseUrl,
  // and the meta's terms say what it allows when it is one we know (Creative Commons' CC0, BY, BY-SA);
  // for another, VRM's defaults, its most restrictive terms, stand.
  ordered_json meta = {{"name", rig.name.empty() ? "facespace rig" : rig.name},
                       {"authors", ordered_json::array({rig.credit.empty() ? rig.name : rig.credit})},
                       {"licenseUrl", "https://vrm.dev/licenses/1.0/"},
                       {"otherLicenseUrl", rig.license_url}};
  if (!rig.credit.empty()) meta["copyrightInformation"] = rig.credit;
  const bool cc0 = rig.license_url.find("creativecommons.org/publicdomain/zero/") != std::string::npos;
  const bool by = rig.license_url.find("creativecommons.org/licenses/by/") != std::string::npos;
  const bool by_sa = rig.license_url.find("creativecommons.org/licenses/by-sa/") != std::string::npos;
  if (cc0 || by || by_sa) {
    meta["avatarPermission"] = "everyone";
    meta["allowExcessivelyViolentUsage"] = true;
    meta["allowExcessivelySexualUsage"] = true;
    meta["commercialUsage"] = "corporation";
    meta["allowPoliticalOrReligiousUsage"] = true;
    meta["allowAntisocialOrHateUsage"] = true;
    meta["creditNotation"] = cc0 ? "unnecessary" : "required";
    meta["allowRedistribution"] = true;
    meta["modification"] = "allowModificationRedistribution";
  }
  ordered_json preset = ordered_json::object(), custom = ordered_json::object();
  for (const Expression& e : rig.expressions) {
    ordered_json x = {{"morphTargetBinds", MorphTargetBinds(rig, e)}, {"isBinary", e.binary}, {"overrideBlink", ExpressionOverrideName(e.blink)},
                      {"overrideLookAt", ExpressionOverrideName(e.look_at)}, {"overrideMouth", ExpressionOverrideName(e.mouth)}};
    (IsExpressionPreset(e.name) ? preset : custom)[e.name] = std::move(x);
  }
  ordered_json vrm = {{"specVersion", "1.0"}, {"meta", meta}, {"humanoid", {{"humanBones", humanoid}}}};
  ordered_json expressions = {{"preset", preset}};
  if (!custom.empty()) expressions["custom"] = custom;
  vrm["expressions"] = expressions;
  const GazeSetup& g = rig.gaze;
  if (g.kind != GazeSetup::Kind::kNone) {
    const int head = humanoid["head"]["node"].get<int>();
    const auto world = NodeWorldMatrices(rig);
    const float share = g.kind == GazeSetup::Kind::kBones ? g.head_share + g.neck_share : 0.0f;
    vrm["lookAt"] = {{"offsetFromHeadBone", {Num(g.origin[0] - world[head][12]), Num(g.origin[1] - world[head][13]), Num(g.origin[2] - world[head][14])}},
                     {"type", g.kind == GazeSetup::Kind::kBones ? "bone" : "expression"},
                     {"rangeMapHorizontalInner", RangeMapJson(g.horizontal_inner, share)},
                     {"rangeMapHorizontalOuter", RangeMapJson(g.horizontal_outer, share)},
                     {"rangeMapVerticalDown", RangeMapJson(g.vertical_down, share)},
                     {"rangeMapVerticalUp", RangeMapJson(g.vertical_up, share)}};
  }
  if (!j.contains("extensionsUsed")) j["extensionsUsed"] = ordered_json::array();
  j["extensionsUsed"].push_back("VRMC_vrm");
  j["extensions"]["VRMC_vrm"] = std::move(vrm);
  const std::vector<unsigned char> out = MakeGlb(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace), bin);
  return std::string(out.begin(), out.end());
}

}  // namespace facespace::writers
