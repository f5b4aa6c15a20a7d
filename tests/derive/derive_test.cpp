// Deriving a face space (core/derive): FaceCap onto itself, FaceCap onto ICT-FaceKit's neutral
// against ICT's own authored shapes, and hostile inputs.
#include "facespace/derive/derive.h"

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "facespace/formats/io.h"
#include "test_util.h"

namespace facespace::derive {
namespace {

using V3 = Eigen::Vector3d;

std::string FaceCapPath() {
  return std::string(FACESPACE_SOURCE_DIR) + "/assets/facecap/facecap.glb";
}
std::string Ict(const std::string& f) {
  return test::SharedAssets() + "/more/OBJ/ICT-FaceKit_subset/" + f;
}

const Rig& FaceCap() {
  static const Rig rig = [] {
    auto r = formats::LoadRigFile(FaceCapPath());
    EXPECT_TRUE(r.ok()) << r.status().message;
    return std::move(r.value());
  }();
  return rig;
}

// The rig without its shapes: a head that has none.
Rig WithoutShapes(Rig rig) {
  rig.shapes.clear();
  for (Mesh& m : rig.meshes) m.target_shapes.clear();
  for (Primitive& p : rig.primitives) p.targets.clear();
  rig.expressions.clear();
  rig.visemes = {};
  rig.gaze = {};
  rig.animations.clear();
  return rig;
}

// Per source vertex (an OBJ's `v` order, primitive 0) the displacement shape `name` makes.
std::vector<V3> Field(const Rig& rig, const std::string& name) {
  const Primitive& p = rig.primitives[0];
  size_t n = p.vertex_count();
  if (!p.source_vertices.empty())
    n = *std::max_element(p.source_vertices.begin(), p.source_vertices.end()) + 1;
  std::vector<V3> out(n, V3::Zero());
  const int s = FindShape(rig, name);
  EXPECT_GE(s, 0) << name;
  const Mesh& mesh = rig.meshes[p.mesh];
  for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
    if (static_cast<int>(mesh.target_shapes[t]) != s) continue;
    const SparseTarget& st = p.targets[t];
    for (size_t k = 0; k < st.indices.size(); ++k) {
      const uint32_t v =
          p.source_vertices.empty() ? st.indices[k] : p.source_vertices[st.indices[k]];
      out[v] = V3(st.position_deltas[3 * k], st.position_deltas[3 * k + 1],
                  st.position_deltas[3 * k + 2]);
    }
  }
  return out;
}

std::vector<V3> Points(const Rig& rig) {
  const Primitive& p = rig.primitives[0];
  std::vector<V3> out(Field(rig, rig.shapes.empty() ? "" : rig.shapes[0].name).size());
  for (size_t i = 0; i < p.vertex_count(); ++i) {
    const uint32_t v = p.source_vertices.empty() ? i : p.source_vertices[i];
    out[v] = V3(p.positions[3 * i], p.positions[3 * i + 1], p.positions[3 * i + 2]);
  }
  return out;
}

// The `v` numbers the faces of material `material` use in an OBJ file (ICT's "M_Face": the skin of
// the face, without lashes, eyes, teeth and the back of the head).
std::vector<uint8_t> ObjMaterialVertices(const std::string& path, const std::string& material,
                                         size_t n) {
  std::vector<uint8_t> in(n, 0);
  std::ifstream f(path);
  std::string line, current;
  while (std::getline(f, line)) {
    if (line.rfind("usemtl ", 0) == 0) current = line.substr(7);
    if (line.rfind("f ", 0) != 0 || current != material) continue;
    std::istringstream corners(line.substr(2));
    std::string c;
    while (corners >> c) in[std::stoul(c.substr(0, c.find('/'))) - 1] = 1;
  }
  return in;
}

double Cosine(const std::vector<V3>& a, const std::vector<V3>& b,
              const std::vector<uint8_t>& over) {
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (over[i]) ab += a[i].dot(b[i]), aa += a[i].squaredNorm(), bb += b[i].squaredNorm();
  }
  return ab / std::sqrt(aa * bb);
}

