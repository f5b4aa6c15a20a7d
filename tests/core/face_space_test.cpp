#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <set>
#include <sstream>

#include "facespace/engine/variants.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace face_space_test {  // Named: core_tests is a unity build, its files share one unit.

Rig FaceCap() {
  auto rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb"));
  EXPECT_TRUE(rig.ok());
  return std::move(rig.value());
}

std::vector<float> Sample(const Rig& rig, const SampleSpec& spec, size_t index) {
  std::vector<float> w(rig.shapes.size(), -99.0f);
  SampleVariant(rig, spec, index, w);
  return w;
}

TEST(Variants, SameSeedAndIndexGiveTheSameWeightsInAnyOrder) {
  const Rig rig = FaceCap();
  SampleSpec spec{.method = SampleMethod::kUniform, .seed = 5, .count = 100};
  const auto a = Sample(rig, spec, 42);
  Sample(rig, spec, 7);  // Other variants in between change nothing: no shared state.
  EXPECT_EQ(Sample(rig, spec, 42), a);
  EXPECT_NE(Sample(rig, spec, 43), a);
  spec.seed = 6;
  EXPECT_NE(Sample(rig, spec, 42), a);
}

TEST(Variants, UniformCoversEachRangeEvenly) {
  Rig rig = FaceCap();
  const int jaw = FindShape(rig, "jawOpen");
  rig.shapes[jaw].min = -0.5f;
  rig.shapes[jaw].max = 1.5f;
  SampleSpec spec{.method = SampleMethod::kUniform, .seed = 1, .count = 4000};
  double sum = 0, lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < spec.count; ++i) {
    const auto w = Sample(rig, spec, i);
    for (size_t s = 0; s < w.size(); ++s) {
      ASSERT_GE(w[s], rig.shapes[s].min);
      ASSERT_LE(w[s], rig.shapes[s].max);
    }
    sum += w[jaw];
    lo = std::min<double>(lo, w[jaw]);
    hi = std::max<double>(hi, w[jaw]);
  }
  EXPECT_NEAR(sum / spec.count, 0.5, 0.03);  // Mean of U(-0.5, 1.5).
  EXPECT_LT(lo, -0.49);
  EXPECT_GT(hi, 1.49);
}

TEST(Variants, ActiveFixedAndSumCap) {
  const Rig rig = FaceCap();
  const uint32_t blink = FindShape(rig, "eyeBlink_L");
  SampleSpec spec{.method = SampleMethod::kUniform,
                  .seed = 3,
                  .count = 200,
                  .fixed = {{blink, 0.25f}},
                  .active = 5,
                  .sum_at_most_one = true};
  ASSERT_TRUE(ValidateSampleSpec(rig, spec).ok());
  for (size_t i = 0; i < spec.count; ++i) {
    const auto w = Sample(rig, spec, i);
    EXPECT_EQ(w[blink], 0.25f);
    size_t moving = 0;
    for (size_t s = 0; s < w.size(); ++s) moving += s != blink && w[s] != 0.0f;
    EXPECT_EQ(moving, 5u);
    EXPECT_LE(std::accumulate(w.begin(), w.end(), 0.0), 1.0 + 1e-6);
  }
}

TEST(Variants, ConvexStaysInTheSimplex) {
  const Rig rig = FaceCap();
  SampleSpec spec{.method = SampleMethod::kConvex, .seed = 9, .count = 500};
  double mean_sum = 0;
  for (size_t i = 0; i < spec.count; ++i) {
    const auto w = Sample(rig, spec, i);
    const double sum = std::accumulate(w.begin(), w.end(), 0.0);
    EXPECT_LE(sum, 1.0 + 1e-6);
    for (float x : w) EXPECT_GE(x, 0.0f);
    mean_sum += sum;
  }
  // Flat Dirichlet over 52 shapes and the base: the base keeps 1/53 on average.
  EXPECT_NEAR(mean_sum / spec.count, 52.0 / 53.0, 0.01);
}

TEST(Variants, GaussianMeanSpreadAndSymmetry) {
  const Rig rig = FaceCap();
  const uint32_t l = FindShape(rig, "mouthSmile_L"), r = FindShape(rig, "mouthSmile_R");
  ASSERT_EQ(rig.shapes[l].partner, static_cast<int>(r));
  std::vector<float> center(rig.shapes.size(), 0.5f);
  SampleSpec spec{.method = SampleMethod::kGaussian,
                  .seed = 2,
                  .count = 3000,
                  .center = center,
                  .spread = 0.1f,
                  .symmetric = true};
  double sum = 0, sq = 0;
  for (size_t i = 0; i < spec.count; ++i) {
    const auto w = Sample(rig, spec, i);
    EXPECT_EQ(w[l], w[r]);
    sum += w[l];
    sq += (w[l] - 0.5) * (w[l] - 0.5);
  }
  EXPECT_NEAR(sum / spec.count, 0.5, 0.01);
  EXPECT_NEAR(std::sqrt(sq / spec.count), 0.1, 0.01);
}

