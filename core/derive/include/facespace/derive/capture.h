// A face tracker's landmarks as a rig's weights (issue 64): MediaPipe's canonical face (468 points,
// vertex i its tracker's landmark i) registered once onto the rig as a derive registers a face
// (MapLandmarks, cached per rig version by its callers), so each landmark has a place on the rig
// and each of the rig's expression shapes a move there; then each frame's points, the head's rigid
// motion taken out (a similarity fitted on the points no shape moves much), less the performer's
// own neutral (a frame of theirs at rest: their face is not the rig's), are fitted by the shapes'
// moves (bounded least squares: shapes the face cannot show stay at 0), and smoothed over time by
// the One Euro filter (Casiez et al. 2012: little lag when the face moves fast, little jitter when
// it rests).
//
//   MapLandmarks(rig, canonical, options) -> LandmarkRig     once per rig
//   SolveFrames(map, frames, options)     -> weights per frame, and the head's turn
#pragma once

#include <array>
#include <memory>
#include <span>
#include <stop_token>
#include <vector>

#include "facespace/derive/derive.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::derive {

inline constexpr size_t kMediaPipeFace = 468;  // Face points; 478 with the irises (ignored).
inline constexpr size_t kMediaPipeIrises = 478;

// Where the landmarks are on a rig, and what its shapes do there (world space).
struct LandmarkRig {
  size_t rig_shapes = 0;         // The rig's shape count (SolveFrames' weights are this long).
  std::vector<uint32_t> shapes;  // The shapes the solve uses: those any vocabulary names (ARKit,
                                 // MMD, VRoid; retarget.h), else every shape; moving a landmark.
  std::vector<float> upper;      // Per used shape: its range's top.
  std::vector<uint8_t> found;    // Per landmark: it landed on the rig.
  std::vector<float> rest;       // 3 per landmark: the rig's neutral there.
  std::vector<double> moves;     // Per used shape, 3 per landmark: its move at weight 1.
  std::vector<float> rigid;      // Per landmark: its weight in the head's rigid fit.
  // The lids' and lips' gaps (MediaPipe's 159-145, 386-374, 13-14): a performer's gap that closes
  // by half closes the rig's by half, whatever the two faces' eyes and mouths measure. Per gap: its
  // landmarks, its length on the rig, and per used shape how a unit of it widens the gap.
  struct Gap {
    uint32_t a = 0, b = 0;
    double length = 0;
    std::vector<double> widen;
  };
  std::vector<Gap> gaps;
  std::vector<double> normal;  // The solve's normal matrix, shapes x shapes (the gaps' rows in).
  double diag = 0;             // The rig head's diagonal.
};

// Registers `canonical` (MediaPipe's canonical face, as a rig) onto `rig`. Errors as DeriveShapes'
// registration (caps, no face, poor fit, cancelled); a rig whose shapes move no landmark is
// refused (kFailedPrecondition: nothing to solve).
Result<LandmarkRig> MapLandmarks(const Rig& rig, const Rig& canonical, const Options& options);

struct CaptureOptions {
  float fps = 30;
  size_t neutral = 0;       // The frame in which the performer's face rests.
  float min_cutoff = 1.5f;  // One Euro: Hz at rest.
  float beta = 0.3f;        // One Euro: how fast the cutoff rises with speed.
  std::stop_token stop;     // Checked between frames.
};

struct Captured {
  std::vector<std::vector<float>> weights;  // Per frame, one per rig shape.
  std::vector<std::array<float, 4>> head;   // Per frame: the head's turn (x, y, z, w),
                                            // in the rig's frame, from the neutral's.
  std::vector<float> residual;              // Per frame: mean distance left, of the diag.
  double solve_seconds = 0;                 // CPU time of the frames' solves.
};

// A performer's frames one at a time (the live socket's, and SolveFrames'): the neutral first,
// then each frame solved and smoothed with the ones before. Holds `map`, which must outlive it.
class FaceTracker {
 public:
  FaceTracker(const LandmarkRig& map, const CaptureOptions& options);
  ~FaceTracker();
  FaceTracker(FaceTracker&&) noexcept;
  // The performer's face at rest: what differs from the rig's there is their face, no expression.
  // Errors as SolveFrames' for frame `index`.
  Status SetNeutral(std::span<const float> frame, size_t index);
  bool has_neutral() const;
  struct Frame {
    std::vector<float> weights;  // One per rig shape.
    std::array<float, 4> head{0, 0, 0, 1};
    float residual = 0;
  };
  // One frame (after SetNeutral); errors as SolveFrames' for frame `index`. `seconds`: since the
  // frame before, for the smoothing (a live camera's rate varies); 0: 1 / fps.
  Status Step(std::span<const float> frame, size_t index, Frame& out, float seconds = 0);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

// `frames`: per frame 3 x 468 (or 478) numbers, MediaPipe's landmarks in the image's pixels (x
// right, y down, z in x's scale, smaller nearer). Errors name the frame ("/frames/3"): a wrong
// count of points, a number that is not finite; kCancelled.
Result<Captured> SolveFrames(const LandmarkRig& map, std::span<const std::vector<float>> frames,
                             const CaptureOptions& options);

}  // namespace facespace::derive
