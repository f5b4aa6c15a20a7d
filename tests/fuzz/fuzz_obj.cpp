// libFuzzer: OBJ import, MakeHuman .target import and MakeHuman proxy (.mhclo) fitting (all read
// files: the input is written to a private temporary folder). The first byte picks the parser.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"

namespace {

const std::string& Dir() {
  static const std::string dir =
      [] {
        std::string d = std::filesystem::temp_directory_path() /
                        ("facespace-fuzz-obj-" + std::to_string(getpid()));
        std::filesystem::create_directories(d + "/targets");
        // A small base for the target files: a quad split in two triangles, 4 vertices.
        std::ofstream(d + "/base.obj")
            << "g body\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n";
        // For the proxy: its OBJ (one triangle) and a fixed target moving two base vertices.
        std::filesystem::create_directories(d + "/fixed");
        std::ofstream(d + "/p.obj")
            << "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n";
        std::ofstream(d + "/fixed/t.target") << "0 0.1 0 0\n2 0 0.2 0.3\n";
        return d;
      }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string& dir = Dir();
  const int mode = data[0] % 3;  // 0: OBJ, 1: .target, 2: .mhclo.
  const std::string path = mode == 1   ? dir + "/targets/t.target"
                           : mode == 2 ? dir + "/p.mhclo"
                                       : dir + "/in.obj";
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data + 1), static_cast<std::streamsize>(size - 1));
  }
  facespace::formats::MakeHumanOptions proxy;
  proxy.proxies = {path};
  facespace::Result<facespace::Rig> rig =
      mode == 1   ? facespace::formats::LoadMakeHuman(dir + "/base.obj",
                                                      std::vector<std::string>{dir + "/targets"}, {})
      : mode == 2 ? facespace::formats::LoadMakeHuman(
                        dir + "/base.obj", std::vector<std::string>{dir + "/fixed"}, proxy)
                  : facespace::formats::LoadObjSequence(std::vector<std::string>{path});
  if (!rig.ok()) return 0;
  std::vector<float> w(rig->shapes.size(), 1.0f);
  facespace::BlendedRig out;
  facespace::BlendContext ctx;
  facespace::EvaluateRig(rig.value(), w, {}, out, ctx);
  return 0;
}