TEST(Variants, GridAlongALineAndOverRanges) {
  const Rig rig = FaceCap();
  const size_t n = rig.shapes.size();
  std::vector<float> a(n, 0.0f), b(n, 0.0f);
  const uint32_t jaw = FindShape(rig, "jawOpen"), smile = FindShape(rig, "mouthSmile_L");
  b[jaw] = 1.0f;
  b[smile] = 0.5f;
  SampleSpec line{.method = SampleMethod::kGrid, .count = 5, .points = {a, b}};
  ASSERT_TRUE(ValidateSampleSpec(rig, line).ok());
  ASSERT_EQ(SampleCount(line, n), 5u);
  EXPECT_FLOAT_EQ(Sample(rig, line, 0)[jaw], 0.0f);
  EXPECT_FLOAT_EQ(Sample(rig, line, 2)[jaw], 0.5f);
  EXPECT_FLOAT_EQ(Sample(rig, line, 2)[smile], 0.25f);
  EXPECT_FLOAT_EQ(Sample(rig, line, 4)[jaw], 1.0f);

  SampleSpec grid{.method = SampleMethod::kGrid, .count = 16, .shapes = {jaw, smile}};
  ASSERT_EQ(SampleCount(grid, n), 16u);         // 4 x 4
  const auto w = Sample(rig, grid, 1 + 4 * 2);  // Step 1 along jaw, step 2 along smile.
  EXPECT_FLOAT_EQ(w[jaw], 1.0f / 3.0f);
  EXPECT_FLOAT_EQ(w[smile], 2.0f / 3.0f);

  SampleSpec too_many{.method = SampleMethod::kGrid, .count = 16};
  const Status s = ValidateSampleSpec(rig, too_many);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/sample/shapes");
}

}  // namespace face_space_test
}  // namespace facespace

#include "facespace/engine/shape_tools.h"

namespace facespace {
namespace face_space_test {

// Mean vertex distance between two shapes' displacements, over every vertex either moves.
double ShapeDifference(const Rig& rig, int a, int b, double* magnitude) {
  double diff = 0, mag = 0;
  size_t count = 0;
  for (const Mesh& m : rig.meshes) {
    for (int pi : m.primitives) {
      const Primitive& p = rig.primitives[pi];
      std::vector<float> da(p.positions.size(), 0.0f), db(p.positions.size(), 0.0f);
      for (size_t t = 0; t < m.target_shapes.size(); ++t) {
        std::vector<float>* dst = m.target_shapes[t] == static_cast<uint32_t>(a)   ? &da
                                  : m.target_shapes[t] == static_cast<uint32_t>(b) ? &db
                                                                                   : nullptr;
        if (!dst) continue;
        const SparseTarget& st = p.targets[t];
        for (size_t k = 0; k < st.indices.size(); ++k) {
          for (int c = 0; c < 3; ++c) (*dst)[3 * st.indices[k] + c] = st.position_deltas[3 * k + c];
        }
      }
      for (size_t v = 0; v < p.vertex_count(); ++v) {
        const double ea = std::hypot(da[3 * v], da[3 * v + 1], da[3 * v + 2]);
        const double eb = std::hypot(db[3 * v], db[3 * v + 1], db[3 * v + 2]);
        if (ea == 0 && eb == 0) continue;
        diff += std::hypot(da[3 * v] - db[3 * v], da[3 * v + 1] - db[3 * v + 1],
                           da[3 * v + 2] - db[3 * v + 2]);
        mag += eb;
        ++count;
      }
    }
  }
  *magnitude = mag / count;
  return diff / count;
}

TEST(ShapeTools, MirrorOfALeftShapeIsItsRightOnFaceCap) {
  Rig rig = FaceCap();
  const int right = FindShape(rig, "mouthSmile_R");
  auto r = DeriveShape(rig, "mirroredSmile", "mouthSmile_L",
                       {.mirror = true, .axis = 0, .tolerance = 1e-3f});
  ASSERT_TRUE(r.ok()) << r.status().message;
  double magnitude = 0;
  const double diff = ShapeDifference(rig, r->shape, right, &magnitude);
  std::printf(
      "mirror(mouthSmile_L) vs mouthSmile_R: mean difference %.5f, mean displacement %.5f, "
      "unmatched %zu\n",
      diff, magnitude, r->unmatched);
  EXPECT_LT(diff, 0.01 * magnitude);  // The authored right smile, within 1% (0.08% measured).
  EXPECT_EQ(r->unmatched, 0u);
  EXPECT_EQ(rig.shapes.back().name, "mirroredSmile");
  EXPECT_EQ(rig.shapes.back().group, rig.shapes[right].group);
  EXPECT_TRUE(ValidateRig(rig).ok());
}

TEST(ShapeTools, MaskKeepsOneSideWithASmoothBand) {
  Rig rig = FaceCap();
  const int jaw = FindShape(rig, "jawOpen");
  auto r = DeriveShape(rig, "jawOpen_left", "jawOpen",
                       {.masked = true, .mask = {.side = 1, .axis = 0, .falloff = 0.0f}});
  ASSERT_TRUE(r.ok()) << r.status().message;
  // Every kept vertex is right of the middle plane, with the source delta unchanged.
  size_t kept = 0, source_pos = 0, source_all = 0;
  for (const Mesh& m : rig.meshes) {
    const auto t_new =
        std::find(m.target_shapes.begin(), m.target_shapes.end(), static_cast<uint32_t>(r->shape)) -
        m.target_shapes.begin();
    const auto t_src =
        std::find(m.target_shapes.begin(), m.target_shapes.end(), static_cast<uint32_t>(jaw)) -
        m.target_shapes.begin();
    if (static_cast<size_t>(t_src) >= m.target_shapes.size()) continue;
    float lo = 1e30f, hi = -1e30f;
    for (int pi : m.primitives) {
      for (size_t i = 0; i < rig.primitives[pi].positions.size(); i += 3) {
        lo = std::min(lo, rig.primitives[pi].positions[i]);
        hi = std::max(hi, rig.primitives[pi].positions[i]);
      }
    }
    const float mid = 0.5f * (lo + hi);
    for (int pi : m.primitives) {
      const Primitive& p = rig.primitives[pi];
      const SparseTarget& a = p.targets[t_new];
      const SparseTarget& s = p.targets[t_src];
      for (size_t k = 0; k < s.indices.size(); ++k)
        source_pos += p.positions[3 * s.indices[k]] > mid;
      source_all += s.indices.size();
      for (size_t k = 0; k < a.indices.size(); ++k) {
        const uint32_t v = a.indices[k];
        ASSERT_GT(p.positions[3 * v], mid);
        const size_t ks =
            std::lower_bound(s.indices.begin(), s.indices.end(), v) - s.indices.begin();
        EXPECT_EQ(a.position_deltas[3 * k + 1], s.position_deltas[3 * ks + 1]);
        ++kept;
      }
    }
  }
  EXPECT_EQ(kept, source_pos);
  EXPECT_GT(kept, source_all / 3);  // About half of the jaw.
  EXPECT_LT(kept, 2 * source_all / 3);
  EXPECT_FALSE(DeriveShape(rig, "x", "nope", {.mirror = true}).ok());
  EXPECT_FALSE(DeriveShape(rig, "jawOpen", "jawOpen", {.mirror = true}).ok());  // Name taken.
}

}  // namespace face_space_test
}  // namespace facespace

