// glTF accessors read as floats or indices, every offset checked against its buffer.
#include <cmath>
#include <cstring>

#include "gltf/gltf_common.h"

namespace facespace::formats {

namespace {

// ---- accessors ----------------------------------------------------------------------------

int ComponentCount(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}

float ConvertComponent(const unsigned char* p, int component_type, bool normalized) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float f;
      std::memcpy(&f, p, 4);
      return f;
    }
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      const int8_t v = static_cast<int8_t>(p[0]);
      return normalized ? std::max(v / 127.0f, -1.0f) : static_cast<float>(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
      return normalized ? p[0] / 255.0f : static_cast<float>(p[0]);
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(v / 32767.0f, -1.0f) : static_cast<float>(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? v / 65535.0f : static_cast<float>(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return normalized ? static_cast<float>(v / 4294967295.0) : static_cast<float>(v);
    }
  }
  return 0.0f;
}

// Bytes [offset, offset + length) of a bufferView, checked against its buffer.
Status ViewBytes(const tinygltf::Model& m, int view_index, std::span<const unsigned char>& out,
                 size_t& stride) {
  if (view_index < 0 || static_cast<size_t>(view_index) >= m.bufferViews.size()) {
    return InvalidArgument("bufferView " + std::to_string(view_index) + " does not exist");
  }
  const tinygltf::BufferView& v = m.bufferViews[view_index];
  if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= m.buffers.size()) {
    return InvalidArgument("bufferView " + std::to_string(view_index) + " names a missing buffer");
  }
  const std::vector<unsigned char>& data = m.buffers[v.buffer].data;
  if (v.byteOffset > data.size() || v.byteLength > data.size() - v.byteOffset) {
    return InvalidArgument("bufferView " + std::to_string(view_index) +
                           " lies beyond its buffer (" + std::to_string(v.byteOffset) + "+" +
                           std::to_string(v.byteLength) + " > " + std::to_string(data.size()) +
                           " bytes)");
  }
  out = std::span<const unsigned char>(data.data() + v.byteOffset, v.byteLength);
  stride = v.byteStride;
  return Status::Ok();
}

// Element e of a strided array inside `bytes`, or nullptr when it would lie outside.
const unsigned char* Element(std::span<const unsigned char> bytes, size_t offset, size_t stride,
                             size_t e, size_t element_size) {
  const size_t start = offset + stride * e;
  if (start < offset || start > bytes.size() || element_size > bytes.size() - start) return nullptr;
  return bytes.data() + start;
}

}  // namespace

