#include "facespace/engine/weights.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace facespace {
inline namespace engine {

std::string FormatNumber(double value) {
  char buf[32];
  const float f = static_cast<float>(value);
  if (std::isfinite(value) && !std::isfinite(f)) {  // Beyond float range: say it as a double.
    auto r = std::to_chars(buf, buf + sizeof buf, value);
    return std::string(buf, r.ptr);
  }
  auto r = std::to_chars(buf, buf + sizeof buf, f);
  return std::string(buf, r.ptr);
}

namespace {

float Norm3(const float* d) { return std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]); }

// `value` to `digits` significant digits: a sum of float weights without its noise (1.9000001
// is 1.9).
double RoundSignificant(double value, int digits = 6) {
  if (!std::isfinite(value) || value == 0.0) return value;
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.*g", digits, value);
  return std::strtod(buf, nullptr);
}

std::string ValidNames(const Rig& rig) {
  std::string s;
  const size_t shown = std::min<size_t>(rig.shapes.size(), 60);
  for (size_t i = 0; i < shown; ++i) {
    if (i) s += ", ";
    s += rig.shapes[i].name;
  }
  if (shown < rig.shapes.size()) s += ", ... (" + std::to_string(rig.shapes.size()) + " in all)";
  return s.empty() ? "(none: this rig has no shapes)" : s;
}

}  // namespace

Result<std::vector<float>> ResolveWeights(const Rig& rig, std::span<const WeightEntry> entries) {
  Status status = InvalidArgument("");
  // A dense array longer than the rig's shapes is refused whole: one error, not one per index.
  size_t indexed = 0;
  for (const WeightEntry& e : entries) indexed += e.name.empty();
  if (indexed > rig.shapes.size()) {
    const std::string& ptr = entries.front().pointer;
    status.AddField(ptr.substr(0, ptr.rfind('/')),
                    "has " + std::to_string(indexed) + " weights: indices from " +
                        std::to_string(rig.shapes.size()) + " on are out of range; this rig has " +
                        std::to_string(rig.shapes.size()) + " shapes");
    status.message = status.fields.front().message;
    return status;
  }
  std::vector<float> weights(rig.shapes.size(), 0.0f);
  std::vector<uint8_t> seen(rig.shapes.size(), 0);
  bool unknown_name = false;
  for (const WeightEntry& e : entries) {
    long long index = e.index;
    auto label = [&e] {
      return e.name.empty() ? "index " + std::to_string(e.index) : "'" + e.name + "'";
    };
    if (!e.name.empty()) {
      index = FindShape(rig, e.name);
      // A map key of digits that names no shape is an index: {"3": 0.5}.
      if (index < 0 && e.name.size() < 10 &&
          e.name.find_first_not_of("0123456789") == std::string::npos) {
        index = std::stoll(e.name);
        if (static_cast<size_t>(index) >= rig.shapes.size()) {
          status.AddField(e.pointer, [&] {
            return "shape index " + e.name + " out of range: this rig has " +
                   std::to_string(rig.shapes.size()) + " shapes";
          });
          continue;
        }
      }
      if (index < 0) {
        status.AddField(e.pointer, [&] {
          std::string msg = "unknown shape '" + e.name + "'";
          const std::string close = ClosestShapeName(rig, e.name);
          if (!close.empty()) msg += " (did you mean '" + close + "'?)";
          return msg;
        });
        unknown_name = true;
        continue;
      }
    } else if (index < 0 || static_cast<size_t>(index) >= rig.shapes.size()) {
      status.AddField(e.pointer, [&] {
        return "shape index " + std::to_string(index) + " out of range: this rig has " +
               std::to_string(rig.shapes.size()) + " shapes (0.." +
               std::to_string(static_cast<long long>(rig.shapes.size()) - 1) + ")";
      });
      continue;
    }
    if (!std::isfinite(e.value)) {
      status.AddField(e.pointer,
                      [&] { return "weight of " + label() + " must be a finite number"; });
      continue;
    }
    if (std::fabs(e.value) > 3.0e38) {
      status.AddField(e.pointer, [&] { return "weight of " + label() + " is too large"; });
      continue;
    }
    if (seen[index]) {
      status.AddField(e.pointer,
                      [&] { return "shape '" + rig.shapes[index].name + "' is given twice"; });
      continue;
    }
    seen[index] = 1;
    weights[index] = static_cast<float>(e.value);
  }
  if (!status.fields.empty()) {
    status.message = status.fields.front().message;
    if (status.field_count() > 1)
      status.message += " (and " + std::to_string(status.field_count() - 1) + " more)";
    // The names a client may use, once: in the message, not in every unknown name's field error.
    if (unknown_name) status.message += "; valid shapes: " + ValidNames(rig);
    return status;
  }
  return weights;
}

