// libFuzzer: glb / glTF JSON import from memory (uploads take this path), then the evaluations
// every reader's target does (evaluate.h: at rest, posed, and the glb writer against ExportMesh).
#include <cstddef>
#include <cstdint>
#include <span>

#include "evaluate.h"
#include "facespace/formats/io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  facespace::formats::LoadOptions options;
  options.allow_external_files = false;  // As for uploads: never our own disk.
  options.read_manifest = false;
  auto rig =
      facespace::formats::LoadGltfMemory(std::span<const unsigned char>(data, size), "", options);
  if (!rig.ok()) return 0;
  // A rig that loads must evaluate without touching memory it does not own.
  EvaluateLoadedRig(rig.value(), 0.5f);
  return 0;
}
