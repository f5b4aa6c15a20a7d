// The evaluator without HTTP: each output checked against core evaluated and exported directly,
// its fast paths against the plain path, and its cache key against what the bytes depend on.
#include "facespace/evaluator/evaluator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>

#include "facespace/formats/lod.h"
#include "facespace/offscreen/render.h"
#include "test_util.h"

namespace facespace {
namespace evaluator_test {  // Named: the target is a unity build, its files share one unit.

const std::shared_ptr<const evaluator::StoredRig>& FaceCapStored() {
  static const auto rig =
      evaluator::Unstored(formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value(), "v1");
  return rig;
}
const Rig& FaceCap() { return FaceCapStored()->rig; }

int Shape(const char* name) {
  for (size_t i = 0; i < FaceCap().shapes.size(); ++i) {
    if (FaceCap().shapes[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

// A point at the weights, checked as a route checks it.
evaluator::ResolvedPoint PointAt(std::initializer_list<std::pair<const char*, float>> weights) {
  evaluator::ResolvedPoint p;
  p.weights.assign(FaceCap().shapes.size(), 0.0f);
  for (const auto& [name, w] : weights) p.weights[Shape(name)] = w;
  evaluator::CheckPoint(FaceCap(), BlendMode::kRelative, p);
  return p;
}

// Core's own answer: the rig evaluated at the point, then exported.
std::string Exported(const Rig& rig, const evaluator::ResolvedPoint& p, formats::MeshFormat format,
                     bool mesh_space = false) {
  BlendedRig blended;
  BlendContext context;
  EXPECT_TRUE(EvaluateRig(rig, p.weights, {}, blended, context).ok());
  formats::ExportOptions options;
  options.mesh_space = mesh_space;
  return ExportMesh(rig, blended, p.weights, p.report.warnings, format, options).value();
}

const offscreen::NullRenderer kNull;

TEST(Evaluator, MeshIsCoreEvaluationEncoded) {
  const evaluator::Evaluator evaluator(kNull);
  evaluator::MeshRequest r;
  r.weights = {{"jawOpen", -1, 0.6, "/weights/jawOpen"},
               {"mouthSmile_L", -1, 0.3, "/weights/mouthSmile_L"}};
  evaluator::Workspace ws;
  auto out = evaluator::ProduceMesh(evaluator, FaceCapStored(), r, formats::MeshFormat::kF32, ws);
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
  formats::WorldPositions(blended, positions);
  ASSERT_GE(out->bytes.size(), positions.size() * 4);
  std::vector<float> got(positions.size());
  std::memcpy(got.data(), out->bytes.data(), got.size() * 4);
  for (size_t i = 0; i < got.size(); ++i) ASSERT_EQ(got[i], positions[i]) << i;
}

// The f32 body blended where it is written, the glb written over a kept template (leased, or the
// workspace's own in pieces): each gives the exporter's bytes, call after call.
TEST(Evaluator, FastPathsGiveTheExportersBytes) {
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  const evaluator::ResolvedPoint points[] = {
      PointAt({{"jawOpen", 0.6f}}), PointAt({{"eyeBlink_L", 1.0f}, {"mouthSmile_R", 0.4f}}),
      PointAt({}), PointAt({{"jawOpen", 0.2f}})};
  for (const evaluator::ResolvedPoint& p : points) {
    for (bool mesh_space : {false, true}) {
      evaluator::OutputSpec f32;
      f32.mesh_format = formats::MeshFormat::kF32;
      f32.mesh_space = mesh_space;
      auto body = evaluator.Run(FaceCapStored(), p, f32, ws);
      ASSERT_TRUE(body.ok());
      EXPECT_TRUE(body->bytes == Exported(FaceCap(), p, formats::MeshFormat::kF32, mesh_space))
          << "f32, mesh space " << mesh_space;
      ws.body = std::move(body->bytes);  // Handed back, as the service does once a response is
                                         // sent: written over next.
    }
    evaluator::OutputSpec glb;
    glb.mesh_format = formats::MeshFormat::kGlb;
    const std::string expected = Exported(FaceCap(), p, formats::MeshFormat::kGlb);
    auto joined = evaluator.Run(FaceCapStored(), p, glb, ws);
    ASSERT_TRUE(joined.ok());
    EXPECT_TRUE(joined->bytes == expected) << "glb";
    glb.pieces = true;
    auto pieces = evaluator.Run(FaceCapStored(), p, glb, ws);
    ASSERT_TRUE(pieces.ok());
    EXPECT_TRUE(pieces->bytes.empty());
    EXPECT_TRUE(std::string(pieces->head) + std::string(pieces->bin) == expected)
        << "glb in pieces";
  }
}

TEST(Evaluator, LevelOfDetailIsTheSimplifiedRigEvaluated) {
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  const evaluator::ResolvedPoint p = PointAt({{"jawOpen", 0.7f}});
  evaluator::OutputSpec spec;
  spec.mesh_format = formats::MeshFormat::kObj;
  spec.lod = 2;
  auto obj = evaluator.Run(FaceCapStored(), p, spec, ws);
  ASSERT_TRUE(obj.ok());
  const Rig lod = formats::MakeLod(FaceCap(), 2).value();
  EXPECT_LT(lod.triangle_count(), FaceCap().triangle_count() / 2);
  EXPECT_TRUE(obj->bytes == Exported(lod, p, formats::MeshFormat::kObj));
  EXPECT_EQ(evaluator.Derived(FaceCapStored(), 2)->rig->triangle_count(), lod.triangle_count());
  EXPECT_EQ(evaluator.Derived(FaceCapStored(), 2),
            evaluator.Derived(FaceCapStored(), 2));  // Kept, not made again.
}

// What the evaluator keeps per rig (levels of detail, focus boxes, glb and f32 writers) never keeps
// the rig alive: a rig deleted or replaced in the store is freed once no request holds it.
TEST(Evaluator, KeepsNothingAliveOfARigGone) {
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  auto rig = evaluator::Unstored(FaceCap(), "gone");
  const std::weak_ptr<const evaluator::StoredRig> weak = rig;
  const evaluator::ResolvedPoint p = PointAt({{"jawOpen", 0.3f}});
  for (formats::MeshFormat format : {formats::MeshFormat::kF32, formats::MeshFormat::kGlb}) {
    evaluator::OutputSpec mesh;
    mesh.mesh_format = format;
    ASSERT_TRUE(evaluator.Run(rig, p, mesh, ws).ok());
  }
  evaluator::RenderRequest render;
  render.render.width = render.render.height = 8;
  for (int lod : {0, 1}) {
    render.mesh.lod = lod;
    ASSERT_TRUE(
        evaluator.Run(rig, p, evaluator::OutputSpec::Image(render, picture::ImageFormat::kPng), ws)
            .ok());
    ASSERT_NE(evaluator.Derived(rig, lod), nullptr);
  }
  rig.reset();
  EXPECT_TRUE(weak.expired());
}

TEST(Evaluator, FramesAreTheSequenceEncodings) {
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  const evaluator::ResolvedPoint p = PointAt({{"mouthFunnel", 0.5f}});
  BlendedRig blended;
  BlendContext context;
  ASSERT_TRUE(EvaluateRig(FaceCap(), p.weights, {}, blended, context).ok());
  auto json = evaluator.Run(FaceCapStored(), p, evaluator::OutputSpec::Frame({}, false), ws);
  ASSERT_TRUE(json.ok());
  EXPECT_EQ(json->bytes, formats::PrimitivesJson(FaceCap(), blended));
  auto f32 = evaluator.Run(FaceCapStored(), p, evaluator::OutputSpec::Frame({}, true), ws);
  ASSERT_TRUE(f32.ok());
  std::vector<float> positions;
  formats::WorldPositions(blended, positions);
  uint32_t size = 0;
  ASSERT_EQ(f32->bytes.size(), 4 + positions.size() * 4);
  std::memcpy(&size, f32->bytes.data(), 4);
  EXPECT_EQ(size, positions.size() * 4);
  EXPECT_EQ(std::memcmp(f32->bytes.data() + 4, positions.data(), size), 0);
}

TEST(Evaluator, CacheKeyChangesWithWhatTheBytesDependOn) {
  const evaluator::StoredRig& rig = *FaceCapStored();
  evaluator::ResolvedPoint p = PointAt({{"jawOpen", 0.5f}});
  evaluator::OutputSpec mesh;
  mesh.mesh_format = formats::MeshFormat::kGlb;
  const std::string key = evaluator::CacheKey(rig, {&p, 1}, mesh);
  EXPECT_EQ(key.rfind(rig.id + "|v1|", 0), 0u) << key;  // The rig's id and version first.
  EXPECT_EQ(evaluator::CacheKey(rig, {&p, 1}, mesh), key);
  evaluator::ResolvedPoint negative_zero = p;
  negative_zero.weights[Shape("cheekPuff")] = -0.0f;  // The same weight as 0.
  EXPECT_EQ(evaluator::CacheKey(rig, {&negative_zero, 1}, mesh), key);

  std::vector<std::string> others;
  evaluator::ResolvedPoint q = PointAt({{"jawOpen", 0.5000001f}});
  others.push_back(evaluator::CacheKey(rig, {&q, 1}, mesh));
  for (int change = 0; change < 6; ++change) {
    evaluator::OutputSpec s = mesh;
    if (change == 0) s.mesh_format = formats::MeshFormat::kObj;
    if (change == 1) s.mesh_space = true;
    if (change == 2) s.keep_targets = true;
    if (change == 3) s.lod = 1;
    if (change == 4) s.blend.normals = NormalMode::kRecompute;
    if (change == 5) s.blend.mode = BlendMode::kAbsolute;
    others.push_back(evaluator::CacheKey(rig, {&p, 1}, s));
  }
  evaluator::StoredRig next = rig;
  next.version = "v2";
  others.push_back(evaluator::CacheKey(next, {&p, 1}, mesh));
  evaluator::RenderRequest render;
  const evaluator::OutputSpec image =
      evaluator::OutputSpec::Image(render, picture::ImageFormat::kPng);
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, image));
  evaluator::OutputSpec wider = image;
  wider.render.width += 1;
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, wider));
  evaluator::OutputSpec jpeg = image;
  jpeg.image_format = picture::ImageFormat::kJpeg;
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, jpeg));
  evaluator::OutputSpec turned = image;
  turned.render.camera.yaw = 10;
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, turned));
  evaluator::SheetRequest sheet_request;
  sheet_request.labels = {"a"};
  evaluator::OutputSpec sheet =
      evaluator::OutputSpec::Sheet(sheet_request, picture::ImageFormat::kPng);
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, sheet));
  sheet.lod = 1;  // Sheets are drawn at the asked level of detail too.
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, sheet));
  sheet.labels = {"b"};
  others.push_back(evaluator::CacheKey(rig, {&p, 1}, sheet));
  for (size_t i = 0; i < others.size(); ++i) {
    EXPECT_NE(others[i], key) << i;
    for (size_t j = 0; j < i; ++j) EXPECT_NE(others[i], others[j]) << i << " " << j;
  }
}