#include "facespace/engine/basis.h"
#include "facespace/engine/blend.h"
#include "facespace/formats/lod.h"

namespace facespace {
namespace face_space_test {

TEST(Lod, EveryLodVertexBlendsToTheFullRigsPosition) {
  const Rig rig = FaceCap();
  std::vector<float> w(rig.shapes.size(), 0.0f);
  for (size_t s = 0; s < w.size(); s += 3) w[s] = 0.1f + 0.8f * static_cast<float>(s % 7) / 7.0f;
  BlendedRig full, lod;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig, w, {}, full, ctx).ok());
  for (int level = 1; level <= 3; ++level) {
    formats::LodReport report;
    auto simplified = MakeLod(rig, level, &report);
    ASSERT_TRUE(simplified.ok()) << simplified.status().message;
    EXPECT_LT(report.triangles_after, report.triangles_before * 0.6 / (1 << (level - 1)));
    EXPECT_GT(report.triangles_after, report.triangles_before * 0.4 / (1 << (level - 1)));
    EXPECT_LT(report.vertices_after, report.vertices_before);
    ASSERT_TRUE(EvaluateRig(simplified.value(), w, {}, lod, ctx).ok());
    for (size_t p = 0; p < lod.primitives.size(); ++p) {
      const auto& src = report.source_vertex[p];
      ASSERT_EQ(src.size() * 3, lod.primitives[p].positions.size());
      for (size_t v = 0; v < src.size(); ++v) {
        for (int c = 0; c < 3; ++c) {
          ASSERT_EQ(lod.primitives[p].positions[3 * v + c],
                    full.primitives[p].positions[3 * src[v] + c])
              << "level " << level;
        }
      }
    }
  }
  EXPECT_FALSE(formats::MakeLod(rig, 9).ok());
}

TEST(Basis, ReconstructionStaysWithinTheBound) {
  const Rig rig = FaceCap();
  BasisReport loose, tight, exact;
  auto a = CompressShapes(rig, 50.0, &loose);
  auto b = CompressShapes(rig, 5.0, &tight);
  auto c = CompressShapes(rig, 0.0, &exact);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_LT(loose.components, tight.components);
  EXPECT_LE(tight.components, exact.components);
  EXPECT_LE(exact.components, rig.shapes.size());
  // Check the bound independently: rebuild every shape from the basis and compare with the targets.
  std::vector<size_t> first(rig.primitives.size() + 1, 0);
  for (size_t p = 0; p < rig.primitives.size(); ++p)
    first[p + 1] = first[p] + rig.primitives[p].vertex_count();
  std::vector<int> row(first.back(), -1);
  for (size_t r = 0; r < a->vertices.size(); ++r) row[a->vertices[r]] = static_cast<int>(r);
  const Eigen::MatrixXf rebuilt = a->components * a->coefficients;
  double worst = 0;
  for (const Mesh& m : rig.meshes) {
    for (int pi : m.primitives) {
      const Primitive& p = rig.primitives[pi];
      for (size_t t = 0; t < p.targets.size(); ++t) {
        const SparseTarget& st = p.targets[t];
        for (size_t k = 0; k < st.indices.size(); ++k) {
          const int r = row[first[pi] + st.indices[k]];
          ASSERT_GE(r, 0);
          Eigen::Vector3d d(st.position_deltas[3 * k], st.position_deltas[3 * k + 1],
                            st.position_deltas[3 * k + 2]);
          worst = std::max(
              worst, (d - rebuilt.block<3, 1>(3 * r, m.target_shapes[t]).cast<double>()).norm());
        }
      }
    }
  }
  EXPECT_LE(worst, 50.0 * 1.001);
  EXPECT_NEAR(worst, loose.max_error, 1e-2 * loose.max_error + 1e-3);
  // Orthonormal components.
  EXPECT_TRUE((a->components.transpose() * a->components).isIdentity(1e-3f));
}

