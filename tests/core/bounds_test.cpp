// Issue 48 in core: parsers that cannot recurse without bound, a reduce whose work is its input's
// size, work that stops when its token fires, and the request's fault reported as the request's.
#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>
#include <random>
#include <stop_token>

#include "facespace/engine/pose_request.h"
#include "facespace/engine/sequence.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace bounds_test {  // Named: core_tests is a unity build, its files share one unit.

const Rig& FaceCap() {
  static const Rig rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  return rig;
}

// FaceCap's glb with its JSON chunk replaced by `text`.
std::string FaceCapWithJson(const std::function<std::string(const nlohmann::json&)>& text_of) {
  const std::vector<unsigned char> glb = test::ReadBytes(test::Bundled("facecap/facecap.glb"));
  uint32_t json_len = 0;
  std::memcpy(&json_len, glb.data() + 12, 4);
  const nlohmann::json j = nlohmann::json::parse(glb.begin() + 20, glb.begin() + 20 + json_len);
  const std::string bin(glb.begin() + 20 + json_len, glb.end());  // Its chunk header included.
  std::string text = text_of(j);
  while (text.size() % 4) text += ' ';
  std::string out = "glTF";
  auto u32 = [&out](uint32_t v) { out.append(reinterpret_cast<const char*>(&v), 4); };
  u32(2);
  u32(static_cast<uint32_t>(12 + 8 + text.size() + bin.size()));
  u32(static_cast<uint32_t>(text.size()));
  u32(0x4E4F534Au);
  return out + text + bin;
}

Result<Rig> Load(const std::string& glb) {
  return LoadRigMemory(std::span<const unsigned char>(
                           reinterpret_cast<const unsigned char*>(glb.data()), glb.size()),
                       formats::RigFormat::kGltf, "t");
}

// The JSON with `depth` nested arrays where the string "DEEP" was.
std::string Nest(std::string text, size_t depth) {
  const size_t at = text.find("\"DEEP\"");
  return text.replace(at, 6, std::string(depth, '[') + std::string(depth, ']'));
}

TEST(JsonDepth, AGlbNestedDeeperThanTheLimitIsRefusedBeforeTinygltfRecurses) {
  for (size_t depth : {20000u, 100000u}) {
    auto rig = Load(FaceCapWithJson([&](nlohmann::json j) {
      j["asset"]["extras"] = "DEEP";
      return Nest(j.dump(), depth);
    }));
    ASSERT_FALSE(rig.ok()) << depth;
    EXPECT_EQ(rig.status().reason, "too-deep") << rig.status().message;
    EXPECT_EQ(rig.status().code, StatusCode::kInvalidArgument);
  }
  // Inside a VRM 0.x extension too (nlohmann's dump recursed there).
  auto vrm = Load(FaceCapWithJson([](nlohmann::json j) {
    j["extensionsUsed"].push_back("VRM");
    j["extensions"]["VRM"] = {
        {"blendShapeMaster", {{"blendShapeGroups", {{{"name", "x"}, {"binds", "DEEP"}}}}}}};
    return Nest(j.dump(), 100000);
  }));
  EXPECT_EQ(vrm.status().reason, "too-deep");
}

TEST(JsonDepth, ExtrasWithinTheLimitAndBracketsInStringsLoad) {
  auto rig = Load(FaceCapWithJson([](nlohmann::json j) {
    j["asset"]["extras"] = {{"note", std::string(5000, '[') + "\\\"" + std::string(5000, '{')},
                            {"nested", "DEEP"}};
    return Nest(j.dump(), 100);
  }));
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  EXPECT_EQ(rig->shapes.size(), FaceCap().shapes.size());
}

TEST(JsonDepth, AManifestNestedDeeperThanTheLimitIsRefused) {
  Rig rig = FaceCap();
  const Status s = formats::ApplyManifest(
      rig, "{\"groups\":" + std::string(20000, '[') + std::string(20000, ']') + "}");
  EXPECT_EQ(s.reason, "too-deep") << s.message;
}

TEST(Vrm, AMemberOfTheWrongTypeIsTheFilesFaultNamingTheMember) {
  auto rig = Load(FaceCapWithJson([](nlohmann::json j) {
    j["extensionsUsed"].push_back("VRM");
    j["extensions"]["VRM"] = {
        {"blendShapeMaster",
         {{"blendShapeGroups", {{{"name", "joy"}, {"presetName", "joy"}, {"isBinary", "yes"}}}}}}};
    return j.dump();
  }));
  ASSERT_FALSE(rig.ok());
  EXPECT_EQ(rig.status().code, StatusCode::kInvalidArgument);
  EXPECT_EQ(rig.status().reason, "invalid-vrm") << rig.status().message;
  ASSERT_FALSE(rig.status().fields.empty());
  EXPECT_EQ(rig.status().fields[0].pointer,
            "/extensions/VRM/blendShapeMaster/blendShapeGroups/0/isBinary");
}

TEST(Expressions, WeightsPastAFloatAreTheRequestsFault) {
  const Rig& rig = FaceCap();
  PoseRequest r;
  r.expressions = {{"happy", -1, 1e308, "/expressions/happy"}};
  std::vector<float> weights;
  Pose pose;
  bool posed = false;
  std::vector<Warning> warnings;
  const Status s = ResolvePoseAndWeights(rig, {}, r, weights, pose, posed, warnings);
  EXPECT_EQ(s.code, StatusCode::kInvalidArgument) << s.message;
  ASSERT_FALSE(s.fields.empty());
  EXPECT_EQ(s.fields[0].pointer, "/expressions");
}