TEST(Evaluator, ErrorsCarryTheirReason) {
  evaluator::ResolvedPoint point;
  evaluator::MeshRequest r;
  r.weights = {{"jawOpn", -1, 1.0, "/weights/jawOpn"}};
  Status s = evaluator::ResolvePoint(FaceCap(), r, point);
  EXPECT_EQ(s.reason, evaluator::kInvalidWeights);
  ASSERT_EQ(s.fields.size(), 1u);
  EXPECT_EQ(s.fields[0].pointer, "/weights/jawOpn");
  EXPECT_NE(s.message.find("jawOpen"), std::string::npos)
      << s.message;  // The closest name is suggested.

  r.weights = {{"jawOpen", -1, 0.9, ""}, {"cheekPuff", -1, 0.8, ""}};
  r.strict = true;
  s = evaluator::ResolvePoint(FaceCap(), r, point);
  EXPECT_EQ(s.reason, evaluator::kLeavesAuthoredSpace);
  ASSERT_FALSE(point.report.warnings.empty());  // Filled even when refused, for the headers.
  EXPECT_EQ(point.report.warnings[0].code, "extrapolation");
  EXPECT_NEAR(point.report.sum, 1.7, 1e-6);
}

// Issue 48: the evaluator's loops end Cancelled at their next step once the request's token fires
// (sheet cells, sequence frames), and nothing half-made comes out.
TEST(Evaluator, AFiredStopTokenEndsSheetsAndSequencesCancelled) {
  evaluator::SheetRequest r;
  r.base.render.width = r.base.render.height = 16;
  r.cells = {{{"jawOpen", -1, 1.0, ""}}, {{"jawOpen", -1, 0.5, ""}}};
  evaluator::SheetPoints points;
  ASSERT_TRUE(evaluator::ResolveSheet(FaceCap(), r, points).ok());
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  std::stop_source stop;
  ws.stop = stop.get_token();
  ASSERT_TRUE(evaluator
                  .Run(FaceCapStored(), points.cells,
                       evaluator::OutputSpec::Sheet(r, picture::ImageFormat::kPng), ws)
                  .ok());
  stop.request_stop();
  auto sheet = evaluator.Run(FaceCapStored(), points.cells,
                             evaluator::OutputSpec::Sheet(r, picture::ImageFormat::kPng), ws);
  ASSERT_FALSE(sheet.ok());
  EXPECT_EQ(sheet.status().code, StatusCode::kCancelled);
  Sequence seq;
  seq.keys.push_back({0.0f, std::vector<float>(FaceCap().shapes.size(), 0.0f), std::nullopt, {}});
  seq.keys.push_back({1.0f, std::vector<float>(FaceCap().shapes.size(), 0.5f), std::nullopt, {}});
  std::vector<Warning> warnings;
  const float times[] = {0.0f, 0.5f, 1.0f};
  auto json =
      evaluator::SampleSequenceJson(evaluator, FaceCapStored(), seq, times, {}, warnings, ws);
  ASSERT_FALSE(json.ok());
  EXPECT_EQ(json.status().code, StatusCode::kCancelled);
}

