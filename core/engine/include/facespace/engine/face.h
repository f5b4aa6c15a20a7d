// The face by name: expressions (VRM 1.0's vocabulary mapped to a rig's own shapes), gaze (eye
// bones or eye shapes turned towards a point or by angles) and natural blinks. Each comes to shape
// weights and bone turns that the blend and skin jobs then apply as any others.
//
// Axes: the rig's world, +y up, the face looking along +z (glTF's convention; every importer turns
// its format's axes so). Yaw > 0 turns the gaze to the character's left (+x), pitch > 0 up.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/hierarchy.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "facespace/engine/weights.h"

namespace facespace {

// Apple's ARKit blend shapes, the 52 names (in alphabetical order) face-tracking apps stream and
// avatars carry.
inline constexpr std::string_view kArkitNames[] = {
    "browDownLeft",      "browDownRight",      "browInnerUp",         "browOuterUpLeft",
    "browOuterUpRight",  "cheekPuff",          "cheekSquintLeft",     "cheekSquintRight",
    "eyeBlinkLeft",      "eyeBlinkRight",      "eyeLookDownLeft",     "eyeLookDownRight",
    "eyeLookInLeft",     "eyeLookInRight",     "eyeLookOutLeft",      "eyeLookOutRight",
    "eyeLookUpLeft",     "eyeLookUpRight",     "eyeSquintLeft",       "eyeSquintRight",
    "eyeWideLeft",       "eyeWideRight",       "jawForward",          "jawLeft",
    "jawOpen",           "jawRight",           "mouthClose",          "mouthDimpleLeft",
    "mouthDimpleRight",  "mouthFrownLeft",     "mouthFrownRight",     "mouthFunnel",
    "mouthLeft",         "mouthLowerDownLeft", "mouthLowerDownRight", "mouthPressLeft",
    "mouthPressRight",   "mouthPucker",        "mouthRight",          "mouthRollLower",
    "mouthRollUpper",    "mouthShrugLower",    "mouthShrugUpper",     "mouthSmileLeft",
    "mouthSmileRight",   "mouthStretchLeft",   "mouthStretchRight",   "mouthUpperUpLeft",
    "mouthUpperUpRight", "noseSneerLeft",      "noseSneerRight",      "tongueOut"};
inline namespace engine {

// VRM 1.0's preset expression names.
inline constexpr std::string_view kExpressionPresets[] = {
    "happy",      "angry",  "sad",      "relaxed",  "surprised", "aa",
    "ih",         "ou",     "ee",       "oh",       "blink",     "blinkLeft",
    "blinkRight", "lookUp", "lookDown", "lookLeft", "lookRight", "neutral"};
bool IsExpressionPreset(std::string_view name);

// The first node of `candidates` ("a|b|c") the rig has, or -1: bones by their names in several
// conventions.
int FirstNodeOf(const Rig& rig, std::string_view candidates);
// The same for shapes (by name or alias).
int FirstShapeOf(const Rig& rig, std::string_view candidates);

// A shape by candidate names ("a|b", FirstShapeOf) at a weight: a row of the tables that map
// expression presets and visemes onto whatever shapes a rig has.
struct CandidateBind {
  const char* shapes;
  float weight;
};

// The binds of VRM preset `preset` in ARKit's names, as the rigs' faces derive it (the table
// DeriveFace uses for ARKit rigs); empty for a name that is no preset, or neutral.
std::span<const CandidateBind> ArkitPresetBinds(std::string_view preset);

// "none", "block", "blend": VRM's and the manifest's word for an override.
const char* ExpressionOverrideName(ExpressionOverride o);

// Index of the rig's expression called `name`, or -1.
int FindExpression(const Rig& rig, std::string_view name);

// Adds the presets the rig's shape names allow and the manifest did not set: ARKit names (FaceCap:
// mouthSmile_L, eyeBlink_L, jawOpen, ...) and MMD's standard morphs (笑い, まばたき, あ い う え
// お, ...). "neutral" (no shapes) is always there. Then picks the gaze (DeriveGaze) unless the
// manifest set it, and the viseme map (speech.h, DeriveVisemes).
void DeriveFace(Rig& rig);

// The gaze the rig allows: MMD's or VRM's eye bones (左目/右目, leftEye/rightEye, ...), else
// ARKit's per-eye shapes, else look expressions; the head bone (頭, head) gives the frame gazes are
// measured in. Keeps range maps and shares already set (the manifest's).
void DeriveGaze(Rig& rig);

// VRM's override rules: how much blink, look-at and mouth expressions still show, each
// max(0, 1 - sum over shown expressions of their override amount), where an expression overriding
// one with "block" counts 1 while it shows (value > 0), with "blend" its value.
struct ExpressionMultipliers {
  float blink = 1.0f, look_at = 1.0f, mouth = 1.0f;
};
// `values`: one per rig expression (binary ones already 0 or 1: ExpressionOutput).
ExpressionMultipliers OverrideMultipliers(const Rig& rig, std::span<const float> values);

// A value as an expression shows it: binary ones 0 or 1 (above 0.5).
float ExpressionOutput(const Expression& e, float value);

// Adds each expression's binds times its shown value (its output times the multiplier of its kind)
// into `weights` (one per shape). Values: one per rig expression.
void AddExpressionWeights(const Rig& rig, std::span<const float> values,
                          const ExpressionMultipliers& m, std::span<float> weights);

// Names and values (WeightEntry: name, value, pointer) to one value per rig expression. Unknown
// names are errors naming their pointer (with the closest name); a VRM preset the rig does not map
// warns expression_unmapped (one vocabulary across rigs: a front end may send every preset to every
// rig).
Status ResolveExpressions(const Rig& rig, std::span<const WeightEntry> entries,
                          std::vector<float>& values, std::vector<Warning>& warnings);

// A gaze: towards a point of the rig's world, or by angles (degrees) from straight ahead.
struct Gaze {
  bool has_target = false;
  std::array<float, 3> target{0, 0, 0};
  float yaw = 0.0f, pitch = 0.0f;
};

// The gaze's angles as the head sees them: straight ahead is +z of the head's rest frame, turned by
// what `pose` does to the head bone (if any); from the eyes (between the eye bones under `pose`, or
// GazeSetup::origin). `world`: the node matrices under the pose; `rest`: at rest
// (NodeWorldMatrices).
void GazeAngles(const Rig& rig, const Gaze& gaze, const std::vector<std::array<float, 16>>& world,
                const std::vector<std::array<float, 16>>& rest, float* yaw, float* pitch);

// What a gaze asked of a rig whose GazeSetup::kind is kNone warns.
Warning GazeUnsupported();

// Applies a gaze: kBones turns the neck and head by their shares and the eye bones (in `pose`,
// before MMD's constraints are solved) by the rest through the range maps; kShapes and kExpressions
// set the look shapes' weights (times `look_at`, the override multiplier). `posed` is set when a
// bone turned
// (`pose` then is the rest pose if it was unposed). A rig without a gaze warns gaze_unsupported.
void ApplyGaze(const Rig& rig, const Gaze& gaze, float look_at, std::span<float> weights,
               Pose& pose, bool& posed, std::vector<Warning>& warnings);

// Natural blinks over [start, end): per_minute of them on average, one at a random moment of each
// 60 / per_minute seconds, each closing fast and opening slower, none within kMinBlinkGap of the
// next. The same seed gives the same blinks (a mt19937_64 and our own draws: no library
// distribution, whose output differs between standard libraries).
struct Blink {
  float start = 0.0f;   // Begins to close.
  float closed = 0.0f;  // Fully closed.
  float opens = 0.0f;   // Begins to open.
  float end = 0.0f;     // Open again.
};
inline constexpr float kMinBlinkGap = 0.3f;
inline constexpr float kMaxBlinksPerMinute = 60.0f;
std::vector<Blink> NaturalBlinks(float start, float end, float per_minute, uint64_t seed);

// How closed the eyes are at t (0 open, 1 closed): ease-in closing, ease-out opening.
float BlinkValue(std::span<const Blink> blinks, float t);

// The face a request or a frame asks for, beyond plain weights.
struct FaceState {
  std::vector<float> expressions;  // One per rig expression, or empty.
  std::optional<Gaze> gaze;
  float blink = 0.0f;  // An automatic blink (0..1), shown as the blink expression.
};

// Whether the rig has a blink expression ("blink", or both "blinkLeft" and "blinkRight") for blinks
// to show on.
bool CanBlink(const Rig& rig);

// Expressions (with the blink, on a rig that CanBlink) into `weights`, then the gaze.
void ApplyFace(const Rig& rig, const FaceState& face, std::span<float> weights, Pose& pose,
               bool& posed, std::vector<Warning>& warnings);

}  // namespace engine
}  // namespace facespace
