// Shared test helpers: asset paths, tolerances, and an independent raw glTF reader that the
// import tests check core's importer against.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "facespace/engine/blend.h"

namespace facespace::test {

// The largest distance between the same vertex in two evaluations of one rig (positions of every
// primitive).
inline double MaxDistance(const BlendedRig& a, const BlendedRig& b) {
  double worst = 0;
  for (size_t p = 0; p < a.primitives.size() && p < b.primitives.size(); ++p) {
    const std::vector<float>& pa = a.primitives[p].positions;
    const std::vector<float>& pb = b.primitives[p].positions;
    for (size_t v = 0; v + 2 < pa.size() && v + 2 < pb.size(); v += 3) {
      worst = std::max(worst, static_cast<double>(std::hypot(pa[v] - pb[v], pa[v + 1] - pb[v + 1],
                                                             pa[v + 2] - pb[v + 2])));
    }
  }
  return worst;
}

constexpr float kExact = 0.0f;
constexpr float kPositionTol = 1e-5f;  // Relative to the mesh's extent, for float sums.
constexpr float kNormalTol = 1e-4f;

inline std::string SharedAssets() { return FACESPACE_SHARED_ASSETS; }
inline std::string RealAsset(const std::string& rel) { return SharedAssets() + "/real/" + rel; }
inline std::string Bundled(const std::string& rel) {
  return std::string(FACESPACE_SOURCE_DIR) + "/assets/" + rel;
}

inline std::vector<unsigned char> ReadBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<unsigned char>((std::istreambuf_iterator<char>(f)),
                                    std::istreambuf_iterator<char>());
}

inline void WriteBytes(const std::string& path, const std::string& data) {
  std::ofstream f(path, std::ios::binary);
  f.write(data.data(), static_cast<std::streamsize>(data.size()));
}

// A temporary directory removed at the end of the test.
struct TempDir {
  std::filesystem::path path;
  TempDir() {
    char tmpl[] = "/tmp/facespace_test_XXXXXX";
    path = mkdtemp(tmpl);
  }
  ~TempDir() { std::filesystem::remove_all(path); }
  std::string operator/(const std::string& name) const { return (path / name).string(); }
};

// A minimal glTF reader written for the tests only: float32 accessors (strided or sparse),
// buffers from .glb, external .bin or base64 data URIs. No quantization, no meshopt.
class RawGltf {
 public:
  explicit RawGltf(const std::string& path) {
    std::vector<unsigned char> bytes = ReadBytes(path);
    std::string dir = std::filesystem::path(path).parent_path().string();
    std::vector<unsigned char> bin;
    if (bytes.size() > 20 && std::memcmp(bytes.data(), "glTF", 4) == 0) {
      uint32_t jlen;
      std::memcpy(&jlen, &bytes[12], 4);
      json = nlohmann::json::parse(bytes.begin() + 20, bytes.begin() + 20 + jlen);
      size_t pos = 20 + jlen;
      uint32_t blen;
      std::memcpy(&blen, &bytes[pos], 4);
      bin.assign(bytes.begin() + pos + 8, bytes.begin() + pos + 8 + blen);
    } else {
      json = nlohmann::json::parse(bytes.begin(), bytes.end());
    }
    for (const auto& b : json["buffers"]) {
      if (!b.contains("uri")) {
        buffers.push_back(bin);
        continue;
      }
      const std::string uri = b["uri"];
      const size_t comma = uri.find(',');
      if (uri.rfind("data:", 0) == 0) {
        buffers.push_back(Base64(uri.substr(comma + 1)));
      } else {
        buffers.push_back(ReadBytes(dir + "/" + uri));
      }
    }
  }

