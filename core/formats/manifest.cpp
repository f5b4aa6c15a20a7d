// The manifest: what glTF drops (groups, ranges, partners, aliases, controls, in-betweens,
// correctives, statistics), as JSON beside a rig file; and MakeHuman's modifiers as controls.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "facespace/formats/io.h"
#include "facespace/core/shape_tools.h"
#include "facespace/core/weights.h"

namespace facespace {

namespace {

using nlohmann::json;

// Left/right controls ("eyes/l-eye-bag-decr|incr" and "eyes/r-...") as partners.
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

// Controls, in-betweens, correctives and statistics: what makes shapes more than a sum.
template <typename Bad>
Status ApplySemantics(Rig& rig, const json& j, Bad bad) {
  auto shape_at = [&](const json& v, const std::string& ptr, uint32_t* out) -> Status {
    if (!v.is_string()) return bad(ptr, "must be a shape name");
    const int s = FindShape(rig, v.get<std::string>());
    if (s < 0) return bad(ptr, "unknown shape '" + v.get<std::string>() + "'");
    *out = static_cast<uint32_t>(s);
    return Status::Ok();
  };
  auto drive = [&](uint32_t s, const std::string& ptr) -> Status {
    if (rig.shapes[s].driven) return bad(ptr, "'" + rig.shapes[s].name + "' is already driven");
    rig.shapes[s].driven = true;
    return Status::Ok();
  };
  if (j.contains("controls")) {
    if (!j["controls"].is_object()) return bad("/controls", "must be an object of control name -> {\"group\", \"negative\", \"positive\"}");
    for (auto it = j["controls"].begin(); it != j["controls"].end(); ++it) {
      const std::string ptr = "/controls/" + JsonPointerEscape(it.key());
      if (!it->is_object()) return bad(ptr, "must be an object");
      Control c;
      c.name = it.key();
      for (const char* side : {"negative", "positive"}) {
        if (!it->contains(side)) continue;
        uint32_t shape = 0;
        if (Status st = shape_at((*it)[side], ptr + "/" + side, &shape); !st.ok()) return st;
        (std::string(side) == "negative" ? c.negative : c.positive) = static_cast<int>(shape);
      }
      if (c.positive < 0) return bad(ptr + "/positive", "is required (the shape driven by values above 0)");
      if (it->contains("group")) {
        if (!(*it)["group"].is_string()) return bad(ptr + "/group", "must be a string");
        c.group = (*it)["group"].get<std::string>();
      }
      c.min = c.negative >= 0 ? -1.0f : 0.0f;
      rig.controls.push_back(std::move(c));
    }
    PairControls(rig);
  }
  if (j.contains("inbetweens")) {
    if (!j["inbetweens"].is_object()) return bad("/inbetweens", "must be an object of slider shape -> [{\"shape\", \"weight\"}]");
    for (auto it = j["inbetweens"].begin(); it != j["inbetweens"].end(); ++it) {
      const std::string ptr = "/inbetweens/" + JsonPointerEscape(it.key());
      InBetweens ib;
      std::vector<std::string> key_ptr;  // Each key's pointer, by weight once sorted.
      if (Status s = shape_at(json(it.key()), ptr, &ib.slider); !s.ok()) return s;
      if (!it->is_array() || it->empty()) return bad(ptr, "must be a non-empty array of {\"shape\", \"weight\"}");
      for (size_t k = 0; k < it->size(); ++k) {
        const json& e = (*it)[k];
        const std::string kp = ptr + "/" + std::to_string(k);
        if (!e.is_object() || !e.contains("shape") || !e.contains("weight") || !e["weight"].is_number()) {
          return bad(kp, "must be {\"shape\": NAME, \"weight\": W} with W a non-zero number");
        }
        uint32_t shape = 0;
        if (Status s = shape_at(e["shape"], kp + "/shape", &shape); !s.ok()) return s;
        const float w = e["weight"].get<float>();
        if (!std::isfinite(w) || w == 0.0f) return bad(kp + "/weight", "must be a finite non-zero number (the base is at 0)");
        if (shape == ib.slider) {  // Where the slider's own shape is reached: 1 unless given.
          ib.full = w;
          continue;
        }
        if (Status s = drive(shape, kp + "/shape"); !s.ok()) return s;
        ib.keys.emplace_back(w, shape);
        key_ptr.push_back(kp + "/weight");
      }
      for (size_t k = 0; k < ib.keys.size(); ++k) {
        if (ib.keys[k].first == ib.full) return bad(key_ptr[k], "is where the slider reaches its own shape (" + std::to_string(ib.full) + "); an in-between needs another weight");
      }
      std::sort(ib.keys.begin(), ib.keys.end());
      for (size_t k = 1; k < ib.keys.size(); ++k) {
        if (ib.keys[k].first == ib.keys[k - 1].first) return bad(ptr, "two in-betweens at the same weight");
      }
      rig.inbetweens.push_back(std::move(ib));
    }
  }
  if (j.contains("correctives")) {
    if (!j["correctives"].is_object()) return bad("/correctives", "must be an object of shape -> {\"drivers\": [...], \"mode\"}");
    for (auto it = j["correctives"].begin(); it != j["correctives"].end(); ++it) {
      const std::string ptr = "/correctives/" + JsonPointerEscape(it.key());
      Corrective c;
      if (Status s = shape_at(json(it.key()), ptr, &c.shape); !s.ok()) return s;
      if (!it->is_object() || !it->contains("drivers") || !(*it)["drivers"].is_array() || (*it)["drivers"].size() < 2) {
        return bad(ptr + "/drivers", "must be an array of at least two shape names");
      }
      for (size_t k = 0; k < (*it)["drivers"].size(); ++k) {
        uint32_t d = 0;
        if (Status s = shape_at((*it)["drivers"][k], ptr + "/drivers/" + std::to_string(k), &d); !s.ok()) return s;
        if (d == c.shape || rig.shapes[d].driven) return bad(ptr + "/drivers/" + std::to_string(k), "a driver must be a slider, not a driven shape");
        c.drivers.push_back(d);
      }
      if (it->contains("mode")) {
        const json& m = (*it)["mode"];
        if (m != "product" && m != "min") return bad(ptr + "/mode", "must be \"product\" or \"min\"");
        c.use_min = m == "min";
      }
      if (Status s = drive(c.shape, ptr); !s.ok()) return s;
      rig.correctives.push_back(std::move(c));
    }
  }
  if (j.contains("statistics")) {
    const json& st = j["statistics"];
    if (!st.is_object()) return bad("/statistics", "must be an object {\"mean\", \"stddev\" | \"components\", \"bound\"}");
    ShapeStatistics stats;
    stats.present = true;
    const size_t n = rig.shapes.size();
    stats.mean.assign(n, 0.0f);
    auto weight_map = [&](const json& m, const std::string& ptr, std::vector<float>& out) -> Status {
      if (!m.is_object()) return bad(ptr, "must be an object of shape name -> number");
      out.assign(n, 0.0f);
      for (auto e = m.begin(); e != m.end(); ++e) {
        uint32_t s = 0;
        if (Status r = shape_at(json(e.key()), ptr + "/" + JsonPointerEscape(e.key()), &s); !r.ok()) return r;
        if (!e->is_number()) return bad(ptr + "/" + JsonPointerEscape(e.key()), "must be a number");
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
        if (!(sd[s] > 0.0f)) return bad("/statistics/stddev/" + JsonPointerEscape(rig.shapes[s].name), "must be > 0");
        stats.components.emplace_back(n, 0.0f);
        stats.components.back()[s] = 1.0f;
        stats.stddev.push_back(sd[s]);
      }
    }
    if (st.contains("components")) {
      if (!st["components"].is_array()) return bad("/statistics/components", "must be an array of {\"weights\", \"stddev\"}");
      for (size_t k = 0; k < st["components"].size(); ++k) {
        const json& c = st["components"][k];
        const std::string ptr = "/statistics/components/" + std::to_string(k);
        if (!c.is_object() || !c.contains("weights") || !c.contains("stddev") || !c["stddev"].is_number() || !(c["stddev"].get<double>() > 0)) {
          return bad(ptr, "must be {\"weights\": {NAME: x}, \"stddev\": s > 0}");
        }
        std::vector<float> dir;
        if (Status r = weight_map(c["weights"], ptr + "/weights", dir); !r.ok()) return r;
        double norm = 0;
        for (float x : dir) norm += static_cast<double>(x) * x;
        if (norm == 0) return bad(ptr + "/weights", "must not be zero");
        for (float& x : dir) x = static_cast<float>(x / std::sqrt(norm));
        for (const auto& other : stats.components) {
          double dot = 0;
          for (size_t s = 0; s < n; ++s) dot += static_cast<double>(dir[s]) * other[s];
          if (std::fabs(dot) > 1e-3) return bad(ptr + "/weights", "must be orthogonal to the other components");
        }
        stats.components.push_back(std::move(dir));
        stats.stddev.push_back(c["stddev"].get<float>());
      }
    }
    if (st.contains("bound")) {
      if (!st["bound"].is_number() || !(st["bound"].get<double>() > 0)) return bad("/statistics/bound", "must be a number > 0 (in standard deviations)");
      stats.bound = st["bound"].get<float>();
    }
    if (stats.components.empty()) return bad("/statistics", "needs \"stddev\" or \"components\"");
    rig.statistics = std::move(stats);
  }
  return Status::Ok();
}

}  // namespace

Status ApplyManifest(Rig& rig, const std::string& text) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidArgument("manifest: not valid JSON");
  if (!j.is_object()) return InvalidArgument("manifest: must be a JSON object");
  auto bad = [](const std::string& pointer, const std::string& msg) {
    Status s = InvalidArgument("manifest: " + pointer + ": " + msg);
    s.fields.push_back({pointer, msg});
    return s;
  };
  static constexpr std::string_view kMembers[] = {"name", "credit", "start", "base_motion", "materials", "shapes", "groups", "controls",
                                                  "derived", "inbetweens", "correctives", "statistics"};
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(std::begin(kMembers), std::end(kMembers), it.key()) == std::end(kMembers)) {
      return bad("/" + JsonPointerEscape(it.key()), "unknown member" + DidYouMean(it.key(), kMembers));
    }
  }
  if (j.contains("name")) {
    if (!j["name"].is_string()) return bad("/name", "must be a string");
    rig.name = j["name"].get<std::string>();
  }
  if (j.contains("credit")) {
    if (!j["credit"].is_string()) return bad("/credit", "must be a string");
    rig.credit = j["credit"].get<std::string>();
  }
  if (j.contains("start")) {
    if (j["start"] != "neutral" && j["start"] != "defaults") return bad("/start", "must be \"neutral\" (every weight 0) or \"defaults\"");
    rig.start_at_defaults = j["start"] == "defaults";
  }
  if (j.contains("base_motion")) {
    const json& b = j["base_motion"];
    if (!b.is_string()) return bad("/base_motion", "must be the name of one of the rig's motions (clips)");
    const std::string name = b.get<std::string>();
    std::vector<std::string_view> names;
    for (const AnimationInfo& a : rig.animations) names.push_back(a.name);
    // A model copied without its motion folder still loads: the base is then a warning.
    if (std::find(names.begin(), names.end(), name) == names.end()) {
      rig.load_warnings.push_back({"manifest_unknown_motion",
                                   "manifest: /base_motion names no motion of the rig: '" + name.substr(0, 60) + "'" + DidYouMean(name, names) +
                                       "; motions play without a base",
                                   name.substr(0, 60), 0.0, false});
    } else {
      rig.base_motion = name;
    }
  }
  if (j.contains("materials")) {
    // A material's base colour (RGBA) by name: for a rig whose textures are not at hand (an MMD
    // model's blush is a red texture on a see-through material).
    const json& m = j["materials"];
    if (!m.is_object()) return bad("/materials", "must be an object of material name -> {\"base_color\": [r, g, b, a]}");
    for (auto it = m.begin(); it != m.end(); ++it) {
      const std::string ptr = "/materials/" + JsonPointerEscape(it.key());
      auto found = std::find_if(rig.materials.begin(), rig.materials.end(), [&](const Material& x) { return x.name == it.key(); });
      const json& c = it.value().is_object() && it.value().contains("base_color") ? it.value()["base_color"] : json();
      if (!it.value().is_object() || it.value().size() != 1 || !c.is_array() || c.size() != 4 ||
          !std::all_of(c.begin(), c.end(), [](const json& x) { return x.is_number() && x.get<double>() >= 0 && x.get<double>() <= 1; })) {
        return bad(ptr, "must be {\"base_color\": [r, g, b, a]}, each in [0, 1]");
      }
      if (found == rig.materials.end()) {
        rig.load_warnings.push_back({"manifest_unknown_material", "manifest: " + ptr + " names no material of the rig", it.key().substr(0, 60), 0.0, false});
        continue;
      }
      for (int k = 0; k < 4; ++k) found->base_color_factor[k] = c[k].get<float>();
    }
  }
  if (j.contains("derived")) {
    // New shapes first, so that the rest of the manifest can describe them too.
    if (!j["derived"].is_object()) return bad("/derived", "must be an object of new shape -> {\"from\", \"mirror\", \"mask\"}");
    for (auto it = j["derived"].begin(); it != j["derived"].end(); ++it) {
      const std::string ptr = "/derived/" + JsonPointerEscape(it.key());
      const json& o = *it;
      if (!o.is_object() || !o.contains("from") || !o["from"].is_string()) return bad(ptr, "must be an object with \"from\": a shape name");
      DeriveOptions d;
      auto axis_of = [](const std::string& a) { return a == "x" ? 0 : a == "y" ? 1 : a == "z" ? 2 : -1; };
      if (o.contains("mirror")) {
        if (!o["mirror"].is_string() || axis_of(o["mirror"].get<std::string>()) < 0) return bad(ptr + "/mirror", "must be \"x\", \"y\" or \"z\" (the axis across which to reflect)");
        d.mirror = true;
        d.axis = axis_of(o["mirror"].get<std::string>());
      }
      if (o.contains("tolerance")) {
        if (!o["tolerance"].is_number() || o["tolerance"].get<double>() <= 0) return bad(ptr + "/tolerance", "must be a positive number");
        d.tolerance = o["tolerance"].get<float>();
      }
      if (o.contains("mask")) {
        const json& m = o["mask"];
        if (!m.is_object()) return bad(ptr + "/mask", "must be an object {\"side\", \"falloff\", \"vertices\"}");
        d.masked = true;
        if (m.contains("side")) {
          const std::string side = m["side"].is_string() ? m["side"].get<std::string>() : "";
          if (side.size() != 2 || (side[0] != '+' && side[0] != '-') || axis_of(side.substr(1)) < 0) {
            return bad(ptr + "/mask/side", "must be \"+x\", \"-x\", \"+y\", \"-y\", \"+z\" or \"-z\"");
          }
          d.mask.side = side[0] == '+' ? 1 : -1;
          d.mask.axis = axis_of(side.substr(1));
        }
        if (m.contains("falloff")) {
          if (!m["falloff"].is_number() || m["falloff"].get<double>() < 0) return bad(ptr + "/mask/falloff", "must be a number >= 0 (mesh units)");
          d.mask.falloff = m["falloff"].get<float>();
        }
        if (m.contains("vertices")) {
          if (!m["vertices"].is_array()) return bad(ptr + "/mask/vertices", "must be an array of vertex indices");
          for (const json& v : m["vertices"]) {
            if (!v.is_number_unsigned()) return bad(ptr + "/mask/vertices", "must be an array of vertex indices");
            d.mask.vertices.push_back(v.get<uint32_t>());
          }
        }
      }
      if (!d.mirror && !d.masked) return bad(ptr, "needs \"mirror\" or \"mask\" (or both)");
      auto r = DeriveShape(rig, it.key(), o["from"].get<std::string>(), d);
      if (!r.ok()) return bad(ptr, r.status().message);
      if (r->unmatched > 0) {
        rig.load_warnings.push_back({"mirror_unmatched", std::to_string(r->unmatched) + " moved vertices of '" + o["from"].get<std::string>() +
                                                             "' have no mirror image; '" + it.key() + "' leaves them still",
                                     it.key(), static_cast<double>(r->unmatched), true});
      }
    }
  }
  if (j.contains("groups")) {
    if (!j["groups"].is_object()) return bad("/groups", "must be an object of group -> [shape names]");
    for (auto it = j["groups"].begin(); it != j["groups"].end(); ++it) {
      const std::string ptr = "/groups/" + JsonPointerEscape(it.key());
      if (!it->is_array()) return bad(ptr, "must be an array of shape names");
      for (const json& name : *it) {
        if (!name.is_string()) return bad(ptr, "must hold strings");
        const int s = FindShape(rig, name.get<std::string>());
        if (s < 0) {
          rig.load_warnings.push_back({"manifest_unknown_shape", "manifest names unknown shape '" + name.get<std::string>() + "'",
                                       name.get<std::string>(), 0.0, false});
          continue;
        }
        rig.shapes[s].group = it.key();
      }
    }
  }
  if (j.contains("shapes")) {
    if (!j["shapes"].is_object()) return bad("/shapes", "must be an object of shape name -> properties");
    for (auto it = j["shapes"].begin(); it != j["shapes"].end(); ++it) {
      const std::string ptr = "/shapes/" + JsonPointerEscape(it.key());
      if (!it->is_object()) return bad(ptr, "must be an object");
      const int s = FindShape(rig, it.key());
      if (s < 0) {
        rig.load_warnings.push_back({"manifest_unknown_shape", "manifest names unknown shape '" + it.key() + "'", it.key(), 0.0, false});
        continue;
      }
      Shape& shape = rig.shapes[s];
      const json& o = *it;
      for (const char* key : {"min", "max", "default"}) {
        if (!o.contains(key)) continue;
        if (!o[key].is_number()) return bad(ptr + "/" + key, "must be a number");
        const float v = o[key].get<float>();
        (std::string(key) == "min" ? shape.min : std::string(key) == "max" ? shape.max : shape.default_weight) = v;
      }
      if (shape.min > shape.max) return bad(ptr, "min is greater than max");
      if (o.contains("group")) {
        if (!o["group"].is_string()) return bad(ptr + "/group", "must be a string");
        shape.group = o["group"].get<std::string>();
      }
      if (o.contains("aliases")) {
        if (!o["aliases"].is_array()) return bad(ptr + "/aliases", "must be an array of strings");
        for (const json& a : o["aliases"]) {
          if (!a.is_string()) return bad(ptr + "/aliases", "must be an array of strings");
          const int other = FindShape(rig, a.get<std::string>());
          if (other >= 0 && other != s) return bad(ptr + "/aliases", "'" + a.get<std::string>() + "' already names another shape");
          shape.aliases.push_back(a.get<std::string>());
        }
      }
      if (o.contains("partner")) {
        if (o["partner"].is_null()) {
          if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
          shape.partner = -1;
          continue;
        }
        if (!o["partner"].is_string()) return bad(ptr + "/partner", "must be a shape name or null");
        const int p = FindShape(rig, o["partner"].get<std::string>());
        if (p < 0 || p == s) return bad(ptr + "/partner", "unknown partner shape '" + o["partner"].get<std::string>() + "'");
        if (shape.partner >= 0) rig.shapes[shape.partner].partner = -1;
        if (rig.shapes[p].partner >= 0) rig.shapes[rig.shapes[p].partner].partner = -1;
        shape.partner = p;
        rig.shapes[p].partner = s;
      }
    }
  }
  if (Status st = ApplySemantics(rig, j, bad); !st.ok()) return st;
  return Status::Ok();
}

