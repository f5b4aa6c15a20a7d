// Deriving a face space: a source rig's shapes (FaceCap's ARKit 52) transferred onto a target head
// that has none. The source's neutral is registered onto the target's (a similarity from landmarks
// or from the heads' own shape, then non-rigid ICP with a stiffness schedule, Amberg et al. 2007),
// and each source shape's deformation gradients are carried to the target's triangles through that
// correspondence and integrated there (Sumner & Popovic 2004 in its Poisson form: one sparse
// factorization of the target's system, reused for every shape). Separate parts are handled as
// what they are: eyes turn for eyeLook*, other small parts (teeth, tongue) follow the skin around
// them rigidly, and what lies outside the face stays still.
//
//   DeriveShapes(target, source, options) -> the target with the shapes added, and a report
//
// The steps (surface, registration, transfer) are src/internal.h's, tested through this.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <functional>
#include <stop_token>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::derive {

// A landmark on the target: a vertex in the file's own numbering (an OBJ's `v` order; a glTF
// primitive's, counted across the rig's primitives in order), or a position (mesh space of the
// first primitive's node: the file's coordinates). Named as the source's landmarks are.
struct TargetLandmark {
  std::string name;
  long long vertex = -1;  // -1: use `position`.
  std::array<double, 3> position{0, 0, 0};
};

// How the target was aligned before the non-rigid fit.
enum class Alignment : uint8_t { kLandmarks, kShape };

struct Options {
  // Source shapes to transfer, by name; empty: all of them. Shapes the target already has by name
  // are kept (the target's own) and not derived.
  std::vector<std::string> shapes;
  // Bake the 15 visemes (OpenXR/Oculus, "viseme_sil" .. "viseme_U", as web avatars carry them) from
  // the derived shapes through the viseme table (core/speech.h), where the target lacks them.
  bool visemes = false;
  std::vector<TargetLandmark> landmarks;  // May be empty, or any subset of the source's names.
  // A fit worse than this (mean distance of the registered source to the target, a fraction of the
  // target's diagonal) is refused, naming where it does not match.
  double max_mean_residual = 0.01;
  // Work caps: a target or source beyond these is refused before any work.
  size_t max_vertices = 300000;
  size_t max_triangles = 600000;
  std::stop_token stop;  // Cancellation, checked between steps and shapes.
  std::function<void(double, const char*)> progress;  // Fraction done and the step, or empty.
};

// A region of the registration, how well it matched: the source's landmarks' names that lie in it.
struct RegionFit {
  std::string name;     // "landmarks", "face", a landmark's name.
  double residual = 0;  // Distance to the target, fraction of the target's diagonal.
};

struct Report {
  Alignment alignment = Alignment::kShape;
  size_t landmarks_used = 0;
  double scale = 1;          // Source units to target units.
  double mean_residual = 0;  // Registered source skin to target, fraction of target diagonal.
  double max_residual = 0;   // The 95th percentile, same units.
  // Source triangles the registration stretched or squeezed over twice (a face bent onto what is
  // not one: 0.1% onto MakeHuman's and ICT's heads, 11% onto a ball), a fraction.
  double distorted = 0;
  std::vector<RegionFit> worst;      // The worst-fitting landmarks (up to 5).
  std::vector<std::string> derived;  // Shapes added, in order.
  std::vector<std::string> kept;     // Source shapes the target already had (its own kept).
  size_t matched_triangles = 0;      // Target triangles that took a source gradient.
  size_t parts_rigid = 0, parts_eyes = 0, parts_still = 0;  // Separate parts of the target.
  double seconds = 0;                                       // CPU time of the whole derive.
  std::string method = "nonrigid-icp+deformation-transfer";
};

// The derived shapes added to `target` (each primitive's targets, meshes' target_shapes, shapes
// named as the source names them, group "derived"); `target` is left unchanged on any error.
// Errors: kInvalidArgument (a landmark off the mesh or unknown, field named), kResourceExhausted
// (beyond the caps), kFailedPrecondition (no face: nothing to register, or the fit is poor: 422
// naming the landmarks that do not match), kCancelled.
Result<Report> DeriveShapes(Rig& target, const Rig& source, const Options& options);

// The names a source offers for `--shapes arkit,visemes`: "arkit" is the source's shapes whose
// names are ARKit's 52 (all of FaceCap's), "visemes" sets Options::visemes; an unknown word is
// refused.
Status ParseShapeSets(const Rig& source, const std::string& list, Options& options);

// A landmarks document, as the manifests write them: {"scheme": NAME, "points": [{"name", "vertex"}
// | {"name", "position": [x, y, z]}, ...]} (any subset; other members of a point, "mesh" say, are
// allowed and ignored). Errors name the member ("/points/3/vertex"). At most 4096 points.
Result<std::vector<TargetLandmark>> ReadLandmarks(std::string_view json_text);

}  // namespace facespace::derive
