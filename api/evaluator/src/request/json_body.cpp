// The JSON body readers shared by the request schemas (json_body.h).
#include "json_body.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <span>

#include "facespace/engine/enum_table.h"
#include "facespace/formats/lod.h"

namespace facespace::evaluator::body {

Status FieldStatus(const std::string& pointer, const std::string& message) {
  return InvalidField(pointer, message);
}

Result<std::vector<WeightEntry>> WeightsFromJson(const json& j, const std::string& pointer) {
  std::vector<WeightEntry> entries;
  Status errors = InvalidArgument("");
  auto value_of = [&](const json& v, const std::string& ptr, WeightEntry& e) {
    if (!v.is_number()) {
      errors.AddField(ptr, std::string("must be a number, not ") + v.type_name());
      return false;
    }
    e.value = v.get<double>();
    return true;
  };
  if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) {
      WeightEntry e;
      e.index = static_cast<long long>(i);
      e.pointer = pointer + "/" + std::to_string(i);
      if (value_of(j[i], e.pointer, e)) entries.push_back(e);
    }
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      WeightEntry e;
      e.name = it.key();
      e.pointer = pointer + "/" + JsonPointerEscape(it.key());
      if (e.name.empty()) {
        errors.AddField(e.pointer, "empty shape name");
        continue;
      }
      if (value_of(it.value(), e.pointer, e)) entries.push_back(e);
    }
  } else {
    return FieldStatus(pointer,
                       std::string("weights must be an array or an object, not ") + j.type_name());
  }
  if (!errors.fields.empty()) {
    errors.message = (errors.fields[0].pointer.empty() ? "" : errors.fields[0].pointer + ": ") +
                     errors.fields[0].message;
    return errors;
  }
  return entries;
}

bool FloatArray(const json& v, float* out, size_t n) {
  if (!v.is_array() || v.size() != n) return false;
  for (size_t i = 0; i < n; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>())) return false;
    out[i] = v[i].get<float>();
  }
  return true;
}

// A clip reference: a name or an index.
bool ClipRef(const json& v, ClipRequest& c) {
  if (v.is_string()) {
    c.name = v.get<std::string>();
    return !c.name.empty();
  }
  if (v.is_number_integer() && v.get<long long>() >= 0) {
    c.index = v.get<long long>();
    return true;
  }
  return false;
}

void PoseFromJson(const json& v, PoseRequest& pose, Status& errors) {
  if (!v.is_object()) {
    errors.fields.push_back(
        {"/pose", "must be an object of joint name -> {rotation|euler, translation, scale}"});
    return;
  }
  for (auto it = v.begin(); it != v.end(); ++it) {
    JointOverride j;
    j.joint = it.key();
    j.pointer = "/pose/" + JsonPointerEscape(it.key());
    if (!it->is_object()) {
      errors.fields.push_back({j.pointer, "must be an object"});
      continue;
    }
    for (auto p = it->begin(); p != it->end(); ++p) {
      const std::string ptr = j.pointer + "/" + JsonPointerEscape(p.key());
      bool ok = true;
      if (p.key() == "rotation")
        ok = j.has_rotation = FloatArray(*p, j.rotation.data(), 4);
      else if (p.key() == "euler")
        ok = j.has_euler = FloatArray(*p, j.euler.data(), 3);
      else if (p.key() == "translation")
        ok = j.has_translation = FloatArray(*p, j.translation.data(), 3);
      else if (p.key() == "scale")
        ok = j.has_scale = FloatArray(*p, j.scale.data(), 3);
      else
        UnknownMember(j.pointer, p.key(), Body::kJoint, errors);
      if (!ok) {
        errors.fields.push_back({ptr, p.key() == "rotation"
                                          ? "must be [x, y, z, w] of finite numbers"
                                          : "must be [x, y, z] of finite numbers"});
      }
    }
    pose.joints.push_back(std::move(j));
  }
}

// The clip a request names with "animation" or "motion" (not one of "blend").
bool IsRequestClip(const ClipRequest& c) {
  return c.pointer == "/animation" || c.pointer == "/motion";
}

namespace {

// A clip's "loop" or "mask" member, in a blend or a layer; false for any other key.
bool LoopOrMask(const std::string& key, const json& v, const std::string& ptr, ClipRequest& c,
                Status& errors) {
  if (key == "loop") {
    if (!v.is_boolean())
      errors.fields.push_back({ptr, "must be true or false"});
    else
      c.loop = v.get<bool>();
    return true;
  }
  if (key != "mask") return false;
  if (!v.is_array()) {
    errors.fields.push_back({ptr, "must be an array of joint names"});
    return true;
  }
  for (const json& m : v) {
    if (!m.is_string())
      errors.fields.push_back({ptr, "must be an array of joint names"});
    else
      c.mask.push_back(m.get<std::string>());
  }
  return true;
}

}  // namespace