double MahalanobisDistance(const Rig& rig, std::span<const float> weights) {
  const ShapeStatistics& st = rig.statistics;
  if (!st.present) return 0.0;
  double d2 = 0;
  for (size_t k = 0; k < st.components.size(); ++k) {
    double proj = 0;
    for (size_t s = 0; s < weights.size() && s < st.mean.size(); ++s)
      proj += (static_cast<double>(weights[s]) - st.mean[s]) * st.components[k][s];
    d2 += (proj / st.stddev[k]) * (proj / st.stddev[k]);
  }
  return std::sqrt(d2);
}

namespace {

// Each index's move length: the target's own (FinalizeTarget), else measured into `scratch`.
std::span<const float> MoveLengths(const SparseTarget& st, std::vector<float>& scratch) {
  const size_t n = std::min(st.indices.size(), st.position_deltas.size() / 3);
  if (st.move_lengths.size() == n) return st.move_lengths;
  scratch.resize(n);
  for (size_t k = 0; k < n; ++k) scratch[k] = Norm3(&st.position_deltas[3 * k]);
  return scratch;
}

}  // namespace

std::vector<float> LargestMoves(const Rig& rig, std::span<const float> active) {
  std::vector<float> most(rig.shapes.size(), 0.0f), scratch;
  for (const Mesh& mesh : rig.meshes) {
    for (int pi : mesh.primitives) {
      const Primitive& p = rig.primitives[pi];
      for (size_t t = 0; t < p.targets.size() && t < mesh.target_shapes.size(); ++t) {
        const uint32_t s = mesh.target_shapes[t];
        if (s >= most.size() || (!active.empty() && (s >= active.size() || !(active[s] > 0.0f))))
          continue;
        for (float length : MoveLengths(p.targets[t], scratch)) most[s] = std::max(most[s], length);
      }
    }
  }
  return most;
}

double LargestVertexSum(const Rig& rig, std::span<const float> weights,
                        std::vector<uint32_t>& shapes) {
  shapes.clear();
  double best = 0.0;
  size_t best_primitive = 0;
  uint32_t best_vertex = 0;
  // Each vertex gets the weight times the share of the shape's largest move (over all its
  // primitives) it moves there: a shape is "full" where it moves most (a left smile moves the
  // middle of the lips half as much).
  const std::vector<float> most = LargestMoves(rig, weights);
  std::vector<float> acc, scratch;
  for (const Mesh& mesh : rig.meshes) {
    for (int pi : mesh.primitives) {
      const Primitive& p = rig.primitives[pi];
      bool any = false;
      for (size_t t = 0; t < p.targets.size() && t < mesh.target_shapes.size(); ++t) {
        const uint32_t s = mesh.target_shapes[t];
        if (s >= weights.size() || s >= most.size() || !(weights[s] > 0.0f) || !(most[s] > 0.0f))
          continue;
        if (!any) acc.assign(p.vertex_count(), 0.0f);
        any = true;
        const std::span<const float> lengths = MoveLengths(p.targets[t], scratch);
        const uint32_t* idx = p.targets[t].indices.data();
        const float share = weights[s] / most[s];
        for (size_t k = 0; k < lengths.size(); ++k) acc[idx[k]] += share * lengths[k];
      }
      for (size_t v = 0; any && v < acc.size(); ++v) {
        if (acc[v] > best)
          best = acc[v], best_primitive = static_cast<size_t>(pi),
          best_vertex = static_cast<uint32_t>(v);
      }
    }
  }
  if (best <= 0.0) return 0.0;
  const Primitive& p = rig.primitives[best_primitive];
  const Mesh& mesh = rig.meshes[static_cast<size_t>(p.mesh)];
  for (size_t t = 0; t < p.targets.size() && t < mesh.target_shapes.size(); ++t) {
    const uint32_t s = mesh.target_shapes[t];
    const auto& idx = p.targets[t].indices;
    const auto at = std::lower_bound(idx.begin(), idx.end(), best_vertex);
    if (s < weights.size() && weights[s] > 0.0f && at != idx.end() && *at == best_vertex &&
        Norm3(&p.targets[t].position_deltas[3 * static_cast<size_t>(at - idx.begin())]) > 0.0f) {
      shapes.push_back(s);
    }
  }
  std::sort(shapes.begin(), shapes.end());
  return RoundSignificant(best, 3);  // A share of a move: three digits say it.
}

