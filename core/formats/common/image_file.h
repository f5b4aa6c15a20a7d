// Reading a texture file for a rig, as every reader that finds its images beside the model does
// (LoadImagesBeside; MakeHuman's proxy materials).
#pragma once

#include <filesystem>
#include <string>

#include "facespace/engine/rig.h"

namespace facespace::formats {

// Reads `file` into `image` (bytes and mime type, the type told by the magic, TGA by its
// extension): at most 64 MiB, PNG, JPEG, BMP or TGA. Empty on success, else why not ("no such
// file", "empty or over 64 MiB", "not a PNG, JPEG, BMP or TGA image"); `image` is untouched then.
std::string ReadImageFile(const std::filesystem::path& file, Image& image);

}  // namespace facespace::formats
