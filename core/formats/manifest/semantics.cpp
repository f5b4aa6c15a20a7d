// The manifest's sections that make shapes more than a sum: controls, in-betweens, correctives and
// statistics.
#include <algorithm>
#include <cmath>

#include "facespace/engine/shape_tools.h"
#include "facespace/formats/io.h"
#include "sections.h"

namespace facespace::formats::manifest {

namespace {

// Marks shape s driven (by an in-between or a corrective); a shape is driven once.
Status Drive(Rig& rig, uint32_t s, const std::string& ptr) {
  if (rig.shapes[s].driven) return Bad(ptr, "'" + rig.shapes[s].name + "' is already driven");
  rig.shapes[s].driven = true;
  return Status::Ok();
}

// One control: the shape values below 0 drive (negative), above 0 (positive, required), its group.
Status ApplyControl(Rig& rig, const std::string& key, const json& item, const std::string& ptr) {
  if (!item.is_object()) return Bad(ptr, "must be an object");
  Control c;
  c.name = key;
  for (const char* side : {"negative", "positive"}) {
    if (!item.contains(side)) continue;
    uint32_t shape = 0;
    if (Status st = ShapeAt(rig, item[side], ptr + "/" + side, &shape); !st.ok()) return st;
    (std::string(side) == "negative" ? c.negative : c.positive) = static_cast<int>(shape);
  }
  if (c.positive < 0)
    return Bad(ptr + "/positive", "is required (the shape driven by values above 0)");
  if (item.contains("group")) {
    if (!item["group"].is_string()) return Bad(ptr + "/group", "must be a string");
    c.group = item["group"].get<std::string>();
  }
  c.min = c.negative >= 0 ? -1.0f : 0.0f;
  rig.controls.push_back(std::move(c));
  return Status::Ok();
}

// One slider's in-betweens: each a driven shape at its weight (the slider's own shape at `full`),
// sorted.
Status ApplyInBetween(Rig& rig, const std::string& key, const json& item, const std::string& ptr) {
  InBetweens ib;
  std::vector<std::string> key_ptr;  // Each key's pointer, by weight once sorted.
  if (Status s = ShapeAt(rig, json(key), ptr, &ib.slider); !s.ok()) return s;
  if (!item.is_array() || item.empty())
    return Bad(ptr, "must be a non-empty array of {\"shape\", \"weight\"}");
  for (size_t k = 0; k < item.size(); ++k) {
    const json& e = item[k];
    const std::string kp = ptr + "/" + std::to_string(k);
    if (!e.is_object() || !e.contains("shape") || !e.contains("weight") ||
        !e["weight"].is_number()) {
      return Bad(kp, "must be {\"shape\": NAME, \"weight\": W} with W a non-zero number");
    }
    uint32_t shape = 0;
    if (Status s = ShapeAt(rig, e["shape"], kp + "/shape", &shape); !s.ok()) return s;
    const float w = e["weight"].get<float>();
    if (!std::isfinite(w) || w == 0.0f)
      return Bad(kp + "/weight", "must be a finite non-zero number (the base is at 0)");
    if (shape == ib.slider) {  // Where the slider's own shape is reached: 1 unless given.
      ib.full = w;
      continue;
    }
    if (Status s = Drive(rig, shape, kp + "/shape"); !s.ok()) return s;
    ib.keys.emplace_back(w, shape);
    key_ptr.push_back(kp + "/weight");
  }
  for (size_t k = 0; k < ib.keys.size(); ++k) {
    if (ib.keys[k].first == ib.full)
      return Bad(key_ptr[k], "is where the slider reaches its own shape (" +
                                 std::to_string(ib.full) + "); an in-between needs another weight");
  }
  std::sort(ib.keys.begin(), ib.keys.end());
  for (size_t k = 1; k < ib.keys.size(); ++k) {
    if (ib.keys[k].first == ib.keys[k - 1].first)
      return Bad(ptr, "two in-betweens at the same weight");
  }
  rig.inbetweens.push_back(std::move(ib));
  return Status::Ok();
}

// One corrective shape: the sliders that drive it (two or more) and how they combine.
Status ApplyCorrective(Rig& rig, const std::string& key, const json& item, const std::string& ptr) {
  Corrective c;
  if (Status s = ShapeAt(rig, json(key), ptr, &c.shape); !s.ok()) return s;
  if (!item.is_object() || !item.contains("drivers") || !item["drivers"].is_array() ||
      item["drivers"].size() < 2) {
    return Bad(ptr + "/drivers", "must be an array of at least two shape names");
  }
  for (size_t k = 0; k < item["drivers"].size(); ++k) {
    uint32_t d = 0;
    if (Status s = ShapeAt(rig, item["drivers"][k], ptr + "/drivers/" + std::to_string(k), &d);
        !s.ok())
      return s;
    if (d == c.shape || rig.shapes[d].driven)
      return Bad(ptr + "/drivers/" + std::to_string(k),
                 "a driver must be a slider, not a driven shape");
    c.drivers.push_back(d);
  }
  if (item.contains("mode")) {
    const json& m = item["mode"];
    if (m != "product" && m != "min") return Bad(ptr + "/mode", "must be \"product\" or \"min\"");
    c.use_min = m == "min";
  }
  if (Status s = Drive(rig, c.shape, ptr); !s.ok()) return s;
  rig.correctives.push_back(std::move(c));
  return Status::Ok();
}

}  // namespace

void PairControls(Rig& rig) {
  for (size_t i = 0; i < rig.controls.size(); ++i) {
    if (rig.controls[i].partner >= 0) continue;
    const std::string other = CounterpartName(rig.controls[i].name);
    if (other.empty()) continue;
    for (size_t k = 0; k < rig.controls.size(); ++k) {
      if (k != i && rig.controls[k].name == other) {
        rig.controls[i].partner = static_cast<int>(k);
        rig.controls[k].partner = static_cast<int>(i);
      }
    }
  }
}

Status ShapeAt(const Rig& rig, const json& v, const std::string& ptr, uint32_t* out) {
  if (!v.is_string()) return Bad(ptr, "must be a shape name");
  const int s = FindShape(rig, v.get<std::string>());
  if (s < 0) return Bad(ptr, "unknown shape '" + v.get<std::string>() + "'");
  *out = static_cast<uint32_t>(s);
  return Status::Ok();
}
// "controls": name -> {group, negative, positive}; left/right ones paired.
Status ApplyControls(Rig& rig, const json& section) {
  if (Status s = ForEachMember(
          section, "/controls",
          "must be an object of control name -> {\"group\", \"negative\", \"positive\"}", rig,
          ApplyControl);
      !s.ok())
    return s;
  PairControls(rig);
  return Status::Ok();
}
// "inbetweens": slider -> [{shape, weight}], sorted by weight.
Status ApplyInBetweens(Rig& rig, const json& section) {
  return ForEachMember(section, "/inbetweens",
                       "must be an object of slider shape -> [{\"shape\", \"weight\"}]", rig,
                       ApplyInBetween);
}
// "correctives": shape -> {drivers, mode}.
Status ApplyCorrectives(Rig& rig, const json& section) {
  return ForEachMember(section, "/correctives",
                       "must be an object of shape -> {\"drivers\": [...], \"mode\"}", rig,
                       ApplyCorrective);
}

// "statistics": {mean, stddev | components, bound}, the face space's distribution.
Status ApplyStatistics(Rig& rig, const json& st) {
  if (!st.is_object())
    return Bad("/statistics",
               "must be an object {\"mean\", \"stddev\" | \"components\", \"bound\"}");
  ShapeStatistics stats;
  stats.present = true;
  const size_t n = rig.shapes.size();
  stats.mean.assign(n, 0.0f);
  auto weight_map = [&](const json& m, const std::string& ptr, std::vector<float>& out) -> Status {
    if (!m.is_object()) return Bad(ptr, "must be an object of shape name -> number");
    out.assign(n, 0.0f);
    for (auto e = m.begin(); e != m.end(); ++e) {
      uint32_t s = 0;
      if (Status r = ShapeAt(rig, json(e.key()), ptr + "/" + JsonPointerEscape(e.key()), &s);
          !r.ok())
        return r;
      if (!e->is_number()) return Bad(ptr + "/" + JsonPointerEscape(e.key()), "must be a number");
      out[s] = e->get<float>();
    }
    return Status::Ok();
  };
  if (st.contains("mean")) {
    if (Status r = weight_map(st["mean"], "/statistics/mean", stats.mean); !r.ok()) return r;
  }
  if (st.contains("stddev")) {  // Diagonal: each shape its own component.
    std::vector<float> sd;
    if (Status r = weight_map(st["stddev"], "/statistics/stddev", sd); !r.ok()) return r;
    for (size_t s = 0; s < n; ++s) {
      if (sd[s] == 0.0f) continue;
      if (!(sd[s] > 0.0f))
        return Bad("/statistics/stddev/" + JsonPointerEscape(rig.shapes[s].name), "must be > 0");
      stats.components.emplace_back(n, 0.0f);
      stats.components.back()[s] = 1.0f;
      stats.stddev.push_back(sd[s]);
    }
  }
  if (st.contains("components")) {
    if (!st["components"].is_array())
      return Bad("/statistics/components", "must be an array of {\"weights\", \"stddev\"}");
    for (size_t k = 0; k < st["components"].size(); ++k) {
      const json& c = st["components"][k];
      const std::string ptr = "/statistics/components/" + std::to_string(k);
      if (!c.is_object() || !c.contains("weights") || !c.contains("stddev") ||
          !c["stddev"].is_number() || !(c["stddev"].get<double>() > 0)) {
        return Bad(ptr, "must be {\"weights\": {NAME: x}, \"stddev\": s > 0}");
      }
      std::vector<float> dir;
      if (Status r = weight_map(c["weights"], ptr + "/weights", dir); !r.ok()) return r;
      double norm = 0;
      for (float x : dir) norm += static_cast<double>(x) * x;
      if (norm == 0) return Bad(ptr + "/weights", "must not be zero");
      for (float& x : dir) x = static_cast<float>(x / std::sqrt(norm));
      for (const auto& other : stats.components) {
        double dot = 0;
        for (size_t s = 0; s < n; ++s) dot += static_cast<double>(dir[s]) * other[s];
        if (std::fabs(dot) > 1e-3)
          return Bad(ptr + "/weights", "must be orthogonal to the other components");
      }
      stats.components.push_back(std::move(dir));
      stats.stddev.push_back(c["stddev"].get<float>());
    }
  }
  if (st.contains("bound")) {
    if (!st["bound"].is_number() || !(st["bound"].get<double>() > 0))
      return Bad("/statistics/bound", "must be a number > 0 (in standard deviations)");
    stats.bound = st["bound"].get<float>();
  }
  if (stats.components.empty()) return Bad("/statistics", "needs \"stddev\" or \"components\"");
  rig.statistics = std::move(stats);
  return Status::Ok();
}

}  // namespace facespace::formats::manifest