WeightReport CheckWeights(const Rig& rig, std::span<const float> weights, BlendMode mode) {
  WeightReport r;
  for (size_t i = 0; i < weights.size() && i < rig.shapes.size(); ++i) {
    const Shape& s = rig.shapes[i];
    const float w = weights[i];
    r.sum += w;
    if (w < s.min || w > s.max) {
      r.warnings.push_back({"out_of_range",
                            "weight " + FormatNumber(w) + " of '" + s.name +
                                "' is outside its range [" + FormatNumber(s.min) + ", " +
                                FormatNumber(s.max) + "]",
                            s.name, w, true});
    } else if (w < 0.0f) {
      r.warnings.push_back(
          {"negative_weight",
           "negative weight " + FormatNumber(w) + " of '" + s.name + "' subtracts the shape",
           s.name, w, true});
    }
  }
  for (size_t i = 0; i < weights.size() && i < rig.shapes.size(); ++i) {
    if (rig.shapes[i].driven && weights[i] != 0.0f) {
      r.warnings.push_back(
          {"driven_shape",
           "'" + rig.shapes[i].name +
               "' is driven by other shapes (an in-between or a corrective): the weight " +
               FormatNumber(weights[i]) + " given for it is ignored",
           rig.shapes[i].name, weights[i], true});
    }
  }
  if (rig.statistics.present) {
    const double d = MahalanobisDistance(rig, weights);
    r.mahalanobis = d;
    if (d > rig.statistics.bound) {
      r.warnings.push_back({"implausible",
                            "implausible: the point is " + FormatNumber(d) +
                                " standard deviations from the mean (Mahalanobis), beyond " +
                                FormatNumber(rig.statistics.bound),
                            "", d, true});
    }
  }
  r.sum = RoundSignificant(r.sum);
  if (r.sum > 1.0 + 1e-6) {
    // Where it matters: the most any one vertex takes, and which shapes stack there.
    r.vertex_sum = LargestVertexSum(rig, weights, r.stacked_shapes);
    std::string where;
    if (r.vertex_sum <= 1.0 + 1e-6) {
      where = "; but no vertex moves more than " + FormatNumber(r.vertex_sum) +
              " of a full shape's move (the shapes act on different vertices)";
    } else {
      std::string names;
      for (size_t k = 0; k < r.stacked_shapes.size() && k < 6; ++k)
        names += (k ? " + " : "") + rig.shapes[r.stacked_shapes[k]].name;
      if (r.stacked_shapes.size() > 6) names += " + ...";
      where = "; on one vertex " + names + " stack to " + FormatNumber(r.vertex_sum) +
              " of a full shape's move";
    }
    r.warnings.insert(r.warnings.begin(), {"extrapolation",
                                           "extrapolation: sum of weights " + FormatNumber(r.sum) +
                                               " exceeds 1" + where,
                                           "", r.sum, true});
  }
  if (mode == BlendMode::kAbsolute && std::fabs(r.sum - 1.0) > 1e-4) {
    r.warnings.push_back({"absolute_sum",
                          "absolute mode: sum of weights " + FormatNumber(r.sum) +
                              " is not 1; the base takes weight " + FormatNumber(1.0 - r.sum),
                          "", r.sum, true});
  }
  return r;
}

Status ApplyControls(const Rig& rig, std::span<const WeightEntry> controls,
                     std::vector<WeightEntry>& weights, std::vector<Warning>& warnings) {
  Status status = InvalidArgument("");
  for (const WeightEntry& e : controls) {
    const Control* c = nullptr;
    for (const Control& k : rig.controls) {
      if (k.name == e.name) c = &k;
    }
    if (!c) {
      status.AddField(e.pointer, [&] {
        std::string msg = "unknown control '" + e.name + "'";
        if (rig.controls.empty()) return msg + ": this rig has no controls";
        std::vector<std::string_view> names;
        for (const Control& k : rig.controls) names.push_back(k.name);
        msg += DidYouMean(e.name, names);
        size_t shown = 0;
        msg += "; controls: ";
        for (const Control& k : rig.controls) {
          if (shown++ == 20) {
            msg += ", ... (" + std::to_string(rig.controls.size()) + " in all)";
            break;
          }
          msg += (shown > 1 ? ", " : "") + k.name;
        }
        return msg;
      });
      continue;
    }
    if (!std::isfinite(e.value)) {
      status.AddField(e.pointer, "control '" + e.name + "' must be a finite number");
      continue;
    }
    if (e.value < c->min || e.value > c->max) {
      warnings.push_back({"control_out_of_range",
                          "control '" + c->name + "' = " + FormatNumber(e.value) +
                              " is outside its range [" + FormatNumber(c->min) + ", " +
                              FormatNumber(c->max) + "]",
                          c->name, e.value, true});
    }
    WeightEntry pos{rig.shapes[c->positive].name, -1,
                    c->negative >= 0 ? std::max(e.value, 0.0) : e.value, e.pointer};
    weights.push_back(pos);
    if (c->negative >= 0)
      weights.push_back({rig.shapes[c->negative].name, -1, std::max(-e.value, 0.0), e.pointer});
  }
  if (status.fields.empty()) return Status::Ok();
  status.message = status.fields[0].pointer + ": " + status.fields[0].message;
  return status;
}

}  // namespace engine
}  // namespace facespace