// Largest vertex distance between the rig at weights a and at b, by brute force.
double Distance(const Rig& rig, std::span<const float> a, std::span<const float> b) {
  double worst = 0;
  for (const Mesh& mesh : rig.meshes) {
    for (int pi : mesh.primitives) {
      const Primitive& p = rig.primitives[pi];
      std::vector<double> d(p.positions.size(), 0.0);
      for (size_t t = 0; t < p.targets.size(); ++t) {
        const double dw = static_cast<double>(a[mesh.target_shapes[t]]) - b[mesh.target_shapes[t]];
        if (dw == 0) continue;
        const SparseTarget& st = p.targets[t];
        for (size_t i = 0; i < st.indices.size(); ++i) {
          for (int k = 0; k < 3; ++k)
            d[3 * st.indices[i] + k] += dw * st.position_deltas[3 * i + k];
        }
      }
      for (size_t v = 0; v < d.size(); v += 3)
        worst = std::max(worst, std::sqrt(d[v] * d[v] + d[v + 1] * d[v + 1] + d[v + 2] * d[v + 2]));
    }
  }
  return worst;
}

Sequence Keys(const Rig& rig, size_t count,
              const std::function<float(size_t key, size_t shape)>& weight) {
  Sequence s;
  for (size_t k = 0; k < count; ++k) {
    Keyframe key;
    key.time = 0.1f * static_cast<float>(k);
    key.weights.resize(rig.shapes.size());
    for (size_t j = 0; j < key.weights.size(); ++j) key.weights[j] = weight(k, j);
    s.keys.push_back(std::move(key));
  }
  return s;
}

// The attack of issue 48 (1,600 identical keys, tolerance 0: 81 s of CPU) at twelve times the keys:
// the bound holds at times between every pair of original keys, and nearly every key goes.
TEST(Reduce, TwentyThousandKeysOfARampKeepTheBoundAndLoseNearlyAll) {
  const Rig& rig = FaceCap();
  const size_t jaw = static_cast<size_t>(FindShape(rig, "jawOpen"));
  const Sequence s = Keys(rig, 20000, [&](size_t k, size_t j) {
    return j == jaw ? static_cast<float>(k) / 20000.0f : 0.1f;
  });
  // FaceCap's mesh units are small (jawOpen moves a vertex 2,400 of them): one float step of a
  // weight is 1.4e-4, so the tolerance stands well above the round-off of sampling at any time.
  const float tolerance = 0.01f;
  auto r = ReduceSequence(rig, s, tolerance);
  ASSERT_TRUE(r.ok()) << r.status().message;
  EXPECT_LT(r->sequence.keys.size(), 200u) << "a ramp is a line: few keys stay";
  EXPECT_EQ(r->removed + r->sequence.keys.size(), s.keys.size());
  EXPECT_LE(r->max_error, tolerance);
  EXPECT_EQ(r->sequence.keys.front().time, s.keys.front().time);
  EXPECT_EQ(r->sequence.keys.back().time, s.keys.back().time);
  std::mt19937 rng(48);
  std::uniform_real_distribution<float> u(s.keys.front().time, s.keys.back().time);
  std::vector<float> a(rig.shapes.size()), b(rig.shapes.size());
  double worst = 0;
  for (int i = 0; i < 400; ++i) {
    const float t = u(rng);
    SampleSequence(s, t, a);
    SampleSequence(r->sequence, t, b);
    worst = std::max(worst, Distance(rig, a, b));
  }
  EXPECT_LE(worst, tolerance * 1.001 + 1e-7);
}

TEST(Reduce, KeysThatTurnStayAndSmoothKeysKeepTheBound) {
  const Rig& rig = FaceCap();
  const size_t jaw = static_cast<size_t>(FindShape(rig, "jawOpen"));
  // A zigzag: every key turns, none may go at a small tolerance.
  const Sequence zig = Keys(rig, 300, [&](size_t k, size_t j) {
    return j == jaw ? static_cast<float>(k % 2) * 0.8f : 0.0f;
  });
  auto r = ReduceSequence(rig, zig, 0.01f);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->sequence.keys.size(), zig.keys.size());
  // A smooth (Catmull-Rom) sine: keys go, and the curve stays within the bound between the kept
  // ones. (The spline is uniform in its keys, so segments of unequal length bend away: at 0.05
  // units of this 2,400-unit motion 1% of the keys go, at 10 units 92%.)
  Sequence sine = Keys(rig, 2000, [&](size_t k, size_t j) {
    return j == jaw ? 0.5f + 0.5f * std::sin(0.01f * static_cast<float>(k)) : 0.0f;
  });
  sine.smooth = true;
  auto sr = ReduceSequence(rig, sine, 10.0f);
  ASSERT_TRUE(sr.ok());
  EXPECT_LT(sr->sequence.keys.size(), sine.keys.size() / 4);
  std::vector<float> a(rig.shapes.size()), b(rig.shapes.size());
  double worst = 0;
  for (size_t k = 0; k + 1 < sine.keys.size(); ++k) {
    for (float q : {0.25f, 0.5f, 0.75f}) {
      const float t = sine.keys[k].time + q * (sine.keys[k + 1].time - sine.keys[k].time);
      SampleSequence(sine, t, a);
      SampleSequence(sr->sequence, t, b);
      worst = std::max(worst, Distance(rig, a, b));
    }
  }
  EXPECT_LE(worst, 10.0 * 1.001);
}

TEST(Reduce, StopsWhenItsTokenFires) {
  const Rig& rig = FaceCap();
  const Sequence s =
      Keys(rig, 1000, [](size_t k, size_t) { return static_cast<float>(k) / 1000.0f; });
  std::stop_source stop;
  stop.request_stop();
  auto r = ReduceSequence(rig, s, 1e-4f, stop.get_token());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code, StatusCode::kCancelled);
}

}  // namespace bounds_test
}  // namespace facespace