void GazeTrackFromJson(const json& v, const std::string& ptr, std::vector<GazeKey>& track,
                       Status& errors) {
  if (!(v.is_object() && v.contains("keys"))) {
    if (auto gaze = GazeFromJson(v, ptr, errors)) track.push_back({0.0f, *gaze});
    return;
  }
  const json& ks = v["keys"];
  if (v.size() != 1 || !ks.is_array() || ks.empty() || ks.size() > 10000) {
    errors.fields.push_back({ptr + "/keys",
                             "must be an array of 1 to 10000 {\"time\", \"target\": [x, y, z]} or "
                             "{\"time\", \"yaw\", \"pitch\"}"});
    return;
  }
  for (size_t k = 0; k < ks.size(); ++k) {
    const std::string kp = ptr + "/keys/" + std::to_string(k);
    if (!ks[k].is_object() || !ks[k].contains("time")) {
      errors.fields.push_back({kp, "needs a time"});
      continue;
    }
    GazeKey g;
    double t = 0;
    if (!Number(ks[k]["time"], -1e9, 1e9, &t))
      errors.fields.push_back({kp + "/time", "must be a number in [-1e9, 1e9]"});
    g.time = static_cast<float>(t);
    json rest = ks[k];
    rest.erase("time");
    if (auto gaze = GazeFromJson(rest, kp, errors)) g.gaze = *gaze;
    if (!track.empty() && !(g.time > track.back().time))
      errors.fields.push_back({kp + "/time", "gaze key times must increase"});
    if (!track.empty() && g.gaze.has_target != track.front().gaze.has_target)
      errors.fields.push_back({kp, "every gaze key gives a target, or every one angles"});
    track.push_back(g);
  }
}

void BlinkFromJson(const json& v, const std::string& ptr, float& per_minute, uint64_t& seed,
                   Status& errors) {
  if (!v.is_object()) {
    errors.fields.push_back({ptr,
                             "must be {\"per_minute\": n, \"seed\": s} (natural blinks; people "
                             "blink 10 to 20 times a minute)"});
    return;
  }
  for (auto m = v.begin(); m != v.end(); ++m) {
    const std::string mp = ptr + "/" + JsonPointerEscape(m.key());
    if (m.key() == "per_minute") {
      if (!m->is_number() || !(m->get<double>() > 0) || m->get<double>() > kMaxBlinksPerMinute)
        errors.fields.push_back({mp, "must be a number in (0, 60]"});
      else
        per_minute = m->get<float>();
    } else if (m.key() == "seed") {
      if (!m->is_number_unsigned())
        errors.fields.push_back({mp, "must be an integer >= 0"});
      else
        seed = m->get<uint64_t>();
    } else {
      UnknownMember(ptr, m.key(), Body::kBlink, errors);
    }
  }
}

void BlendFromJson(const json& v, PoseRequest& pose, Status& errors) {
  if (!v.is_array() || v.empty()) {
    errors.fields.push_back(
        {"/blend", "must be a non-empty array of {animation, time, weight, mask, loop}"});
    return;
  }
  for (size_t i = 0; i < v.size(); ++i) {
    ClipRequest c;
    c.pointer = "/blend/" + std::to_string(i);
    const json& e = v[i];
    if (!e.is_object() || !e.contains("animation") || !ClipRef(e["animation"], c)) {
      errors.fields.push_back({c.pointer + "/animation", "needs an animation name or index"});
      continue;
    }
    for (auto p = e.begin(); p != e.end(); ++p) {
      const std::string ptr = c.pointer + "/" + JsonPointerEscape(p.key());
      if (p.key() == "animation") continue;
      if (p.key() == "time" || p.key() == "weight") {
        if (!p->is_number() || !std::isfinite(p->get<double>()))
          errors.fields.push_back({ptr, "must be a finite number"});
        else
          (p.key() == "time" ? c.time : c.weight) = p->get<float>();
      } else if (!LoopOrMask(p.key(), *p, ptr, c, errors)) {
        UnknownMember(c.pointer, p.key(), Body::kBlendClip, errors);
      }
    }
    if (c.weight < 0.0f) errors.fields.push_back({c.pointer + "/weight", "must be >= 0"});
    pose.clips.push_back(std::move(c));
  }
}