TEST(Evaluator, SheetResolvesEveryCellBeforeRendering) {
  evaluator::SheetRequest r;
  r.base.render.width = r.base.render.height = 16;
  r.cells = {{{"jawOpen", -1, 1.0, "/cells/0/weights/jawOpen"}},
             {{"nope", -1, 1.0, "/cells/1/weights/nope"}}};
  r.labels = {"a", "b"};
  evaluator::SheetPoints points;
  const Status s = evaluator::ResolveSheet(FaceCap(), r, points);
  EXPECT_EQ(s.reason, evaluator::kInvalidWeights);
  EXPECT_EQ(s.message.rfind("cell 1: ", 0), 0u) << s.message;

  r.cells[1] = {{"jawOpen", -1, 0.9, ""}, {"cheekPuff", -1, 0.8, ""}};
  ASSERT_TRUE(evaluator::ResolveSheet(FaceCap(), r, points).ok());
  ASSERT_EQ(points.warnings.size(), 1u);
  EXPECT_EQ(points.warnings[0].message.rfind("cell 1: ", 0), 0u);
  EXPECT_NEAR(points.max_sum, 1.7, 1e-6);
  const evaluator::Evaluator evaluator(kNull);
  evaluator::Workspace ws;
  auto png = evaluator.Run(FaceCapStored(), points.cells,
                           evaluator::OutputSpec::Sheet(r, picture::ImageFormat::kPng), ws);
  ASSERT_TRUE(png.ok());
  auto image = offscreen::Decode(
      {reinterpret_cast<const unsigned char*>(png->bytes.data()), png->bytes.size()});
  ASSERT_TRUE(image.ok());
  EXPECT_EQ(ws.cells.size(), 2u);
  EXPECT_EQ(ws.cells[0].width, 16);
  // One point for a mesh or an image; more is the caller's mistake, said as such.
  auto two = evaluator.Run(FaceCapStored(), points.cells, evaluator::OutputSpec{}, ws);
  EXPECT_EQ(two.status().code, StatusCode::kInternal);
}

