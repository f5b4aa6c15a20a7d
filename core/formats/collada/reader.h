// The COLLADA reader (collada_import.cpp says what it reads): the document's ids, sources and
// geometry split per material (reader_geometry.cpp), then the scene, its instances, materials and
// animations (collada_import.cpp). Every index checked, every reference resolved or reported.
#pragma once

#include <Eigen/Geometry>
#include <map>
#include <pugixml.hpp>
#include <set>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "common/split_mesh.h"
#include "facespace/engine/bezier.h"
#include "facespace/formats/io.h"

namespace facespace::formats::collada {

using Mat4 = Eigen::Matrix4d;
using Vec3 = Eigen::Vector3d;

constexpr size_t kMaxDepth = 128;  // Node nesting (instance_node included).
constexpr size_t kMaxNodes = 100'000;
constexpr size_t kMaxValues = 64'000'000;  // Numbers in one array.
constexpr size_t kMaxSamples = 100'000;

Status Bad(const std::string& what);

std::string Describe(const pugi::xml_node& n);

// A number read from the file, as it would be printed in a message: never cast to an integer
// type first (a finite double such as 7e65 does not fit in one).
std::string Number(double v);

// "#id" -> "id" (a bare id is taken as is).
std::string_view Fragment(std::string_view url);

// Whitespace separated numbers; false on a token that is not a finite number.
bool ParseNumbers(const char* text, std::vector<double>& out, size_t limit);

std::vector<std::string> ParseWords(const char* text);

// A <source>: numbers or names, read through its accessor (count x stride, from an offset).
struct Source {
  std::vector<double> numbers;
  std::vector<std::string> names;
  size_t count = 0, stride = 1;
  const double* At(size_t i) const { return &numbers[i * stride]; }
};

Mat4 RowMajor(const double* v);

class Reader {
 public:
  explicit Reader(const pugi::xml_document& doc, std::string name) : doc_(doc) {
    rig_.name = std::move(name);
  }

  Result<Rig> Run();

 private:
  void IndexIds(pugi::xml_node root);

  pugi::xml_node ById(std::string_view url) const;

  Status ReadSource(pugi::xml_node src, Source& out);

  // ---- geometry ----

  struct Split {
    std::vector<Primitive> primitives;
    std::vector<std::vector<uint32_t>> point_of_vertex;  // Position index of each vertex.
    std::vector<std::string> material_symbol;
    size_t point_count = 0;
    std::vector<double> points;  // xyz per position index.
  };

  // The <mesh>'s positions (through <vertices>).
  Status Positions(pugi::xml_node mesh, std::vector<double>& out,
                   pugi::xml_node* vertices_out = nullptr);

  Status SplitGeometry(pugi::xml_node geometry, Split& out);

  // ---- controllers ----

  struct Morph {
    pugi::xml_node controller;
    std::string weights_source;  // Its MORPH_WEIGHT source's id (animation channels address it).
    std::vector<std::string> names;
    std::vector<std::vector<double>> targets;  // Positions per target (xyz per position index).
    std::vector<double> weights;
  };

  Status ReadMorph(pugi::xml_node controller, pugi::xml_node morph, size_t points,
                   const std::vector<double>& base, Morph& out);

  struct SkinData {
    Mat4 bind_shape = Mat4::Identity();
    std::vector<std::string> joint_names;
    std::vector<Mat4> inverse_binds;
    bool names_are_ids = false;
    std::vector<Influences> influences;  // Per position index.
  };

  Status ReadSkin(pugi::xml_node controller, pugi::xml_node skin, size_t points, SkinData& out);

  // ---- the scene ----

  Mat4 LocalTransform(pugi::xml_node node);

  Status Scene();

  // The node a skin's joint name means: a sid under the <skeleton> roots, else an id, else a name.
  int JointNode(const std::string& name, bool is_id, const std::vector<int>& skeleton_roots) const;

  int NodeOfXml(pugi::xml_node x) const;

  Mat4 World(int node) const;

  // The file a diffuse <texture texture="NAME"> shows: NAME is a sampler2D newparam whose <source>
  // names a surface newparam whose <init_from> is an image (COLLADA 1.4), or a sampler2D with an
  // <instance_image> (1.5), or, as some exporters write, the image's id itself. The image's URI is
  // made a path relative to the model's folder ("file://" and %-escapes undone); an absolute path
  // keeps its file name only (exporters write where the image was on the author's disk; tools then
  // look beside the model). LoadImagesBeside reads it from the model's folder, never outside it.
  std::string TextureFile(pugi::xml_node profile, const std::string& name) const;