TEST(Basis, QuantisationErrorIsHalfAStep) {
  const Rig rig = FaceCap();
  Rig dequantized;
  const QuantizeReport q16 = QuantizeDisplacements(rig, 16, &dequantized);
  const QuantizeReport q8 = QuantizeDisplacements(rig, 8, nullptr);
  EXPECT_GT(q8.max_error, 100 * q16.max_error);  // 256x coarser steps.
  double largest = 0;
  for (const Primitive& p : rig.primitives) {
    for (const SparseTarget& t : p.targets) {
      for (float d : t.position_deltas)
        largest = std::max(largest, static_cast<double>(std::fabs(d)));
    }
  }
  EXPECT_LE(q16.max_error, std::sqrt(3.0) * 0.5 * largest / 32767 * 1.0001);
  EXPECT_GT(q16.max_error, 0.0);
  // The dequantised rig blends within sum(w) x the error of the original, and not exactly.
  std::vector<float> w(rig.shapes.size(), 0.0f);
  w[FindShape(rig, "jawOpen")] = 1.0f;
  w[FindShape(rig, "mouthSmile_L")] = 0.5f;
  BlendedRig a, b;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig, w, {}, a, ctx).ok());
  ASSERT_TRUE(EvaluateRig(dequantized, w, {}, b, ctx).ok());
  const double diff = test::MaxDistance(a, b);
  EXPECT_GT(diff, 0.0);
  EXPECT_LE(diff, 1.5 * q16.max_error + 1e-3);
}

}  // namespace face_space_test
}  // namespace facespace

#include "facespace/engine/weights.h"

namespace facespace {
namespace face_space_test {

std::vector<float> Effective(const Rig& rig, std::vector<std::pair<const char*, float>> given) {
  std::vector<float> w(rig.shapes.size(), 0.0f), out(rig.shapes.size(), 0.0f);
  for (auto& [n, v] : given) w[FindShape(rig, n)] = v;
  EffectiveWeights(rig, w, out);
  return out;
}

TEST(Semantics, AManifestMemberOutOfTheSchemaIsRefusedWithTheClosestName) {
  Rig rig = FaceCap();
  const Status s =
      formats::ApplyManifest(rig, R"({"name": "x", "shapse": {"jawOpen": {"max": 2}}})");
  ASSERT_FALSE(s.ok());
  ASSERT_EQ(s.fields.size(), 1u);
  EXPECT_EQ(s.fields[0].pointer, "/shapse");
  EXPECT_NE(s.message.find("'shapes'"), std::string::npos) << s.message;
  EXPECT_EQ(rig.shapes[FindShape(rig, "jawOpen")].max, 1.0f);  // Nothing applied.
}

TEST(Semantics, InBetweensInterpolateInOrderAndExtrapolate) {
  Rig rig = FaceCap();
  ASSERT_TRUE(
      formats::ApplyManifest(
          rig,
          R"({"inbetweens": {"jawOpen": [{"shape": "mouthFunnel", "weight": 0.5}, {"shape": "mouthPucker", "weight": 0.25}]}})")
          .ok());
  const int jaw = FindShape(rig, "jawOpen"), half = FindShape(rig, "mouthFunnel"),
            quarter = FindShape(rig, "mouthPucker");
  EXPECT_TRUE(rig.shapes[half].driven && rig.shapes[quarter].driven && !rig.shapes[jaw].driven);
  auto e = Effective(rig, {{"jawOpen", 0.125f}});  // Base -> quarter key.
  EXPECT_FLOAT_EQ(e[quarter], 0.5f);
  EXPECT_FLOAT_EQ(e[half], 0.0f);
  EXPECT_FLOAT_EQ(e[jaw], 0.0f);
  e = Effective(rig, {{"jawOpen", 0.375f}});  // Quarter -> half.
  EXPECT_FLOAT_EQ(e[quarter], 0.5f);
  EXPECT_FLOAT_EQ(e[half], 0.5f);
  e = Effective(rig, {{"jawOpen", 0.75f}});  // Half -> the slider's own shape.
  EXPECT_FLOAT_EQ(e[half], 0.5f);
  EXPECT_FLOAT_EQ(e[jaw], 0.5f);
  EXPECT_FLOAT_EQ(e[quarter], 0.0f);
  e = Effective(rig, {{"jawOpen", 1.5f}});  // Past 1: the last segment extended.
  EXPECT_FLOAT_EQ(e[jaw], 2.0f);
  EXPECT_FLOAT_EQ(e[half], -1.0f);
  // The blend uses the effective weights: the same mesh as a rig without in-betweens given them.
  const Rig plain = FaceCap();
  std::vector<float> slider(rig.shapes.size(), 0.0f);
  slider[jaw] = 0.75f;
  const auto eff = Effective(rig, {{"jawOpen", 0.75f}});
  BlendedRig a, b;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig, slider, {}, a, ctx).ok());
  ASSERT_TRUE(EvaluateRig(plain, eff, {}, b, ctx).ok());
  for (size_t p = 0; p < a.primitives.size(); ++p)
    EXPECT_EQ(a.primitives[p].positions, b.primitives[p].positions);
  // A weight given for a driven shape is ignored, with a warning.
  slider[half] = 0.3f;
  const WeightReport r = CheckWeights(rig, slider, BlendMode::kRelative);
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_EQ(r.warnings.back().code, "driven_shape");
  EXPECT_FLOAT_EQ(Effective(rig, {{"jawOpen", 0.75f}, {"mouthFunnel", 0.3f}})[half], 0.5f);
}

