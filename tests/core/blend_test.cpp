#include "facespace/engine/blend.h"

#include <gtest/gtest.h>

#include <random>

#include "facespace/engine/sparse_blend.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace {
namespace blend_test {  // Named: core_tests is a unity build, its files share one unit.

// Two triangles sharing an edge (a unit square in z = 0) with two shapes.
Rig Square() {
  Rig rig;
  Primitive p;
  p.positions = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  p.indices = {0, 1, 2, 0, 2, 3};
  SparseTarget lift;  // Lifts vertex 2 by 1 in z.
  lift.indices = {2};
  lift.position_deltas = {0, 0, 1};
  SparseTarget slide;  // Slides vertices 0 and 1 by 0.5 in x.
  slide.indices = {0, 1};
  slide.position_deltas = {0.5f, 0, 0, 0.5f, 0, 0};
  p.targets = {lift, slide};
  FinalizePrimitive(p);
  rig.primitives.push_back(p);
  Mesh m;
  m.name = "square";
  m.primitives = {0};
  m.target_shapes = {0, 1};
  rig.meshes.push_back(m);
  rig.shapes = {Shape{.name = "lift"}, Shape{.name = "slide"}};
  rig.nodes.push_back(Node{.name = "square", .mesh = 0});
  rig.scene_roots = {0};
  CountMovedVertices(rig);
  EXPECT_TRUE(ValidateRig(rig).ok());
  return rig;
}

TEST(JobValidity, BlendShapeJob) {
  Rig rig = Square();
  const Primitive& p = rig.primitives[0];
  std::vector<float> out(p.positions.size(), -7.0f), w = {1.0f, 0.0f};
  const std::vector<float> untouched = out;
  BlendShapeJob ok{.base = p.positions, .weights = w, .targets = p.targets, .out = out};
  EXPECT_TRUE(ok.Validate());

  BlendShapeJob short_out = ok;
  std::vector<float> small(3);
  short_out.out = small;
  EXPECT_FALSE(short_out.Validate());
  EXPECT_FALSE(short_out.Run());

  BlendShapeJob few_weights = ok;
  std::vector<float> one = {1.0f};
  few_weights.weights = one;
  EXPECT_FALSE(few_weights.Run());
  EXPECT_EQ(out, untouched) << "a failed Run must not write";

  BlendShapeJob no_normals = ok;  // Active target without normal deltas.
  no_normals.channel = TargetChannel::kNormal;
  EXPECT_FALSE(no_normals.Validate());

  // A target that reaches beyond the vertex count is refused, as run or as index list.
  SparseTarget far;
  far.indices = {0, 1, 2, 3, 4, 5, 6, 7, 9};
  far.position_deltas.assign(27, 1.0f);
  FinalizeTarget(far);
  std::vector<SparseTarget> ts = {far};
  std::vector<float> w1 = {1.0f};
  BlendShapeJob beyond{.base = p.positions, .weights = w1, .targets = ts, .out = out};
  EXPECT_FALSE(beyond.Validate());
  far.runs.clear();
  ts = {far};
  beyond.targets = ts;
  EXPECT_FALSE(beyond.Validate());
}

TEST(JobResult, BlendShapeJob) {
  Rig rig = Square();
  const Primitive& p = rig.primitives[0];
  std::vector<float> out(p.positions.size());
  std::vector<float> w = {0.25f, -2.0f};
  BlendShapeJob job{.base = p.positions, .weights = w, .targets = p.targets, .out = out};
  ASSERT_TRUE(job.Run());
  const std::vector<float> expected = {-1, 0, 0, 0, 0, 0, 1, 1, 0.25f, 0, 1, 0};
  EXPECT_EQ(out, expected);

  // Zero weights leave the base exactly; aliasing out with base is allowed.
  std::vector<float> inplace = p.positions;
  std::vector<float> zero = {0.0f, 0.0f};
  BlendShapeJob alias{.base = inplace, .weights = zero, .targets = p.targets, .out = inplace};
  ASSERT_TRUE(alias.Run());
  EXPECT_EQ(inplace, p.positions);
}

TEST(JobResult, RunsAndScatteredAgree) {
  // The same random targets blended as runs and as scattered index lists agree exactly.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1);
  const size_t n = 2000;
  std::vector<float> base(3 * n);
  for (float& f : base) f = u(rng);
  std::vector<SparseTarget> runs, scattered;
  for (int t = 0; t < 6; ++t) {
    SparseTarget st;
    for (uint32_t v = 0; v < n; ++v) {
      if ((v / 37 + t) % 3 == 0) st.indices.push_back(v);
    }
    for (size_t k = 0; k < 3 * st.indices.size(); ++k) st.position_deltas.push_back(u(rng));
    FinalizeTarget(st);
    ASSERT_FALSE(st.runs.empty());
    runs.push_back(st);
    st.runs.clear();
    scattered.push_back(st);
  }
  std::vector<float> w = {0.5f, 0.0f, 1.5f, -0.25f, 0.125f, 2.0f};
  std::vector<float> a(base.size()), b(base.size());
  ASSERT_TRUE((BlendShapeJob{.base = base, .weights = w, .targets = runs, .out = a}).Run());
  ASSERT_TRUE((BlendShapeJob{.base = base, .weights = w, .targets = scattered, .out = b}).Run());
  EXPECT_EQ(a, b);
}

TEST(Evaluate, RelativeAndAbsoluteAreTheSamePoint) {
  Rig rig = Square();
  // Absolute encoding computed literally: (1 - sum w) base + sum w_j S_j, with S_j dense.
  const Primitive& p = rig.primitives[0];
  std::vector<std::vector<float>> S(2, p.positions);
  for (int j = 0; j < 2; ++j) {
    const SparseTarget& t = p.targets[j];
    for (size_t k = 0; k < t.indices.size(); ++k) {
      for (int c = 0; c < 3; ++c) S[j][3 * t.indices[k] + c] += t.position_deltas[3 * k + c];
    }
  }
  for (std::vector<float> w : {std::vector<float>{0.3f, 0.7f}, {0.2f, 0.1f}, {1.5f, -0.2f}}) {
    BlendedRig rel, abs;
    BlendContext ctx;
    ASSERT_TRUE(EvaluateRig(rig, w, {.mode = BlendMode::kRelative}, rel, ctx).ok());
    ASSERT_TRUE(EvaluateRig(rig, w, {.mode = BlendMode::kAbsolute}, abs, ctx).ok());
    const float sum = w[0] + w[1];
    for (size_t i = 0; i < p.positions.size(); ++i) {
      const float literal = (1 - sum) * p.positions[i] + w[0] * S[0][i] + w[1] * S[1][i];
      EXPECT_NEAR(rel.primitives[0].positions[i], literal, 1e-6f);
      EXPECT_EQ(rel.primitives[0].positions[i], abs.primitives[0].positions[i]);
    }
  }
}

TEST(Evaluate, RefusesBadWeights) {
  Rig rig = Square();
  BlendedRig out;
  BlendContext ctx;
  std::vector<float> nan = {std::nanf(""), 0.0f};
  EXPECT_FALSE(EvaluateRig(rig, nan, {}, out, ctx).ok());
  std::vector<float> one = {1.0f};
  EXPECT_FALSE(EvaluateRig(rig, one, {}, out, ctx).ok());
}

TEST(Normals, RecomputedOnlyAroundMovedVertices) {
  // A 5x5 grid in z = 0; a shape lifts the centre vertex.
  Rig rig;
  Primitive p;
  const int g = 5;
  for (int y = 0; y < g; ++y) {
    for (int x = 0; x < g; ++x) p.positions.insert(p.positions.end(), {float(x), float(y), 0.0f});
  }
  for (int y = 0; y + 1 < g; ++y) {
    for (int x = 0; x + 1 < g; ++x) {
      const uint32_t a = y * g + x, b = a + 1, c = a + g, d = c + 1;
      p.indices.insert(p.indices.end(), {a, b, d, a, d, c});
    }
  }
  SparseTarget lift;
  lift.indices = {12};
  lift.position_deltas = {0, 0, 1};
  p.targets = {lift};
  FinalizePrimitive(p);
  // Author base normals slightly off the smooth ones, to see that far vertices keep them.
  for (size_t v = 0; v < 25; ++v) {
    p.normals[3 * v] = 0.1f;
    p.normals[3 * v + 2] = std::sqrt(1 - 0.01f);
  }
  rig.primitives.push_back(p);
  rig.meshes.push_back(Mesh{.name = "grid", .primitives = {0}, .target_shapes = {0}});
  rig.shapes = {Shape{.name = "lift"}};
  ASSERT_TRUE(ValidateRig(rig).ok());

  BlendedRig out;
  BlendContext ctx;
  std::vector<float> w = {1.0f};
  ASSERT_TRUE(EvaluateRig(rig, w, {.normals = NormalMode::kRecompute}, out, ctx).ok());
  const auto& n = out.primitives[0].normals;
  for (int v = 0; v < 25; ++v) {
    const int x = v % g, y = v / g;
    const bool near = std::abs(x - 2) <= 1 && std::abs(y - 2) <= 1;
    const float len =
        std::sqrt(n[3 * v] * n[3 * v] + n[3 * v + 1] * n[3 * v + 1] + n[3 * v + 2] * n[3 * v + 2]);
    EXPECT_NEAR(len, 1.0f, 1e-6f);
    if (!near) {
      EXPECT_EQ(n[3 * v], p.normals[3 * v]) << "vertex " << v << " is far from the moved one";
      EXPECT_EQ(n[3 * v + 2], p.normals[3 * v + 2]);
    }
  }
  // The lifted apex stays vertical by symmetry (plus the authored tilt), its neighbours
  // tilt away from it: the neighbour at x = 1 leans towards -x.
  EXPECT_NEAR(n[3 * 12], 0.1f, 1e-5f);
  EXPECT_NEAR(n[3 * 12 + 1], 0.0f, 1e-5f);
  EXPECT_LT(n[3 * 11], 0.0f);
  EXPECT_GT(n[3 * 13], 0.1f);

  // Weight zero: the authored normals come back exactly.
  std::vector<float> zero = {0.0f};
  ASSERT_TRUE(EvaluateRig(rig, zero, {.normals = NormalMode::kRecompute}, out, ctx).ok());
  EXPECT_EQ(out.primitives[0].normals, rig.primitives[0].normals);
}

TEST(Normals, BlendedDeltasAreRenormalised) {
  Rig rig = Square();
  Primitive& p = rig.primitives[0];
  p.normals.assign(12, 0.0f);
  for (int v = 0; v < 4; ++v) p.normals[3 * v + 2] = 1.0f;
  p.targets[0].normal_deltas = {1, 0, -1};  // Vertex 2 turns to +x at weight 1.
  p.targets[1].normal_deltas = {0, 0, 0, 0, 0, 0};
  BlendedRig out;
  BlendContext ctx;
  std::vector<float> w = {0.5f, 1.0f};
  ASSERT_TRUE(EvaluateRig(rig, w, {.normals = NormalMode::kBlend}, out, ctx).ok());
  const float s = 1.0f / std::sqrt(2.0f);
  EXPECT_NEAR(out.primitives[0].normals[6], s, 1e-6f);
  EXPECT_NEAR(out.primitives[0].normals[8], s, 1e-6f);
  // Without normal deltas on an active target, blend mode recomputes instead of going stale.
  p.targets[1].normal_deltas.clear();
  ASSERT_TRUE(EvaluateRig(rig, w, {.normals = NormalMode::kBlend}, out, ctx).ok());
  EXPECT_NE(out.primitives[0].normals, rig.primitives[0].normals);
}

TEST(Weights, ResolveByNameIndexAndAlias) {
  Rig rig = Square();
  rig.shapes[1].aliases = {"glide"};
  std::vector<WeightEntry> e = {{.name = "glide", .value = 0.5}, {.index = 0, .value = 0.25}};
  auto w = ResolveWeights(rig, e);
  ASSERT_TRUE(w.ok());
  EXPECT_EQ(w.value(), (std::vector<float>{0.25f, 0.5f}));
  std::vector<WeightEntry> digits = {{.name = "1", .value = 2.0}};
  EXPECT_EQ(ResolveWeights(rig, digits).value(), (std::vector<float>{0.0f, 2.0f}));
  std::vector<WeightEntry> none;
  EXPECT_EQ(ResolveWeights(rig, none).value(), (std::vector<float>{0.0f, 0.0f}))
      << "missing shapes are 0";
}

TEST(Weights, Errors) {
  Rig rig = Square();
  auto check = [&](std::vector<WeightEntry> e, const std::string& pointer,
                   const std::string& needle) {
    auto r = ResolveWeights(rig, e);
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.status().code, StatusCode::kInvalidArgument);
    ASSERT_FALSE(r.status().fields.empty());
    EXPECT_EQ(r.status().fields[0].pointer, pointer);
    EXPECT_NE(r.status().fields[0].message.find(needle), std::string::npos)
        << r.status().fields[0].message;
  };
  check({{.name = "lfit", .value = 1, .pointer = "/weights/lfit"}}, "/weights/lfit",
        "did you mean 'lift'");
  check({{.name = "zzzzzzzz", .value = 1, .pointer = "/w"}}, "/w", "unknown shape 'zzzzzzzz'");
  // The valid names are listed once, in the message, however many names are unknown (not per
  // field).
  {
    std::vector<WeightEntry> two = {{.name = "zzzz", .value = 1, .pointer = "/weights/zzzz"},
                                    {.name = "lfit", .value = 1, .pointer = "/weights/lfit"}};
    auto r = ResolveWeights(rig, two);
    ASSERT_FALSE(r.ok());
    ASSERT_EQ(r.status().fields.size(), 2u);
    for (const auto& f : r.status().fields)
      EXPECT_EQ(f.message.find("valid shapes"), std::string::npos) << f.message;
    const std::string& m = r.status().message;
    EXPECT_NE(m.find("(and 1 more); valid shapes: lift, slide"), std::string::npos) << m;
    EXPECT_EQ(m.find("valid shapes"), m.rfind("valid shapes")) << m;
  }
  check({{.index = 2, .value = 1, .pointer = "/weights/2"}}, "/weights/2", "out of range");
  check({{.index = -1, .value = 1, .pointer = "/weights/-1"}}, "/weights/-1", "out of range");
  check({{.name = "lift", .value = std::nan(""), .pointer = "/a"}}, "/a", "finite");
  check({{.name = "lift", .value = INFINITY, .pointer = "/a"}}, "/a", "finite");
  check({{.name = "lift", .value = 1e39, .pointer = "/a"}}, "/a", "too large");
  check({{.name = "lift", .value = 1}, {.index = 0, .value = 1, .pointer = "/b"}}, "/b", "twice");
}

