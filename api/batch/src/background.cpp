// A dataset's background pictures: a folder's files decoded once, scaled to cover the render, and
// blended behind each sample's transparent pixels.
#include "background.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "facespace/batch/dataset.h"
#include "facespace/engine/color.h"

namespace facespace::batch {

namespace {

namespace fs = std::filesystem;

constexpr uintmax_t kMaxFileBytes = uintmax_t{64} << 20;
constexpr size_t kMaxHeldBytes = size_t{512} << 20;  // All the pictures, scaled, together.

// Whether a file's extension names a picture (the decoder itself tells the format by its magic).
bool IsPicture(std::string ext) {
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  for (const char* e : {".png", ".jpg", ".jpeg", ".webp", ".exr", ".tif", ".tiff", ".bmp"}) {
    if (ext == e) return true;
  }
  return false;
}

// `picture` (linear RGBA) scaled to cover w x h, centred, sampled bilinearly.
BatchPlan::Background Covering(std::string name, const picture::Image& picture, int w, int h) {
  BatchPlan::Background bg{std::move(name), {}, {}};
  const double scale =
      std::max(static_cast<double>(w) / picture.width, static_cast<double>(h) / picture.height);
  const double x0 = (picture.width - w / scale) / 2, y0 = (picture.height - h / scale) / 2;
  bg.linear.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * 3);
  bg.srgb8.resize(bg.linear.size());
  auto at = [&](int x, int y, int c) {
    x = std::clamp(x, 0, picture.width - 1), y = std::clamp(y, 0, picture.height - 1);
    return picture.rgba[(static_cast<size_t>(y) * static_cast<size_t>(picture.width) +
                         static_cast<size_t>(x)) *
                            4 +
                        static_cast<size_t>(c)];
  };
  for (int y = 0; y < h; ++y) {
    const double sy = y0 + (y + 0.5) / scale - 0.5;
    const int iy = static_cast<int>(std::floor(sy));
    const float fy = static_cast<float>(sy - iy);
    for (int x = 0; x < w; ++x) {
      const double sx = x0 + (x + 0.5) / scale - 0.5;
      const int ix = static_cast<int>(std::floor(sx));
      const float fx = static_cast<float>(sx - ix);
      for (int c = 0; c < 3; ++c) {
        const float top = at(ix, iy, c) * (1 - fx) + at(ix + 1, iy, c) * fx,
                    bottom = at(ix, iy + 1, c) * (1 - fx) + at(ix + 1, iy + 1, c) * fx;
        const size_t k =
            (static_cast<size_t>(y) * static_cast<size_t>(w) + static_cast<size_t>(x)) * 3 +
            static_cast<size_t>(c);
        bg.linear[k] = top * (1 - fy) + bottom * fy;
        bg.srgb8[k] = static_cast<unsigned char>(std::lround(SrgbEncode(bg.linear[k]) * 255.0));
      }
    }
  }
  return bg;
}

Status Refused(const std::string& message) {
  return WithReason(InvalidField("/randomize/background/images", message), "invalid-request");
}

}  // namespace

Status LoadBackgroundImages(BatchPlan& plan, const picture::Renderer& renderer) {
  const std::string& dir = plan.request.dataset.randomize.background_images;
  if (dir.empty()) return Status::Ok();
  std::error_code ec;
  std::vector<fs::path> files;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec) && IsPicture(it->path().extension().string()))
      files.push_back(it->path());
  }
  if (ec) return Refused("cannot read the folder '" + dir + "': " + ec.message());
  if (files.empty())
    return Refused("'" + dir + "' holds no pictures (.png, .jpg, .webp, .exr, .tif, .bmp)");
  if (files.size() > kMaxBackgrounds)
    return Refused("'" + dir + "' holds " + std::to_string(files.size()) + " pictures; at most " +
                   std::to_string(kMaxBackgrounds));
  std::sort(files.begin(), files.end());
  const int w = plan.output.render.width, h = plan.output.render.height;
  if (files.size() * static_cast<size_t>(w) * static_cast<size_t>(h) * 15 > kMaxHeldBytes) {
    return Refused(std::to_string(files.size()) + " pictures at " + std::to_string(w) + " x " +
                   std::to_string(h) + " are over 512 MB held; use fewer");
  }
  nlohmann::json listed = nlohmann::json::array();
  for (const fs::path& f : files) {
    const uintmax_t size = fs::file_size(f, ec);
    if (ec || size > kMaxFileBytes)
      return Refused("'" + f.filename().string() + "' is over 64 MB or cannot be read");
    std::ifstream in(f, std::ios::binary);
    std::vector<unsigned char> bytes(static_cast<size_t>(size));
    if (!in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size)))
      return Refused("cannot read '" + f.filename().string() + "'");
    auto picture = renderer.DecodePicture(bytes, "");
    if (!picture.ok())
      return Refused("'" + f.filename().string() + "': " + picture.status().message);
    plan.backgrounds.push_back(Covering(f.filename().string(), picture.value(), w, h));
    listed.push_back({{"name", f.filename().string()}, {"bytes", size}});
  }
  // Another folder's pictures make another batch: batch.json names them.
  nlohmann::json spec = nlohmann::json::parse(plan.spec_json);
  spec["background_images"] = std::move(listed);
  plan.spec_json = spec.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  return Status::Ok();
}

void BlendOver(picture::Image& image, const BatchPlan::Background& bg) {
  const size_t n = static_cast<size_t>(image.width) * static_cast<size_t>(image.height);
  if (bg.linear.size() != 3 * n) return;
  if (!image.srgb8.empty()) {
    static const std::array<float, 256> linear = [] {
      std::array<float, 256> t{};
      for (size_t i = 0; i < 256; ++i)
        t[i] = static_cast<float>(SrgbDecode(static_cast<double>(i) / 255.0));
      return t;
    }();
    for (size_t p = 0; p < n; ++p) {
      unsigned char* px = &image.srgb8[4 * p];
      if (px[3] == 255) continue;
      const float a = px[3] / 255.0f;
      for (size_t c = 0; c < 3; ++c) {
        px[c] = a == 0.0f
                    ? bg.srgb8[3 * p + c]
                    : static_cast<unsigned char>(std::lround(
                          SrgbEncode(linear[px[c]] * a + bg.linear[3 * p + c] * (1 - a)) * 255.0));
      }
      px[3] = 255;
    }
    return;
  }
  for (size_t p = 0; p < n && 4 * p + 3 < image.rgba.size(); ++p) {
    float* px = &image.rgba[4 * p];
    const float a = std::clamp(px[3], 0.0f, 1.0f);
    for (size_t c = 0; c < 3; ++c) px[c] = px[c] * a + bg.linear[3 * p + c] * (1 - a);
    px[3] = 1.0f;
  }
}

}  // namespace facespace::batch