// "layers": motions stacked as MMD players stack them: the first is the base (the whole body), each
// later one an overlay that replaces only what it moves, over what lies below, by its weight.
void LayersFromJson(const json& v, PoseRequest& pose, Status& errors) {
  if (!v.is_array() || v.empty() || v.size() > 16) {
    errors.fields.push_back({"/layers",
                             "must be an array of 1 to 16 {motion, time|frame, weight, loop, "
                             "fade_in, fade_out, mask}: a base, then overlays"});
    return;
  }
  for (size_t i = 0; i < v.size(); ++i) {
    ClipRequest c;
    c.pointer = "/layers/" + std::to_string(i);
    c.overlay = i > 0;
    const json& e = v[i];
    const char* clip_key = e.is_object() && e.contains("motion") ? "motion" : "animation";
    if (!e.is_object() || !e.contains(clip_key) || !ClipRef(e[clip_key], c)) {
      errors.fields.push_back(
          {c.pointer + "/motion", "needs a motion (or animation) name or index"});
      continue;
    }
    if (e.contains("motion") && e.contains("animation"))
      errors.fields.push_back({c.pointer + "/motion", "give motion or animation, not both"});
    if (e.contains("time") && e.contains("frame"))
      errors.fields.push_back({c.pointer + "/frame", "give time or frame, not both"});
    for (auto p = e.begin(); p != e.end(); ++p) {
      const std::string ptr = c.pointer + "/" + JsonPointerEscape(p.key());
      const std::string& k = p.key();
      if (k == "motion" || k == "animation") continue;
      if (k == "time" || k == "frame" || k == "weight" || k == "fade_in" || k == "fade_out") {
        if (!p->is_number() || !std::isfinite(p->get<double>())) {
          errors.fields.push_back({ptr, "must be a finite number"});
          continue;
        }
        const double x = p->get<double>();
        if (k != "time" && k != "frame" && x < 0) errors.fields.push_back({ptr, "must be >= 0"});
        if (k == "time") c.time = static_cast<float>(x);
        if (k == "frame") c.time = static_cast<float>(x / 30.0);
        if (k == "weight") c.weight = static_cast<float>(x);
        if (k == "fade_in") c.fade_in = static_cast<float>(x);
        if (k == "fade_out") c.fade_out = static_cast<float>(x);
      } else if (!LoopOrMask(k, *p, ptr, c, errors)) {
        UnknownMember(c.pointer, k, Body::kLayer, errors);
      }
    }
    pose.clips.push_back(std::move(c));
  }
}

std::optional<Gaze> GazeFromJson(const json& v, const std::string& ptr, Status& errors) {
  const size_t before = errors.fields.size();
  Gaze g;
  if (!v.is_object()) {
    errors.fields.push_back(
        {ptr,
         "must be {\"target\": [x, y, z]} (a point in the rig's world) or {\"yaw\": degrees, "
         "\"pitch\": degrees} (yaw > 0: to the character's left; pitch > 0: up)"});
    return std::nullopt;
  }
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string p = ptr + "/" + JsonPointerEscape(it.key());
    if (it.key() == "target") {
      if (!FloatArray(*it, g.target.data(), 3))
        errors.fields.push_back(
            {p, "must be [x, y, z], three finite numbers (the rig's world units)"});
      g.has_target = true;
    } else if (it.key() == "yaw" || it.key() == "pitch") {
      if (!it->is_number() || !std::isfinite(it->get<double>()) ||
          std::fabs(it->get<double>()) > 180) {
        errors.fields.push_back({p, "must be degrees in [-180, 180]"});
        continue;
      }
      (it.key() == "yaw" ? g.yaw : g.pitch) = it->get<float>();
    } else {
      UnknownMember(ptr, it.key(), Body::kGaze, errors);
    }
  }
  if (g.has_target && (v.contains("yaw") || v.contains("pitch")))
    errors.fields.push_back({ptr, "give target, or yaw and pitch, not both"});
  if (errors.fields.size() != before) return std::nullopt;
  return g;
}