TEST(Weights, Warnings) {
  Rig rig = Square();
  rig.shapes[1].min = -1.0f;
  std::vector<float> w = {0.9f, 0.8f};
  WeightReport r = CheckWeights(rig, w, BlendMode::kRelative);
  EXPECT_NEAR(r.sum, 1.7, 1e-6);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0].code, "extrapolation");
  // The square's two shapes move different vertices: none takes more than 0.9 of a full move.
  EXPECT_EQ(r.warnings[0].message,
            "extrapolation: sum of weights 1.7 exceeds 1; but no vertex moves more than 0.9 of a "
            "full shape's move (the shapes act on different vertices)");

  w = {1.5f, -0.5f};  // Sum 1: no extrapolation; lift out of range, slide negative in range.
  r = CheckWeights(rig, w, BlendMode::kRelative);
  ASSERT_EQ(r.warnings.size(), 2u);
  EXPECT_EQ(r.warnings[0].code, "out_of_range");
  EXPECT_EQ(r.warnings[0].shape, "lift");
  EXPECT_EQ(r.warnings[0].value, 1.5);
  EXPECT_EQ(r.warnings[1].code, "negative_weight");
  EXPECT_EQ(r.warnings[1].shape, "slide");

  w = {0.25f, 0.25f};
  EXPECT_TRUE(CheckWeights(rig, w, BlendMode::kRelative).warnings.empty());
  r = CheckWeights(rig, w, BlendMode::kAbsolute);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_EQ(r.warnings[0].code, "absolute_sum");
  EXPECT_EQ(r.warnings[0].value, 0.5);
  w = {0.5f, 0.5f};
  EXPECT_TRUE(CheckWeights(rig, w, BlendMode::kAbsolute).warnings.empty());
}