TEST(Semantics, CorrectivesFollowProductOrMinimum) {
  Rig rig = FaceCap();
  ASSERT_TRUE(formats::ApplyManifest(
                  rig, R"({"correctives": {"cheekPuff": {"drivers": ["mouthSmile_L", "eyeBlink_L"]},
                                                      "cheekSquint_L": {"drivers": ["mouthSmile_L", "eyeBlink_L"], "mode": "min"}}})")
                  .ok());
  const auto e = Effective(rig, {{"mouthSmile_L", 0.5f}, {"eyeBlink_L", 0.8f}});
  EXPECT_FLOAT_EQ(e[FindShape(rig, "cheekPuff")], 0.4f);
  EXPECT_FLOAT_EQ(e[FindShape(rig, "cheekSquint_L")], 0.5f);
  EXPECT_FLOAT_EQ(Effective(rig, {{"mouthSmile_L", 1.0f}})[FindShape(rig, "cheekPuff")],
                  0.0f);  // One driver alone: no fix.
}

// The extrapolation warning says where it matters: each vertex takes w_j |d_j(v)| / max |d_j| of
// every shape moving it (1: one full shape), and the sum carries no float noise.
TEST(Semantics, ExtrapolationSaysWhatStacksOnOneVertex) {
  // Two vertices: A moves v0 by 2 and v1 by 1 (half its largest), B moves v1 by 4.
  Rig two;
  Primitive p;
  p.mode = PrimitiveMode::kPoints;
  p.positions = {0, 0, 0, 1, 0, 0};
  SparseTarget a, b;
  a.indices = {0, 1};
  a.position_deltas = {0, 2, 0, 0, 1, 0};
  b.indices = {1};
  b.position_deltas = {0, 0, 4};
  p.targets = {a, b};
  two.primitives = {p};
  two.meshes = {Mesh{.name = "m", .primitives = {0}, .target_shapes = {0, 1}}};
  two.shapes = {Shape{.name = "A"}, Shape{.name = "B"}};
  std::vector<uint32_t> stacked;
  EXPECT_DOUBLE_EQ(LargestVertexSum(two, std::vector<float>{0.8f, 0.5f}, stacked),
                   0.9);  // v1: 0.8 x 0.5 + 0.5 x 1.
  EXPECT_EQ(stacked, (std::vector<uint32_t>{0, 1}));
  EXPECT_DOUBLE_EQ(LargestVertexSum(two, std::vector<float>{1.0f, 0.2f}, stacked),
                   1.0);  // v0: A whole.
  EXPECT_EQ(stacked, (std::vector<uint32_t>{0}));
  EXPECT_DOUBLE_EQ(LargestVertexSum(two, std::vector<float>{0.0f, -1.0f}, stacked),
                   0.0);  // Negative weights do not stack.
  // Finalized targets carry their move lengths (measured once per rig): the same answers from them.
  for (SparseTarget& t : two.primitives[0].targets) FinalizeTarget(t);
  EXPECT_EQ(two.primitives[0].targets[0].move_lengths, (std::vector<float>{2, 1}));
  EXPECT_EQ(LargestMoves(two, {}), (std::vector<float>{2, 4}));
  EXPECT_DOUBLE_EQ(LargestVertexSum(two, std::vector<float>{0.8f, 0.5f}, stacked), 0.9);
  EXPECT_EQ(stacked, (std::vector<uint32_t>{0, 1}));

  Rig rig = FaceCap();
  std::vector<float> w(rig.shapes.size(), 0.0f);
  auto set = [&](const char* name, float v) { w[FindShape(rig, name)] = v; };
  set("jawOpen", 0.7f), set("mouthSmile_L", 0.6f), set("mouthSmile_R", 0.6f);
  WeightReport r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_EQ(r.sum, 1.9);  // Not 1.9000001.
  ASSERT_FALSE(r.warnings.empty());
  EXPECT_EQ(r.warnings[0].message.rfind("extrapolation: sum of weights 1.9 exceeds 1", 0), 0u)
      << r.warnings[0].message;
  // A symmetric smile sums to 2, but each half moves its own side: no vertex takes more than one
  // full move.
  std::fill(w.begin(), w.end(), 0.0f);
  set("mouthSmile_L", 1.0f), set("mouthSmile_R", 1.0f);
  r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_EQ(r.sum, 2.0);
  EXPECT_DOUBLE_EQ(r.vertex_sum, 1.0);
  EXPECT_NE(r.warnings[0].message.find("no vertex moves more than 1 of a full shape's move"),
            std::string::npos)
      << r.warnings[0].message;
  // jawOpen and mouthFunnel stack on the lips.
  std::fill(w.begin(), w.end(), 0.0f);
  set("jawOpen", 0.6f), set("mouthFunnel", 0.8f);
  r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_GT(r.vertex_sum, 1.2);
  EXPECT_LE(r.vertex_sum, 1.4);
  std::vector<std::string> names;
  for (uint32_t s : r.stacked_shapes) names.push_back(rig.shapes[s].name);
  EXPECT_EQ(names, (std::vector<std::string>{"jawOpen", "mouthFunnel"}));
  EXPECT_NE(r.warnings[0].message.find("on one vertex jawOpen + mouthFunnel stack to"),
            std::string::npos)
      << r.warnings[0].message;
}