// Handles a member shared by the mesh, check, render and sheet bodies. Returns false when
// the key is not one of them.
namespace {

// The clip a mesh body names with its flat members (animation or motion, time or frame, loop).
void ClipMember(const std::string& key, const json& v, const std::string& ptr, PoseRequest& pose,
                Status& errors) {
  // Gathered into one clip at the front of pose.clips by FinishPose. "motion" names a clip as
  // "animation" does (MMD's word: a .vmd is a clip); "frame" is a time in MMD frames, 30 a
  // second.
  if (pose.clips.empty() || !IsRequestClip(pose.clips.front())) {
    ClipRequest c;
    c.pointer = "/animation";
    c.index = -2;  // Marks "no animation named yet".
    c.over_base = true;
    pose.clips.insert(pose.clips.begin(), c);
  }
  ClipRequest& c = pose.clips.front();
  if (key == "animation" || key == "motion") {
    if (!c.name.empty() || c.index != -2)
      errors.fields.push_back({ptr, "give animation or motion, not both"});
    else if (!ClipRef(v, c))
      errors.fields.push_back({ptr, "must be " +
                                        std::string(key == "motion" ? "a motion" : "an animation") +
                                        " name or index"});
    c.pointer = ptr;
  } else if (key == "time" || key == "frame") {
    if (c.timed)
      errors.fields.push_back({ptr, "give time or frame, not both"});
    else if (!v.is_number() || !std::isfinite(v.get<double>()))
      errors.fields.push_back({ptr, key == "time"
                                        ? "must be a finite number of seconds"
                                        : "must be a finite number of frames (30 a second)"});
    else
      c.time = key == "time" ? v.get<float>() : static_cast<float>(v.get<double>() / 30.0);
    c.timed = true;
  } else if (!v.is_boolean()) {
    errors.fields.push_back({ptr, "must be true or false"});
  } else {
    c.loop = v.get<bool>();
  }
}

// An object of name -> weight at `ptr`, into `dst`; its errors into `errors`.
void WeightsMember(const json& v, const std::string& ptr, std::vector<WeightEntry>& dst,
                   Status& errors) {
  auto w = WeightsFromJson(v, ptr);
  if (w.ok())
    dst = std::move(w.value());
  else
    errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
}

}  // namespace

bool MeshMember(const std::string& key, const json& v, MeshRequest& r, bool mesh_format,
                Status& errors) {
  const std::string ptr = "/" + JsonPointerEscape(key);
  if (key == "pose") {
    PoseFromJson(v, r.pose, errors);
    return true;
  }
  if (key == "blend" || key == "layers") {
    const bool other = std::any_of(r.pose.clips.begin(), r.pose.clips.end(),
                                   [](const ClipRequest& c) { return !IsRequestClip(c); });
    if (other)
      errors.fields.push_back({"/" + key, "give blend or layers, not both"});
    else if (key == "blend")
      BlendFromJson(v, r.pose, errors);
    else
      LayersFromJson(v, r.pose, errors);
    return true;
  }
  if (key == "animation" || key == "motion" || key == "time" || key == "frame" || key == "loop") {
    ClipMember(key, v, ptr, r.pose, errors);
    return true;
  }
  auto string_field = [&](auto parse, auto* dst, const char* allowed) {
    if (!v.is_string() || !parse(v.get<std::string>(), dst))
      errors.fields.push_back({ptr, std::string("must be one of ") + allowed});
  };
  if (key == "weights") {
    WeightsMember(v, ptr, r.weights, errors);
  } else if (key == "expressions") {
    if (!v.is_object()) {
      errors.fields.push_back({ptr,
                               "must be an object of expression name -> value (VRM's presets: "
                               "happy, aa, blink, lookLeft, ...; or the rig's own)"});
      return true;
    }
    WeightsMember(v, ptr, r.pose.expressions, errors);
  } else if (key == "gaze") {
    if (auto g = GazeFromJson(v, ptr, errors)) r.pose.gaze = *g;
  } else if (key == "vocabulary") {
    if (!v.is_string() || !ParseVocabulary(v.get<std::string>(), r))
      errors.fields.push_back({ptr, "must be \"arkit\", \"vrm\", \"mmd\" or a rig's id"});
  } else if (key == "controls") {
    if (!v.is_object()) {
      errors.fields.push_back({ptr, "must be an object of control name -> value"});
      return true;
    }
    WeightsMember(v, ptr, r.controls, errors);
  } else if (key == "mode") {
    string_field(ParseBlendMode, &r.options.mode, "\"relative\", \"absolute\"");
  } else if (key == "normals") {
    string_field(ParseNormalMode, &r.options.normals, "\"blend\", \"recompute\"");
  } else if (key == "skinning") {
    if (!v.is_string() || (v != "linear" && v != "dual_quaternion")) {
      errors.fields.push_back({ptr, "must be one of \"linear\", \"dual_quaternion\""});
    } else {
      r.options.dual_quaternion = v == "dual_quaternion";
    }
  } else if (key == "format" && mesh_format) {
    formats::MeshFormat f;
    if (!v.is_string() || !ParseMeshFormat(v.get<std::string>(), &f)) {
      errors.fields.push_back({ptr, "must be one of \"glb\", \"obj\", \"json\", \"f32\", \"vrm\""});
    } else {
      r.format = f;
    }
  } else if (key == "lod") {
    if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > formats::kMaxLod) {
      errors.fields.push_back({ptr, "must be " + formats::LodExpected()});
    } else {
      r.lod = v.get<int>();
    }
  } else if (key == "space" && mesh_format) {
    if (!v.is_string() || (v != "world" && v != "mesh"))
      errors.fields.push_back({ptr, "must be \"world\" (the default) or \"mesh\""});
    else
      r.mesh_space = v == "mesh";
  } else if (key == "strict" || (key == "keep_targets" && mesh_format)) {
    if (!v.is_boolean())
      errors.fields.push_back({ptr, "must be true or false"});
    else
      (key == "strict" ? r.strict : r.keep_targets) = v.get<bool>();
  } else {
    return false;
  }
  return true;
}

