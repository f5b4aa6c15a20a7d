// Batch variants as training samples: each one's render with labels exact to it (depth, normals,
// segmentation, landmarks), its camera and its point, and what varies from sample to sample
// (randomize) drawn from its own seeded stream. Shared by the folder and the tar archive (run.h).
//
// A sample's files share its key (the variant's id): KEY.png (the render; or the batch's image
// format), KEY.depth.exr (one float32 channel "Y": the distance along the pixel's ray from the eye,
// metres; 0 where nothing was drawn), KEY.normals.exr (half floats R, G, B: the camera-space unit
// normal, x right, y up, z toward the eye; 0 where nothing was drawn), KEY.seg.png (grey, 8 or 16
// bits: segment ids, 0 background; the legend in KEY.json) and KEY.json:
//   {"key", "index", "image": {"file", "width", "height"},
//    "camera": {"K": 3 x 3 in pixels, "world_to_camera": 4 x 4 row-major (glTF's camera: looking
//    down
//               -z, y up), "projection": how they map a point to a pixel, "fov_y_degrees", "near",
//               "far" (what was drawn lies between them along -z)},
//    "depth": "distance along the ray, metres", "segmentation": {"0": "background", "1": NAME,
//    ...}, "landmarks": [{"name", "xy": [px, py] (pixel centres at +0.5, origin top left), "xyz":
//    world,
//                   "visible"}], "landmark_scheme",
//    "weights" (non-zero, by name), "expressions", "gaze", "pose", "render" (what was drawn with),
//    "warnings"}
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "facespace/batch/plan.h"

namespace facespace::batch {

// One file of a sample: its name after "KEY." ("png", "depth.exr", "json") and its bytes.
struct SampleFile {
  std::string suffix;
  std::string bytes;
};

// What sample `index` drew (BatchRequest's dataset.randomize) beyond its weights.
struct SampleDraw {
  picture::RenderOptions
      render;  // The batch's render settings with the draw's camera, light and background.
  std::vector<WeightEntry>
      expressions;  // Randomised ones (the batch's own are in its pose request).
  std::optional<Gaze> gaze;
};
SampleDraw DrawSample(const BatchPlan& plan, size_t index);

// The pictures of randomize.background.images (`facespace batch` alone: the service reads no folder
// a client names): each PNG/JPEG/WebP/EXR/TIFF/BMP file of the folder, in name order, decoded by
// `renderer`, scaled to cover the render and centred. At most kMaxBackgrounds files of at most 64
// MB; their names and sizes join batch.json, so another folder makes another batch. Errors name
// /randomize/background/images.
inline constexpr size_t kMaxBackgrounds = 1000;
Status LoadBackgroundImages(BatchPlan& plan, const picture::Renderer& renderer);

// A pinhole camera in pixels, from a draw's matrices: pixel = K (x, -y, -z) / -z for a point (x, y,
// z) in camera space (glTF's camera looks down -z with y up; the image's origin is its top left
// corner and pixel centres are at +0.5).
struct PinholeCamera {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::array<double, 16> world_to_camera{};  // Row-major.
  int width = 0, height = 0;
  double near = 0,
         far = 0;  // What was drawn lies between these distances along -z (GL's clip planes).
  // The pixel position of world point p, and its camera-space point; false behind the eye.
  bool Project(const std::array<double, 3>& p, std::array<double, 2>& xy,
               std::array<double, 3>& camera) const;
};
PinholeCamera CameraOf(const picture::Image& image);

// A landmark is visible when it is in the frame, before the eye, and no drawn triangle (the
// renderer's: not wholly transparent, not clipped by the near plane) crosses the ray from the eye
// to it nearer than its own distance less this share of it: only where its own surface is drawn.
inline constexpr double kLandmarkOcclusionSlack = 1e-4;

// Labelled sample `index` of `plan` made: its point (with the drawn face), the render and label
// planes (left in ws), and its files into `files`, the picture first and KEY.json last.
Status MakeSample(const BatchPlan& plan, size_t index, const evaluator::Evaluator& evaluator,
                  evaluator::Workspace& ws, evaluator::ResolvedPoint& point,
                  std::vector<SampleFile>& files);

// The segment ids of a rig's primitives (its regions, then one id per material of the primitives in
// none) and their names by id (0: "background").
void SegmentsOf(const Rig& rig, std::vector<uint32_t>& of_primitive,
                std::vector<std::string>& names);

}  // namespace facespace::batch