// Pictures come from the renderer handed in: without one the evaluator still makes meshes and
// frames, and refuses pictures; with one, it draws and encodes through it, and a sheet's labels are
// what its fonts can draw.
class AsciiOnly final : public picture::Renderer {
 public:
  Status Draw(const Rig& rig, const BlendedRig& b, const picture::RenderOptions& o,
              picture::Image& out) const override {
    ++draws;
    return null.Draw(rig, b, o, out);
  }
  std::string Info() const override { return "ascii only"; }
  int Concurrency() const override { return 1; }
  Result<std::string> Encode(const picture::Image& image, picture::ImageFormat, int,
                             HelperCpu*) const override {
    return std::to_string(image.width) + "x" + std::to_string(image.height);
  }
  picture::Image Sheet(std::span<const picture::Image> cells, std::span<const std::string>,
                       int columns, std::array<float, 4>) const override {
    return {static_cast<int>(columns),
            static_cast<int>((cells.size() + columns - 1) / columns),
            {},
            {}};
  }
  bool CanDrawText(const std::string& text) const override {
    return std::all_of(text.begin(), text.end(),
                       [](char c) { return static_cast<unsigned char>(c) < 0x80; });
  }
  Result<std::string> EncodeData(std::span<const float> v, int, int, int,
                                 picture::DataPrecision) const override {
    return std::to_string(v.size()) + " floats";
  }
  Result<std::string> EncodeIds(std::span<const uint16_t> v, int, int) const override {
    return std::to_string(v.size()) + " ids";
  }
  Result<picture::Image> DecodePicture(std::span<const unsigned char> b,
                                       const std::string& t) const override {
    return null.DecodePicture(b, t);
  }
  mutable int draws = 0;
  offscreen::NullRenderer null;
};

