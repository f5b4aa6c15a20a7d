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
#include "facespace/formats/rig_json.h"
#include "facespace/core/face.h"
#include "facespace/core/shape_tools.h"
#include "facespace/core/speech.h"
#include "facespace/core/weights.h"
#include "common/json_depth.h"

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


// "visemes": viseme name (speech.h) -> {SHAPE: w} (or null: none), "nolip" and "jaw": lists of shapes.
template <typename Bad>
Status ApplyVisemesManifest(Rig& rig, const json& v, Bad bad) {
  if (!v.is_object()) return bad("/visemes", "must be an object of viseme (sil PP FF TH DD kk CH SS nn RR aa E ih oh ou) -> {SHAPE: w}, and \"nolip\", \"jaw\": [SHAPE, ...]");
  auto shape_of = [&](const std::string& name, const std::string& ptr, int* out) -> Status {
    *out = FindShape(rig, name);
    if (*out >= 0) return Status::Ok();
    std::vector<std::string_view> names;
    for (const Shape& sh : rig.shapes) names.push_back(sh.name);
    return bad(ptr, "unknown shape '" + name + "'" + DidYouMean(name, names));
  };
  VisemeMap& m = rig.visemes;
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string ptr = "/visemes/" + JsonPointerEscape(it.key());
    if (it.key() == "nolip" || it.key() == "jaw") {
      if (!it->is_array()) return bad(ptr, "must be a list of shape names");
      std::vector<uint32_t>& list = it.key() == "nolip" ? m.nolip : m.jaw;
      list.clear();
      for (size_t k = 0; k < it->size(); ++k) {
        const json& name = (*it)[k];
        const std::string p = ptr + "/" + std::to_string(k);
        if (!name.is_string()) return bad(p, "must be a shape name");
        int s;
        if (Status st = shape_of(name.get<std::string>(), p, &s); !st.ok()) return st;
        list.push_back(static_cast<uint32_t>(s));
      }
      (it.key() == "nolip" ? m.nolip_named : m.jaw_named) = true;
      continue;
    }
    const std::optional<Viseme> viseme = VisemeByName(it.key());
    if (!viseme) {
      std::vector<std::string_view> names(std::begin(kVisemeNames), std::end(kVisemeNames));
      names.push_back("nolip");
      names.push_back("jaw");
      return bad(ptr, "unknown viseme" + DidYouMean(it.key(), names) + " (OpenXR's 15: sil PP FF TH DD kk CH SS nn RR aa E ih oh ou)");
    }
    auto& binds = m.binds[static_cast<size_t>(*viseme)];
    binds.clear();
    if (!it->is_null()) {
      if (!it->is_object()) return bad(ptr, "must be an object of shape name -> weight (or null: no shape)");
      for (auto w = it->begin(); w != it->end(); ++w) {
        const std::string wp = ptr + "/" + JsonPointerEscape(w.key());
        int s;
        if (Status st = shape_of(w.key(), wp, &s); !st.ok()) return st;
        if (!w->is_number() || !std::isfinite(w->get<double>())) return bad(wp, "must be a finite number");
        binds.emplace_back(static_cast<uint32_t>(s), w->get<float>());
      }
    }
    m.named |= static_cast<uint16_t>(1u << static_cast<unsigned>(*viseme));
  }
  return Status::Ok();
}