TEST(Semantics, MahalanobisWarnsBeyondTheBound) {
  Rig rig = FaceCap();
  ASSERT_TRUE(
      formats::ApplyManifest(
          rig,
          R"({"statistics": {"mean": {"jawOpen": 0.1}, "stddev": {"jawOpen": 0.2, "mouthSmile_L": 0.5}}})")
          .ok());
  std::vector<float> w(rig.shapes.size(), 0.0f);
  w[FindShape(rig, "jawOpen")] = 0.5f;  // (0.5 - 0.1) / 0.2 = 2 sigma.
  WeightReport r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_NEAR(r.mahalanobis, 2.0, 1e-5);
  EXPECT_TRUE(r.warnings.empty());
  w[FindShape(rig, "mouthSmile_L")] = 1.5f;  // sqrt(2^2 + 3^2) = 3.6 sigma.
  r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_NEAR(r.mahalanobis, std::sqrt(13.0), 1e-5);
  bool implausible = false;
  for (const Warning& x : r.warnings)
    implausible |= x.code == "implausible" && std::fabs(x.value - std::sqrt(13.0)) < 1e-5;
  EXPECT_TRUE(implausible);
  // A rotated component: distance along (1, 1)/sqrt(2).
  Rig other = FaceCap();
  ASSERT_TRUE(
      formats::ApplyManifest(
          other,
          R"({"statistics": {"components": [{"weights": {"jawOpen": 1, "mouthSmile_L": 1}, "stddev": 0.5}], "bound": 2}})")
          .ok());
  std::vector<float> v(other.shapes.size(), 0.0f);
  v[FindShape(other, "jawOpen")] = 1.0f;
  v[FindShape(other, "mouthSmile_L")] = 1.0f;
  EXPECT_NEAR(MahalanobisDistance(other, v), std::sqrt(2.0) / 0.5, 1e-5);
}

TEST(Semantics, ManifestErrorsNameTheField) {
  Rig rig = FaceCap();
  Status s = formats::ApplyManifest(
      rig, R"({"inbetweens": {"jawOpen": [{"shape": "mouthFunnel", "weight": 1}]}})");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/inbetweens/jawOpen/0/weight");
  rig = FaceCap();
  s = formats::ApplyManifest(rig,
                             R"({"correctives": {"cheekPuff": {"drivers": ["mouthSmile_L"]}}})");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/correctives/cheekPuff/drivers");
  rig = FaceCap();
  s = formats::ApplyManifest(
      rig,
      R"({"statistics": {"components": [{"weights": {"jawOpen": 1}, "stddev": 1}, {"weights": {"jawOpen": 1, "mouthSmile_L": 1}, "stddev": 1}]}})");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/statistics/components/1/weights");
  rig = FaceCap();
  s = formats::ApplyManifest(rig, R"({"derived": {"x": {"from": "nope", "mirror": "x"}}})");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/derived/x");
}

}  // namespace face_space_test
}  // namespace facespace

