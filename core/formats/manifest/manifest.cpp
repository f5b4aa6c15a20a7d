// The manifest: what glTF drops (groups, ranges, partners, aliases, controls, in-betweens,
// correctives, statistics), as JSON beside a rig file; and MakeHuman's modifiers as controls.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "../common/json_depth.h"
#include "facespace/engine/face.h"
#include "facespace/engine/shape_tools.h"
#include "facespace/engine/speech.h"
#include "facespace/engine/weights.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"
#include "sections.h"

namespace facespace::formats {

using manifest::Bad;
using nlohmann::json;

namespace {

// The sections after the plain members, in the order they are read: the shapes' own (derived shapes
// first, so the rest can describe them), what makes them more than a sum, then the face's.
using Section = Status (*)(Rig& rig, const json& value);
constexpr std::pair<std::string_view, Section> kSections[] = {
    {"materials", manifest::ApplyMaterials},     {"derived", manifest::ApplyDerived},
    {"groups", manifest::ApplyGroups},           {"shapes", manifest::ApplyShapes},
    {"controls", manifest::ApplyControls},       {"inbetweens", manifest::ApplyInBetweens},
    {"correctives", manifest::ApplyCorrectives}, {"statistics", manifest::ApplyStatistics},
    {"expressions", manifest::ApplyExpressions}, {"gaze", manifest::ApplyGaze},
    {"visemes", manifest::ApplyVisemes},         {"terms", manifest::ApplyTerms},
    {"regions", manifest::ApplyRegions},         {"landmarks", manifest::ApplyLandmarks},
    {"derivation", manifest::ApplyDerivation}};
constexpr std::string_view kPlainMembers[] = {"name", "credit", "license_url", "start",
                                              "base_motion"};

// "base_motion": one of the rig's motions; one it lacks (a model copied without its motion folder)
// warns, and motions play without a base.
void ApplyBaseMotion(Rig& rig, const std::string& name) {
  std::vector<std::string_view> names;
  for (const AnimationInfo& a : rig.animations) names.push_back(a.name);
  if (std::find(names.begin(), names.end(), name) != names.end()) {
    rig.base_motion = name;
    return;
  }
  rig.load_warnings.push_back({"manifest_unknown_motion",
                               "manifest: /base_motion names no motion of the rig: '" +
                                   name.substr(0, 60) + "'" + DidYouMean(name, names) +
                                   "; motions play without a base",
                               name.substr(0, 60), 0.0, false});
}

// The plain members: name, credit, license_url, start, base_motion.
Status ApplyPlainMembers(Rig& rig, const json& j) {
  for (const char* key : {"name", "credit"}) {
    if (!j.contains(key)) continue;
    if (!j[key].is_string()) return Bad(std::string("/") + key, "must be a string");
    (std::string_view(key) == "name" ? rig.name : rig.credit) = j[key].get<std::string>();
  }
  if (j.contains("license_url")) {
    if (!j["license_url"].is_string() || j["license_url"].get<std::string>().empty())
      return Bad("/license_url", "must be the URL of the rig's licence");
    rig.license_url = j["license_url"].get<std::string>();
  }
  if (j.contains("start")) {
    if (j["start"] != "neutral" && j["start"] != "defaults")
      return Bad("/start", "must be \"neutral\" (every weight 0) or \"defaults\"");
    rig.start_at_defaults = j["start"] == "defaults";
  }
  if (j.contains("base_motion")) {
    if (!j["base_motion"].is_string())
      return Bad("/base_motion", "must be the name of one of the rig's motions (clips)");
    ApplyBaseMotion(rig, j["base_motion"].get<std::string>());
  }
  return Status::Ok();
}

}  // namespace

std::vector<std::string_view> ManifestMembers() {
  std::vector<std::string_view> members(std::begin(kPlainMembers), std::end(kPlainMembers));
  for (const auto& section : kSections) members.push_back(section.first);
  return members;
}

Status ApplyManifest(Rig& rig, const std::string& text) {
  if (Status s = CheckJsonDepth(text, "manifest"); !s.ok()) return s;
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidArgument("manifest: not valid JSON");
  if (!j.is_object()) return InvalidArgument("manifest: must be a JSON object");
  const std::vector<std::string_view> members = ManifestMembers();
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (std::find(members.begin(), members.end(), it.key()) == members.end()) {
      return Bad("/" + JsonPointerEscape(it.key()),
                 "unknown member" + DidYouMean(it.key(), members));
    }
  }
  if (Status s = ApplyPlainMembers(rig, j); !s.ok()) return s;
  for (const auto& [name, apply] : kSections) {
    const auto member = j.find(name);
    if (member == j.end()) continue;
    if (Status s = apply(rig, *member); !s.ok()) return s;
  }
  return Status::Ok();
}