// "expressions" (VRM's vocabulary, or the rig's own names, to weights of its shapes) and "gaze" (how the
// eyes follow: bones or shapes, range maps, the head's and neck's shares). Read after the shapes.
template <typename Bad>
Status ApplyFaceManifest(Rig& rig, const json& j, Bad bad) {
  if (j.contains("expressions")) {
    const json& ex = j["expressions"];
    if (!ex.is_object()) return bad("/expressions", "must be an object of expression name -> {\"weights\": {SHAPE: w}, \"binary\", \"override_blink\", \"override_look_at\", \"override_mouth\"} (or null: none)");
    for (auto it = ex.begin(); it != ex.end(); ++it) {
      const std::string ptr = "/expressions/" + JsonPointerEscape(it.key());
      if (it.key().empty() || it.key().size() > 64) return bad(ptr, "an expression's name must have 1 to 64 bytes");
      Expression e;
      e.name = it.key();
      const json& o = *it;
      if (!o.is_null()) {
        if (!o.is_object()) return bad(ptr, "must be an object {\"weights\": {SHAPE: w}, ...} or null");
        for (auto m = o.begin(); m != o.end(); ++m) {
          static constexpr std::string_view kKeys[] = {"weights", "binary", "override_blink", "override_look_at", "override_mouth"};
          if (std::find(std::begin(kKeys), std::end(kKeys), m.key()) == std::end(kKeys)) {
            return bad(ptr + "/" + JsonPointerEscape(m.key()), "unknown member" + DidYouMean(m.key(), kKeys));
          }
        }
        if (!o.contains("weights") || !o["weights"].is_object()) return bad(ptr + "/weights", "is required: an object of shape name -> weight at the expression's full value");
        for (auto w = o["weights"].begin(); w != o["weights"].end(); ++w) {
          const std::string wp = ptr + "/weights/" + JsonPointerEscape(w.key());
          const int s = FindShape(rig, w.key());
          if (s < 0) {
            std::vector<std::string_view> names;
            for (const Shape& sh : rig.shapes) names.push_back(sh.name);
            return bad(wp, "unknown shape '" + w.key() + "'" + DidYouMean(w.key(), names));
          }
          if (!w->is_number() || !std::isfinite(w->get<double>())) return bad(wp, "must be a finite number");
          e.binds.emplace_back(static_cast<uint32_t>(s), w->get<float>());
        }
        if (o.contains("binary")) {
          if (!o["binary"].is_boolean()) return bad(ptr + "/binary", "must be true or false");
          e.binary = o["binary"].get<bool>();
        }
        for (const auto& [key, field] : {std::pair{"override_blink", &e.blink}, std::pair{"override_look_at", &e.look_at}, std::pair{"override_mouth", &e.mouth}}) {
          if (!o.contains(key)) continue;
          const json& v = o[key];
          if (v == "none") *field = ExpressionOverride::kNone;
          else if (v == "block") *field = ExpressionOverride::kBlock;
          else if (v == "blend") *field = ExpressionOverride::kBlend;
          else return bad(ptr + "/" + key, "must be \"none\", \"block\" or \"blend\" (VRM's override rules)");
        }
      }
      const int at = FindExpression(rig, e.name);
      if (at >= 0) rig.expressions[at] = std::move(e);
      else rig.expressions.push_back(std::move(e));
    }
  }
  if (j.contains("gaze")) {
    const json& g = j["gaze"];
    if (!g.is_object()) return bad("/gaze", "must be an object {\"eyes\", \"head\", \"neck\", \"coefficient\", \"limits\", \"range_maps\", \"type\"}");
    static constexpr std::string_view kKeys[] = {"type", "eyes", "head", "neck", "coefficient", "limits", "range_maps"};
    for (auto m = g.begin(); m != g.end(); ++m) {
      if (std::find(std::begin(kKeys), std::end(kKeys), m.key()) == std::end(kKeys)) return bad("/gaze/" + JsonPointerEscape(m.key()), "unknown member" + DidYouMean(m.key(), kKeys));
    }
    GazeSetup setup;
    setup.from_manifest = true;
    auto bone = [&](const json& v, const std::string& ptr, int* out) -> Status {
      if (!v.is_string()) return bad(ptr, "must be a bone (node) name");
      *out = FindNode(rig, v.get<std::string>());
      if (*out < 0) return bad(ptr, "the rig has no bone '" + v.get<std::string>() + "'");
      return Status::Ok();
    };
    if (g.contains("eyes")) {
      const json& e = g["eyes"];
      if (!e.is_object() || !e.contains("left") || !e.contains("right")) return bad("/gaze/eyes", "must be {\"left\": BONE, \"right\": BONE}");
      if (Status s = bone(e["left"], "/gaze/eyes/left", &setup.eyes[0]); !s.ok()) return s;
      if (Status s = bone(e["right"], "/gaze/eyes/right", &setup.eyes[1]); !s.ok()) return s;
      setup.kind = GazeSetup::Kind::kBones;
    }
    for (const auto& [key, node, share] : {std::tuple{"head", &setup.head, &setup.head_share}, std::tuple{"neck", &setup.neck, &setup.neck_share}}) {
      if (!g.contains(key)) continue;
      const std::string ptr = std::string("/gaze/") + key;
      const json& h = g[key];
      if (!h.is_object() || !h.contains("bone")) return bad(ptr, "must be {\"bone\": NAME, \"share\": s} (s in [0, 1]: the part of the gaze's angles it turns)");
      if (Status s = bone(h["bone"], ptr + "/bone", node); !s.ok()) return s;
      if (h.contains("share")) {
        if (!h["share"].is_number() || h["share"].get<double>() < 0 || h["share"].get<double>() > 1) return bad(ptr + "/share", "must be a number in [0, 1]");
        *share = h["share"].get<float>();
      }
    }
    if (setup.head_share + setup.neck_share > 1.0f) return bad("/gaze", "the head's and neck's shares add up to more than 1");
    if (g.contains("type")) {
      const json& t = g["type"];
      if (t == "bones") {
        if (setup.kind != GazeSetup::Kind::kBones) return bad("/gaze/type", "\"bones\" needs \"eyes\": {\"left\", \"right\"}");
      } else if (t == "shapes" || t == "expressions" || t == "none") {
        setup.kind = GazeSetup::Kind::kNone;  // "shapes", "expressions": found by DeriveGaze below.
      } else {
        return bad("/gaze/type", "must be \"bones\", \"shapes\", \"expressions\" or \"none\"");
      }
    }
    // The kind and the default range maps (DeriveGaze), then the coefficient and limits (MMDAgent's
    // EYE_ROTATION_COEF: eye turn = coefficient x angle, up to the limit), then explicit range maps.
    const bool none = g.contains("type") && g["type"] == "none";
    rig.gaze = setup;
    if (!none) DeriveGaze(rig);
    const bool bones = rig.gaze.kind == GazeSetup::Kind::kBones;
    if (g.contains("coefficient") || g.contains("limits")) {
      if (!bones) return bad(g.contains("coefficient") ? "/gaze/coefficient" : "/gaze/limits", "is for eye bones (\"eyes\"); eye shapes take \"range_maps\"");
      float coef = 1.0f, horizontal = 30.0f, up = 20.0f, down = 20.0f;
      if (g.contains("coefficient")) {
        if (!g["coefficient"].is_number() || !(g["coefficient"].get<double>() > 0) || g["coefficient"].get<double>() > 1) return bad("/gaze/coefficient", "must be a number in (0, 1]");
        coef = g["coefficient"].get<float>();
      }
      if (g.contains("limits")) {
        const json& l = g["limits"];
        if (!l.is_object()) return bad("/gaze/limits", "must be {\"horizontal\", \"up\", \"down\"} in degrees");
        for (const auto& [key, out] : {std::pair{"horizontal", &horizontal}, std::pair{"up", &up}, std::pair{"down", &down}}) {
          if (!l.contains(key)) continue;
          const json& v = l[key];
          if (!v.is_number() || !(v.get<double>() > 0) || v.get<double>() > 90) return bad(std::string("/gaze/limits/") + key, "must be degrees in (0, 90]");
          *out = v.get<float>();
        }
      }
      rig.gaze.horizontal_inner = rig.gaze.horizontal_outer = {horizontal / coef, horizontal};
      rig.gaze.vertical_up = {up / coef, up};
      rig.gaze.vertical_down = {down / coef, down};
    }
    if (g.contains("range_maps")) {
      const json& r = g["range_maps"];
      if (!r.is_object()) return bad("/gaze/range_maps", "must be {\"horizontal_inner\", \"horizontal_outer\", \"vertical_down\", \"vertical_up\"}");
      for (const auto& [key, map] : {std::pair{"horizontal_inner", &rig.gaze.horizontal_inner}, std::pair{"horizontal_outer", &rig.gaze.horizontal_outer},
                                     std::pair{"vertical_down", &rig.gaze.vertical_down}, std::pair{"vertical_up", &rig.gaze.vertical_up}}) {
        if (!r.contains(key)) continue;
        const json& m = r[key];
        const std::string ptr = std::string("/gaze/range_maps/") + key;
        if (!m.is_object() || !m.contains("input_max") || !m.contains("output_scale") || !m["input_max"].is_number() || !m["output_scale"].is_number() ||
            !(m["input_max"].get<double>() > 0) || m["input_max"].get<double>() > 180 || !(m["output_scale"].get<double>() >= 0) || m["output_scale"].get<double>() > 180) {
          return bad(ptr, "must be {\"input_max\": degrees in (0, 180], \"output_scale\": >= 0} (VRM's range map: degrees of a bone, or a shape's weight)");
        }
        *map = {m["input_max"].get<float>(), m["output_scale"].get<float>()};
      }
    }
  }
  if (j.contains("visemes")) {
    if (Status st = ApplyVisemesManifest(rig, j["visemes"], bad); !st.ok()) return st;
  }
  return Status::Ok();
}

}  // namespace