  // The rig's image for a file beside the model: one per file, however many materials show it.
  int ImageNamed(const std::string& file);

  int Material(pugi::xml_node inst, const std::string& symbol);

  // An <instance_geometry> or <instance_controller> on `node`: its geometry split into primitives
  // (placed by the skin's bind shape), its morph's targets as shapes, its skin, the mesh on the
  // node.
  Status Instance(pugi::xml_node inst, int node);
  // What an instance leads to: controller(skin) -> controller(morph) -> geometry.
  struct InstanceChain {
    pugi::xml_node target, skin, skin_controller, morph, morph_controller;
  };
  Status ResolveInstance(pugi::xml_node inst, InstanceChain& chain);
  void PlacePrimitives(pugi::xml_node inst, int mesh_index, const SkinData* skin, const Morph& m,
                       Split& split);
  void AddMorphShapes(const Morph& m, int node, facespace::Mesh& mesh);
  Status AddSkin(pugi::xml_node inst, const InstanceChain& chain, int node, SkinData& sd,
                 Split& split, facespace::Mesh& mesh);
  void AttachMesh(Split& split, facespace::Mesh mesh, int node, const std::string& weights_source);

  // ---- animation: morph weights ----

  // One curve of a <sampler>: keys, values, interpolation per key, BEZIER tangents (time, value).
  struct Curve {
    std::vector<double> t, v, in, out;  // in/out: 2 per key when BEZIER.
    std::vector<std::string> interp;
    // The curve between times a < b that lie within one of its segments (or outside its keys), as
    // one kBezier key: the value at a, handles (x1, y1), (x2, y2) with x as a fraction of b - a,
    // and the value reached at b. The same curve, cut exactly (de Casteljau); STEP and LINEAR too.
    std::array<double, 6> Part(double a, double b) const {
      const auto flat = [](double y) {
        return std::array<double, 6>{y, 1.0 / 3, y, 2.0 / 3, y, y};
      };
      if (b <= t.front()) return flat(v.front());
      if (a >= t.back()) return flat(v.back());
      const size_t k = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), a) - t.begin()) - 1;
      const std::string& mode = k < interp.size() ? interp[k] : std::string("LINEAR");
      if (mode == "STEP") return flat(v[k]);
      const double gap = t[k + 1] - t[k];
      if (mode == "BEZIER" && out.size() >= 2 * (k + 1) && in.size() >= 2 * (k + 2)) {
        const std::array<double, 4> x = {t[k], out[2 * k], in[2 * (k + 1)], t[k + 1]};
        const std::array<double, 4> y = {v[k], out[2 * k + 1], in[2 * (k + 1) + 1], v[k + 1]};
        const double s0 = a <= t[k] ? 0.0 : BezierParameterAtX(x[0], x[1], x[2], x[3], a);
        const double s1 = b >= t[k + 1] ? 1.0 : BezierParameterAtX(x[0], x[1], x[2], x[3], b);
        const std::array<double, 4> px = BezierPart(x, s0, s1), py = BezierPart(y, s0, s1);
        // Handles outside their segment (x not rising) are clamped into it.
        const auto frac = [&](double h) { return std::clamp((h - a) / (b - a), 0.0, 1.0); };
        return {py[0], frac(px[1]), py[1], frac(px[2]), py[2], py[3]};
      }
      const double ya = v[k] + (v[k + 1] - v[k]) * (a - t[k]) / gap,
                   yb = v[k] + (v[k + 1] - v[k]) * (b - t[k]) / gap;
      return {ya, 1.0 / 3, ya + (yb - ya) / 3, 2.0 / 3, ya + 2 * (yb - ya) / 3, yb};
    }
  };

  Status Animations();

  const pugi::xml_document& doc_;
  pugi::xml_node root_;
  Rig rig_;
  std::unordered_map<std::string, pugi::xml_node> ids_;
  std::vector<pugi::xml_node> node_xml_;  // Per node read from the scene: node first_node_ + i.
  size_t first_node_ = 0;
  std::vector<std::array<float, 16>> world_;
  std::map<std::string, int> material_of_;
  std::map<std::string, std::vector<uint32_t>> morph_shapes_;  // Weights source id -> shapes.
  std::map<std::string, int> morph_node_;                      // Weights source id -> node.
};

}  // namespace facespace::formats::collada
