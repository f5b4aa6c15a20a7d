// libFuzzer: the MD5 reader (.md5mesh, and an .md5anim when the first byte's low bit is set: the
// rest is the mesh text, a NUL, then the clip text), then an evaluation at rest and at a clip time.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "evaluate.h"
#include "facespace/formats/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const std::string_view all(reinterpret_cast<const char*>(data + 1), size - 1);
  std::string_view mesh = all;
  std::vector<std::pair<std::string, std::string>> anims;
  if (data[0] & 1) {
    const size_t nul = all.find('\0');
    if (nul != std::string_view::npos) {
      mesh = all.substr(0, nul);
      anims.emplace_back("clip", std::string(all.substr(nul + 1)));
    }
  }
  auto rig = facespace::formats::LoadMd5Memory(mesh, "fuzz.md5mesh", anims);
  if (rig.ok()) EvaluateLoadedRig(rig.value(), 0.0f);
  return 0;
}
