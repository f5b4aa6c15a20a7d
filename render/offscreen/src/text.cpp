// Text on images with FreeType: DejaVu Sans, and Noto Sans CJK for what DejaVu has no glyph for
// (Uka's Japanese shape names on a contact sheet). OpenImageIO 2.4's render_text decodes UTF-8
// wrongly (ま drew as '>'), so labels are drawn here, glyph by glyph, over linear RGBA.
#include "text.h"

#include <ft2build.h>

#include "facespace/engine/utf8.h"
#include FT_FREETYPE_H

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>

namespace facespace::offscreen {

namespace {

// Code points of UTF-8 text; a byte that starts no well-formed sequence is U+FFFD.
std::u32string Decode(std::string_view s) {
  std::u32string out;
  for (size_t i = 0; i < s.size();) {
    char32_t cp = 0;
    const size_t n = DecodeUtf8(s, i, cp);
    out.push_back(n ? cp : 0xFFFD);
    i += n ? n : 1;
  }
  return out;
}

std::string FirstFile(std::initializer_list<const char*> paths) {
  for (const char* p : paths) {
    if (std::filesystem::exists(p)) return p;
  }
  return "";
}

// The faces, opened once; FreeType faces are not thread-safe, so each use holds the lock (labels
// are a few dozen glyphs: the lock is held for microseconds).
class Fonts {
 public:
  static Fonts& Get() {
    static Fonts fonts;
    return fonts;
  }
  std::mutex mu;
  FT_Face latin = nullptr, cjk = nullptr;

  // The face that has `cp` (the Latin one first), and the glyph's index there; 0 when none has it.
  std::pair<FT_Face, FT_UInt> Glyph(char32_t cp) const {
    for (FT_Face f : {latin, cjk}) {
      if (!f) continue;
      if (const FT_UInt g = FT_Get_Char_Index(f, cp)) return {f, g};
    }
    return {latin ? latin : cjk, 0};  // The .notdef box.
  }

 private:
  Fonts() {
    if (FT_Init_FreeType(&lib_) != 0) return;
    const std::string latin_path = FirstFile(
        {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"});
    // Noto Sans CJK's collection: its first face is the Japanese one (fonts-noto-cjk).
    const std::string cjk_path =
        FirstFile({"/usr/share/fonts/opentype/noto/NotoSansCJK-Regular.ttc",
                   "/usr/share/fonts/noto-cjk/NotoSansCJK-Regular.ttc"});
    if (!latin_path.empty() && FT_New_Face(lib_, latin_path.c_str(), 0, &latin) != 0)
      latin = nullptr;
    if (!cjk_path.empty() && FT_New_Face(lib_, cjk_path.c_str(), 0, &cjk) != 0) cjk = nullptr;
  }
  ~Fonts() {
    if (latin) FT_Done_Face(latin);
    if (cjk) FT_Done_Face(cjk);
    if (lib_) FT_Done_FreeType(lib_);
  }
  FT_Library lib_ = nullptr;
};

// Walks the glyphs of `text` at `size` pixels from pen x = 0 on the baseline: calls
// `glyph(bitmap, left, top, pen_x)` for each rendered glyph (when `render`), returns the advance.
template <typename F>
int Walk(Fonts& fonts, const std::u32string& text, int size, bool render, F&& glyph) {
  int pen = 0;
  for (char32_t cp : text) {
    const auto [face, index] = fonts.Glyph(cp);
    if (!face) return -1;
    if (FT_Set_Pixel_Sizes(face, 0, static_cast<FT_UInt>(size)) != 0) return -1;
    if (FT_Load_Glyph(face, index, render ? FT_LOAD_RENDER : FT_LOAD_DEFAULT) != 0) continue;
    const FT_GlyphSlot g = face->glyph;
    if (render) glyph(g->bitmap, g->bitmap_left, g->bitmap_top, pen);
    pen += static_cast<int>(g->advance.x >> 6);
  }
  return pen;
}

}  // namespace

bool CanDrawText(const std::string& text) {
  Fonts& fonts = Fonts::Get();
  std::lock_guard<std::mutex> lock(fonts.mu);
  for (char32_t cp : Decode(text)) {
    if (cp == 0xFFFD || fonts.Glyph(cp).second == 0) return false;
  }
  return true;
}

int TextAdvance(const std::string& text, int size) {
  if (text.empty() || size < 1) return 0;
  Fonts& fonts = Fonts::Get();
  std::lock_guard<std::mutex> lock(fonts.mu);
  return Walk(fonts, Decode(text), std::min(size, 512), false,
              [](const FT_Bitmap&, int, int, int) {});
}

bool DrawGlyphs(float* rgba, int width, int height, int x, int y, const std::string& text, int size,
                const float linear[3]) {
  if (text.empty() || size < 1) return false;
  Fonts& fonts = Fonts::Get();
  std::lock_guard<std::mutex> lock(fonts.mu);
  bool inked = false;
  const int advance = Walk(fonts, Decode(text), std::min(size, 512), true,
                           [&](const FT_Bitmap& b, int left, int top, int pen) {
                             for (unsigned row = 0; row < b.rows; ++row) {
                               const int py = y - top + static_cast<int>(row);
                               if (py < 0 || py >= height) continue;
                               for (unsigned col = 0; col < b.width; ++col) {
                                 const int px = x + pen + left + static_cast<int>(col);
                                 if (px < 0 || px >= width) continue;
                                 const float a =
                                     b.buffer[row * static_cast<unsigned>(b.pitch) + col] /
                                     255.0f;  // Grey coverage.
                                 if (a <= 0.0f) continue;
                                 float* p = &rgba[(static_cast<size_t>(py) * width + px) * 4];
                                 for (int c = 0; c < 3; ++c) p[c] += (linear[c] - p[c]) * a;
                                 p[3] = std::max(p[3], a);
                                 inked = true;
                               }
                             }
                           });
  return advance >= 0 && inked;
}

}  // namespace facespace::offscreen