namespace facespace {
namespace face_space_test {

const std::string kMakeHuman = std::string(FACESPACE_SHARED_ASSETS) + "/more/MakeHumanFace";

// The .target file itself, read here independently: vertex -> displacement.
std::map<uint32_t, std::array<float, 3>> ReadTargetFile(const std::string& path) {
  std::map<uint32_t, std::array<float, 3>> out;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream in(line);
    uint32_t i;
    std::array<float, 3> d;
    if (in >> i >> d[0] >> d[1] >> d[2]) out[i] = d;
  }
  return out;
}

// MakeHuman's CC0 eyes (a proxy: eyes/high-poly.mhclo places each of its 1,064 vertices on the
// base mesh's helper eyeballs, vertices 14598-14741, by three weights and an offset): they sit on
// the helper eyeballs and move exactly as they do. l-eye-trans-up lifts one helper eyeball by 0.061
// dm (every one of its 72 vertices): that eye's every vertex rises 6.1 mm at weight 1, the other
// stays.
TEST(MakeHuman, TheEyeProxySitsOnTheHelperEyeballsAndMovesWithThem) {
  formats::MakeHumanOptions options;
  options.metres = true;
  options.proxies = {kMakeHuman + "/eyes/high-poly.mhclo"};
  auto rig = LoadMakeHuman(kMakeHuman + "/base.obj",
                           std::vector<std::string>{kMakeHuman + "/targets/eyes"}, options);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  ASSERT_EQ(rig->primitives.size(), 2u);
  const Primitive& eyes = rig->primitives[1];
  EXPECT_EQ(std::set<uint32_t>(eyes.source_vertices.begin(), eyes.source_vertices.end()).size(),
            1064u);
  ASSERT_GE(eyes.material, 0);
  const Material& m = rig->materials[static_cast<size_t>(eyes.material)];
  EXPECT_EQ(m.name, "Eye_brown");
  EXPECT_EQ(m.alpha_mode, "MASK");
  ASSERT_GE(m.base_color_image, 0);
  EXPECT_EQ(rig->images[static_cast<size_t>(m.base_color_image)].mime_type, "image/png");
  EXPECT_EQ(rig->images[static_cast<size_t>(m.base_color_image)].bytes.size(),
            std::filesystem::file_size(kMakeHuman + "/eyes/brown_eye.png"));

  // The helper eyeballs from base.obj, in metres.
  std::vector<std::array<float, 3>> helpers;
  {
    std::ifstream f(kMakeHuman + "/base.obj");
    std::string line;
    for (size_t v = 0; std::getline(f, line);) {
      if (line.rfind("v ", 0) != 0) continue;
      std::istringstream in(line.substr(2));
      std::array<float, 3> x;
      in >> x[0] >> x[1] >> x[2];
      if (v >= 14598 && v <= 14741) helpers.push_back({0.1f * x[0], 0.1f * x[1], 0.1f * x[2]});
      ++v;
    }
  }
  ASSERT_EQ(helpers.size(), 144u);
  // Each eye, seen from the front, centred on its helper eyeball (the proxy is the eyeball's front
  // with a cornea, a little larger: 29.6 mm wide where the helper is 27.6): box centres in x and y
  // within 0.5 mm, widths within 3 mm.
  for (const int side : {-1, 1}) {
    std::array<float, 2> lo_a{INFINITY, INFINITY}, hi_a{-INFINITY, -INFINITY}, lo_b = lo_a,
                                                                               hi_b = hi_a;
    for (size_t v = 0; v < eyes.vertex_count(); ++v) {
      if ((eyes.positions[3 * v] > 0) != (side > 0)) continue;
      for (int c = 0; c < 2; ++c)
        lo_a[c] = std::min(lo_a[c], eyes.positions[3 * v + c]),
        hi_a[c] = std::max(hi_a[c], eyes.positions[3 * v + c]);
    }
    for (const auto& x : helpers) {
      if ((x[0] > 0) != (side > 0)) continue;
      for (int c = 0; c < 2; ++c)
        lo_b[c] = std::min(lo_b[c], x[c]), hi_b[c] = std::max(hi_b[c], x[c]);
    }
    for (int c = 0; c < 2; ++c) {
      EXPECT_NEAR(lo_a[c] + hi_a[c], lo_b[c] + hi_b[c], 0.001f) << "side " << side << " axis " << c;
      EXPECT_NEAR(hi_a[c] - lo_a[c], hi_b[c] - lo_b[c], 0.003f) << "side " << side << " axis " << c;
    }
  }

  const auto target = ReadTargetFile(kMakeHuman + "/targets/eyes/l-eye-trans-up.target");
  int lifted_side = 0;
  for (const auto& [i, d] : target) {
    if (i < 14598 || i > 14741) continue;
    EXPECT_FLOAT_EQ(d[1], 0.061f);
    lifted_side = helpers[i - 14598][0] > 0 ? 1 : -1;
  }
  ASSERT_NE(lifted_side, 0);
  const int s = FindShape(rig.value(), "l-eye-trans-up");
  ASSERT_GE(s, 0);
  std::vector<float> w(rig->shapes.size(), 0.0f);
  w[static_cast<size_t>(s)] = 1.0f;
  BlendedRig out;
  BlendContext ctx;
  ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
  for (size_t v = 0; v < eyes.vertex_count(); ++v) {
    const bool lifted = (eyes.positions[3 * v] > 0) == (lifted_side > 0);
    for (int c = 0; c < 3; ++c) {
      const float want = eyes.positions[3 * v + c] + (lifted && c == 1 ? 0.0061f : 0.0f);
      ASSERT_NEAR(out.primitives[1].positions[3 * v + c], want, 2e-6f)
          << "vertex " << v << " axis " << c;
    }
  }
}

TEST(MakeHuman, EveryMovedVertexIsBasePlusWeightTimesTheTargetFile) {
  const std::vector<std::string> dirs = {kMakeHuman + "/targets/nose",
                                         kMakeHuman + "/targets/eyes"};
  formats::MakeHumanOptions options;
  options.modifiers = kMakeHuman + "/modifiers/modeling_modifiers.json";
  auto rig = LoadMakeHuman(kMakeHuman + "/base.obj", dirs, options);
  ASSERT_TRUE(rig.ok()) << rig.status().message;
  ASSERT_EQ(rig->primitives.size(), 1u);
  const Primitive& p = rig->primitives[0];
  // The skin (OBJ group "body"): 13,380 vertices, split where their UVs differ per face corner
  // (glTF has one UV per vertex); each copy remembers its OBJ vertex.
  ASSERT_EQ(p.source_vertices.size(), p.vertex_count());
  ASSERT_EQ(p.texcoords.size(), 2 * p.vertex_count());
  EXPECT_EQ(std::set<uint32_t>(p.source_vertices.begin(), p.source_vertices.end()).size(), 13380u);
  EXPECT_GT(p.vertex_count(), 13380u);
  for (const Warning& w : rig->load_warnings)
    EXPECT_EQ(w.message.find("texture coordinates"), std::string::npos) << w.message;
  // Each face corner has its own UV: no triangle reaches across the atlas. Had each vertex one UV
  // (its first corner's), triangles along the seams would join islands far apart.
  std::map<uint32_t, uint32_t> first_copy;
  for (uint32_t v = 0; v < p.vertex_count(); ++v) first_copy.emplace(p.source_vertices[v], v);
  float longest = 0.0f, longest_unsplit = 0.0f;
  for (size_t f = 0; f < p.indices.size(); f += 3) {
    for (int e = 0; e < 3; ++e) {
      const uint32_t va = p.indices[f + e], vb = p.indices[f + (e + 1) % 3];
      auto edge = [&](uint32_t a, uint32_t b) {
        return std::hypot(p.texcoords[2 * a] - p.texcoords[2 * b],
                          p.texcoords[2 * a + 1] - p.texcoords[2 * b + 1]);
      };
      longest = std::max(longest, edge(va, vb));
      longest_unsplit = std::max(longest_unsplit, edge(first_copy[p.source_vertices[va]],
                                                       first_copy[p.source_vertices[vb]]));
    }
  }
  EXPECT_LT(longest, 0.07f);  // hm08: 0.062 of the atlas.
  EXPECT_GT(longest_unsplit, 0.2f) << "the seams should matter";
  size_t files = 0;
  for (const std::string& dir : dirs) {
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
      if (e.path().extension() != ".target") continue;
      ++files;
      const int s = FindShape(rig.value(), e.path().stem().string());
      ASSERT_GE(s, 0) << e.path();
      EXPECT_EQ(rig->shapes[s].group, e.path().parent_path().filename().string());
      const auto target = ReadTargetFile(e.path().string());
      std::vector<float> w(rig->shapes.size(), 0.0f);
      w[s] = 0.7f;
      BlendedRig out;
      BlendContext ctx;
      ASSERT_TRUE(EvaluateRig(rig.value(), w, {}, out, ctx).ok());
      for (size_t v = 0; v < p.vertex_count(); ++v) {
        auto it = target.find(p.source_vertices[v]);  // Every copy moves as its OBJ vertex.

        for (int c = 0; c < 3; ++c) {
          const float want =
              p.positions[3 * v + c] + (it == target.end() ? 0.0f : 0.7f * it->second[c]);
          ASSERT_NEAR(out.primitives[0].positions[3 * v + c], want, 1e-6f)
              << e.path() << " vertex " << v;
        }
      }
    }
  }
  EXPECT_EQ(files, rig->shapes.size());
  // Controls: nose-trans is two-sided; l-/r- eye controls are partners.
  const auto control = [&](const std::string& name) -> const Control* {
    for (const Control& c : rig->controls)
      if (c.name == name) return &c;
    return nullptr;
  };
  const Control* nose = control("nose/nose-trans-down|up");
  ASSERT_NE(nose, nullptr);
  EXPECT_EQ(rig->shapes[nose->negative].name, "nose-trans-down");
  EXPECT_EQ(rig->shapes[nose->positive].name, "nose-trans-up");
  EXPECT_EQ(nose->min, -1.0f);
  const Control* left = control("eyes/l-eye-bag-decr|incr");
  ASSERT_NE(left, nullptr);
  ASSERT_GE(left->partner, 0);
  EXPECT_EQ(rig->controls[left->partner].name, "eyes/r-eye-bag-decr|incr");
  // Both ways through ApplyControls.
  std::vector<WeightEntry> entries;
  std::vector<Warning> warnings;
  std::vector<WeightEntry> given = {{"nose/nose-trans-down|up", -1, -0.4, "/controls/x"}};
  ASSERT_TRUE(ApplyControls(rig.value(), given, entries, warnings).ok());
  auto w = ResolveWeights(rig.value(), entries);
  ASSERT_TRUE(w.ok());
  EXPECT_FLOAT_EQ(w.value()[nose->negative], 0.4f);
  EXPECT_FLOAT_EQ(w.value()[nose->positive], 0.0f);
  entries.clear();
  given[0].value = 1.5;
  ASSERT_TRUE(ApplyControls(rig.value(), given, entries, warnings).ok());
  w = ResolveWeights(rig.value(), entries);
  EXPECT_FLOAT_EQ(w.value()[nose->positive], 1.5f);
  EXPECT_FLOAT_EQ(w.value()[nose->negative], 0.0f);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].code, "control_out_of_range");
  given[0].name = "nose/nope";
  EXPECT_FALSE(ApplyControls(rig.value(), given, entries, warnings).ok());
}