  // Floats of a float32 accessor, sparse substitution applied.
  std::vector<float> Floats(int index) const {
    const auto& a = json["accessors"][index];
    const int comps = Components(a["type"]);
    const size_t count = a["count"];
    EXPECT_EQ(a["componentType"].get<int>(), 5126) << "test reader handles float32 only";
    std::vector<float> out(count * comps, 0.0f);
    if (a.contains("bufferView")) {
      const auto& bv = json["bufferViews"][a["bufferView"].get<int>()];
      const size_t stride = bv.value("byteStride", comps * 4);
      const size_t off = bv.value("byteOffset", 0) + a.value("byteOffset", 0);
      const auto& buf = buffers[bv["buffer"].get<int>()];
      for (size_t e = 0; e < count; ++e)
        std::memcpy(&out[e * comps], &buf[off + e * stride], comps * 4);
    }
    if (a.contains("sparse")) {
      const auto& sp = a["sparse"];
      const size_t n = sp["count"];
      const auto& ibv = json["bufferViews"][sp["indices"]["bufferView"].get<int>()];
      const auto& vbv = json["bufferViews"][sp["values"]["bufferView"].get<int>()];
      const int ict = sp["indices"]["componentType"];
      const size_t isz = ict == 5121 ? 1 : ict == 5123 ? 2 : 4;
      const auto& ib = buffers[ibv["buffer"].get<int>()];
      const auto& vb = buffers[vbv["buffer"].get<int>()];
      const size_t ioff = ibv.value("byteOffset", 0) + sp["indices"].value("byteOffset", 0);
      const size_t voff = vbv.value("byteOffset", 0) + sp["values"].value("byteOffset", 0);
      for (size_t k = 0; k < n; ++k) {
        uint32_t idx = 0;
        std::memcpy(&idx, &ib[ioff + k * isz], isz);
        std::memcpy(&out[idx * comps], &vb[voff + k * comps * 4], comps * 4);
      }
    }
    return out;
  }

  // Unsigned 16-bit accessor (JOINTS_n), no sparse.
  std::vector<uint16_t> U16(int index) const {
    const auto& a = json["accessors"][index];
    EXPECT_EQ(a["componentType"].get<int>(), 5123) << "test reader handles uint16 only here";
    const int comps = Components(a["type"]);
    const size_t count = a["count"];
    const auto& bv = json["bufferViews"][a["bufferView"].get<int>()];
    const size_t stride = bv.value("byteStride", comps * 2);
    const size_t off = bv.value("byteOffset", 0) + a.value("byteOffset", 0);
    const auto& buf = buffers[bv["buffer"].get<int>()];
    std::vector<uint16_t> out(count * comps);
    for (size_t e = 0; e < count; ++e)
      std::memcpy(&out[e * comps], &buf[off + e * stride], comps * 2);
    return out;
  }

  nlohmann::json json;
  std::vector<std::vector<unsigned char>> buffers;

 private:
  static int Components(const std::string& t) {
    return t == "SCALAR" ? 1
           : t == "VEC2" ? 2
           : t == "VEC3" ? 3
           : t == "VEC4" ? 4
           : t == "MAT4" ? 16
                         : 0;
  }
  static std::vector<unsigned char> Base64(const std::string& s) {
    std::vector<unsigned char> out;
    int val = 0, bits = -8;
    for (unsigned char c : s) {
      const char* table = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      const char* p = std::strchr(table, c);
      if (!p || c == 0) break;
      val = (val << 6) + static_cast<int>(p - table);
      bits += 6;
      if (bits >= 0) {
        out.push_back(static_cast<unsigned char>((val >> bits) & 0xFF));
        bits -= 8;
      }
    }
    return out;
  }
};

// Max |a - b| over two equal-size arrays (fails the test when sizes differ).
inline float MaxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float m = 0.0f;
  for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) m = std::max(m, std::fabs(a[i] - b[i]));
  return m;
}

// The rig at rest into `rest` and with shape `s` alone at weight 1 into `shaped`.
inline void RestAndShape(const Rig& rig, int s, BlendedRig& rest, BlendedRig& shaped) {
  std::vector<float> zero(rig.shapes.size(), 0.0f), one = zero;
  one[static_cast<size_t>(s)] = 1.0f;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig, zero, {}, rest, ctx).ok());
  ASSERT_TRUE(EvaluateRig(rig, one, {}, shaped, ctx).ok());
}

}  // namespace facespace::test
