// libFuzzer: the PMX reader (the bytes are the .pmx file), then an evaluation at rest with every
// shape at 0.7.
#include <cstddef>
#include <cstdint>
#include <span>

#include "facespace/core/io.h"
#include "evaluate.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  auto rig = facespace::LoadPmxMemory(std::span<const unsigned char>(data, size), "fuzz");
  if (rig.ok()) EvaluateLoadedRig(rig.value(), 0.7f);
  return 0;
}
