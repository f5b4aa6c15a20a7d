// The manifest's "regions" (named parts of the surface, by mesh or material) and "landmarks" (named
// points on it): what a labelled dataset's segmentation and landmarks are made of (api/batch).
#include <algorithm>
#include <set>

#include "sections.h"

namespace facespace::formats::manifest {

namespace {

constexpr size_t kMaxLandmarks = 4096;

// The primitives of the mesh or material called `name`, appended; false when the rig has none so
// named.
bool PrimitivesNamed(const Rig& rig, const std::string& name, bool material,
                     std::vector<uint32_t>& out) {
  bool found = false;
  for (size_t i = 0; i < (material ? rig.materials.size() : rig.meshes.size()); ++i) {
    if ((material ? rig.materials[i].name : rig.meshes[i].name) != name) continue;
    found = true;
    for (uint32_t p = 0; p < rig.primitives.size(); ++p) {
      const int of = material ? rig.primitives[p].material : rig.primitives[p].mesh;
      if (of == static_cast<int>(i) && std::find(out.begin(), out.end(), p) == out.end())
        out.push_back(p);
    }
  }
  return found;
}

Status ApplyRegion(Rig& rig, const std::string& name, const json& v, const std::string& ptr) {
  if (!v.is_object())
    return Bad(ptr, "must be an object {\"meshes\": [NAME, ...], \"materials\": [NAME, ...]}");
  Region region{name, {}};
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string at = ptr + "/" + JsonPointerEscape(it.key());
    if (it.key() != "meshes" && it.key() != "materials")
      return Bad(at, "unknown member (meshes, materials)");
    if (!it->is_array()) return Bad(at, "must be an array of names");
    for (size_t i = 0; i < it->size(); ++i) {
      const json& n = (*it)[i];
      if (!n.is_string() ||
          !PrimitivesNamed(rig, n.get<std::string>(), it.key() == "materials", region.primitives)) {
        return Bad(at + "/" + std::to_string(i), std::string("must name a ") +
                                                     (it.key() == "meshes" ? "mesh" : "material") +
                                                     " of the rig");
      }
    }
  }
  rig.regions.push_back(std::move(region));
  return Status::Ok();
}

// {"name", "mesh", "primitive"?, "vertex": V | "vertices": [a, b, c], "weights": [wa, wb, wc]}.
Status ReadLandmark(const Rig& rig, const json& v, const std::string& ptr, Landmark& out) {
  if (!v.is_object() || !v.contains("name") || !v["name"].is_string() || !v.contains("mesh") ||
      !v["mesh"].is_string()) {
    return Bad(ptr,
               "must be {\"name\", \"mesh\", \"vertex\"} or {\"name\", \"mesh\", \"vertices\": [a, "
               "b, c], \"weights\": [wa, wb, wc]}");
  }
  out.name = v["name"].get<std::string>();
  std::vector<uint32_t> prims;
  if (!PrimitivesNamed(rig, v["mesh"].get<std::string>(), false, prims))
    return Bad(ptr + "/mesh", "must name a mesh of the rig");
  const size_t k = v.contains("primitive") && v["primitive"].is_number_unsigned()
                       ? v["primitive"].get<size_t>()
                       : 0;
  if (k >= prims.size())
    return Bad(ptr + "/primitive",
               "the mesh has " + std::to_string(prims.size()) + " primitive(s)");
  out.primitive = prims[k];
  const size_t count = rig.primitives[out.primitive].vertex_count();
  const bool one = v.contains("vertex");
  const json list = one ? json::array({v["vertex"]}) : v.value("vertices", json());
  if (!list.is_array() || list.size() != (one ? 1u : 3u))
    return Bad(ptr, "needs \"vertex\", or \"vertices\" (three) with \"weights\"");
  for (size_t i = 0; i < list.size(); ++i) {
    if (!list[i].is_number_unsigned() || list[i].get<size_t>() >= count) {
      return Bad(ptr + (one ? "/vertex" : "/vertices/" + std::to_string(i)),
                 "must be a vertex index below " + std::to_string(count));
    }
    out.vertices[i] = list[i].get<uint32_t>();
  }
  if (one) return Status::Ok();
  const json& w = v.value("weights", json());
  if (!w.is_array() || w.size() != 3 || !w[0].is_number() || !w[1].is_number() ||
      !w[2].is_number()) {
    return Bad(ptr + "/weights", "must be three numbers (barycentric, summing to 1)");
  }
  for (int i = 0; i < 3; ++i) out.weights[i] = w[i].get<float>();
  if (std::abs(out.weights[0] + out.weights[1] + out.weights[2] - 1.0f) > 1e-3f)
    return Bad(ptr + "/weights", "must sum to 1");
  return Status::Ok();
}

}  // namespace