Status ApplyMakeHumanModifiers(Rig& rig, const std::string& text) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_array()) return InvalidArgument("not a modifiers file: want a JSON array of {\"group\", \"modifiers\"}");
  std::vector<std::string> missing;
  for (size_t g = 0; g < j.size(); ++g) {
    const json& group = j[g];
    if (!group.is_object() || !group.contains("group") || !group["group"].is_string() || !group.contains("modifiers") ||
        !group["modifiers"].is_array()) {
      return InvalidArgument("/" + std::to_string(g) + ": want {\"group\": NAME, \"modifiers\": [...]}");
    }
    const std::string gname = group["group"].get<std::string>();
    for (const json& m : group["modifiers"]) {
      auto missing_target = [&](const std::string& name) {
        missing.push_back(gname + "/" + name);
      };
      if (!m.is_object() || !m.contains("target") || !m["target"].is_string()) continue;  // Macro modifiers: no target.
      const std::string target = m["target"].get<std::string>();
      Control c;
      c.group = gname;
      if (m.contains("min") && m.contains("max") && m["min"].is_string() && m["max"].is_string()) {
        const std::string lo = m["min"].get<std::string>(), hi = m["max"].get<std::string>();
        c.name = gname + "/" + target + "-" + lo + "|" + hi;
        c.negative = FindShape(rig, target + "-" + lo);
        c.positive = FindShape(rig, target + "-" + hi);
        if (c.negative < 0 || c.positive < 0) {
          missing_target(target + "-" + lo + "|" + hi);
          continue;
        }
        c.min = -1.0f;
      } else {
        c.name = gname + "/" + target;
        c.positive = FindShape(rig, target);
        if (c.positive < 0) {
          missing_target(target);
          continue;
        }
      }
      for (int s : {c.negative, c.positive}) {
        if (s >= 0) rig.shapes[s].group = gname;
      }
      rig.controls.push_back(std::move(c));
    }
  }
  PairControls(rig);
  if (!missing.empty()) {  // One warning naming them (a folder left out gives dozens).
    std::string names;
    for (size_t i = 0; i < missing.size() && i < 12; ++i) names += (i ? ", " : "") + missing[i];
    if (missing.size() > 12) names += ", ... (" + std::to_string(missing.size()) + " in all)";
    rig.load_warnings.push_back({"modifier_targets_missing",
                                 std::to_string(missing.size()) + " modifier(s) name targets that were not found, so they are no controls: " + names,
                                 "", static_cast<double>(missing.size()), true});
  }
  return Status::Ok();
}

