// The shapes a derive writes: appended per mesh, the visemes baked from the viseme table, and
// the named sets (arkit, visemes) a request asks for.
#include <algorithm>

#include "facespace/engine/face.h"
#include "facespace/engine/speech.h"
#include "parts.h"

namespace facespace::derive {

// Appends shape `shape` (its targets per primitive) to the rig.
// A shape that moves nothing here (a tongueOut on a head without a tongue) is still there, on the
// first mesh, so a client naming it finds it.
void AppendShape(Rig& rig, Shape shape, std::vector<SparseTarget> targets) {
  const uint32_t index = static_cast<uint32_t>(rig.shapes.size());
  bool anywhere = false;
  for (const SparseTarget& t : targets) anywhere |= !t.indices.empty();
  for (size_t m = 0; m < rig.meshes.size(); ++m) {
    Mesh& mesh = rig.meshes[m];
    bool moves = !anywhere && m == 0;
    for (int p : mesh.primitives) moves |= !targets[p].indices.empty();
    if (!moves) continue;
    for (int p : mesh.primitives) rig.primitives[p].targets.push_back(std::move(targets[p]));
    mesh.target_shapes.push_back(index);
  }
  rig.shapes.push_back(std::move(shape));
}

// The 15 visemes as shapes ("viseme_sil" .. "viseme_U", the names web avatars carry), each the sum
// of the shapes the viseme table (core/speech.h) binds, where `rig` lacks one by that name.
void BakeVisemes(Rig& rig, Report& report) {
  Rig probe;
  probe.shapes = rig.shapes;
  DeriveVisemes(probe);
  for (size_t v = 0; v < kVisemeCount; ++v) {
    const std::string name(kOvrVisemeNames[v]);
    if (FindShape(rig, name) >= 0 || probe.visemes.binds[v].empty()) continue;
    std::vector<SparseTarget> targets(rig.primitives.size());
    for (const Mesh& mesh : rig.meshes) {
      for (int p : mesh.primitives) {
        std::vector<float> dense(rig.primitives[p].positions.size(), 0.0f);
        bool any = false;
        for (const auto& [shape, w] : probe.visemes.binds[v]) {
          for (size_t t = 0; t < mesh.target_shapes.size(); ++t) {
            if (mesh.target_shapes[t] != shape) continue;
            const SparseTarget& st = rig.primitives[p].targets[t];
            for (size_t k = 0; k < st.indices.size(); ++k) {
              for (int c = 0; c < 3; ++c)
                dense[3 * st.indices[k] + c] += w * st.position_deltas[3 * k + c];
            }
            any |= !st.indices.empty();
          }
        }
        if (!any) continue;
        for (uint32_t i = 0; i < dense.size() / 3; ++i) {
          if (dense[3 * i] == 0 && dense[3 * i + 1] == 0 && dense[3 * i + 2] == 0) continue;
          targets[p].indices.push_back(i);
          targets[p].position_deltas.insert(targets[p].position_deltas.end(), &dense[3 * i],
                                            &dense[3 * i] + 3);
        }
        FinalizeTarget(targets[p]);
      }
    }
    Shape shape;
    shape.name = name;
    shape.group = "viseme";
    AppendShape(rig, std::move(shape), std::move(targets));
    report.derived.push_back(name);
  }
}

Status ParseShapeSets(const Rig& source, const std::string& list, Options& options) {
  size_t start = 0;
  while (start <= list.size()) {
    const size_t comma = std::min(list.find(',', start), list.size());
    const std::string word = list.substr(start, comma - start);
    if (word == "arkit") {
      for (const Shape& s : source.shapes) {
        std::string n = s.name;
        if (n.ends_with("_L")) n = n.substr(0, n.size() - 2) + "Left";
        if (n.ends_with("_R")) n = n.substr(0, n.size() - 2) + "Right";
        if (std::find(std::begin(kArkitNames), std::end(kArkitNames), n) != std::end(kArkitNames))
          options.shapes.push_back(s.name);
      }
    } else if (word == "visemes") {
      options.visemes = true;
    } else {
      return InvalidField("--shapes", "'" + word + "' is not a set of shapes (arkit, visemes)");
    }
    start = comma + 1;
  }
  return Status::Ok();
}

}  // namespace facespace::derive