// "time", "frame" or "loop" without "animation" (or "motion") is an error; "animation" with "blend"
// too.
void FinishPose(PoseRequest& pose, Status& errors) {
  if (pose.clips.empty() || !IsRequestClip(pose.clips.front())) return;
  const ClipRequest& c = pose.clips.front();
  if (c.name.empty() && c.index == -2) {
    errors.fields.push_back({"/animation", "time, frame and loop need an animation (or motion)"});
  } else if (pose.clips.size() > 1) {
    errors.fields.push_back({c.pointer, "give animation + time, or blend, or layers: one of them"});
  }
}

Status Finish(Status errors) {
  errors.message = errors.fields[0].pointer + ": " + errors.fields[0].message;
  return errors;
}

bool ParseBackground(const json& v, std::array<float, 4>& out) {
  if (v.is_array()) {
    if (v.size() < 3 || v.size() > 4) return false;
    for (size_t i = 0; i < v.size(); ++i) {
      if (!v[i].is_number()) return false;
      const double c = v[i].get<double>();
      if (!(c >= 0.0 && c <= 1.0)) return false;
      out[i] = static_cast<float>(c);
    }
    if (v.size() == 3) out[3] = 1.0f;
    return true;
  }
  if (!v.is_string()) return false;
  const std::string s = v.get<std::string>();
  if (s == "transparent") {
    out = {1, 1, 1, 0};
    return true;
  }
  if (s.size() != 7 && s.size() != 9) return false;
  if (s[0] != '#' || s.find_first_not_of("0123456789abcdefABCDEF", 1) != std::string::npos)
    return false;
  for (size_t i = 0; i < 4; ++i) {
    out[i] = 2 * i + 1 < s.size()
                 ? static_cast<float>(std::stoi(s.substr(2 * i + 1, 2), nullptr, 16)) / 255.0f
                 : 1.0f;
  }
  return true;
}

bool ParseVec3(const json& v, std::array<float, 3>& out) {
  if (!v.is_array() || v.size() != 3) return false;
  for (size_t i = 0; i < 3; ++i) {
    if (!v[i].is_number() || !std::isfinite(v[i].get<double>())) return false;
    out[i] = v[i].get<float>();
  }
  return true;
}

// Range-checked number members of the camera and image.
bool Number(const json& v, double lo, double hi, double* out) {
  if (!v.is_number()) return false;
  const double d = v.get<double>();
  if (!(d >= lo && d <= hi)) return false;
  *out = d;
  return true;
}

// The camera's framing: all, shapes, auto or joint:NAME. False for anything else.
bool ParseFraming(const std::string& value, picture::Camera& cam) {
  if (value == "all" || value == "shapes" || value == "auto") {
    cam.frame = value == "shapes" ? picture::Framing::kShapes
                : value == "all"  ? picture::Framing::kAll
                                  : picture::Framing::kAuto;
    return true;
  }
  if (value.size() > 6 && value.compare(0, 6, "joint:") == 0) {
    cam.frame = picture::Framing::kJoint;
    cam.frame_joint = value.substr(6);
    return true;
  }
  return false;
}

