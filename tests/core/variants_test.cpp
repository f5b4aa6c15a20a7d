#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "facespace/core/io.h"
#include "facespace/core/variants.h"
#include "test_util.h"

namespace facespace {
namespace {

Rig FaceCap() {
  auto rig = LoadRigFile(test::Bundled("facecap/facecap.glb"));
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
  SampleSpec spec{.method = SampleMethod::kUniform, .seed = 3, .count = 200, .fixed = {{blink, 0.25f}}, .active = 5,
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
  SampleSpec spec{.method = SampleMethod::kGaussian, .seed = 2, .count = 3000, .center = center, .spread = 0.1f, .symmetric = true};
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
  ASSERT_EQ(SampleCount(grid, n), 16u);  // 4 x 4
  const auto w = Sample(rig, grid, 1 + 4 * 2);  // Step 1 along jaw, step 2 along smile.
  EXPECT_FLOAT_EQ(w[jaw], 1.0f / 3.0f);
  EXPECT_FLOAT_EQ(w[smile], 2.0f / 3.0f);

  SampleSpec too_many{.method = SampleMethod::kGrid, .count = 16};
  const Status s = ValidateSampleSpec(rig, too_many);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.fields[0].pointer, "/sample/shapes");
}

}  // namespace
}  // namespace facespace