double Norm(const std::vector<V3>& a, const std::vector<uint8_t>& over) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) s += over[i] ? a[i].squaredNorm() : 0.0;
  return std::sqrt(s);
}

// Triangles of primitive 0 that a displacement turns over.
size_t TurnedOver(const Rig& rig, const std::vector<V3>& x, const std::vector<V3>& d) {
  const Primitive& p = rig.primitives[0];
  auto src = [&](uint32_t i) { return p.source_vertices.empty() ? i : p.source_vertices[i]; };
  size_t n = 0;
  for (size_t f = 0; f + 2 < p.indices.size(); f += 3) {
    const uint32_t a = src(p.indices[f]), b = src(p.indices[f + 1]), c = src(p.indices[f + 2]);
    const V3 n0 = (x[b] - x[a]).cross(x[c] - x[a]);
    const V3 n1 = (x[b] + d[b] - x[a] - d[a]).cross(x[c] + d[c] - x[a] - d[a]);
    n += n0.dot(n1) < 0;
  }
  return n;
}

TEST(Derive, FaceCapOntoItselfReproducesItsShapes) {
  Rig target = WithoutShapes(FaceCap());
  auto report = DeriveShapes(target, FaceCap(), {});
  ASSERT_TRUE(report.ok()) << report.status().message;
  EXPECT_EQ(report->derived.size(), 52u);
  const double diag = RigDiagonal(FaceCap());
  const Rig& fc = FaceCap();
  const int head = 2;  // The head mesh's primitive: the one the shapes move.
  double worst = 0;
  std::string worst_shape;
  for (const Shape& s : fc.shapes) {
    auto field = [&](const Rig& rig) {
      std::vector<V3> out(rig.primitives[head].vertex_count(), V3::Zero());
      const int si = FindShape(rig, s.name);
      const Mesh& mesh = rig.meshes[rig.primitives[head].mesh];
      for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
        if (static_cast<int>(mesh.target_shapes[t]) != si) continue;
        const SparseTarget& st = rig.primitives[head].targets[t];
        for (size_t k = 0; k < st.indices.size(); ++k)
          out[st.indices[k]] = V3(st.position_deltas[3 * k], st.position_deltas[3 * k + 1],
                                  st.position_deltas[3 * k + 2]);
      }
      return out;
    };
    const auto a = field(fc), b = field(target);
    for (size_t i = 0; i < a.size(); ++i) {
      if ((a[i] - b[i]).norm() > worst) worst = (a[i] - b[i]).norm(), worst_shape = s.name;
    }
  }
  EXPECT_LE(worst / diag, 1e-4) << worst_shape;
}

struct IctFigures {
  double cosine, ratio;
  size_t turned, turned_own;
};

class IctDerive : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto own = formats::LoadObjSequence(
        std::vector<std::string>{Ict("generic_neutral_mesh.obj"), Ict("jawOpen.obj"),
                                 Ict("eyeBlink_L.obj"), Ict("mouthSmile_L.obj")});
    ASSERT_TRUE(own.ok()) << own.status().message;
    own_ = new Rig(std::move(own.value()));
    auto neutral = formats::LoadRigFile(Ict("generic_neutral_mesh.obj"));
    ASSERT_TRUE(neutral.ok());
    derived_ = new Rig(std::move(neutral.value()));
    auto r = DeriveShapes(*derived_, FaceCap(), {});
    ASSERT_TRUE(r.ok()) << r.status().message;
    report_ = new Report(r.value());
    face_ = new std::vector<uint8_t>(
        ObjMaterialVertices(Ict("generic_neutral_mesh.obj"), "M_Face", Points(*own_).size()));
  }
  static IctFigures Compare(const std::string& name) {
    const auto x = Points(*own_);
    const auto a = Field(*own_, name), b = Field(*derived_, name);
    return {Cosine(a, b, *face_), Norm(b, *face_) / Norm(a, *face_), TurnedOver(*derived_, x, b),
            TurnedOver(*own_, x, a)};
  }
  static inline Rig* own_ = nullptr;
  static inline Rig* derived_ = nullptr;
  static inline Report* report_ = nullptr;
  static inline std::vector<uint8_t>* face_ = nullptr;
};

