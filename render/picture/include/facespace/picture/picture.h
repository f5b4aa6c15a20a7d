// What a picture of a blended rig is, without what draws it: the view, the camera, the options, the
// image, the file formats, and the Renderer interface that draws and encodes (render/render.h has
// the OSMesa renderer and the encoders). Plain data and an interface on core alone, so the
// evaluator takes a renderer handed to it without linking GL, the image codecs or video.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/engine/cpu.h"
#include "facespace/engine/occlusion.h"
#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"

namespace facespace::picture {

enum class View {
  kShaded,     // The glTF metallic-roughness material (base colour, metallic, roughness, normal,
               // occlusion and emissive maps, alpha modes) under a studio light, tone mapped.
  kWireframe,  // Shaded with the triangle edges drawn over it.
  kHeatmap,    // Per-vertex displacement from the base shape, viridis colour map, legend.
  kNormals,    // World-space normals as colours (n * 0.5 + 0.5).
  kClay,       // One neutral grey material under the same light: shape only.
};

bool ParseView(const std::string& name, View* view);
const char* ViewName(View view);

// What the orbit camera frames: every vertex, the vertices the rig's shapes move (ShapeFocusBox:
// a face on a whole body), the vertices a joint carries (Camera::frame_joint, under the pose), or
// by default the shapes when they act on a small part of the rig (FrameShapesByDefault; on a
// skinned rig the vertices of the joint carrying them, ShapeFocusJoint, so a pose does not carry
// the face out of view), else everything. Every vertex means the rest shape's when the render is
// not posed, so the camera stays still while weights change (frames of a sequence line up).
enum class Framing { kAuto, kAll, kShapes, kJoint };

struct Camera {
  float yaw = 0.0f;       // Degrees around the vertical axis; 0 looks at the model's front (+Z).
  float pitch = 0.0f;     // Degrees up (positive) or down.
  float distance = 0.0f;  // From the framed centre; 0 frames the bounding sphere.
  float zoom = 1.0f;      // Divides the distance.
  float fov = 30.0f;      // Vertical field of view, degrees.
  bool look_at = false;   // Use eye/target/up instead of the orbit above.
  Framing frame = Framing::kAuto;
  std::string frame_joint;  // kJoint: the node's name.
  // The box the shapes' framing orbits, when the caller has it already (ShapeFocusBox of the rig,
  // kept by a caller that renders one rig many times, with FrameShapesByDefault in focus_small);
  // computed per render otherwise.
  bool has_focus = false;
  bool focus_small = false;
  int focus_joint =
      -1;  // ShapeFocusJoint, with has_focus: what a skinned rig's auto framing follows.
  std::array<float, 3> focus_min{0, 0, 0}, focus_max{0, 0, 0};
  std::array<float, 3> eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
};

struct RenderOptions {
  int width = 512;
  int height = 512;
  View view = View::kShaded;
  Camera camera;
  std::array<float, 4> background{0.86f, 0.87f, 0.89f, 1.0f};  // sRGB, alpha 0 = transparent.
  int supersample = 1;    // 1..4: render at N x N the size, box-filter down.
  float exposure = 0.0f;  // Stops (EV) before tone mapping: +1 twice the light.
  // Draw into 8-bit sRGB (Image::srgb8) rather than linear floats, for a picture that only goes to
  // an 8-bit file: GL converts at its store, so there is no float frame to clear, read back and
  // convert. Ignored (floats drawn) with supersampling and the heatmap, which work on floats after.
  bool srgb8 = false;
  // Occlusion baked for this rig (core/occlusion.h: BakeRigOcclusion), drawn as ambient occlusion
  // and soft shadows of every light in the shaded, wireframe and clay views; null draws without
  // (every vertex open). The evaluator bakes it once per rig and level of detail
  // (DerivedRigs::Prepare).
  std::shared_ptr<const RigOcclusion> occlusion;
  // The studio's lights turned about the camera: yaw (degrees, about its up axis, positive to the
  // right) then pitch (degrees, about its right axis, positive up). 0, 0: key light high on the
  // left.
  float light_yaw = 0.0f, light_pitch = 0.0f;
  // Draw the label planes too (Image::labels), width x height, one sample at each pixel's centre
  // (no supersampling, no blending): what a synthetic-data pipeline trains on.
  bool labels = false;
  // The segment id of each primitive's pixels in Image::labels.segment; empty: its material + 1
  // (0 for a primitive without one). Ids above 65535 are cut to it.
  std::vector<uint32_t> segment_of_primitive;
  // Not of the picture: where the CPU the renderer's helper threads (llvmpipe's rasteriser) spend
  // for this draw is charged (facespace/engine/cpu.h); null charges nowhere.
  HelperCpu* helper_cpu = nullptr;
};

// What a draw with RenderOptions::labels says about each pixel, top row first, at its centre: the
// triangles (not lines or points) of every primitive whose material shows (alpha above 0), nearest
// first.
struct LabelPlanes {
  std::vector<float>
      distance;  // Along the pixel's ray from the eye, scene units (glTF: metres); 0: nothing.
  std::vector<float>
      normal;  // xyz, camera space (x right, y up, z toward the eye), the blended vertex
               // normals interpolated and turned to face the eye; 0, 0, 0: nothing.
  std::vector<uint16_t> segment;  // RenderOptions::segment_of_primitive; 0: nothing.
};

// Linear-light RGBA, top row first. Encoding converts to sRGB for 8-bit formats. A draw asked for
// 8 bits (RenderOptions::srgb8) fills `srgb8` instead (8-bit sRGB RGBA, straight alpha, top row
// first) and leaves `rgba` empty; Encode takes either.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;
  std::vector<unsigned char> srgb8;
  // The camera of the draw (column-major 4 x 4, as GL takes them): world to camera (glTF's: looking
  // down -z, y up), and camera to clip (NDC x, y in -1..1 across the image, y up).
  std::array<float, 16> view{}, projection{};
  LabelPlanes labels;  // With RenderOptions::labels; else empty.
};

