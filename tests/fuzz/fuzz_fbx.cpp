// libFuzzer: the FBX reader (binary and ASCII: the bytes are the file), then an evaluation at rest
// with every shape at 0.7 (in-betweens included), and at a clip time.
#include <cstddef>
#include <cstdint>
#include <span>

#include "evaluate.h"
#include "facespace/formats/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto rig = facespace::formats::LoadFbxMemory(std::span<const unsigned char>(data, size), "fuzz");
  if (rig.ok()) EvaluateLoadedRig(rig.value(), 0.7f);
  return 0;
}
