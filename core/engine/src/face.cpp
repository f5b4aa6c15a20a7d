#include "facespace/engine/face.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "facespace/engine/speech.h"

namespace facespace {
inline namespace engine {

float RangeMap::Map(float degrees) const {
  if (!(input_max > 0.0f)) return 0.0f;
  return output_scale * std::clamp(degrees / input_max, 0.0f, 1.0f);
}

bool IsExpressionPreset(std::string_view name) {
  return std::find(std::begin(kExpressionPresets), std::end(kExpressionPresets), name) !=
         std::end(kExpressionPresets);
}

namespace {

// The first of `candidates` ("a|b|c") that `find` finds (>= 0), or -1.
template <typename Find>
int FirstFound(std::string_view candidates, Find find) {
  size_t from = 0;
  while (from <= candidates.size()) {
    const size_t bar = std::min(candidates.find('|', from), candidates.size());
    const int i = find(std::string(candidates.substr(from, bar - from)));
    if (i >= 0) return i;
    from = bar + 1;
  }
  return -1;
}

}  // namespace

int FirstNodeOf(const Rig& rig, std::string_view candidates) {
  return FirstFound(candidates, [&](const std::string& name) { return FindNode(rig, name); });
}

int FirstShapeOf(const Rig& rig, std::string_view candidates) {
  return FirstFound(candidates, [&](const std::string& name) { return FindShape(rig, name); });
}

const char* ExpressionOverrideName(ExpressionOverride o) {
  return o == ExpressionOverride::kBlock   ? "block"
         : o == ExpressionOverride::kBlend ? "blend"
                                           : "none";
}

int FindExpression(const Rig& rig, std::string_view name) {
  for (size_t i = 0; i < rig.expressions.size(); ++i) {
    if (rig.expressions[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

namespace {

using Override = ExpressionOverride;

struct Default {
  const char* preset;
  std::vector<CandidateBind> binds;
  Override blink = Override::kNone, look_at = Override::kNone, mouth = Override::kNone;
};

// ARKit's 52 names (FaceCap, Live Link Face, most VTuber rigs), with both of Apple's spellings of a
// side.
const std::vector<Default>& ArkitDefaults() {
  static const std::vector<Default> kDefaults = {
      {"happy",
       {{"mouthSmile_L|mouthSmileLeft", 1},
        {"mouthSmile_R|mouthSmileRight", 1},
        {"cheekSquint_L|cheekSquintLeft", 0.5f},
        {"cheekSquint_R|cheekSquintRight", 0.5f},
        {"eyeSquint_L|eyeSquintLeft", 0.4f},
        {"eyeSquint_R|eyeSquintRight", 0.4f}},
       Override::kBlend},
      {"angry",
       {{"browDown_L|browDownLeft", 1},
        {"browDown_R|browDownRight", 1},
        {"noseSneer_L|noseSneerLeft", 0.6f},
        {"noseSneer_R|noseSneerRight", 0.6f},
        {"mouthFrown_L|mouthFrownLeft", 0.5f},
        {"mouthFrown_R|mouthFrownRight", 0.5f},
        {"eyeSquint_L|eyeSquintLeft", 0.3f},
        {"eyeSquint_R|eyeSquintRight", 0.3f}},
       Override::kBlend},
      {"sad",
       {{"browInnerUp", 1},
        {"mouthFrown_L|mouthFrownLeft", 0.8f},
        {"mouthFrown_R|mouthFrownRight", 0.8f},
        {"mouthShrugLower", 0.3f},
        {"eyeLookDown_L|eyeLookDownLeft", 0.2f},
        {"eyeLookDown_R|eyeLookDownRight", 0.2f}},
       Override::kBlend,
       Override::kBlend},
      {"relaxed",
       {{"mouthSmile_L|mouthSmileLeft", 0.35f},
        {"mouthSmile_R|mouthSmileRight", 0.35f},
        {"eyeBlink_L|eyeBlinkLeft", 0.25f},
        {"eyeBlink_R|eyeBlinkRight", 0.25f}},
       Override::kBlend},
      {"surprised",
       {{"eyeWide_L|eyeWideLeft", 1},
        {"eyeWide_R|eyeWideRight", 1},
        {"browInnerUp", 1},
        {"browOuterUp_L|browOuterUpLeft", 1},
        {"browOuterUp_R|browOuterUpRight", 1},
        {"jawOpen", 0.4f}},
       Override::kBlend,
       Override::kNone,
       Override::kBlend},
      {"aa",
       {{"jawOpen", 0.8f},
        {"mouthLowerDown_L|mouthLowerDownLeft", 0.3f},
        {"mouthLowerDown_R|mouthLowerDownRight", 0.3f}}},
      {"ih",
       {{"jawOpen", 0.2f},
        {"mouthStretch_L|mouthStretchLeft", 0.6f},
        {"mouthStretch_R|mouthStretchRight", 0.6f}}},
      {"ou", {{"jawOpen", 0.15f}, {"mouthPucker", 1}}},
      {"ee",
       {{"jawOpen", 0.35f},
        {"mouthStretch_L|mouthStretchLeft", 0.4f},
        {"mouthStretch_R|mouthStretchRight", 0.4f}}},
      {"oh", {{"jawOpen", 0.5f}, {"mouthFunnel", 1}}},
      {"blink", {{"eyeBlink_L|eyeBlinkLeft", 1}, {"eyeBlink_R|eyeBlinkRight", 1}}},
      {"blinkLeft", {{"eyeBlink_L|eyeBlinkLeft", 1}}},
      {"blinkRight", {{"eyeBlink_R|eyeBlinkRight", 1}}},
      {"lookUp", {{"eyeLookUp_L|eyeLookUpLeft", 1}, {"eyeLookUp_R|eyeLookUpRight", 1}}},
      {"lookDown", {{"eyeLookDown_L|eyeLookDownLeft", 1}, {"eyeLookDown_R|eyeLookDownRight", 1}}},
      {"lookLeft", {{"eyeLookOut_L|eyeLookOutLeft", 1}, {"eyeLookIn_R|eyeLookInRight", 1}}},
      {"lookRight", {{"eyeLookIn_L|eyeLookInLeft", 1}, {"eyeLookOut_R|eyeLookOutRight", 1}}},
  };
  return kDefaults;
}

// MikuMikuDance's standard morph names (those of its bundled models, which most PMD/PMX rigs keep).
const std::vector<Default>& MmdDefaults() {
  static const std::vector<Default> kDefaults = {
      {"happy",
       {{"笑い", 1}, {"にっこり", 0.6f}},
       Override::kBlock},  // 笑い closes the eyes in a smile: no blink over it.
      {"angry", {{"怒り", 1}}, Override::kBlend},
      {"sad", {{"困る", 1}}, Override::kBlend},
      {"relaxed", {{"なごみ", 1}}, Override::kBlock},
      {"surprised", {{"びっくり", 1}}, Override::kBlend},
      {"aa", {{"あ", 1}}},
      {"ih", {{"い", 1}}},
      {"ou", {{"う", 1}}},
      {"ee", {{"え", 1}}},
      {"oh", {{"お", 1}}},
      {"blink", {{"まばたき", 1}}},
      {"blinkLeft", {{"まば左|ウィンク２|ウィンク", 1}}},
      {"blinkRight", {{"まば右|ｳｨﾝｸ２右|ウィンク右", 1}}},
  };
  return kDefaults;
}

// How many of the table's binds the rig has.
size_t Matches(const Rig& rig, const std::vector<Default>& table) {
  size_t n = 0;
  for (const Default& d : table) {
    for (const CandidateBind& b : d.binds) n += FirstShapeOf(rig, b.shapes) >= 0;
  }
  return n;
}

}  // namespace

std::span<const CandidateBind> ArkitPresetBinds(std::string_view preset) {
  for (const Default& d : ArkitDefaults()) {
    if (d.preset == preset) return d.binds;
  }
  return {};
}

namespace {

bool IsBlinkName(std::string_view n) {
  return n == "blink" || n == "blinkLeft" || n == "blinkRight";
}
bool IsLookName(std::string_view n) {
  return n == "lookUp" || n == "lookDown" || n == "lookLeft" || n == "lookRight";
}
bool IsMouthName(std::string_view n) {
  return n == "aa" || n == "ih" || n == "ou" || n == "ee" || n == "oh";
}

float OverrideAmount(Override o, float output) {
  if (o == Override::kBlock) return output > 0.0f ? 1.0f : 0.0f;
  if (o == Override::kBlend) return output;
  return 0.0f;
}

Eigen::Quaternionf RotationOf(const std::array<float, 16>& m) {
  Eigen::Matrix3f r;
  for (int c = 0; c < 3; ++c) {
    Eigen::Vector3f col(m[4 * c], m[4 * c + 1], m[4 * c + 2]);
    const float n = col.norm();
    r.col(c) = n > 0.0f ? Eigen::Vector3f(col / n) : Eigen::Vector3f::Unit(c);
  }
  return Eigen::Quaternionf(r).normalized();
}

Eigen::Vector3f PositionOf(const std::array<float, 16>& m) { return {m[12], m[13], m[14]}; }

// A turn by yaw (about +y, left positive) and pitch (up positive: about -x), degrees, in a frame
// turned by `frame`.
Eigen::Quaternionf Turn(const Eigen::Quaternionf& frame, float yaw, float pitch) {
  constexpr float kRad = static_cast<float>(M_PI / 180.0);
  const Eigen::Quaternionf local = Eigen::AngleAxisf(yaw * kRad, Eigen::Vector3f::UnitY()) *
                                   Eigen::AngleAxisf(-pitch * kRad, Eigen::Vector3f::UnitX());
  return frame * local * frame.conjugate();
}

// Turns `node` by the world-space rotation `turn` about its own origin: local' = P^-1 turn P local.
void TurnNode(const Rig& rig, int node, const Eigen::Quaternionf& turn,
              const std::vector<std::array<float, 16>>& world, Pose& pose) {
  const int parent = rig.nodes[node].parent;
  const Eigen::Quaternionf p =
      parent >= 0 ? RotationOf(world[parent]) : Eigen::Quaternionf::Identity();
  Transform& t = pose.local[node];
  const Eigen::Quaternionf local(t.rotation[3], t.rotation[0], t.rotation[1], t.rotation[2]);
  const Eigen::Quaternionf q = (p.conjugate() * turn * p * local).normalized();
  t.rotation = {q.x(), q.y(), q.z(), q.w()};
  pose.from_matrix[node] = 0;
}

// Where the face looks at rest: +z, or -z (a VRM 0.x), as a turn of +z.
Eigen::Quaternionf Facing(const Rig& rig) {
  return rig.gaze.faces_minus_z ? Eigen::Quaternionf(Eigen::AngleAxisf(static_cast<float>(M_PI),
                                                                       Eigen::Vector3f::UnitY()))
                                : Eigen::Quaternionf::Identity();
}

// The head's turn from its rest (world), or none.
Eigen::Quaternionf HeadTurn(const Rig& rig, const std::vector<std::array<float, 16>>& world,
                            const std::vector<std::array<float, 16>>& rest) {
  const int h = rig.gaze.head;
  if (h < 0 || static_cast<size_t>(h) >= world.size()) return Eigen::Quaternionf::Identity();
  return (RotationOf(world[h]) * RotationOf(rest[h]).conjugate()).normalized();
}

}  // namespace

void DeriveGaze(Rig& rig) {
  GazeSetup& g = rig.gaze;
  if (g.head < 0) g.head = FirstNodeOf(rig, "頭|head|Head|J_Bip_C_Head|mixamorig:Head|DEF-head");
  if (g.neck < 0) g.neck = FirstNodeOf(rig, "首|neck|Neck|J_Bip_C_Neck|mixamorig:Neck|DEF-neck");
  if (g.kind == GazeSetup::Kind::kNone) {
    const int left =
        FirstNodeOf(rig, "左目|leftEye|LeftEye|J_Adj_L_FaceEye|eye.L|Eye_L|mixamorig:LeftEye");
    const int right =
        FirstNodeOf(rig, "右目|rightEye|RightEye|J_Adj_R_FaceEye|eye.R|Eye_R|mixamorig:RightEye");
    if (left >= 0 && right >= 0) {
      g.kind = GazeSetup::Kind::kBones;
      g.eyes = {left, right};
    } else {
      g.look_in = {FirstShapeOf(rig, "eyeLookIn_L|eyeLookInLeft"),
                   FirstShapeOf(rig, "eyeLookIn_R|eyeLookInRight")};
      g.look_out = {FirstShapeOf(rig, "eyeLookOut_L|eyeLookOutLeft"),
                    FirstShapeOf(rig, "eyeLookOut_R|eyeLookOutRight")};
      g.look_up = {FirstShapeOf(rig, "eyeLookUp_L|eyeLookUpLeft"),
                   FirstShapeOf(rig, "eyeLookUp_R|eyeLookUpRight")};
      g.look_down = {FirstShapeOf(rig, "eyeLookDown_L|eyeLookDownLeft"),
                     FirstShapeOf(rig, "eyeLookDown_R|eyeLookDownRight")};
      bool all = true;
      for (const auto* a : {&g.look_in, &g.look_out, &g.look_up, &g.look_down})
        all = all && (*a)[0] >= 0 && (*a)[1] >= 0;
      if (all)
        g.kind = GazeSetup::Kind::kShapes;
      else if (FindExpression(rig, "lookLeft") >= 0 && FindExpression(rig, "lookRight") >= 0)
        g.kind = GazeSetup::Kind::kExpressions;
    }
  }
  if (g.kind != GazeSetup::Kind::kBones) {
    // Shapes: full weight at 30 degrees sideways, 25 up or down (where ARKit's eyeLook shapes are
    // at 1).
    g.horizontal_inner = g.horizontal_outer = {30.0f, 1.0f};
    g.vertical_up = g.vertical_down = {25.0f, 1.0f};
  } else {
    // Bones: the eyes turn as far as the gaze, to 30 degrees sideways and 20 up or down.
    g.horizontal_inner = g.horizontal_outer = {30.0f, 30.0f};
    g.vertical_up = g.vertical_down = {20.0f, 20.0f};
  }
  // Where the eyes are at rest: between the eye bones, else the middle of what the look shapes
  // move.
  const auto world = NodeWorldMatrices(rig);
  if (g.kind == GazeSetup::Kind::kBones) {
    const Eigen::Vector3f mid =
        0.5f * (PositionOf(world[g.eyes[0]]) + PositionOf(world[g.eyes[1]]));
    g.origin = {mid.x(), mid.y(), mid.z()};
  } else if (g.kind != GazeSetup::Kind::kNone) {
    std::vector<uint32_t> shapes;
    if (g.kind == GazeSetup::Kind::kShapes) {
      for (const auto* a : {&g.look_in, &g.look_out})
        shapes.insert(shapes.end(),
                      {static_cast<uint32_t>((*a)[0]), static_cast<uint32_t>((*a)[1])});
    } else {
      for (const char* n : {"lookLeft", "lookRight"}) {
        for (const auto& [s, w] : rig.expressions[FindExpression(rig, n)].binds)
          shapes.push_back(s);
      }
    }
    const auto prim_world = PrimitiveWorldMatrices(rig);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    size_t count = 0;
    for (const Mesh& mesh : rig.meshes) {
      for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
        if (std::find(shapes.begin(), shapes.end(), mesh.target_shapes[t]) == shapes.end())
          continue;
        for (int pi : mesh.primitives) {
          const Primitive& p = rig.primitives[pi];
          if (t >= p.targets.size()) continue;
          for (uint32_t v : p.targets[t].indices) {
            float out[3];
            TransformPoint(prim_world[pi], &p.positions[3 * v], out);
            sum += Eigen::Vector3d(out[0], out[1], out[2]);
            ++count;
          }
        }
      }
    }
    if (count > 0) {
      sum /= static_cast<double>(count);
      g.origin = {static_cast<float>(sum.x()), static_cast<float>(sum.y()),
                  static_cast<float>(sum.z())};
    }
  }
}

void DeriveFace(Rig& rig) {
  const bool arkit = Matches(rig, ArkitDefaults()) >= Matches(rig, MmdDefaults());
  const std::vector<Default>& table = arkit ? ArkitDefaults() : MmdDefaults();
  for (const Default& d : table) {
    if (FindExpression(rig, d.preset) >= 0) continue;
    Expression e;
    e.name = d.preset;
    for (const CandidateBind& b : d.binds) {
      const int s = FirstShapeOf(rig, b.shapes);
      if (s >= 0) e.binds.emplace_back(static_cast<uint32_t>(s), b.weight);
    }
    if (e.binds.empty()) continue;
    e.blink = d.blink;
    e.look_at = d.look_at;
    e.mouth = d.mouth;
    e.derived = true;
    rig.expressions.push_back(std::move(e));
  }
  if (FindExpression(rig, "neutral") < 0) {
    Expression neutral;
    neutral.name = "neutral";
    neutral.derived = true;
    rig.expressions.push_back(std::move(neutral));
  }
  if (!rig.gaze.from_manifest) DeriveGaze(rig);
  DeriveVisemes(rig);
}

float ExpressionOutput(const Expression& e, float value) {
  return e.binary ? (value > 0.5f ? 1.0f : 0.0f) : value;
}

ExpressionMultipliers OverrideMultipliers(const Rig& rig, std::span<const float> values) {
  ExpressionMultipliers m;
  for (size_t i = 0; i < rig.expressions.size() && i < values.size(); ++i) {
    const Expression& e = rig.expressions[i];
    const float out = ExpressionOutput(e, values[i]);
    m.blink -= OverrideAmount(e.blink, out);
    m.look_at -= OverrideAmount(e.look_at, out);
    m.mouth -= OverrideAmount(e.mouth, out);
  }
  m.blink = std::max(0.0f, m.blink);
  m.look_at = std::max(0.0f, m.look_at);
  m.mouth = std::max(0.0f, m.mouth);
  return m;
}

void AddExpressionWeights(const Rig& rig, std::span<const float> values,
                          const ExpressionMultipliers& m, std::span<float> weights) {
  for (size_t i = 0; i < rig.expressions.size() && i < values.size(); ++i) {
    const Expression& e = rig.expressions[i];
    float out = ExpressionOutput(e, values[i]);
    if (out == 0.0f) continue;
    if (IsBlinkName(e.name)) out *= m.blink;
    if (IsLookName(e.name)) out *= m.look_at;
    if (IsMouthName(e.name)) out *= m.mouth;
    for (const auto& [s, w] : e.binds) {
      if (s < weights.size()) weights[s] += out * w;
    }
  }
}

Status ResolveExpressions(const Rig& rig, std::span<const WeightEntry> entries,
                          std::vector<float>& values, std::vector<Warning>& warnings) {
  values.assign(rig.expressions.size(), 0.0f);
  Status bad = InvalidArgument("");
  std::vector<std::string_view> names;
  for (const Expression& e : rig.expressions) names.push_back(e.name);
  std::vector<uint8_t> seen(rig.expressions.size(), 0);
  for (const WeightEntry& entry : entries) {
    const int i = FindExpression(rig, entry.name);
    if (!std::isfinite(entry.value)) {
      bad.AddField(entry.pointer, "must be a finite number");
      continue;
    }
    if (i < 0) {
      if (IsExpressionPreset(entry.name)) {
        warnings.push_back(
            {"expression_unmapped",
             "this rig maps no shapes to the expression '" + entry.name + "': it is ignored",
             entry.name, entry.value, true});
      } else {
        bad.AddField(entry.pointer, [&] {
          std::string list;
          for (size_t k = 0; k < names.size(); ++k) list += (k ? ", " : "") + std::string(names[k]);
          return "unknown expression '" + entry.name.substr(0, 60) + "'" +
                 DidYouMean(entry.name, names) + "; this rig's expressions: " + list;
        });
      }
      continue;
    }
    if (seen[i]++) {
      bad.AddField(entry.pointer, "expression '" + entry.name + "' is given twice");
      continue;
    }
    values[i] = static_cast<float>(entry.value);
    if (entry.value < 0.0 || entry.value > 1.0) {
      warnings.push_back(
          {"expression_out_of_range",
           "expression '" + entry.name + "' at " + FormatNumber(entry.value) + " is outside [0, 1]",
           entry.name, entry.value, true});
    }
  }
  if (!bad.fields.empty()) {
    bad.message = bad.fields[0].pointer + ": " + bad.fields[0].message;
    return bad;
  }
  return Status::Ok();
}

void GazeAngles(const Rig& rig, const Gaze& gaze, const std::vector<std::array<float, 16>>& world,
                const std::vector<std::array<float, 16>>& rest, float* yaw, float* pitch) {
  if (!gaze.has_target) {
    *yaw = gaze.yaw;
    *pitch = gaze.pitch;
    return;
  }
  const GazeSetup& g = rig.gaze;
  const Eigen::Quaternionf head = HeadTurn(rig, world, rest);
  Eigen::Vector3f origin(g.origin[0], g.origin[1], g.origin[2]);
  if (g.kind == GazeSetup::Kind::kBones) {
    origin = 0.5f * (PositionOf(world[g.eyes[0]]) + PositionOf(world[g.eyes[1]]));
  } else if (g.head >= 0) {  // The rest origin carried by the head's move.
    origin = head * (origin - PositionOf(rest[g.head])) + PositionOf(world[g.head]);
  }
  const Eigen::Vector3f d =
      (head * Facing(rig)).conjugate() *
      (Eigen::Vector3f(gaze.target[0], gaze.target[1], gaze.target[2]) - origin);
  constexpr float kDeg = static_cast<float>(180.0 / M_PI);
  *yaw = std::atan2(d.x(), d.z()) * kDeg;
  *pitch = std::atan2(d.y(), std::hypot(d.x(), d.z())) * kDeg;
}

namespace {

// Signed: an eye turning towards its own side (out) or the nose (in); up or down.
float Horizontal(const GazeSetup& g, int eye, float yaw) {
  const bool out = (eye == 0) == (yaw >= 0.0f);  // The left eye looks out to the left (yaw > 0).
  const float deg = (out ? g.horizontal_outer : g.horizontal_inner).Map(std::fabs(yaw));
  return yaw >= 0.0f ? deg : -deg;
}
float Vertical(const GazeSetup& g, float pitch) {
  return pitch >= 0.0f ? g.vertical_up.Map(pitch) : -g.vertical_down.Map(-pitch);
}

}  // namespace

Warning GazeUnsupported() {
  return {"gaze_unsupported",
          "this rig has no eye bones (左目/右目, leftEye/rightEye), no eye shapes "
          "(eyeLookIn/Out/Up/Down_L/R) and no look "
          "expressions (lookLeft/lookRight in its manifest): the gaze is ignored",
          "", 0.0, false};
}

void ApplyGaze(const Rig& rig, const Gaze& gaze, float look_at, std::span<float> weights,
               Pose& pose, bool& posed, std::vector<Warning>& warnings) {
  const GazeSetup& g = rig.gaze;
  if (g.kind == GazeSetup::Kind::kNone) {
    warnings.push_back(GazeUnsupported());
    return;
  }
  if (!posed) {
    pose = RestPose(rig);
  }
  std::vector<std::array<float, 16>> world = WorldMatrices(rig, pose);
  float yaw = 0.0f, pitch = 0.0f;
  const std::vector<std::array<float, 16>> rest = NodeWorldMatrices(rig);
  GazeAngles(rig, gaze, world, rest, &yaw, &pitch);
  if (!std::isfinite(yaw) || !std::isfinite(pitch)) return;
  float share = 0.0f;
  bool turned = false;
  for (const auto& [node, part] :
       {std::pair{g.neck, g.neck_share}, std::pair{g.head, g.head_share}}) {
    if (node < 0 || part == 0.0f) continue;
    TurnNode(rig, node, Turn(HeadTurn(rig, world, rest) * Facing(rig), yaw * part, pitch * part),
             world, pose);
    world = WorldMatrices(rig, pose);
    share += part;
    turned = true;
  }
  yaw *= 1.0f - share;
  pitch *= 1.0f - share;
  if (g.kind == GazeSetup::Kind::kBones) {
    const Eigen::Quaternionf frame = HeadTurn(rig, world, rest) * Facing(rig);
    for (int eye = 0; eye < 2; ++eye) {
      TurnNode(rig, g.eyes[eye], Turn(frame, Horizontal(g, eye, yaw), Vertical(g, pitch)), world,
               pose);
    }
    posed = true;
    return;
  }
  if (turned) posed = true;
  if (g.kind == GazeSetup::Kind::kShapes) {
    for (int eye = 0; eye < 2; ++eye) {
      const float h = Horizontal(g, eye, yaw), v = Vertical(g, pitch);
      const bool out = (eye == 0) == (yaw >= 0.0f);
      weights[g.look_out[eye]] = look_at * (out ? std::fabs(h) : 0.0f);
      weights[g.look_in[eye]] = look_at * (out ? 0.0f : std::fabs(h));
      weights[g.look_up[eye]] = look_at * std::max(v, 0.0f);
      weights[g.look_down[eye]] = look_at * std::max(-v, 0.0f);
    }
    return;
  }
  // kExpressions: VRM's expression look-at (the outer map both ways).
  const float side = g.horizontal_outer.Map(std::fabs(yaw)),
              up = g.vertical_up.Map(std::max(pitch, 0.0f)),
              down = g.vertical_down.Map(std::max(-pitch, 0.0f));
  for (const auto& [name, value] :
       {std::pair{"lookLeft", yaw > 0 ? side : 0.0f}, std::pair{"lookRight", yaw < 0 ? side : 0.0f},
        std::pair{"lookUp", up}, std::pair{"lookDown", down}}) {
    const int e = FindExpression(rig, name);
    if (e < 0 || value == 0.0f) continue;
    for (const auto& [s, w] : rig.expressions[e].binds) weights[s] += look_at * value * w;
  }
}

std::vector<Blink> NaturalBlinks(float start, float end, float per_minute, uint64_t seed) {
  std::vector<Blink> out;
  if (!(per_minute > 0.0f) || !(end > start) || !std::isfinite(end - start)) return out;
  per_minute = std::min(per_minute, kMaxBlinksPerMinute);
  std::mt19937_64 gen(seed);
  auto uniform = [&] { return static_cast<double>(gen() >> 11) * 0x1.0p-53; };  // [0, 1)
  // The span cut into slots of 60 / per_minute seconds, one blink somewhere in each: the rate is
  // the one asked for, the intervals irregular (from nearly back to back to two slots apart), and a
  // blink ends kMinBlinkGap before its slot does, so none overlaps the next. A last, partial slot
  // has its blink with the probability of its length.
  const double slot = 60.0 / per_minute;
  const double span = static_cast<double>(end) - start;
  const size_t whole = static_cast<size_t>(std::min(span / slot, 1e5));
  for (size_t k = 0; k <= whole; ++k) {
    const double from = start + static_cast<double>(k) * slot;
    const double length_here = std::min(slot, static_cast<double>(end) - from);
    const double close = 0.06 + 0.04 * uniform(), hold = 0.02 + 0.04 * uniform(),
                 open = 0.12 + 0.1 * uniform();
    const double length = close + hold + open;
    const double u = uniform(), chance = uniform();
    if (k == whole && chance >= length_here / slot) break;
    const double room = length_here - length - kMinBlinkGap;
    if (room <= 0.0) continue;
    const double t = from + u * room;
    out.push_back({static_cast<float>(t), static_cast<float>(t + close),
                   static_cast<float>(t + close + hold), static_cast<float>(t + length)});
  }
  return out;
}

float BlinkValue(std::span<const Blink> blinks, float t) {
  auto it = std::upper_bound(blinks.begin(), blinks.end(), t,
                             [](float v, const Blink& b) { return v < b.start; });
  if (it == blinks.begin()) return 0.0f;
  const Blink& b = *std::prev(it);
  auto smooth = [](float u) {
    u = std::clamp(u, 0.0f, 1.0f);
    return u * u * (3.0f - 2.0f * u);
  };
  if (t >= b.end) return 0.0f;
  if (t < b.closed) return smooth((t - b.start) / (b.closed - b.start));
  if (t < b.opens) return 1.0f;
  return 1.0f - smooth((t - b.opens) / (b.end - b.opens));
}

bool CanBlink(const Rig& rig) {
  return FindExpression(rig, "blink") >= 0 ||
         (FindExpression(rig, "blinkLeft") >= 0 && FindExpression(rig, "blinkRight") >= 0);
}

void ApplyFace(const Rig& rig, const FaceState& face, std::span<float> weights, Pose& pose,
               bool& posed, std::vector<Warning>& warnings) {
  std::vector<float> values = face.expressions;
  values.resize(rig.expressions.size(), 0.0f);
  if (face.blink != 0.0f) {
    const int blink = FindExpression(rig, "blink");
    const int left = FindExpression(rig, "blinkLeft"), right = FindExpression(rig, "blinkRight");
    if (blink >= 0)
      values[blink] = std::min(1.0f, values[blink] + face.blink);
    else if (left >= 0 && right >= 0) {
      values[left] = std::min(1.0f, values[left] + face.blink);
      values[right] = std::min(1.0f, values[right] + face.blink);
    }
  }
  const ExpressionMultipliers m = OverrideMultipliers(rig, values);
  AddExpressionWeights(rig, values, m, weights);
  if (face.gaze) ApplyGaze(rig, *face.gaze, m.look_at, weights, pose, posed, warnings);
}

}  // namespace engine
}  // namespace facespace
