// Weights in another vocabulary (ARKit's names, VRM's presets, MMD's morphs, another rig's shapes)
// as this rig's own: the rig's weights that best reproduce them, by a bounded least-squares solve
// in a space every vocabulary shares.
//
// The shared space is ARKit's 52 shapes (kArkitNames' order), one full shape a unit on an axis.
// A name sits in it by a documented table (src/vocabulary.cpp): an ARKit name on its own axis, a
// VRM preset by the table the rig's faces use (face.cpp), an MMD morph or a VRoid Fcl_ shape by
// what it does in ARKit's terms (あ is aa: jawOpen 0.8 and the lower lip down 0.3). A rig's shapes
// and its VRM preset expressions are the solve's columns; weights asked in the vocabulary are the
// target. So an MMD あ opens FaceCap's jaw, and an ARKit stream moves a rig that has only
// あいうえお.
#pragma once

#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "facespace/engine/weights.h"

namespace facespace {
inline namespace engine {

// What the names of a request's weights are: the rig's own (no retarget), ARKit's 52, VRM 1.0's
// presets, MMD's standard morphs, or another rig's shapes.
enum class Vocabulary : uint8_t { kOwn, kArkit, kVrm, kMmd, kRig };

inline constexpr int kArkitAxes = 52;

// A share of one axis of the shared space.
struct AxisTerm {
  uint8_t axis;  // Index into kArkitNames.
  float amount;  // Full shapes.
};

// Where `name` of vocabulary `v` sits, empty when the vocabulary does not know it (or, as VRM's
// neutral, it moves nothing). kArkit: either of Apple's spellings (eyeBlinkLeft, eyeBlink_L), any
// case. kVrm: the presets. kMmd: MMD's morphs. kOwn and kRig (a shape's name): any of these,
// VRoid's Fcl_ shapes, or an ARKit name without its side (eyeBlink: both eyes).
std::span<const AxisTerm> Place(Vocabulary v, std::string_view name);

// The names a vocabulary knows (kArkit, kVrm, kMmd), for errors' "did you mean".
std::vector<std::string_view> VocabularyNames(Vocabulary v);

// Where the weights come from: a vocabulary, and for kRig the rig whose shapes they name.
struct RetargetSource {
  Vocabulary vocabulary = Vocabulary::kOwn;
  const Rig* rig = nullptr;  // kRig.
  std::string label;         // "arkit", "mmd", the rig's id: for messages.
};

struct Retargeted {
  std::vector<WeightEntry> weights;      // This rig's shapes, by name.
  std::vector<WeightEntry> expressions;  // This rig's VRM preset expressions (its own, not
                                         // derived), by name: VRM's override rules still apply.
};

// The rig's weights (shapes in [0, max], preset expressions in [0, 1]) that come closest to
// `entries` in the shared space. A column whose name is the vocabulary's own (FaceCap's jawOpen for
// ARKit's jawOpen, Uka's あ for MMD's) is free; the others (a table's combination, a both-sides
// shape, an expression) costs 0.01 a unit of weight (a lasso's price), so the own name wins where
// both would do, and one combination, not a share of each, where several would. A kRig
// source's shape that sits nowhere passes to this rig's shape of the same name, if any.
// Errors (fields name the entry): a name the vocabulary does not know (with the closest), an index
// outside a kRig source or one given to a named vocabulary, a value that is not finite.
// Warns vocabulary_unexpressed naming what the rig cannot show (an axis more than 0.05 off, a
// source shape that sits nowhere), with the amount asked.
Status Retarget(const Rig& rig, const RetargetSource& from, std::span<const WeightEntry> entries,
                Retargeted& out, std::vector<Warning>& warnings);

// The other way (issue 64: a rig's face sent to the apps VTubers use, in ARKit's names and VRM's
// presets). Each shape's place in the shared space (empty where its name sits nowhere), looked up
// once: the names are hashed.
std::vector<std::span<const AxisTerm>> ShapePlaces(const Rig& rig);
// The rig's weights (one a shape) as a point of the shared space: each shape's place times its
// weight, summed, each axis clamped to [0, 1].
void ArkitOfWeights(std::span<const std::span<const AxisTerm>> places,
                    std::span<const float> weights, std::span<float, kArkitAxes> out);
// A point of the shared space as VRM's presets (kExpressionPresets' order, neutral always 0): their
// weights in [0, 1] that come closest, each priced alike (Retarget's solve), so blink is one
// preset, not its two sides.
void PresetsOfArkit(std::span<const float, kArkitAxes> arkit, std::span<float> out);

}  // namespace engine
}  // namespace facespace
