// The pipeline without HTTP: each step's outcome checked against core evaluated directly.
#include <gtest/gtest.h>

#include <cstring>

#include "facespace/api/pipeline.h"
#include "test_util.h"

namespace facespace {
namespace {

const Rig& FaceCap() {
  static const Rig rig = LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  return rig;
}

int Shape(const char* name) {
  for (size_t i = 0; i < FaceCap().shapes.size(); ++i) {
    if (FaceCap().shapes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

TEST(Pipeline, MeshIsCoreEvaluationEncoded) {
  api::MeshRequest r;
  r.weights = {{"jawOpen", -1, 0.6, "/weights/jawOpen"}, {"mouthSmile_L", -1, 0.3, "/weights/mouthSmile_L"}};
  api::Workspace ws;
  auto out = api::ProduceMesh(FaceCap(), r, MeshFormat::kF32, ws);
  ASSERT_TRUE(out.ok()) << out.status().message;
  EXPECT_EQ(out->content_type, "application/octet-stream");
  EXPECT_NEAR(out->weight_sum, 0.9, 1e-6);
  EXPECT_TRUE(out->warnings.empty());
  // Independently: core at the same weights, then the world positions.
  std::vector<float> w(FaceCap().shapes.size(), 0.0f);
  w[Shape("jawOpen")] = 0.6f;
  w[Shape("mouthSmile_L")] = 0.3f;
  BlendedRig blended;
  BlendContext context;
  ASSERT_TRUE(EvaluateRig(FaceCap(), w, {}, blended, context).ok());
  std::vector<float> positions;
  WorldPositions(blended, positions);
  ASSERT_GE(out->bytes.size(), positions.size() * 4);
  std::vector<float> got(positions.size());
  std::memcpy(got.data(), out->bytes.data(), got.size() * 4);
  for (size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], positions[i]) << i;
}

TEST(Pipeline, ErrorsCarryTheirReason) {
  api::Point point;
  api::MeshRequest r;
  r.weights = {{"jawOpn", -1, 1.0, "/weights/jawOpn"}};
  Status s = api::ResolvePoint(FaceCap(), r, point);
  EXPECT_EQ(s.reason, api::kInvalidWeights);
  ASSERT_EQ(s.fields.size(), 1u);
  EXPECT_EQ(s.fields[0].pointer, "/weights/jawOpn");
  EXPECT_NE(s.message.find("jawOpen"), std::string::npos) << s.message;  // The closest name is suggested.

  r.weights = {{"jawOpen", -1, 0.9, ""}, {"cheekPuff", -1, 0.8, ""}};
  r.strict = true;
  s = api::ResolvePoint(FaceCap(), r, point);
  EXPECT_EQ(s.reason, api::kLeavesAuthoredSpace);
  ASSERT_FALSE(point.report.warnings.empty());  // Filled even when refused, for the headers.
  EXPECT_EQ(point.report.warnings[0].code, "extrapolation");
  EXPECT_NEAR(point.report.sum, 1.7, 1e-6);
}

TEST(Pipeline, SheetResolvesEveryCellBeforeRendering) {
  api::SheetRequest r;
  r.base.render.width = r.base.render.height = 16;
  r.cells = {{{"jawOpen", -1, 1.0, "/cells/0/weights/jawOpen"}}, {{"nope", -1, 1.0, "/cells/1/weights/nope"}}};
  r.labels = {"a", "b"};
  api::SheetPoints points;
  const Status s = api::ResolveSheet(FaceCap(), r, points);
  EXPECT_EQ(s.reason, api::kInvalidWeights);
  EXPECT_EQ(s.message.rfind("cell 1: ", 0), 0u) << s.message;

  r.cells[1] = {{"jawOpen", -1, 0.9, ""}, {"cheekPuff", -1, 0.8, ""}};
  ASSERT_TRUE(api::ResolveSheet(FaceCap(), r, points).ok());
  ASSERT_EQ(points.warnings.size(), 1u);
  EXPECT_EQ(points.warnings[0].message.rfind("cell 1: ", 0), 0u);
  EXPECT_NEAR(points.max_sum, 1.7, 1e-6);
  const render::NullRenderer null;
  api::Workspace ws;
  auto png = api::EncodeSheet(FaceCap(), points, r, render::ImageFormat::kPng, null, ws);
  ASSERT_TRUE(png.ok());
  auto image = render::Decode({reinterpret_cast<const unsigned char*>(png->data()), png->size()});
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(ws.cells.size(), 2u);
  EXPECT_EQ(ws.cells[0].width, 16);
}

TEST(Pipeline, BatchVariantsAreAPureFunctionOfThePlanAndIndex) {
  auto plan = api::MakeBatchPlan(api::UnownedRig(FaceCap()), "v1",
                                 R"({"sample": {"method": "uniform", "count": 5, "seed": 7, "shapes": ["jawOpen", "cheekPuff"]},
                                     "format": "json"})");
  ASSERT_TRUE(plan.ok()) << plan.status().message;
  EXPECT_EQ(plan->total, 5u);
  EXPECT_EQ(api::VariantFile(plan.value(), 3), "v000003.json");
  api::Point a, b;
  api::VariantPoint(plan.value(), 3, a);
  api::VariantPoint(plan.value(), 1, b);
  api::VariantPoint(plan.value(), 3, b);  // The same index again, after another: the same point.
  EXPECT_EQ(a.weights, b.weights);
  const render::NullRenderer null;
  api::VariantEncoder encoder;
  auto bytes = api::EncodeVariant(plan.value(), a, null, encoder);
  ASSERT_TRUE(bytes.ok());
  EXPECT_EQ(bytes.value()[0].front(), '{');
  EXPECT_TRUE(bytes.value()[1].empty());
  // A bad plan names its field.
  auto bad = api::MakeBatchPlan(api::UnownedRig(FaceCap()), "v1", R"({"sample": {"method": "random", "count": 5}})");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().fields.at(0).pointer, "/sample/method");
}

}  // namespace
}  // namespace facespace
