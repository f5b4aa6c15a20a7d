// Request schemas of a point of face space: mesh, check, render, sheet (bodies and GET queries).
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <span>
#include <unordered_set>

#include "facespace/engine/enum_table.h"
#include "facespace/evaluator/store.h"
#include "facespace/formats/lod.h"
#include "facespace/picture/picture.h"
#include "json_body.h"

namespace facespace::evaluator {

using namespace body;  // The shared readers of json_body.h.

namespace {
constexpr EnumName<BlendMode> kBlendModes[] = {{BlendMode::kRelative, "relative"},
                                               {BlendMode::kAbsolute, "absolute"}};
constexpr EnumName<NormalMode> kNormalModes[] = {{NormalMode::kBlend, "blend"},
                                                 {NormalMode::kRecompute, "recompute"}};
constexpr EnumName<Vocabulary> kVocabularies[] = {
    {Vocabulary::kArkit, "arkit"}, {Vocabulary::kVrm, "vrm"}, {Vocabulary::kMmd, "mmd"}};
}  // namespace

bool ParseVocabulary(std::string_view text, MeshRequest& r) {
  if (ParseEnum(kVocabularies, text, &r.vocabulary)) return true;
  if (!IsValidRigId(std::string(text))) return false;
  r.vocabulary = Vocabulary::kRig;
  r.vocabulary_rig = std::string(text);
  return true;
}

const char* VocabularyLabel(Vocabulary v) { return EnumEntry(kVocabularies, v).name; }

bool ParseBlendMode(std::string_view s, BlendMode* mode) { return ParseEnum(kBlendModes, s, mode); }
bool ParseNormalMode(std::string_view s, NormalMode* mode) {
  return ParseEnum(kNormalModes, s, mode);
}

Result<std::vector<WeightEntry>> ParseWeightsJson(std::string_view text,
                                                  const std::string& pointer) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded())
    return WithReason(InvalidArgument(std::string(kMalformed) + ": weights are not valid JSON"),
                      kMalformedJson);
  return WeightsFromJson(j, pointer);
}

