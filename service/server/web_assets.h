// The character-creator page (service/web), embedded at build time so the binary serves it
// with no files beside it.
#pragma once

#include <cstddef>

namespace facespace::web {

struct Asset {
  const char* path;  // "/index.html", "/app.js", ...
  const unsigned char* data;
  size_t size;
};

extern const Asset kAssets[];
extern const size_t kAssetCount;

}  // namespace facespace::web