Status ApplyRegions(Rig& rig, const json& v) {
  rig.regions.clear();
  return ForEachMember(v, "/regions",
                       "must be an object {NAME: {\"meshes\": [...], \"materials\": [...]}}", rig,
                       ApplyRegion);
}

Status ApplyLandmarks(Rig& rig, const json& v) {
  if (!v.is_object() || !v.contains("points") || !v["points"].is_array()) {
    return Bad("/landmarks",
               "must be an object {\"scheme\": NAME, \"points\": [{\"name\", \"mesh\", "
               "\"vertex\"}, ...]}");
  }
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (it.key() != "scheme" && it.key() != "source" && it.key() != "points")
      return Bad("/landmarks/" + JsonPointerEscape(it.key()),
                 "unknown member (scheme, source, points)");
  }
  const json& points = v["points"];
  if (points.size() > kMaxLandmarks)
    return Bad("/landmarks/points", "at most " + std::to_string(kMaxLandmarks) + " points");
  std::vector<Landmark> read(points.size());
  std::set<std::string> names;
  for (size_t i = 0; i < points.size(); ++i) {
    const std::string ptr = "/landmarks/points/" + std::to_string(i);
    if (Status s = ReadLandmark(rig, points[i], ptr, read[i]); !s.ok()) return s;
    if (!names.insert(read[i].name).second)
      return Bad(ptr + "/name", "'" + read[i].name + "' is given twice");
  }
  rig.landmarks = std::move(read);
  rig.landmark_scheme =
      v.value("scheme", json("")).is_string() ? v.value("scheme", std::string()) : std::string();
  return Status::Ok();
}

json RegionsValue(const Rig& rig) {
  json o = json::object();
  for (const Region& r : rig.regions) {
    json meshes = json::array();
    for (uint32_t p : r.primitives) {
      const int m = rig.primitives[p].mesh;
      if (m >= 0 && std::find(meshes.begin(), meshes.end(), rig.meshes[m].name) == meshes.end())
        meshes.push_back(rig.meshes[m].name);
    }
    o[r.name] = {{"meshes", meshes}};
  }
  return o;
}

json LandmarksValue(const Rig& rig) {
  json points = json::array();
  for (const Landmark& l : rig.landmarks) {
    const Primitive& p = rig.primitives[l.primitive];
    size_t k = 0;  // Which of its mesh's primitives.
    for (uint32_t q = 0; q < l.primitive; ++q) k += rig.primitives[q].mesh == p.mesh ? 1 : 0;
    json o = {{"name", l.name}, {"mesh", p.mesh >= 0 ? rig.meshes[p.mesh].name : ""}};
    if (k > 0) o["primitive"] = k;
    if (l.weights[0] == 1.0f)
      o["vertex"] = l.vertices[0];
    else
      o["vertices"] = l.vertices, o["weights"] = l.weights;
    points.push_back(std::move(o));
  }
  return {{"scheme", rig.landmark_scheme}, {"points", points}};
}

}  // namespace facespace::formats::manifest