enum class ImageFormat { kPng, kJpeg, kExr, kTiff, kWebp };
bool ParseImageFormat(const std::string& name, ImageFormat* format);
const char* ImageFormatMimeType(ImageFormat format);
const char* ImageFormatExtension(ImageFormat format);

// How a data plane's values are stored: 32-bit floats (depth: a millimetre at any distance), or
// 16-bit halves (unit normals: 11 bits of mantissa, an angle within 0.06 degrees; half the bytes to
// deflate, hash and write).
enum class DataPrecision { kFloat, kHalf };

// Draws a blended rig (the rig evaluated at some weights) with the rig's node transforms and
// materials into a linear-light image, and encodes images. Implementations are thread-safe; callers
// own them and pass them down (the service owns one for all its threads).
class Renderer {
 public:
  virtual ~Renderer() = default;
  virtual Status Draw(const Rig& rig, const BlendedRig& blended, const RenderOptions& options,
                      Image& out) const = 0;
  // What draws, for logs: "llvmpipe (LLVM 15.0.6, 256 bits), OpenGL 4.5 (Core Profile)
  // Mesa 22.3.6".
  virtual std::string Info() const = 0;
  // How many draws run at once; more wait their turn.
  virtual int Concurrency() const = 0;
  // The file of an image (render/render.h's Encode) and a labelled grid of images (ContactSheet):
  // the encoders live with what draws, so a caller handed a renderer needs nothing else for
  // pictures.
  // `helper_cpu` is charged what the encoder's helper threads spend (null: nowhere).
  virtual Result<std::string> Encode(const Image& image, ImageFormat format, int quality,
                                     HelperCpu* helper_cpu) const = 0;
  virtual Image Sheet(std::span<const Image> cells, std::span<const std::string> labels,
                      int columns, std::array<float, 4> background) const = 0;
  // Whether every character of UTF-8 `text` has a glyph in the fonts the sheet's labels use.
  virtual bool CanDrawText(const std::string& text) const = 0;
  // Label planes as files (render/render.h's EncodeDataExr and EncodeIdPng): `channels` (1 or 3)
  // floats a pixel as an EXR of 32-bit floats or 16-bit halves, and ids as a grey PNG.
  virtual Result<std::string> EncodeData(std::span<const float> values, int width, int height,
                                         int channels, DataPrecision precision) const = 0;
  virtual Result<std::string> EncodeIds(std::span<const uint16_t> ids, int width,
                                        int height) const = 0;
  // PNG/JPEG/EXR/TIFF/BMP/WebP bytes as linear RGBA (a dataset's background pictures).
  virtual Result<Image> DecodePicture(std::span<const unsigned char> bytes,
                                      const std::string& mime_type) const = 0;
};

// The inputs every renderer refuses: an image size outside 1..8192, supersample outside 1..4,
// a blended rig that does not match the rig.
Status CheckDrawInputs(const Rig& rig, const BlendedRig& blended, const RenderOptions& options);

}  // namespace facespace::picture
