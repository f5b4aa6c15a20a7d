// libFuzzer: glb / glTF JSON import from memory (uploads take this path), then one evaluation.
#include <cstddef>
#include <cstdint>
#include <span>

#include "facespace/core/blend.h"
#include "facespace/core/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  facespace::LoadOptions options;
  options.allow_external_files = false;  // As for uploads: never our own disk.
  options.read_manifest = false;
  auto rig = facespace::LoadGltfMemory(std::span<const unsigned char>(data, size), "", options);
  if (!rig.ok()) return 0;
  // A rig that loads must evaluate without touching memory it does not own.
  std::vector<float> w(rig->shapes.size(), 0.5f);
  facespace::BlendedRig out;
  facespace::BlendContext ctx;
  facespace::EvaluateRig(rig.value(), w, {}, out, ctx);
  return 0;
}