TEST(Evaluator, PicturesComeFromTheRendererHandedIn) {
  evaluator::RenderRequest request;
  request.render.width = 40;
  request.render.height = 30;
  const evaluator::ResolvedPoint point = PointAt({{"jawOpen", 0.5f}});
  evaluator::Workspace ws;
  const evaluator::Evaluator meshes;
  EXPECT_EQ(meshes.renderer(), nullptr);
  EXPECT_TRUE(meshes
                  .Run(FaceCapStored(), point,
                       evaluator::OutputSpec::Mesh(request.mesh, formats::MeshFormat::kObj), ws)
                  .ok());
  auto refused = meshes.Run(FaceCapStored(), point,
                            evaluator::OutputSpec::Image(request, picture::ImageFormat::kPng), ws);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status().code, StatusCode::kFailedPrecondition);

  const AsciiOnly renderer;
  const evaluator::Evaluator pictures(renderer);
  auto drawn = pictures.Run(FaceCapStored(), point,
                            evaluator::OutputSpec::Image(request, picture::ImageFormat::kPng), ws);
  ASSERT_TRUE(drawn.ok()) << drawn.status().message;
  EXPECT_EQ(drawn->bytes, "40x30");
  EXPECT_EQ(renderer.draws, 1);
  evaluator::SheetRequest sheet;
  sheet.base = request;
  sheet.columns = 2;
  const evaluator::ResolvedPoint cells[] = {point, point, point};
  auto grid = pictures.Run(FaceCapStored(), cells,
                           evaluator::OutputSpec::Sheet(sheet, picture::ImageFormat::kPng), ws);
  ASSERT_TRUE(grid.ok()) << grid.status().message;
  EXPECT_EQ(grid->bytes, "2x2");  // Three cells two columns wide, laid out by the renderer's Sheet.
  EXPECT_EQ(renderer.draws, 4);

  // A shape named in a script the renderer's fonts lack is labelled by its ASCII alias.
  Rig rig = FaceCap();
  rig.shapes[0].name = "\xe3\x81\xbe\xe3\x81\xb0\xe3\x81\x9f\xe3\x81\x8d";  // まばたき
  rig.shapes[0].aliases = {"blink"};
  evaluator::SheetRequest by_shape;
  by_shape.shape_cells = "shapes";
  ASSERT_TRUE(evaluator::ExpandShapeCells(rig, &renderer, by_shape).ok());
  EXPECT_EQ(by_shape.labels[0], "blink");
  evaluator::SheetRequest any_font;
  any_font.shape_cells = "shapes";
  ASSERT_TRUE(evaluator::ExpandShapeCells(rig, nullptr, any_font).ok());
  EXPECT_EQ(any_font.labels[0], rig.shapes[0].name + " (blink)");
}

}  // namespace evaluator_test
}  // namespace facespace