Status ApplyMakeHumanModifiers(Rig& rig, const std::string& text) {
  if (Status s = CheckJsonDepth(text, "modifiers"); !s.ok()) return s;
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_array())
    return InvalidArgument("not a modifiers file: want a JSON array of {\"group\", \"modifiers\"}");
  std::vector<std::string> missing;
  for (size_t g = 0; g < j.size(); ++g) {
    const json& group = j[g];
    if (!group.is_object() || !group.contains("group") || !group["group"].is_string() ||
        !group.contains("modifiers") || !group["modifiers"].is_array()) {
      return InvalidArgument("/" + std::to_string(g) +
                             ": want {\"group\": NAME, \"modifiers\": [...]}");
    }
    const std::string gname = group["group"].get<std::string>();
    for (const json& m : group["modifiers"]) {
      auto missing_target = [&](const std::string& name) { missing.push_back(gname + "/" + name); };
      if (!m.is_object() || !m.contains("target") || !m["target"].is_string())
        continue;  // Macro modifiers: no target.
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
  manifest::PairControls(rig);
  if (!missing.empty()) {  // One warning naming them (a folder left out gives dozens).
    std::string names;
    for (size_t i = 0; i < missing.size() && i < 12; ++i) names += (i ? ", " : "") + missing[i];
    if (missing.size() > 12) names += ", ... (" + std::to_string(missing.size()) + " in all)";
    rig.load_warnings.push_back(CountWarning(
        "modifier_targets_missing", missing.size(),
        "modifier(s) name targets that were not found, so they are no controls: " + names));
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
    json o = {{"weights", weights},
              {"binary", e.binary},
              {"override_blink", ExpressionOverrideName(e.blink)},
              {"override_look_at", ExpressionOverrideName(e.look_at)},
              {"override_mouth", ExpressionOverrideName(e.mouth)}};
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
  o["type"] = g.kind == K::kBones         ? "bones"
              : g.kind == K::kShapes      ? "shapes"
              : g.kind == K::kExpressions ? "expressions"
                                          : "none";
  if (g.kind == K::kBones)
    o["eyes"] = {{"left", rig.nodes[g.eyes[0]].name}, {"right", rig.nodes[g.eyes[1]].name}};
  if (g.kind == K::kShapes && !for_manifest) {
    auto pair = [&](const std::array<int, 2>& a) {
      return json::array({rig.shapes[a[0]].name, rig.shapes[a[1]].name});
    };
    o["shapes"] = {{"look_in", pair(g.look_in)},
                   {"look_out", pair(g.look_out)},
                   {"look_up", pair(g.look_up)},
                   {"look_down", pair(g.look_down)}};
  }
  if (g.head >= 0) o["head"] = {{"bone", rig.nodes[g.head].name}, {"share", Num(g.head_share)}};
  if (g.neck >= 0) o["neck"] = {{"bone", rig.nodes[g.neck].name}, {"share", Num(g.neck_share)}};
  auto map = [](const RangeMap& m) {
    return json{{"input_max", Num(m.input_max)}, {"output_scale", Num(m.output_scale)}};
  };
  if (g.kind != K::kNone) {
    o["range_maps"] = {{"horizontal_inner", map(g.horizontal_inner)},
                       {"horizontal_outer", map(g.horizontal_outer)},
                       {"vertical_down", map(g.vertical_down)},
                       {"vertical_up", map(g.vertical_up)}};
  }
  if (!for_manifest && g.kind != K::kNone)
    o["origin"] = {Num(g.origin[0]), Num(g.origin[1]), Num(g.origin[2])};
  return o;
}

}  // namespace

json ExpressionsValue(const Rig& rig) { return ExpressionsObject(rig, true); }
json GazeValue(const Rig& rig) { return GazeObject(rig, false); }
json VisemesValue(const Rig& rig) {
  return rig.visemes.empty() ? json() : VisemesObject(rig, true);
}

std::string ManifestJson(const Rig& rig) {
  json m = json::object();
  m["name"] = rig.name;
  if (!rig.credit.empty()) m["credit"] = rig.credit;
  if (!rig.license_url.empty()) m["license_url"] = rig.license_url;
  if (rig.start_at_defaults) m["start"] = "defaults";
  if (!rig.base_motion.empty()) m["base_motion"] = rig.base_motion;
  if (!rig.terms.source.empty()) m["terms"] = manifest::TermsValue(rig.terms);
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
      for (const auto& [w, shape] : ib.keys)
        keys.push_back({{"shape", rig.shapes[shape].name}, {"weight", w}});
      if (ib.full != 1.0f)
        keys.push_back({{"shape", rig.shapes[ib.slider].name}, {"weight", ib.full}});
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
  if (!rig.regions.empty()) m["regions"] = manifest::RegionsValue(rig);
  if (!rig.landmarks.empty()) m["landmarks"] = manifest::LandmarksValue(rig);
  if (!rig.derivation.source.empty()) m["derivation"] = manifest::DerivationValue(rig.derivation);
  return m.dump(1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace facespace::formats
