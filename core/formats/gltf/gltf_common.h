// Accessor readers shared by the glTF importer and its tests. Private to core.
#pragma once

#include <tiny_gltf.h>

#include <string>
#include <vector>

#include "facespace/core/status.h"

namespace facespace {

// Reads any accessor (float, normalized or plain integers, sparse or not) as floats,
// `components` per element, checking every offset against its buffer.
Status ReadAccessor(const tinygltf::Model& m, int index, std::vector<float>& out, int& components,
                    const std::string& what);

// Reads an unsigned integer scalar accessor.
Status ReadIndices(const tinygltf::Model& m, int index, std::vector<uint32_t>& out, const std::string& what);

}  // namespace facespace