TEST(Rig, SymmetricPartnersFromNames) {
  Rig rig;
  for (const char* n : {"eyeBlink_L", "eyeBlink_R", "jawOpen", "mouthLeft", "mouthRight",
                        "nose/l-nostril", "nose/r-nostril"}) {
    rig.shapes.push_back(Shape{.name = n});
  }
  DetectSymmetricPartners(rig);
  EXPECT_EQ(rig.shapes[0].partner, 1);
  EXPECT_EQ(rig.shapes[1].partner, 0);
  EXPECT_EQ(rig.shapes[2].partner, -1);
  EXPECT_EQ(rig.shapes[3].partner, 4);
  EXPECT_EQ(rig.shapes[5].partner, 6);
}

}  // namespace blend_test
}  // namespace facespace

namespace facespace {
namespace blend_test {

// SparseBlend gives EvaluateRig's bits for the primitives a point moves and says the rest stand:
// FaceCap, where a point of the head's shapes moves the head and leaves the eyes and teeth.
TEST(SparseBlend, BlendsWhatAPointMovesAsEvaluateRigDoes) {
  auto face = formats::LoadRigFile(test::RealAsset("FaceCap/facecap_decoded.glb"));
  ASSERT_TRUE(face.ok());
  const Rig& rig = face.value();
  ASSERT_TRUE(SparseBlend::Serves(rig, {}));
  BlendedRig rest;
  const SparseBlend sparse(rig, &rest);
  ASSERT_TRUE(sparse.ok());
  ASSERT_EQ(rest.primitives.size(), rig.primitives.size());
  std::vector<float> w(rig.shapes.size(), 0.0f);
  w[FindShape(rig, "jawOpen")] = 0.7f;
  w[FindShape(rig, "mouthSmile_L")] = -0.3f;  // Negative weights too.
  ASSERT_TRUE(sparse.Accepts(rig, w));
  BlendedRig full;
  BlendContext context;
  ASSERT_TRUE(EvaluateRig(rig, w, {}, full, context).ok());
  SparseBlend::Scratch scratch;
  size_t blended = 0;
  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const SparseBlend::Outcome outcome = sparse.Blend(rig, w, pi, scratch);
    ASSERT_NE(outcome, SparseBlend::Outcome::kDeclined);
    if (outcome == SparseBlend::Outcome::kRest) {
      EXPECT_EQ(full.primitives[pi].positions, rest.primitives[pi].positions)
          << pi;  // Nothing moved it.
      continue;
    }
    ++blended;
    EXPECT_EQ(scratch.positions, full.primitives[pi].positions) << pi;
    // Normals: the blend's sums, which EvaluateRig then scales to unit length where a target moved
    // a vertex.
    size_t marked = 0;
    for (size_t v = 0; v < rig.primitives[pi].vertex_count(); ++v) {
      const bool moved = (scratch.moved[v / 64] >> (v % 64)) & 1;
      marked += moved;
      const float* n = &scratch.normals[3 * v];
      const float* want = &full.primitives[pi].normals[3 * v];
      if (!moved) {
        ASSERT_EQ(n[0], want[0]) << v;
        continue;
      }
      const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(n[c] / len, want[c], 1e-6f) << v;
    }
    EXPECT_GT(marked, 0u);
  }
  EXPECT_EQ(blended, 1u);  // The head only.
  // Another rig's weights, and NaN, are not accepted.
  EXPECT_FALSE(sparse.Accepts(rig, std::vector<float>(rig.shapes.size() + 1, 0.0f)));
  w[0] = std::nanf("");
  EXPECT_FALSE(sparse.Accepts(rig, w));
}

}  // namespace blend_test
}  // namespace facespace