void CameraFromJson(const json& c, picture::Camera& cam, Status& errors) {
  if (!c.is_object()) {
    errors.fields.push_back({"/camera", "must be an object"});
    return;
  }
  for (auto it = c.begin(); it != c.end(); ++it) {
    const std::string ptr = "/camera/" + JsonPointerEscape(it.key());
    double d = 0;
    const std::string& k = it.key();
    if (k == "yaw" || k == "pitch" || k == "distance" || k == "zoom" || k == "fov") {
      if (ReadNumber(Body::kCamera, k, *it, ptr, &d, errors)) {
        float& dst = k == "yaw"        ? cam.yaw
                     : k == "pitch"    ? cam.pitch
                     : k == "distance" ? cam.distance
                     : k == "zoom"     ? cam.zoom
                                       : cam.fov;
        dst = static_cast<float>(d);
      }
    } else if (k == "eye" || k == "target" || k == "up") {
      std::array<float, 3>& dst = k == "eye" ? cam.eye : k == "target" ? cam.target : cam.up;
      if (!ParseVec3(*it, dst))
        errors.fields.push_back({ptr, "must be [x, y, z]"});
      else if (k != "up")
        cam.look_at = true;
    } else if (k == "frame") {
      if (!it->is_string() || !ParseFraming(it->get<std::string>(), cam)) {
        errors.fields.push_back({ptr, "must be \"all\", \"shapes\", \"auto\" or \"joint:NAME\""});
      }
    } else {
      UnknownMember("/camera", k, Body::kCamera, errors);
    }
  }
  if (cam.look_at && !(c.contains("eye") && c.contains("target"))) {
    errors.fields.push_back({"/camera", "a look-at camera needs both eye and target"});
  }
}

// "light": {"yaw": D, "pitch": D}: the studio's lights turned about the camera.
void LightFromJson(const json& v, picture::RenderOptions& o, Status& errors) {
  if (!v.is_object()) {
    errors.fields.push_back({"/light", "must be an object {\"yaw\": degrees, \"pitch\": degrees}"});
    return;
  }
  for (auto it = v.begin(); it != v.end(); ++it) {
    double d = 0;
    const std::string ptr = "/light/" + JsonPointerEscape(it.key());
    if (!FindMember(Body::kLight, it.key()))
      UnknownMember("/light", it.key(), Body::kLight, errors);
    else if (ReadNumber(Body::kLight, it.key(), *it, ptr, &d, errors))
      (it.key() == "yaw" ? o.light_yaw : o.light_pitch) = static_cast<float>(d);
  }
}

// A render member; false when the key is not one.
bool RenderMember(const std::string& key, const json& v, RenderRequest& r, Status& errors) {
  const std::string ptr = "/" + JsonPointerEscape(key);
  double d = 0;
  if (key == "width" || key == "height") {
    if (ReadNumber(Body::kRender, key, v, ptr, &d, errors))
      (key == "width" ? r.render.width : r.render.height) = static_cast<int>(d);
  } else if (key == "view") {
    if (!v.is_string() || !picture::ParseView(v.get<std::string>(), &r.render.view)) {
      errors.fields.push_back(
          {ptr, "must be one of \"shaded\", \"wireframe\", \"heatmap\", \"normals\", \"clay\""});
    }
  } else if (key == "background") {
    if (!ParseBackground(v, r.render.background)) {
      errors.fields.push_back(
          {ptr, "must be \"#rrggbb\", \"#rrggbbaa\", \"transparent\" or [r, g, b, a] in 0..1"});
    }
  } else if (key == "supersample") {
    if (ReadNumber(Body::kRender, key, v, ptr, &d, errors))
      r.render.supersample = static_cast<int>(d);
  } else if (key == "format") {
    picture::ImageFormat f;
    if (!v.is_string() || !picture::ParseImageFormat(v.get<std::string>(), &f)) {
      errors.fields.push_back(
          {ptr, "must be one of \"png\", \"jpeg\", \"exr\", \"tiff\", \"webp\""});
    } else {
      r.format = f;
    }
  } else if (key == "exposure") {
    if (ReadNumber(Body::kRender, key, v, ptr, &d, errors))
      r.render.exposure = static_cast<float>(d);
  } else if (key == "quality") {
    if (ReadNumber(Body::kRender, key, v, ptr, &d, errors)) r.quality = static_cast<int>(d);
  } else if (key == "camera") {
    CameraFromJson(v, r.render.camera, errors);
  } else if (key == "light") {
    LightFromJson(v, r.render, errors);
  } else {
    return false;
  }
  return true;
}

}  // namespace facespace::evaluator::body