Result<MeshRequest> ParseMeshRequest(std::string_view body) {
  MeshRequest r;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(body, kPointBody, [&](const std::string& key, const json& v) {
    if (!MeshMember(key, v, r, true, errors)) UnknownMember("", key, Body::kMesh, errors);
  });
  if (!parsed.ok()) return parsed;
  FinishPose(r.pose, errors);
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Result<RenderRequest> ParseRenderRequest(std::string_view body) {
  RenderRequest r;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(body, kPointBody, [&](const std::string& key, const json& v) {
    if (!MeshMember(key, v, r.mesh, false, errors) && !RenderMember(key, v, r, errors)) {
      UnknownMember("", key, Body::kRender, errors);
    }
  });
  if (!parsed.ok()) return parsed;
  FinishPose(r.mesh.pose, errors);
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Result<SheetRequest> ParseSheetRequest(std::string_view body) {
  SheetRequest r;
  r.base.render.width = r.base.render.height = 256;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(body, kSheetBody, [&](const std::string& key, const json& v) {
    if (key == "cells") {
      if (v.is_string() && (v == "shapes" || v.get<std::string>().starts_with("shapes:"))) {
        r.shape_cells = v.get<std::string>();
        return;
      }
      if (!v.is_array() || v.empty()) {
        errors.fields.push_back({"/cells",
                                 "must be a non-empty array of {\"weights\", \"label\"}, or "
                                 "\"shapes\" or \"shapes:GROUP\""});
        return;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        const std::string ptr = "/cells/" + std::to_string(i);
        if (!v[i].is_object()) {
          errors.fields.push_back({ptr, "must be an object"});
          continue;
        }
        RefuseUnknown(v[i], ptr, Body::kCell, errors);
        std::vector<WeightEntry> w;
        if (v[i].contains("weights")) {
          auto read = WeightsFromJson(v[i]["weights"], ptr + "/weights");
          if (read.ok())
            w = std::move(read.value());
          else
            errors.fields.insert(errors.fields.end(), read.status().fields.begin(),
                                 read.status().fields.end());
        }
        std::string label;
        if (v[i].contains("label")) {
          if (!v[i]["label"].is_string())
            errors.fields.push_back({ptr + "/label", "must be a string"});
          else
            label = v[i]["label"].get<std::string>().substr(0, 80);
        }
        r.cells.push_back(std::move(w));
        r.labels.push_back(label);
      }
    } else if (key == "columns") {
      double d = 0;
      if (ReadNumber(Body::kSheet, key, v, "/columns", &d, errors)) r.columns = static_cast<int>(d);
    } else if (!MeshMember(key, v, r.base.mesh, false, errors) &&
               !RenderMember(key, v, r.base, errors)) {
      UnknownMember("", key, Body::kSheet, errors);
    }
  });
  if (!parsed.ok()) return parsed;
  FinishPose(r.base.mesh.pose, errors);
  if (errors.fields.empty() && r.cells.empty() && r.shape_cells.empty())
    errors.fields.push_back({"/cells", "is required"});
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Status ExpandShapeCells(const Rig& rig, const picture::Renderer* renderer, SheetRequest& r) {
  if (r.shape_cells.empty()) return Status::Ok();
  const std::string group = r.shape_cells == "shapes" ? "" : r.shape_cells.substr(7);
  std::set<std::string> groups;
  for (const Shape& s : rig.shapes) {
    groups.insert(s.group);
    if (!group.empty() && s.group != group) continue;
    WeightEntry e;
    e.name = s.name;
    e.value = 1.0f;
    e.pointer = "/cells";
    r.cells.push_back({e});
    // A label is the shape's name, with its first ASCII alias beside a name in another script
    // ("まばたき (blink)"); a name the fonts cannot draw gives way to the alias, else the index.
    auto ascii = [](const std::string& t) {
      return std::all_of(t.begin(), t.end(), [](char c) { return c >= 0x20 && c < 0x7f; });
    };
    std::string alias;
    for (size_t k = 0; k < s.aliases.size() && alias.empty(); ++k) {
      if (ascii(s.aliases[k])) alias = s.aliases[k];
    }
    std::string label = ascii(s.name) ? s.name
                        : !renderer || renderer->CanDrawText(s.name)
                            ? (alias.empty() ? s.name : s.name + " (" + alias + ")")
                            : alias;
    if (label.size() > 80) {  // Whole UTF-8 characters.
      size_t cut = 80;
      while (cut > 0 && (static_cast<unsigned char>(label[cut]) & 0xC0) == 0x80) --cut;
      label.resize(cut);
    }
    r.labels.push_back(label.empty() ? "shape " + std::to_string(&s - rig.shapes.data()) : label);
  }
  if (r.cells.empty()) {
    std::string list;
    for (const std::string& g : groups) list += (list.empty() ? "" : ", ") + g;
    Status errors = InvalidArgument("");
    errors.fields.push_back({"/cells", group.empty()
                                           ? "the rig has no shapes"
                                           : "no shape in group '" + group + "'; groups: " + list});
    return Finish(errors);
  }
  return Status::Ok();
}

std::string ApplyRenderSetting(const std::string& key, const std::string& value, RenderRequest& r,
                               bool* known) {
  *known = true;
  if (key == "camera") {
    json c = json::parse(value, nullptr, false);
    if (c.is_discarded()) return "must be a JSON object";
    Status errors = InvalidArgument("");
    CameraFromJson(c, r.render.camera, errors);
    return errors.fields.empty() ? "" : errors.fields[0].pointer + ": " + errors.fields[0].message;
  }
  if (key == "frame") {
    // The camera's framing (all, shapes, auto), or else a time in MMD frames for the pose
    // (ApplyPoseSetting).
    if (ParseFraming(std::string(value), r.render.camera)) return "";
    double d = 0;
    const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), d);
    if (ec != std::errc() || end != value.data() + value.size()) {
      return "must be all, shapes, auto or joint:NAME (the camera's framing) or a number of frames "
             "(30 a second)";
    }
    *known = false;
    return "";
  }
  const bool camera_key =
      key == "yaw" || key == "pitch" || key == "distance" || key == "zoom" || key == "fov";
  const bool string_key = key == "view" || key == "format" || key == "background";
  if (!camera_key && !string_key && key != "width" && key != "height" && key != "supersample" &&
      key != "quality" && key != "exposure") {
    *known = false;
    return "";
  }
  json v;
  if (string_key && !(key == "background" && !value.empty() && value[0] == '[')) {
    v = value;
  } else {
    v = json::parse(value, nullptr, false);
    if (v.is_discarded() || v.is_string()) return "'" + value.substr(0, 40) + "' is not a number";
  }
  Status errors = InvalidArgument("");
  if (camera_key)
    CameraFromJson(json{{key, v}}, r.render.camera, errors);
  else
    RenderMember(key, v, r, errors);
  return errors.fields.empty() ? "" : errors.fields[0].message;
}

std::string GazeShortForm(const std::string& value) {
  std::vector<double> n;
  size_t from = 0;
  while (from <= value.size() && n.size() < 4) {
    const size_t comma = std::min(value.find(',', from), value.size());
    double x = 0;
    const auto res = std::from_chars(value.data() + from, value.data() + comma, x);
    if (res.ec != std::errc() || res.ptr != value.data() + comma) return "";
    n.push_back(x);
    from = comma + 1;
  }
  if (n.size() == 2) return json{{"yaw", n[0]}, {"pitch", n[1]}}.dump();
  if (n.size() == 3) return json{{"target", n}}.dump();
  return "";
}

std::string ApplyPoseSetting(const std::string& key, const std::string& value, MeshRequest& r,
                             bool* known) {
  *known = key == "animation" || key == "motion" || key == "time" || key == "frame" ||
           key == "loop" || key == "pose" || key == "blend" || key == "layers" ||
           key == "skinning" || key == "lod" || key == "gaze" || key == "expressions";
  if (!*known) return "";
  json v;
  if (key == "gaze" && !value.empty() && value[0] != '{') {
    const std::string text = GazeShortForm(value);
    if (text.empty()) return "must be YAW,PITCH (degrees), X,Y,Z (a target) or JSON";
    v = json::parse(text);
  } else if (key == "skinning") {
    v = value;
  } else if (key == "animation" || key == "motion") {
    const bool digits = !value.empty() &&
                        value.find_first_not_of("0123456789") == std::string::npos &&
                        value.size() < 10;
    v = digits ? json(std::stoll(value)) : json(value);
  } else if (key == "lod") {
    int lod = 0;
    if (!formats::ParseLod(value, &lod)) return "must be " + formats::LodExpected();
    v = lod;
  } else if (key == "loop") {
    if (value == "true" || value == "1")
      v = true;
    else if (value == "false" || value == "0")
      v = false;
    else
      return "must be true or false";
  } else {
    v = json::parse(value, nullptr, false);
    if (v.is_discarded())
      return key == "time"    ? "must be a number of seconds"
             : key == "frame" ? "must be a number of frames"
                              : "must be JSON";
  }
  Status errors = InvalidArgument("");
  MeshMember(key, v, r, false, errors);
  return errors.fields.empty() ? "" : errors.fields[0].message;
}

std::string FinishPoseSettings(MeshRequest& r) {
  Status errors = InvalidArgument("");
  FinishPose(r.pose, errors);
  return errors.fields.empty() ? "" : errors.fields[0].message;
}

}  // namespace facespace::evaluator
