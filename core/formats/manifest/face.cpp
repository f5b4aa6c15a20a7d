// The manifest's sections about the face: expressions (VRM's vocabulary, or the rig's own names, to
// weights of its shapes), gaze (how the eyes follow: bones or shapes, range maps, the head's and
// neck's shares) and visemes. Read after the shapes.
#include "facespace/engine/face.h"

#include <algorithm>
#include <cmath>

#include "facespace/engine/speech.h"
#include "facespace/formats/io.h"
#include "sections.h"

namespace facespace::formats::manifest {

namespace {

// One expression: its weights by shape at full value, binary, VRM's override rules; null: none.
Status ApplyExpression(Rig& rig, const std::string& key, const json& o, const std::string& ptr) {
  if (key.empty() || key.size() > 64)
    return Bad(ptr, "an expression's name must have 1 to 64 bytes");
  Expression e;
  e.name = key;
  if (!o.is_null()) {
    if (!o.is_object()) return Bad(ptr, "must be an object {\"weights\": {SHAPE: w}, ...} or null");
    for (auto m = o.begin(); m != o.end(); ++m) {
      static constexpr std::string_view kKeys[] = {"weights", "binary", "override_blink",
                                                   "override_look_at", "override_mouth"};
      if (std::find(std::begin(kKeys), std::end(kKeys), m.key()) == std::end(kKeys)) {
        return Bad(ptr + "/" + JsonPointerEscape(m.key()),
                   "unknown member" + DidYouMean(m.key(), kKeys));
      }
    }
    if (!o.contains("weights") || !o["weights"].is_object())
      return Bad(ptr + "/weights",
                 "is required: an object of shape name -> weight at the expression's full value");
    for (auto w = o["weights"].begin(); w != o["weights"].end(); ++w) {
      const std::string wp = ptr + "/weights/" + JsonPointerEscape(w.key());
      const int s = FindShape(rig, w.key());
      if (s < 0) {
        std::vector<std::string_view> names;
        for (const Shape& sh : rig.shapes) names.push_back(sh.name);
        return Bad(wp, "unknown shape '" + w.key() + "'" + DidYouMean(w.key(), names));
      }
      if (!w->is_number() || !std::isfinite(w->get<double>()))
        return Bad(wp, "must be a finite number");
      e.binds.emplace_back(static_cast<uint32_t>(s), w->get<float>());
    }
    if (o.contains("binary")) {
      if (!o["binary"].is_boolean()) return Bad(ptr + "/binary", "must be true or false");
      e.binary = o["binary"].get<bool>();
    }
    for (const auto& [member, field] :
         {std::pair{"override_blink", &e.blink}, std::pair{"override_look_at", &e.look_at},
          std::pair{"override_mouth", &e.mouth}}) {
      if (!o.contains(member)) continue;
      const json& v = o[member];
      if (v == "none")
        *field = ExpressionOverride::kNone;
      else if (v == "block")
        *field = ExpressionOverride::kBlock;
      else if (v == "blend")
        *field = ExpressionOverride::kBlend;
      else
        return Bad(ptr + "/" + member,
                   "must be \"none\", \"block\" or \"blend\" (VRM's override rules)");
    }
  }
  const int at = FindExpression(rig, e.name);
  if (at >= 0)
    rig.expressions[at] = std::move(e);
  else
    rig.expressions.push_back(std::move(e));
  return Status::Ok();
}

}  // namespace

// "expressions": name -> {weights, binary, override_*} (or null: none).
Status ApplyExpressions(Rig& rig, const json& ex) {
  return ForEachMember(
      ex, "/expressions",
      "must be an object of expression name -> {\"weights\": {SHAPE: w}, \"binary\", "
      "\"override_blink\", \"override_look_at\", \"override_mouth\"} (or null: none)",
      rig, ApplyExpression);
}

// "gaze": {type, eyes, head, neck, coefficient, limits, range_maps}.
Status ApplyGaze(Rig& rig, const json& g) {
  if (!g.is_object())
    return Bad("/gaze",
               "must be an object {\"eyes\", \"head\", \"neck\", \"coefficient\", \"limits\", "
               "\"range_maps\", \"type\"}");
  static constexpr std::string_view kKeys[] = {"type",        "eyes",   "head",      "neck",
                                               "coefficient", "limits", "range_maps"};
  for (auto m = g.begin(); m != g.end(); ++m) {
    if (std::find(std::begin(kKeys), std::end(kKeys), m.key()) == std::end(kKeys))
      return Bad("/gaze/" + JsonPointerEscape(m.key()),
                 "unknown member" + DidYouMean(m.key(), kKeys));
  }
  GazeSetup setup;
  setup.from_manifest = true;
  auto bone = [&](const json& v, const std::string& ptr, int* out) -> Status {
    if (!v.is_string()) return Bad(ptr, "must be a bone (node) name");
    *out = FindNode(rig, v.get<std::string>());
    if (*out < 0) return Bad(ptr, "the rig has no bone '" + v.get<std::string>() + "'");
    return Status::Ok();
  };
  if (g.contains("eyes")) {
    const json& e = g["eyes"];
    if (!e.is_object() || !e.contains("left") || !e.contains("right"))
      return Bad("/gaze/eyes", "must be {\"left\": BONE, \"right\": BONE}");
    if (Status s = bone(e["left"], "/gaze/eyes/left", &setup.eyes[0]); !s.ok()) return s;
    if (Status s = bone(e["right"], "/gaze/eyes/right", &setup.eyes[1]); !s.ok()) return s;
    setup.kind = GazeSetup::Kind::kBones;
  }
  for (const auto& [key, node, share] : {std::tuple{"head", &setup.head, &setup.head_share},
                                         std::tuple{"neck", &setup.neck, &setup.neck_share}}) {
    if (!g.contains(key)) continue;
    const std::string ptr = std::string("/gaze/") + key;
    const json& h = g[key];
    if (!h.is_object() || !h.contains("bone"))
      return Bad(ptr,
                 "must be {\"bone\": NAME, \"share\": s} (s in [0, 1]: the part of the gaze's "
                 "angles it turns)");
    if (Status s = bone(h["bone"], ptr + "/bone", node); !s.ok()) return s;
    if (h.contains("share")) {
      if (!h["share"].is_number() || h["share"].get<double>() < 0 || h["share"].get<double>() > 1)
        return Bad(ptr + "/share", "must be a number in [0, 1]");
      *share = h["share"].get<float>();
    }
  }
  if (setup.head_share + setup.neck_share > 1.0f)
    return Bad("/gaze", "the head's and neck's shares add up to more than 1");
  if (g.contains("type")) {
    const json& t = g["type"];
    if (t == "bones") {
      if (setup.kind != GazeSetup::Kind::kBones)
        return Bad("/gaze/type", "\"bones\" needs \"eyes\": {\"left\", \"right\"}");
    } else if (t == "shapes" || t == "expressions" || t == "none") {
      setup.kind = GazeSetup::Kind::kNone;  // "shapes", "expressions": found by DeriveGaze below.
    } else {
      return Bad("/gaze/type", "must be \"bones\", \"shapes\", \"expressions\" or \"none\"");
    }
  }
  // The kind and the default range maps (DeriveGaze), then the coefficient and limits (MMDAgent's
  // EYE_ROTATION_COEF: eye turn = coefficient x angle, up to the limit), then explicit range maps.
  const bool none = g.contains("type") && g["type"] == "none";
  rig.gaze = setup;
  if (!none) DeriveGaze(rig);
  const bool bones = rig.gaze.kind == GazeSetup::Kind::kBones;
  if (g.contains("coefficient") || g.contains("limits")) {
    if (!bones)
      return Bad(g.contains("coefficient") ? "/gaze/coefficient" : "/gaze/limits",
                 "is for eye bones (\"eyes\"); eye shapes take \"range_maps\"");
    float coef = 1.0f, horizontal = 30.0f, up = 20.0f, down = 20.0f;
    if (g.contains("coefficient")) {
      if (!g["coefficient"].is_number() || !(g["coefficient"].get<double>() > 0) ||
          g["coefficient"].get<double>() > 1)
        return Bad("/gaze/coefficient", "must be a number in (0, 1]");
      coef = g["coefficient"].get<float>();
    }
    if (g.contains("limits")) {
      const json& l = g["limits"];
      if (!l.is_object())
        return Bad("/gaze/limits", "must be {\"horizontal\", \"up\", \"down\"} in degrees");
      for (const auto& [key, out] :
           {std::pair{"horizontal", &horizontal}, std::pair{"up", &up}, std::pair{"down", &down}}) {
        if (!l.contains(key)) continue;
        const json& v = l[key];
        if (!v.is_number() || !(v.get<double>() > 0) || v.get<double>() > 90)
          return Bad(std::string("/gaze/limits/") + key, "must be degrees in (0, 90]");
        *out = v.get<float>();
      }
    }
    rig.gaze.horizontal_inner = rig.gaze.horizontal_outer = {horizontal / coef, horizontal};
    rig.gaze.vertical_up = {up / coef, up};
    rig.gaze.vertical_down = {down / coef, down};
  }
  if (g.contains("range_maps")) {
    const json& r = g["range_maps"];
    if (!r.is_object())
      return Bad("/gaze/range_maps",
                 "must be {\"horizontal_inner\", \"horizontal_outer\", \"vertical_down\", "
                 "\"vertical_up\"}");
    for (const auto& [key, map] : {std::pair{"horizontal_inner", &rig.gaze.horizontal_inner},
                                   std::pair{"horizontal_outer", &rig.gaze.horizontal_outer},
                                   std::pair{"vertical_down", &rig.gaze.vertical_down},
                                   std::pair{"vertical_up", &rig.gaze.vertical_up}}) {
      if (!r.contains(key)) continue;
      const json& m = r[key];
      const std::string ptr = std::string("/gaze/range_maps/") + key;
      if (!m.is_object() || !m.contains("input_max") || !m.contains("output_scale") ||
          !m["input_max"].is_number() || !m["output_scale"].is_number() ||
          !(m["input_max"].get<double>() > 0) || m["input_max"].get<double>() > 180 ||
          !(m["output_scale"].get<double>() >= 0) || m["output_scale"].get<double>() > 180) {
        return Bad(ptr,
                   "must be {\"input_max\": degrees in (0, 180], \"output_scale\": >= 0} (VRM's "
                   "range map: degrees of a bone, or a shape's weight)");
      }
      *map = {m["input_max"].get<float>(), m["output_scale"].get<float>()};
    }
  }
  return Status::Ok();
}

// "visemes": viseme name (speech.h) -> {SHAPE: w} (or null: none), "nolip" and "jaw": lists of
// shapes.
Status ApplyVisemes(Rig& rig, const json& v) {
  if (!v.is_object())
    return Bad("/visemes",
               "must be an object of viseme (sil PP FF TH DD kk CH SS nn RR aa E ih oh ou) -> "
               "{SHAPE: w}, and \"nolip\", \"jaw\": [SHAPE, ...]");
  auto shape_of = [&](const std::string& name, const std::string& ptr, int* out) -> Status {
    *out = FindShape(rig, name);
    if (*out >= 0) return Status::Ok();
    std::vector<std::string_view> names;
    for (const Shape& sh : rig.shapes) names.push_back(sh.name);
    return Bad(ptr, "unknown shape '" + name + "'" + DidYouMean(name, names));
  };
  VisemeMap& m = rig.visemes;
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string ptr = "/visemes/" + JsonPointerEscape(it.key());
    if (it.key() == "nolip" || it.key() == "jaw") {
      if (!it->is_array()) return Bad(ptr, "must be a list of shape names");
      std::vector<uint32_t>& list = it.key() == "nolip" ? m.nolip : m.jaw;
      list.clear();
      for (size_t k = 0; k < it->size(); ++k) {
        const json& name = (*it)[k];
        const std::string p = ptr + "/" + std::to_string(k);
        if (!name.is_string()) return Bad(p, "must be a shape name");
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
      return Bad(ptr, "unknown viseme" + DidYouMean(it.key(), names) +
                          " (OpenXR's 15: sil PP FF TH DD kk CH SS nn RR aa E ih oh ou)");
    }
    auto& binds = m.binds[static_cast<size_t>(*viseme)];
    binds.clear();
    if (!it->is_null()) {
      if (!it->is_object())
        return Bad(ptr, "must be an object of shape name -> weight (or null: no shape)");
      for (auto w = it->begin(); w != it->end(); ++w) {
        const std::string wp = ptr + "/" + JsonPointerEscape(w.key());
        int s;
        if (Status st = shape_of(w.key(), wp, &s); !st.ok()) return st;
        if (!w->is_number() || !std::isfinite(w->get<double>()))
          return Bad(wp, "must be a finite number");
        binds.emplace_back(static_cast<uint32_t>(s), w->get<float>());
      }
    }
    m.named |= static_cast<uint16_t>(1u << static_cast<unsigned>(*viseme));
  }
  return Status::Ok();
}

}  // namespace facespace::formats::manifest