TEST_F(IctDerive, ShapesAgreeWithIctsOwn) {
  for (const char* name : {"jawOpen", "eyeBlink_L", "mouthSmile_L"}) {
    const IctFigures f = Compare(name);
    std::printf("%-13s cosine %.3f  norm ratio %.2f  turned over %zu (ICT's own %zu)\n", name,
                f.cosine, f.ratio, f.turned, f.turned_own);
    EXPECT_GE(f.cosine, 0.8) << name;
    EXPECT_GE(f.ratio, 0.5) << name;
    EXPECT_LE(f.ratio, 2.0) << name;
    EXPECT_LE(f.turned, 2 * f.turned_own) << name;
  }
}

// The left upper lid's middle (where ICT's blink moves the face most) and the lower lid's point it
// closes onto.
TEST_F(IctDerive, BlinkClosesTheLeftLidsAndLeavesTheRight) {
  const auto x = Points(*own_);
  const auto own = Field(*own_, "eyeBlink_L"), derived = Field(*derived_, "eyeBlink_L");
  size_t upper = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if ((*face_)[i] && own[i].norm() > own[upper].norm()) upper = i;
  }
  const V3 closed = x[upper] + own[upper];
  size_t lower = upper;
  for (size_t i = 0; i < x.size(); ++i) {
    if ((*face_)[i] && own[i].norm() < 0.3 * own[upper].norm() &&
        (lower == upper || (x[i] - closed).norm() < (x[lower] - closed).norm()))
      lower = i;
  }
  // The gap along the blink: the lids at different depths, and ICT's lower lid sliding sideways
  // as it closes, only the part along the upper lid's own move is the lids' gap.
  const V3 along = own[upper].normalized();
  const double gap = (x[upper] - x[lower]).dot(along);
  const double after = (x[upper] + derived[upper] - x[lower] - derived[lower]).dot(along);
  const double own_after = (x[upper] + own[upper] - x[lower] - own[lower]).dot(along);
  std::printf(
      "upper lid %zu at %.2f %.2f %.2f: ICT moves it %.3f %.3f %.3f, derived %.3f %.3f %.3f; lower "
      "%zu derived %.3f\n",
      upper, x[upper].x(), x[upper].y(), x[upper].z(), own[upper].x(), own[upper].y(),
      own[upper].z(), derived[upper].x(), derived[upper].y(), derived[upper].z(), lower,
      derived[lower].norm());
  std::printf(
      "left lids: gap %.3f along the blink, %.3f after the derived blink (closed %.0f%%; "
      "ICT's own blink closes %.0f%%)\n",
      -gap, -after, 100 * (1 - after / gap), 100 * (1 - own_after / gap));
  EXPECT_GE(1 - own_after / gap, 0.9);  // The measure itself: ICT's own blink closes the lids.
  EXPECT_GE(1 - after / gap, 0.75);
  size_t right = 0;
  const V3 mirrored(-x[upper].x(), x[upper].y(), x[upper].z());
  for (size_t i = 0; i < x.size(); ++i) {
    if ((x[i] - mirrored).norm() < (x[right] - mirrored).norm()) right = i;
  }
  EXPECT_LE(derived[right].norm(), 0.05 * derived[upper].norm());
}

TEST_F(IctDerive, JawOpenLeavesTheForeheadStill) {
  const auto x = Points(*own_);
  const auto jaw = Field(*derived_, "jawOpen");
  double top = -1e9, bottom = 1e9, largest = 0, forehead = 0, eyes = 0;
  const auto blink = Field(*own_, "eyeBlink_L");
  size_t lid = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    top = std::max(top, x[i].y()), bottom = std::min(bottom, x[i].y());
    largest = std::max(largest, jaw[i].norm());
    if (blink[i].norm() > blink[lid].norm()) lid = i;
  }
  eyes = x[lid].y();
  size_t counted = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!(*face_)[i] || x[i].y() < eyes + 0.1 * (top - bottom)) continue;
    forehead = std::max(forehead, jaw[i].norm());
    ++counted;
  }
  std::printf("jawOpen: largest move %.3f, forehead's (%zu vertices) %.4f (%.2f%%)\n", largest,
              counted, forehead, 100 * forehead / largest);
  EXPECT_GT(counted, 100u);
  EXPECT_LE(forehead, 0.02 * largest);
}