TEST(MakeHuman, BadTargetFilesNameFileAndLine) {
  const std::string dir = ::testing::TempDir() + "/mh_bad";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir + "/t");
  struct Case {
    const char* text;
    const char* want;
  } cases[] = {
      {"# ok\n1 0 0 0.1\n2 0 0.1\n", "x.target:3: malformed line"},
      {"5 0 0 0.1\n13380 0 0 1\n",
       ""},  // The body ends at 13379, but 13380 is a vertex of the OBJ (helpers): fine.
      {"19158 0 0 1\n", "x.target:1: vertex index 19158 is beyond the mesh's 19158 vertices"},
      {"7 0 0 1\n# c\n7 1 0 0\n", "x.target:3: vertex 7 is given twice (first on line 1)"},
      {"7 0 zero 1\n", "x.target:1: malformed line"},
  };
  for (const Case& c : cases) {
    std::ofstream(dir + "/t/x.target") << c.text;
    const std::vector<std::string> dirs = {dir + "/t"};
    auto rig = formats::LoadMakeHuman(kMakeHuman + "/base.obj", dirs, {});
    if (!*c.want) {
      EXPECT_TRUE(rig.ok()) << rig.status().message;
      continue;
    }
    ASSERT_FALSE(rig.ok()) << c.text;
    EXPECT_NE(rig.status().message.find(c.want), std::string::npos) << rig.status().message;
  }
}

}  // namespace face_space_test
}  // namespace facespace
