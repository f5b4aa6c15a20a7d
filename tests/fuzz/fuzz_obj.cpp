// libFuzzer: OBJ import and MakeHuman .target import (both read files: the input is written to
// a private temporary folder). The first byte picks the parser.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "facespace/core/blend.h"
#include "facespace/formats/io.h"

namespace {

const std::string& Dir() {
  static const std::string dir = [] {
    std::string d = std::filesystem::temp_directory_path() / ("facespace-fuzz-obj-" + std::to_string(getpid()));
    std::filesystem::create_directories(d + "/targets");
    // A small base for the target files: a quad split in two triangles, 4 vertices.
    std::ofstream(d + "/base.obj") << "g body\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string& dir = Dir();
  const bool target = data[0] & 1;
  const std::string path = target ? dir + "/targets/t.target" : dir + "/in.obj";
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  facespace::Result<facespace::Rig> rig = target ? facespace::LoadMakeHuman(dir + "/base.obj", std::vector<std::string>{dir + "/targets"}, {})
                                                 : facespace::LoadObjSequence(std::vector<std::string>{path});
  if (!rig.ok()) return 0;
  std::vector<float> w(rig->shapes.size(), 1.0f);
  facespace::BlendedRig out;
  facespace::BlendContext ctx;
  facespace::EvaluateRig(rig.value(), w, {}, out, ctx);
  return 0;
}