// ---- hostile targets: each refused naming its field, or derived sanely; nothing half-written ----

// The first field a refusal names, or "".
std::string FirstField(const Status& s) { return s.fields.empty() ? "" : s.fields[0].pointer; }

// A unit sphere of `rings` x `segments` quads as a one-primitive OBJ rig: a head with no face.
Rig Sphere(int rings, int segments) {
  std::ostringstream obj;
  for (int r = 0; r <= rings; ++r) {
    const double t = 3.14159265358979 * r / rings;
    for (int s = 0; s < segments; ++s) {
      const double p = 2 * 3.14159265358979 * s / segments;
      obj << "v " << std::sin(t) * std::cos(p) << ' ' << std::cos(t) << ' '
          << std::sin(t) * std::sin(p) << '\n';
    }
  }
  for (int r = 0; r < rings; ++r) {
    for (int s = 0; s < segments; ++s) {
      const int a = r * segments + s + 1, b = r * segments + (s + 1) % segments + 1;
      obj << "f " << a << ' ' << b << ' ' << b + segments << ' ' << a + segments << '\n';
    }
  }
  const std::string path = ::testing::TempDir() + "/derive_sphere.obj";
  std::ofstream(path) << obj.str();
  auto rig = formats::LoadRigFile(path);
  EXPECT_TRUE(rig.ok()) << rig.status().message;
  return std::move(rig.value());
}