int ComponentSize(int component_type) {
  switch (component_type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}

Status ReadAccessor(const tinygltf::Model& m, int index, std::vector<float>& out, int& components,
                    const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= m.accessors.size()) {
    return InvalidArgument(what + ": accessor " + std::to_string(index) + " does not exist");
  }
  const tinygltf::Accessor& a = m.accessors[index];
  const std::string where = what + " (accessor " + std::to_string(index) + ")";
  components = ComponentCount(a.type);
  const int csize = ComponentSize(a.componentType);
  if (components == 0 || csize == 0)
    return InvalidArgument(where + ": unsupported type or componentType");
  if (a.count > kMaxElements) return InvalidArgument(where + ": count too large");
  const size_t esize = static_cast<size_t>(components) * csize;
  out.assign(a.count * components, 0.0f);
  if (a.bufferView >= 0) {
    std::span<const unsigned char> bytes;
    size_t stride = 0;
    if (Status s = ViewBytes(m, a.bufferView, bytes, stride); !s.ok())
      return InvalidArgument(where + ": " + s.message);
    if (stride == 0) stride = esize;
    if (stride < esize) return InvalidArgument(where + ": byteStride smaller than an element");
    if (a.count > 0 && !Element(bytes, a.byteOffset, stride, a.count - 1, esize)) {
      return InvalidArgument(where + ": data lies beyond its bufferView");
    }
    for (size_t e = 0; e < a.count; ++e) {
      const unsigned char* p = bytes.data() + a.byteOffset + stride * e;
      for (int c = 0; c < components; ++c) {
        out[e * components + c] = ConvertComponent(p + c * csize, a.componentType, a.normalized);
      }
    }
  }
  if (a.sparse.isSparse) {
    const size_t count =
        a.sparse.count < 0 ? kMaxElements + 1 : static_cast<size_t>(a.sparse.count);
    if (count > a.count) return InvalidArgument(where + ": sparse count exceeds accessor count");
    const int isize = ComponentSize(a.sparse.indices.componentType);
    if (isize == 0 || a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
        a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
        a.sparse.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
      return InvalidArgument(where + ": sparse indices must be unsigned integers");
    }
    if (a.sparse.indices.byteOffset < 0 || a.sparse.values.byteOffset < 0) {
      return InvalidArgument(where + ": negative sparse byteOffset");
    }
    std::span<const unsigned char> ibytes, vbytes;
    size_t istride = 0, vstride = 0;
    if (Status s = ViewBytes(m, a.sparse.indices.bufferView, ibytes, istride); !s.ok()) {
      return InvalidArgument(where + ": sparse indices: " + s.message);
    }
    if (Status s = ViewBytes(m, a.sparse.values.bufferView, vbytes, vstride); !s.ok()) {
      return InvalidArgument(where + ": sparse values: " + s.message);
    }
    if (count > 0 && (!Element(ibytes, a.sparse.indices.byteOffset, isize, count - 1, isize) ||
                      !Element(vbytes, a.sparse.values.byteOffset, esize, count - 1, esize))) {
      return InvalidArgument(where + ": sparse data lies beyond its bufferView");
    }
    for (size_t k = 0; k < count; ++k) {
      const unsigned char* ip = ibytes.data() + a.sparse.indices.byteOffset + isize * k;
      const uint32_t target =
          static_cast<uint32_t>(ConvertComponent(ip, a.sparse.indices.componentType, false));
      if (target >= a.count)
        return InvalidArgument(where + ": sparse index " + std::to_string(target) +
                               " beyond count");
      const unsigned char* vp = vbytes.data() + a.sparse.values.byteOffset + esize * k;
      for (int c = 0; c < components; ++c) {
        out[target * components + c] =
            ConvertComponent(vp + c * csize, a.componentType, a.normalized);
      }
    }
  }
  for (float f : out) {
    if (!std::isfinite(f)) return InvalidArgument(where + ": contains NaN or infinity");
  }
  return Status::Ok();
}

Status ReadIndices(const tinygltf::Model& m, int index, std::vector<uint32_t>& out,
                   const std::string& what) {
  if (index < 0 || static_cast<size_t>(index) >= m.accessors.size()) {
    return InvalidArgument(what + ": accessor " + std::to_string(index) + " does not exist");
  }
  const tinygltf::Accessor& a = m.accessors[index];
  if (a.type != TINYGLTF_TYPE_SCALAR ||
      (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
       a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
       a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)) {
    return InvalidArgument(what + ": indices must be unsigned integer scalars");
  }
  std::vector<float> tmp;
  int comps = 0;
  // Unsigned 32-bit values above 2^24 do not survive a float; read them directly.
  if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT && !a.sparse.isSparse) {
    std::span<const unsigned char> bytes;
    size_t stride = 0;
    if (Status s = ViewBytes(m, a.bufferView, bytes, stride); !s.ok())
      return InvalidArgument(what + ": " + s.message);
    if (stride == 0) stride = 4;
    if (a.count > kMaxElements) return InvalidArgument(what + ": count too large");
    if (a.count > 0 && !Element(bytes, a.byteOffset, stride, a.count - 1, 4)) {
      return InvalidArgument(what + ": data lies beyond its bufferView");
    }
    out.resize(a.count);
    for (size_t e = 0; e < a.count; ++e) out[e] = ReadU32(bytes.data() + a.byteOffset + stride * e);
    return Status::Ok();
  }
  if (Status s = ReadAccessor(m, index, tmp, comps, what); !s.ok()) return s;
  out.resize(tmp.size());
  for (size_t i = 0; i < tmp.size(); ++i) out[i] = static_cast<uint32_t>(tmp[i]);
  return Status::Ok();
}
}  // namespace facespace::formats