std::string ManifestJson(const Rig& rig) {
  json m = json::object();
  m["name"] = rig.name;
  if (!rig.credit.empty()) m["credit"] = rig.credit;
  if (rig.start_at_defaults) m["start"] = "defaults";
  if (!rig.base_motion.empty()) m["base_motion"] = rig.base_motion;
  json shapes = json::object();
  for (const Shape& s : rig.shapes) {
    json o = {{"group", s.group}, {"min", s.min}, {"max", s.max}, {"default", s.default_weight}};
    if (s.partner >= 0) o["partner"] = rig.shapes[s.partner].name;
    if (!s.aliases.empty()) o["aliases"] = s.aliases;
    shapes[s.name] = o;
  }
  m["shapes"] = shapes;
  if (!rig.inbetweens.empty()) {
    json inbetweens = json::object();
    for (const InBetweens& ib : rig.inbetweens) {
      json keys = json::array();
      for (const auto& [w, shape] : ib.keys) keys.push_back({{"shape", rig.shapes[shape].name}, {"weight", w}});
      if (ib.full != 1.0f) keys.push_back({{"shape", rig.shapes[ib.slider].name}, {"weight", ib.full}});
      inbetweens[rig.shapes[ib.slider].name] = keys;
    }
    m["inbetweens"] = inbetweens;
  }
  if (!rig.controls.empty()) {
    json controls = json::object();
    for (const Control& c : rig.controls) {
      json o = {{"group", c.group}, {"positive", rig.shapes[c.positive].name}};
      if (c.negative >= 0) o["negative"] = rig.shapes[c.negative].name;
      controls[c.name] = o;
    }
    m["controls"] = controls;
  }
  return m.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace facespace
