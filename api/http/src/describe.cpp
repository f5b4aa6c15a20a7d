// What a rig holds, as JSON: GET /v1/rigs/{id} (with the store's id and version) and
// `facespace info --json` give the same document.
#include "facespace/http/describe.h"

#include <cmath>

#include "facespace/engine/transform.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"

namespace facespace::http {

using nlohmann::json;

json DescribeRig(const Rig& r) {
  json j = {{"name", r.name},
            {"vertices", r.vertex_count()},
            {"triangles", r.triangle_count()},
            {"has_skeleton", r.skin_count > 0}};
  if (!r.credit.empty()) j["credit"] = r.credit;
  j["start"] = r.start_at_defaults ? "defaults" : "neutral";  // Where an editor starts and resets.
  json shapes = json::array();
  for (size_t i = 0; i < r.shapes.size(); ++i) {
    const Shape& sh = r.shapes[i];
    json o = {{"index", i},
              {"name", sh.name},
              {"group", sh.group},
              {"min", sh.min},
              {"max", sh.max},
              {"default", sh.default_weight},
              {"vertices_moved", sh.vertices_moved}};
    o["partner"] = sh.partner >= 0 ? json(r.shapes[sh.partner].name) : json(nullptr);
    o["aliases"] = sh.aliases;
    o["driven"] = sh.driven;
    shapes.push_back(o);
  }
  j["shapes"] = shapes;
  // What the manifest says beyond the shapes: in-betweens, correctives, statistics.
  json inbetweens = json::array();
  for (const InBetweens& ib : r.inbetweens) {
    json keys = json::array();
    for (const auto& [w, shape] : ib.keys)
      keys.push_back({{"shape", r.shapes[shape].name}, {"weight", w}});
    inbetweens.push_back({{"slider", r.shapes[ib.slider].name}, {"full", ib.full}, {"keys", keys}});
  }
  j["inbetweens"] = inbetweens;
  json correctives = json::array();
  for (const Corrective& c : r.correctives) {
    json drivers = json::array();
    for (uint32_t d : c.drivers) drivers.push_back(r.shapes[d].name);
    correctives.push_back({{"shape", r.shapes[c.shape].name},
                           {"drivers", drivers},
                           {"mode", c.use_min ? "min" : "product"}});
  }
  j["correctives"] = correctives;
  json controls = json::array();
  for (const Control& c : r.controls) {
    controls.push_back(
        {{"name", c.name},
         {"group", c.group},
         {"min", c.min},
         {"max", c.max},
         {"negative", c.negative >= 0 ? json(r.shapes[c.negative].name) : json(nullptr)},
         {"positive", r.shapes[c.positive].name},
         {"partner", c.partner >= 0 ? json(r.controls[c.partner].name) : json(nullptr)}});
  }
  j["controls"] = controls;
  j["expressions"] = formats::ExpressionsValue(r);
  j["gaze"] = formats::GazeValue(r);
  j["visemes"] = formats::VisemesValue(r);
  j["derivation"] = formats::DerivationValue(r);  // Where derived shapes came from; null: none.
  j["statistics"] = r.statistics.present ? json{{"components", r.statistics.components.size()},
                                                {"bound", r.statistics.bound}}
                                         : json(nullptr);
  // Bounding box of the base mesh as shown (world space, every primitive).
  const auto world = PrimitiveWorldMatrices(r);
  float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
  json prims = json::array();
  for (size_t p = 0; p < r.primitives.size(); ++p) {
    const Primitive& pr = r.primitives[p];
    const auto& m = world[p];
    for (size_t v = 0; v < pr.positions.size(); v += 3) {
      float x[3];
      TransformPoint(m, &pr.positions[v], x);
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min(lo[c], x[c]);
        hi[c] = std::max(hi[c], x[c]);
      }
    }
    prims.push_back({{"mesh", pr.mesh},
                     {"primitive", pr.index_in_mesh},
                     {"name", r.meshes[pr.mesh].name},
                     {"vertices", pr.vertex_count()},
                     {"triangles", pr.triangle_count()},
                     {"material", pr.material},
                     {"has_normals", pr.source_has_normals},
                     {"has_tangents", !pr.tangents.empty()}});
  }
  j["primitives"] = prims;
  j["bounding_box"] = r.primitives.empty()
                          ? json(nullptr)
                          : json({{"min", {lo[0], lo[1], lo[2]}}, {"max", {hi[0], hi[1], hi[2]}}});
  if (r.skins.empty()) {
    j["skeleton"] = nullptr;
  } else {
    json skins = json::array();
    for (const Skin& sk : r.skins) {
      json joints = json::array();
      for (int n : sk.joints)
        joints.push_back({{"node", n}, {"name", r.nodes[n].name}, {"parent", r.nodes[n].parent}});
      skins.push_back({{"name", sk.name}, {"joints", joints}});
    }
    j["skeleton"] = {{"skins", skins}, {"joints", r.joint_count}};
  }
  json anims = json::array();
  for (size_t a = 0; a < r.animations.size(); ++a) {
    const AnimationInfo& an = r.animations[a];
    anims.push_back({{"index", a},
                     {"name", an.name},
                     {"duration", an.duration},
                     {"channels", an.channels},
                     {"morph_weights", an.has_weights}});
  }
  j["animations"] = anims;
  j["load_warnings"] = formats::WarningsValue(r.load_warnings);
  return j;
}

}  // namespace facespace::http