TEST(DeriveHostile, AHeadWithoutAFaceIsRefusedWithItsFigure) {
  Rig target = Sphere(48, 64);
  const size_t before = target.shapes.size();
  auto r = DeriveShapes(target, FaceCap(), {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().reason, "poor-fit") << r.status().message;
  EXPECT_NE(r.status().message.find('%'), std::string::npos) << r.status().message;  // Its figure.
  EXPECT_FALSE(FirstField(r.status()).empty());
  EXPECT_EQ(target.shapes.size(), before);  // Nothing written.
}

TEST(DeriveHostile, TooManyVerticesIsRefusedBeforeAnyWork) {
  Rig target = WithoutShapes(FaceCap());
  target.primitives[0].positions.resize(3 * 1'000'000, 0.0f);
  auto r = DeriveShapes(target, FaceCap(), {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code, StatusCode::kResourceExhausted);
  EXPECT_EQ(FirstField(r.status()), "/target");
}

TEST(DeriveHostile, OnlyDegenerateTrianglesIsNoSurface) {
  Rig target = WithoutShapes(FaceCap());
  for (Primitive& p : target.primitives) {
    for (size_t i = 0; i + 2 < p.indices.size(); i += 3)
      p.indices[i + 1] = p.indices[i + 2] = p.indices[i];
  }
  auto r = DeriveShapes(target, FaceCap(), {});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().reason, "no-face");
  EXPECT_EQ(FirstField(r.status()), "/target");
  EXPECT_TRUE(target.shapes.empty());
}

TEST(DeriveHostile, ALandmarkOffTheMeshNamesItsPosition) {
  Rig target = WithoutShapes(FaceCap());
  Options o;
  o.landmarks = {{"nose_tip", -1, {1e6f, 0, 0}}};
  ASSERT_FALSE(FaceCap().landmarks.empty());
  o.landmarks[0].name = FaceCap().landmarks[30].name;
  auto r = DeriveShapes(target, FaceCap(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(FirstField(r.status()), "/landmarks/points/0/position") << r.status().message;
  o.landmarks = {{"no-such-point", 5, {}}};
  r = DeriveShapes(target, FaceCap(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(FirstField(r.status()), "/landmarks/points/0/name");
  o.landmarks = {{FaceCap().landmarks[30].name, 99'999'999, {}}};
  r = DeriveShapes(target, FaceCap(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(FirstField(r.status()), "/landmarks/points/0/vertex");
  EXPECT_TRUE(target.shapes.empty());
}

TEST(DeriveHostile, AnUnknownShapeIsNamed) {
  Rig target = WithoutShapes(FaceCap());
  Options o;
  o.shapes = {"jawOpen", "jawOpn"};
  auto r = DeriveShapes(target, FaceCap(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(FirstField(r.status()), "/shapes/1");
  EXPECT_NE(r.status().message.find("jawOpen"), std::string::npos)
      << r.status().message;  // Did you mean.
}

// The sets a derive takes: FaceCap's ARKit-named shapes are all 52 of its shapes (named _L/_R as
// FaceCap names them); visemes a flag; another word refused.
TEST(DeriveHostile, ShapeSetsAreTheSourcesArkitShapesAndTheVisemes) {
  Options o;
  ASSERT_TRUE(ParseShapeSets(FaceCap(), "arkit", o).ok());
  EXPECT_EQ(o.shapes.size(), 52u);
  EXPECT_NE(std::find(o.shapes.begin(), o.shapes.end(), "mouthSmile_L"), o.shapes.end());
  EXPECT_FALSE(o.visemes);
  Options both;
  ASSERT_TRUE(ParseShapeSets(FaceCap(), "arkit,visemes", both).ok());
  EXPECT_TRUE(both.visemes);
  Options bad;
  const Status s = ParseShapeSets(FaceCap(), "arkit,teeth", bad);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(FirstField(s), "--shapes");
}

// A derive stopped as it registers (a job deleted, its client gone) ends there, cancelled, the
// target unchanged: no step after the registration is reached.
TEST(DeriveHostile, AStopDuringTheRegistrationEndsIt) {
  Rig target = WithoutShapes(FaceCap());
  const size_t before = target.shapes.size();
  std::stop_source stop;
  std::vector<std::string> steps;
  Options o;
  o.stop = stop.get_token();
  o.progress = [&](double, const char* step) {
    steps.push_back(step);
    if (steps.back() == "register") stop.request_stop();
  };
  auto r = DeriveShapes(target, FaceCap(), o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code, StatusCode::kCancelled);
  EXPECT_EQ(target.shapes.size(), before);
  EXPECT_EQ(steps.back(), "register");
}

// A head with holes (every seventh triangle gone) and in pieces still derives: finite shapes that
// open the jaw where the whole head's do.
TEST(DeriveHostile, AHeadWithHolesStillDerives) {
  Rig target = WithoutShapes(FaceCap());
  std::vector<uint32_t>& idx = target.primitives[2].indices;
  std::vector<uint32_t> kept;
  for (size_t t = 0; t * 3 < idx.size(); ++t) {
    if (t % 7 != 3) kept.insert(kept.end(), idx.begin() + 3 * t, idx.begin() + 3 * t + 3);
  }
  idx = kept;
  Options o;
  o.shapes = {"jawOpen", "eyeBlink_L"};
  auto r = DeriveShapes(target, FaceCap(), o);
  ASSERT_TRUE(r.ok()) << r.status().message;
  const int s = FindShape(target, "jawOpen");
  ASSERT_GE(s, 0);
  double largest = 0;
  for (const Primitive& p : target.primitives) {
    for (const SparseTarget& t : p.targets) {
      for (float d : t.position_deltas) {
        ASSERT_TRUE(std::isfinite(d));
        largest = std::max(largest, static_cast<double>(std::abs(d)));
      }
    }
  }
  EXPECT_GT(largest, 500);  // FaceCap's jaw moves its chin over 1,000 of its mesh units.
  EXPECT_EQ(target.derivation.source, FaceCap().name);
  EXPECT_EQ(target.derivation.shapes.size(), 2u);
}

}  // namespace
}  // namespace facespace::derive