Status ApplyManifest(Rig& rig, const std::string& text) {
  if (Status s = CheckJsonDepth(text, "manifest"); !s.ok()) return s;
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidArgument("manifest: not valid JSON");
  if (!j.is_object()) return InvalidArgument("manifest: must be a JSON object");
  auto bad = [](const std::string& pointer, const std::string& msg) {
    Status s = InvalidArgument("manifest: " + pointer + ": " + msg);
    s.fields.push_back({pointer, msg});
    return s;
  };
  static constexpr std::string_view kMembers[] = {"name", "credit", "license_url", "start", "base_motion", "materials", "shapes", "groups", "controls",
                                                  "derived", "inbetweens", "correctives", "statistics", "expressions", "gaze", "visemes"};
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
  if (j.contains("license_url")) {
    if (!j["license_url"].is_string() || j["license_url"].get<std::string>().empty()) return bad("/license_url", "must be the URL of the rig's licence");
    rig.license_url = j["license_url"].get<std::string>();
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
  return ApplyFaceManifest(rig, j, bad);
}

Status ApplyMakeHumanModifiers(Rig& rig, const std::string& text) {
  if (Status s = CheckJsonDepth(text, "modifiers"); !s.ok()) return s;
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

namespace {

// A float as the shortest decimal that reads back as it (0.4, not 0.4000000059604645).
double Num(float x) { return std::stod(FormatNumber(x)); }

json ExpressionsObject(const Rig& rig, bool derived_too) {
  json out = json::object();
  for (const Expression& e : rig.expressions) {
    if (e.derived && !derived_too) continue;
    json weights = json::object();
    for (const auto& [s, w] : e.binds) weights[rig.shapes[s].name] = Num(w);
    json o = {{"weights", weights}, {"binary", e.binary}, {"override_blink", ExpressionOverrideName(e.blink)},
                                {"override_look_at", ExpressionOverrideName(e.look_at)}, {"override_mouth", ExpressionOverrideName(e.mouth)}};
    if (derived_too) o["derived"] = e.derived;
    out[e.name] = o;
  }
  return out;
}

json VisemesObject(const Rig& rig, bool derived_too) {
  const VisemeMap& m = rig.visemes;
  json o = json::object();
  for (size_t v = 0; v < kVisemeCount; ++v) {
    if (!derived_too && !(m.named & (1u << v))) continue;
    json binds = json::object();
    for (const auto& [s, w] : m.binds[v]) binds[rig.shapes[s].name] = Num(w);
    o[std::string(kVisemeNames[v])] = std::move(binds);
  }
  auto names = [&](const std::vector<uint32_t>& list) {
    json a = json::array();
    for (uint32_t s : list) a.push_back(rig.shapes[s].name);
    return a;
  };
  if (derived_too || m.nolip_named) o["nolip"] = names(m.nolip);
  if (derived_too || m.jaw_named) o["jaw"] = names(m.jaw);
  return o;
}

json GazeObject(const Rig& rig, bool for_manifest) {
  const GazeSetup& g = rig.gaze;
  using K = GazeSetup::Kind;
  json o;
  o["type"] = g.kind == K::kBones ? "bones" : g.kind == K::kShapes ? "shapes" : g.kind == K::kExpressions ? "expressions" : "none";
  if (g.kind == K::kBones) o["eyes"] = {{"left", rig.nodes[g.eyes[0]].name}, {"right", rig.nodes[g.eyes[1]].name}};
  if (g.kind == K::kShapes && !for_manifest) {
    auto pair = [&](const std::array<int, 2>& a) { return json::array({rig.shapes[a[0]].name, rig.shapes[a[1]].name}); };
    o["shapes"] = {{"look_in", pair(g.look_in)}, {"look_out", pair(g.look_out)}, {"look_up", pair(g.look_up)}, {"look_down", pair(g.look_down)}};
  }
  if (g.head >= 0) o["head"] = {{"bone", rig.nodes[g.head].name}, {"share", Num(g.head_share)}};
  if (g.neck >= 0) o["neck"] = {{"bone", rig.nodes[g.neck].name}, {"share", Num(g.neck_share)}};
  auto map = [](const RangeMap& m) { return json{{"input_max", Num(m.input_max)}, {"output_scale", Num(m.output_scale)}}; };
  if (g.kind != K::kNone) {
    o["range_maps"] = {{"horizontal_inner", map(g.horizontal_inner)}, {"horizontal_outer", map(g.horizontal_outer)},
                       {"vertical_down", map(g.vertical_down)}, {"vertical_up", map(g.vertical_up)}};
  }
  if (!for_manifest && g.kind != K::kNone) o["origin"] = {Num(g.origin[0]), Num(g.origin[1]), Num(g.origin[2])};
  return o;
}

}  // namespace

json ExpressionsValue(const Rig& rig) { return ExpressionsObject(rig, true); }
json GazeValue(const Rig& rig) { return GazeObject(rig, false); }
json VisemesValue(const Rig& rig) { return rig.visemes.empty() ? json() : VisemesObject(rig, true); }

std::string ManifestJson(const Rig& rig) {
  json m = json::object();
  m["name"] = rig.name;
  if (!rig.credit.empty()) m["credit"] = rig.credit;
  if (!rig.license_url.empty()) m["license_url"] = rig.license_url;
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
  json expressions = ExpressionsObject(rig, false);
  if (!expressions.empty()) m["expressions"] = std::move(expressions);
  if (rig.gaze.from_manifest) m["gaze"] = GazeObject(rig, true);
  json visemes = VisemesObject(rig, false);
  if (!visemes.empty()) m["visemes"] = std::move(visemes);
  return m.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace facespace
