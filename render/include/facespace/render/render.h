// Offscreen rendering of a blended rig (OSMesa, llvmpipe) and image encoding (OpenImageIO).
// GL and OIIO types stay inside render/src.
#pragma once

#include <array>
#include <span>
#include <string>
#include <vector>

#include "facespace/core/blend.h"
#include "facespace/core/rig.h"
#include "facespace/core/status.h"

namespace facespace::render {

enum class View {
  kShaded,     // Blinn-Phong with the material's base colour factor and texture.
  kWireframe,  // Shaded with the triangle edges drawn over it.
  kHeatmap,    // Per-vertex displacement from the base shape, viridis colour map, legend.
  kNormals,    // World-space normals as colours (n * 0.5 + 0.5).
};

bool ParseView(const std::string& name, View* view);
const char* ViewName(View view);

struct Camera {
  float yaw = 0.0f;       // Degrees around the vertical axis; 0 looks at the model's front (+Z).
  float pitch = 0.0f;     // Degrees up (positive) or down.
  float distance = 0.0f;  // From the framed centre; 0 frames the bounding sphere.
  float zoom = 1.0f;      // Divides the distance.
  float fov = 30.0f;      // Vertical field of view, degrees.
  bool look_at = false;   // Use eye/target/up instead of the orbit above.
  bool frame_shapes = false;  // Orbit around the vertices the rig's shapes move (ShapeFocusBox: a face on a whole body).
  // The box frame_shapes orbits, when the caller has it already (ShapeFocusBox of the rig,
  // kept by a caller that renders one rig many times); computed per render otherwise.
  bool has_focus = false;
  std::array<float, 3> focus_min{0, 0, 0}, focus_max{0, 0, 0};
  std::array<float, 3> eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
};

struct RenderOptions {
  int width = 512;
  int height = 512;
  View view = View::kShaded;
  Camera camera;
  std::array<float, 4> background{0.86f, 0.87f, 0.89f, 1.0f};  // sRGB, alpha 0 = transparent.
  int supersample = 1;                           // 1..4: render at N x N the size, box-filter down.
};

// Linear-light RGBA, top row first. Encoding converts to sRGB for 8-bit formats.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgba;
};

// Renders `blended` (the rig evaluated at some weights) with the rig's node transforms and
// materials. Thread-safe: the GL part leases one of a bounded set of contexts (SetMaxContexts),
// so renders run in parallel up to that many and wait beyond it.
Status Render(const Rig& rig, const BlendedRig& blended, const RenderOptions& options, Image& out);

// How many GL contexts may exist at once (each holds its framebuffer: about 20 MB at
// 1024 x 1024 samples). 0, the default: one per core.
void SetMaxContexts(int n);
int MaxContexts();

// "llvmpipe (LLVM 15.0.6, 256 bits), OpenGL 4.5 (Core Profile) Mesa 22.3.6".
std::string RendererInfo();

enum class ImageFormat { kPng, kJpeg, kExr, kTiff };
bool ParseImageFormat(const std::string& name, ImageFormat* format);
const char* ImageFormatMimeType(ImageFormat format);
const char* ImageFormatExtension(ImageFormat format);

// Encodes to file bytes: PNG/JPEG/TIFF as 8-bit sRGB (alpha kept where the format has it),
// EXR as linear half floats. `quality` is JPEG's 1..100.
Result<std::string> Encode(const Image& image, ImageFormat format, int quality = 90);

// Decodes PNG/JPEG/... bytes to linear RGBA (for tests and textures).
Result<Image> Decode(std::span<const unsigned char> bytes);

// Draws text (DejaVu Sans, sRGB colour) at pixel (x, y) = baseline start. False if no font.
bool DrawText(Image& image, int x, int y, const std::string& text, int size, std::array<float, 3> srgb);

// A grid of cells, `columns` wide, each labelled under its picture.
Image ContactSheet(std::span<const Image> cells, std::span<const std::string> labels, int columns,
                   std::array<float, 4> background);

}  // namespace facespace::render
