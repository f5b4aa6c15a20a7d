// libFuzzer: the MMD model readers (the bytes are a .pmx file, or a .pmd when they start "Pmd"),
// then an evaluation at rest with every shape at 0.7.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

#include "evaluate.h"
#include "facespace/formats/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const unsigned char> bytes(data, size);
  const bool pmd = size >= 3 && std::memcmp(data, "Pmd", 3) == 0;
  auto rig = pmd ? facespace::formats::LoadPmdMemory(bytes, "fuzz")
                 : facespace::formats::LoadPmxMemory(bytes, "fuzz");
  if (rig.ok()) EvaluateLoadedRig(rig.value(), 0.7f);
  return 0;
}
