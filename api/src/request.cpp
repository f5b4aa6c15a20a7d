#include "facespace/api/request.h"
#include "facespace/core/enum_table.h"

#include "facespace/core/lod.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <set>
#include <span>
#include <unordered_set>
#include <nlohmann/json.hpp>

namespace facespace::api {

namespace {

using nlohmann::json;

constexpr char kMalformed[] = "malformed JSON";

// The members each body takes, for "did you mean" when one is not.
constexpr std::string_view kMeshMembers[] = {"weights", "controls", "format", "space", "mode", "normals", "skinning", "lod", "strict",
                                             "keep_targets", "pose", "blend", "animation", "motion", "time", "frame", "loop"};
constexpr std::string_view kRenderMembers[] = {"weights", "controls", "mode", "normals", "skinning", "lod", "strict", "pose",
                                               "blend", "animation", "motion", "time", "frame", "loop", "width", "height",
                                               "view", "background", "supersample", "format", "quality", "camera", "exposure"};
constexpr std::string_view kSheetMembers[] = {"cells", "columns", "weights", "controls", "mode", "normals", "skinning", "lod",
                                              "strict", "pose", "blend", "animation", "motion", "time", "frame", "loop",
                                              "width", "height", "view", "background", "supersample", "quality", "camera", "exposure"};
constexpr std::string_view kSequenceMembers[] = {"keys", "times", "fps", "animation", "motion", "transition", "smooth",
                                                 "format", "tolerance", "mode", "normals"};
constexpr std::string_view kBatchMembers[] = {"variants", "sample", "format", "space", "controls", "mode", "normals", "skinning", "lod",
                                              "pose", "blend", "animation", "motion", "time", "frame", "loop", "width",
                                              "height", "view", "background", "supersample", "quality", "camera", "exposure"};

void UnknownMember(const std::string& key, std::span<const std::string_view> members, Status& errors) {
  std::string message = "unknown member" + DidYouMean(key, members);
  if (message.size() == 14) {
    message += "; the members are";
    for (std::string_view m : members) message += std::string(m == members.front() ? " " : ", ") + std::string(m);
  }
  errors.fields.push_back({"/" + JsonPointerEscape(key), message});
}

Status FieldStatus(const std::string& pointer, const std::string& message) {
  Status s = InvalidArgument(pointer.empty() ? message : pointer + ": " + message);
  s.fields.push_back({pointer, message});
  return s;
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
    return FieldStatus(pointer, std::string("weights must be an array or an object, not ") + j.type_name());
  }
  if (!errors.fields.empty()) {
    errors.message = (errors.fields[0].pointer.empty() ? "" : errors.fields[0].pointer + ": ") + errors.fields[0].message;
    return errors;
  }
  return entries;
}

}  // namespace


namespace {
constexpr EnumName<BlendMode> kBlendModes[] = {{BlendMode::kRelative, "relative"}, {BlendMode::kAbsolute, "absolute"}};
constexpr EnumName<NormalMode> kNormalModes[] = {{NormalMode::kBlend, "blend"}, {NormalMode::kRecompute, "recompute"}};
}  // namespace

bool ParseBlendMode(std::string_view s, BlendMode* mode) { return ParseEnum(kBlendModes, s, mode); }
bool ParseNormalMode(std::string_view s, NormalMode* mode) { return ParseEnum(kNormalModes, s, mode); }

Result<std::vector<WeightEntry>> ParseWeightsJson(std::string_view text, const std::string& pointer) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return WithReason(InvalidArgument(std::string(kMalformed) + ": weights are not valid JSON"), kMalformedJson);
  return WeightsFromJson(j, pointer);
}

namespace {

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
    errors.fields.push_back({"/pose", "must be an object of joint name -> {rotation|euler, translation, scale}"});
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
      if (p.key() == "rotation") ok = j.has_rotation = FloatArray(*p, j.rotation.data(), 4);
      else if (p.key() == "euler") ok = j.has_euler = FloatArray(*p, j.euler.data(), 3);
      else if (p.key() == "translation") ok = j.has_translation = FloatArray(*p, j.translation.data(), 3);
      else if (p.key() == "scale") ok = j.has_scale = FloatArray(*p, j.scale.data(), 3);
      else errors.fields.push_back({ptr, "unknown member (rotation, euler, translation, scale)"});
      if (!ok) {
        errors.fields.push_back({ptr, p.key() == "rotation" ? "must be [x, y, z, w] of finite numbers" : "must be [x, y, z] of finite numbers"});
      }
    }
    pose.joints.push_back(std::move(j));
  }
}

// The clip a request names with "animation" or "motion" (not one of "blend").
bool IsRequestClip(const ClipRequest& c) { return c.pointer == "/animation" || c.pointer == "/motion"; }

void BlendFromJson(const json& v, PoseRequest& pose, Status& errors) {
  if (!v.is_array() || v.empty()) {
    errors.fields.push_back({"/blend", "must be a non-empty array of {animation, time, weight, mask, loop}"});
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
        if (!p->is_number() || !std::isfinite(p->get<double>())) errors.fields.push_back({ptr, "must be a finite number"});
        else (p.key() == "time" ? c.time : c.weight) = p->get<float>();
      } else if (p.key() == "loop") {
        if (!p->is_boolean()) errors.fields.push_back({ptr, "must be true or false"});
        else c.loop = p->get<bool>();
      } else if (p.key() == "mask") {
        if (!p->is_array()) {
          errors.fields.push_back({ptr, "must be an array of joint names"});
          continue;
        }
        for (const json& m : *p) {
          if (!m.is_string()) errors.fields.push_back({ptr, "must be an array of joint names"});
          else c.mask.push_back(m.get<std::string>());
        }
      } else {
        errors.fields.push_back({ptr, "unknown member (animation, time, weight, loop, mask)"});
      }
    }
    if (c.weight < 0.0f) errors.fields.push_back({c.pointer + "/weight", "must be >= 0"});
    pose.clips.push_back(std::move(c));
  }
}

// Handles a member shared by the mesh, check, render and sheet bodies. Returns false when
// the key is not one of them.
bool MeshMember(const std::string& key, const json& v, MeshRequest& r, bool mesh_format, Status& errors) {
  const std::string ptr = "/" + JsonPointerEscape(key);
  if (key == "pose") {
    PoseFromJson(v, r.pose, errors);
    return true;
  }
  if (key == "blend") {
    BlendFromJson(v, r.pose, errors);
    return true;
  }
  if (key == "animation" || key == "motion" || key == "time" || key == "frame" || key == "loop") {
    // Gathered into one clip at the front of pose.clips by FinishPose. "motion" names a clip as
    // "animation" does (MMD's word: a .vmd is a clip); "frame" is a time in MMD frames, 30 a second.
    if (r.pose.clips.empty() || !IsRequestClip(r.pose.clips.front())) {
      ClipRequest c;
      c.pointer = "/animation";
      c.index = -2;  // Marks "no animation named yet".
      r.pose.clips.insert(r.pose.clips.begin(), c);
    }
    ClipRequest& c = r.pose.clips.front();
    if (key == "animation" || key == "motion") {
      if (!c.name.empty() || c.index != -2) errors.fields.push_back({ptr, "give animation or motion, not both"});
      else if (!ClipRef(v, c)) errors.fields.push_back({ptr, "must be " + std::string(key == "motion" ? "a motion" : "an animation") + " name or index"});
      c.pointer = ptr;
    } else if (key == "time" || key == "frame") {
      if (c.timed) errors.fields.push_back({ptr, "give time or frame, not both"});
      else if (!v.is_number() || !std::isfinite(v.get<double>())) errors.fields.push_back({ptr, key == "time" ? "must be a finite number of seconds" : "must be a finite number of frames (30 a second)"});
      else c.time = key == "time" ? v.get<float>() : static_cast<float>(v.get<double>() / 30.0);
      c.timed = true;
    } else if (!v.is_boolean()) {
      errors.fields.push_back({ptr, "must be true or false"});
    } else {
      c.loop = v.get<bool>();
    }
    return true;
  }
  auto string_field = [&](auto parse, auto* dst, const char* allowed) {
    if (!v.is_string() || !parse(v.get<std::string>(), dst)) errors.fields.push_back({ptr, std::string("must be one of ") + allowed});
  };
  if (key == "weights") {
    auto w = WeightsFromJson(v, "/weights");
    if (w.ok()) r.weights = std::move(w.value());
    else errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
  } else if (key == "controls") {
    if (!v.is_object()) {
      errors.fields.push_back({ptr, "must be an object of control name -> value"});
      return true;
    }
    auto w = WeightsFromJson(v, "/controls");
    if (w.ok()) r.controls = std::move(w.value());
    else errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
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
    MeshFormat f;
    if (!v.is_string() || !ParseMeshFormat(v.get<std::string>(), &f)) {
      errors.fields.push_back({ptr, "must be one of \"glb\", \"obj\", \"json\", \"f32\""});
    } else {
      r.format = f;
    }
  } else if (key == "lod") {
    if (!v.is_number_integer() || v.get<long long>() < 0 || v.get<long long>() > kMaxLod) {
      errors.fields.push_back({ptr, "must be an integer level of detail 0.." + std::to_string(kMaxLod) + " (0: full)"});
    } else {
      r.lod = v.get<int>();
    }
  } else if (key == "space" && mesh_format) {
    if (!v.is_string() || (v != "world" && v != "mesh")) errors.fields.push_back({ptr, "must be \"world\" (the default) or \"mesh\""});
    else r.mesh_space = v == "mesh";
  } else if (key == "strict" || (key == "keep_targets" && mesh_format)) {
    if (!v.is_boolean()) errors.fields.push_back({ptr, "must be true or false"});
    else (key == "strict" ? r.strict : r.keep_targets) = v.get<bool>();
  } else {
    return false;
  }
  return true;
}

// "time", "frame" or "loop" without "animation" (or "motion") is an error; "animation" with "blend" too.
void FinishPose(PoseRequest& pose, Status& errors) {
  if (pose.clips.empty() || !IsRequestClip(pose.clips.front())) return;
  const ClipRequest& c = pose.clips.front();
  if (c.name.empty() && c.index == -2) {
    errors.fields.push_back({"/animation", "time, frame and loop need an animation (or motion)"});
  } else if (pose.clips.size() > 1) {
    errors.fields.push_back({c.pointer, "give animation + time, or blend, not both"});
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
  if (s[0] != '#' || s.find_first_not_of("0123456789abcdefABCDEF", 1) != std::string::npos) return false;
  for (size_t i = 0; i < 4; ++i) {
    out[i] = 2 * i + 1 < s.size() ? static_cast<float>(std::stoi(s.substr(2 * i + 1, 2), nullptr, 16)) / 255.0f : 1.0f;
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
bool ParseFraming(const std::string& value, render::Camera& cam) {
  if (value == "all" || value == "shapes" || value == "auto") {
    cam.frame = value == "shapes" ? render::Framing::kShapes : value == "all" ? render::Framing::kAll : render::Framing::kAuto;
    return true;
  }
  if (value.size() > 6 && value.compare(0, 6, "joint:") == 0) {
    cam.frame = render::Framing::kJoint;
    cam.frame_joint = value.substr(6);
    return true;
  }
  return false;
}

void CameraFromJson(const json& c, render::Camera& cam, Status& errors) {
  if (!c.is_object()) {
    errors.fields.push_back({"/camera", "must be an object"});
    return;
  }
  for (auto it = c.begin(); it != c.end(); ++it) {
    const std::string ptr = "/camera/" + JsonPointerEscape(it.key());
    double d = 0;
    const std::string& k = it.key();
    if (k == "yaw" || k == "pitch") {
      if (!Number(*it, -3600, 3600, &d)) errors.fields.push_back({ptr, "must be a number of degrees"});
      else (k == "yaw" ? cam.yaw : cam.pitch) = static_cast<float>(d);
    } else if (k == "distance") {
      if (!Number(*it, 0, 1e9, &d)) errors.fields.push_back({ptr, "must be a number >= 0 (0: auto)"});
      else cam.distance = static_cast<float>(d);
    } else if (k == "zoom") {
      if (!Number(*it, 0.01, 100, &d)) errors.fields.push_back({ptr, "must be a number in [0.01, 100]"});
      else cam.zoom = static_cast<float>(d);
    } else if (k == "fov") {
      if (!Number(*it, 1, 170, &d)) errors.fields.push_back({ptr, "must be degrees in [1, 170]"});
      else cam.fov = static_cast<float>(d);
    } else if (k == "eye" || k == "target" || k == "up") {
      std::array<float, 3>& dst = k == "eye" ? cam.eye : k == "target" ? cam.target : cam.up;
      if (!ParseVec3(*it, dst)) errors.fields.push_back({ptr, "must be [x, y, z]"});
      else if (k != "up") cam.look_at = true;
    } else if (k == "frame") {
      if (!it->is_string() || !ParseFraming(it->get<std::string>(), cam)) {
        errors.fields.push_back({ptr, "must be \"all\", \"shapes\", \"auto\" or \"joint:NAME\""});
      }
    } else {
      errors.fields.push_back({ptr, "unknown camera member (yaw, pitch, distance, zoom, fov, frame, eye, target, up)"});
    }
  }
  if (cam.look_at && !(c.contains("eye") && c.contains("target"))) {
    errors.fields.push_back({"/camera", "a look-at camera needs both eye and target"});
  }
}

// A render member; false when the key is not one.
bool RenderMember(const std::string& key, const json& v, RenderRequest& r, Status& errors) {
  const std::string ptr = "/" + JsonPointerEscape(key);
  double d = 0;
  if (key == "width" || key == "height") {
    if (!v.is_number_integer() || !Number(v, 1, 1 << 20, &d)) errors.fields.push_back({ptr, "must be a positive integer"});
    else (key == "width" ? r.render.width : r.render.height) = static_cast<int>(d);
  } else if (key == "view") {
    if (!v.is_string() || !render::ParseView(v.get<std::string>(), &r.render.view)) {
      errors.fields.push_back({ptr, "must be one of \"shaded\", \"wireframe\", \"heatmap\", \"normals\", \"clay\""});
    }
  } else if (key == "background") {
    if (!ParseBackground(v, r.render.background)) {
      errors.fields.push_back({ptr, "must be \"#rrggbb\", \"#rrggbbaa\", \"transparent\" or [r, g, b, a] in 0..1"});
    }
  } else if (key == "supersample") {
    if (!v.is_number_integer() || !Number(v, 1, 4, &d)) errors.fields.push_back({ptr, "must be 1, 2, 3 or 4"});
    else r.render.supersample = static_cast<int>(d);
  } else if (key == "format") {
    render::ImageFormat f;
    if (!v.is_string() || !render::ParseImageFormat(v.get<std::string>(), &f)) {
      errors.fields.push_back({ptr, "must be one of \"png\", \"jpeg\", \"exr\", \"tiff\", \"webp\""});
    } else {
      r.format = f;
    }
  } else if (key == "exposure") {
    if (!v.is_number() || !Number(v, -10, 10, &d)) errors.fields.push_back({ptr, "must be a number of stops in -10..10"});
    else r.render.exposure = static_cast<float>(d);
  } else if (key == "quality") {
    if (!v.is_number_integer() || !Number(v, 1, 100, &d)) errors.fields.push_back({ptr, "must be an integer in 1..100"});
    else r.quality = static_cast<int>(d);
  } else if (key == "camera") {
    CameraFromJson(v, r.render.camera, errors);
  } else {
    return false;
  }
  return true;
}

// What one body may hold, sized to its route: a limit on the values parsed (every number, string,
// array and object counts one) bounds the memory and time of the parse before any work.
struct BodyLimits {
  size_t values;
  size_t depth = 64;
};
constexpr BodyLimits kPointBody{100000};      // mesh, check, render: weights, controls, a pose.
constexpr BodyLimits kSheetBody{400000};      // Up to --max-sheet-cells points.
constexpr BodyLimits kSequenceBody{500000};   // Keys and times.
constexpr BodyLimits kFitBody{3100000};       // A target mesh: three numbers a vertex, a million vertices.
constexpr BodyLimits kBatchBody{500000};      // Explicit variants.

// nlohmann's DOM builder under a SAX reader that tracks where it is (for JSON Pointers), refuses a
// member given twice in any object (JSON parsers keep the last, or the first: the client's intent
// is unknown), and stops at the body's limits. Linear in the body: the callback parser this
// replaces scanned the parent again at every object's end, so 100,000 empty objects took seconds.
class CheckedDom {
 public:
  CheckedDom(json& root, BodyLimits limits) : dom_(root, false), limits_(limits) {}

  bool null() { return Value() && dom_.null(); }
  bool boolean(bool v) { return Value() && dom_.boolean(v); }
  bool number_integer(json::number_integer_t v) { return Value() && dom_.number_integer(v); }
  bool number_unsigned(json::number_unsigned_t v) { return Value() && dom_.number_unsigned(v); }
  bool number_float(json::number_float_t v, const std::string& s) { return Value() && dom_.number_float(v, s); }
  bool string(std::string& v) { return Value() && dom_.string(v); }
  bool binary(json::binary_t& v) { return Value() && dom_.binary(v); }
  bool start_object(size_t n) { return Open(false) && dom_.start_object(n); }
  bool start_array(size_t n) { return Open(true) && dom_.start_array(n); }
  bool end_object() { return Close() && dom_.end_object(); }
  bool end_array() { return Close() && dom_.end_array(); }
  bool key(std::string& k) {
    Level& level = levels_.back();
    level.key = k;
    if (!level.keys.insert(k).second) {
      duplicate_ = Pointer();
      return false;
    }
    return dom_.key(k);
  }
  bool parse_error(size_t position, const std::string& token, const nlohmann::detail::exception& e) {
    malformed_ = true;
    return dom_.parse_error(position, token, e);
  }

  bool malformed() const { return malformed_; }
  const std::string& duplicate() const { return duplicate_; }
  const std::string& over() const { return over_; }  // Which limit was passed, and where.

 private:
  struct Level {
    bool array = false;
    size_t index = 0;
    std::string key;
    std::unordered_set<std::string> keys;
  };

  std::string Pointer() const {
    std::string p;
    for (const Level& l : levels_) p += "/" + (l.array ? std::to_string(l.index) : JsonPointerEscape(l.key));
    return p;
  }
  bool Count() {
    if (++values_ <= limits_.values) return true;
    over_ = "more than " + std::to_string(limits_.values) + " JSON values (numbers, strings, arrays, objects) at " +
            (levels_.empty() ? "/" : Pointer()) + "; this route takes at most that many";
    return false;
  }
  bool Value() {  // A scalar ended: the next one of its array.
    if (!Count()) return false;
    if (!levels_.empty() && levels_.back().array) ++levels_.back().index;
    return true;
  }
  bool Open(bool array) {
    if (!Count()) return false;
    if (levels_.size() >= limits_.depth) {
      over_ = "nested deeper than " + std::to_string(limits_.depth) + " levels at " + Pointer();
      return false;
    }
    levels_.push_back({array, 0, {}, {}});
    return true;
  }
  bool Close() {
    levels_.pop_back();
    if (!levels_.empty() && levels_.back().array) ++levels_.back().index;
    return true;
  }

  nlohmann::detail::json_sax_dom_parser<json> dom_;
  BodyLimits limits_;
  std::vector<Level> levels_;
  size_t values_ = 0;
  bool malformed_ = false;
  std::string duplicate_, over_;
};

// A JSON object within `limits`, named by JSON Pointers when it is not one.
Result<json> ParseObject(std::string_view body, BodyLimits limits) {
  if (body.find_first_not_of(" \t\r\n") == std::string_view::npos) {
    return WithReason(InvalidArgument(std::string(kMalformed) + ": the body is empty; send a JSON object"), kMalformedJson);
  }
  json j;
  CheckedDom sax(j, limits);
  const bool parsed = json::sax_parse(body, &sax);
  if (!sax.over().empty()) return WithReason(ResourceExhausted("the body has " + sax.over()), "body-too-complex");
  if (!sax.duplicate().empty()) return FieldStatus(sax.duplicate(), "is given more than once; give each member once");
  if (!parsed || sax.malformed()) return WithReason(InvalidArgument(std::string(kMalformed) + ": the body is not valid JSON"), kMalformedJson);
  if (!j.is_object()) return FieldStatus("", std::string("the body must be a JSON object, not ") + j.type_name());
  return j;
}

}  // namespace

Result<MeshRequest> ParseMeshRequest(std::string_view body) {
  auto j = ParseObject(body, kPointBody);
  if (!j.ok()) return j.status();
  MeshRequest r;
  Status errors = InvalidArgument("");
  for (auto it = j->begin(); it != j->end(); ++it) {
    if (!MeshMember(it.key(), it.value(), r, true, errors)) UnknownMember(it.key(), kMeshMembers, errors);
  }
  FinishPose(r.pose, errors);
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Result<RenderRequest> ParseRenderRequest(std::string_view body) {
  auto j = ParseObject(body, kPointBody);
  if (!j.ok()) return j.status();
  RenderRequest r;
  Status errors = InvalidArgument("");
  for (auto it = j->begin(); it != j->end(); ++it) {
    if (!MeshMember(it.key(), it.value(), r.mesh, false, errors) && !RenderMember(it.key(), it.value(), r, errors)) {
      UnknownMember(it.key(), kRenderMembers, errors);
    }
  }
  FinishPose(r.mesh.pose, errors);
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Result<SheetRequest> ParseSheetRequest(std::string_view body) {
  auto j = ParseObject(body, kSheetBody);
  if (!j.ok()) return j.status();
  SheetRequest r;
  r.base.render.width = r.base.render.height = 256;
  Status errors = InvalidArgument("");
  for (auto it = j->begin(); it != j->end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    if (key == "cells") {
      if (v.is_string() && (v == "shapes" || v.get<std::string>().starts_with("shapes:"))) {
        r.shape_cells = v.get<std::string>();
        continue;
      }
      if (!v.is_array() || v.empty()) {
        errors.fields.push_back({"/cells", "must be a non-empty array of {\"weights\", \"label\"}, or \"shapes\" or \"shapes:GROUP\""});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        const std::string ptr = "/cells/" + std::to_string(i);
        if (!v[i].is_object()) {
          errors.fields.push_back({ptr, "must be an object"});
          continue;
        }
        std::vector<WeightEntry> w;
        if (v[i].contains("weights")) {
          auto parsed = WeightsFromJson(v[i]["weights"], ptr + "/weights");
          if (parsed.ok()) w = std::move(parsed.value());
          else errors.fields.insert(errors.fields.end(), parsed.status().fields.begin(), parsed.status().fields.end());
        }
        std::string label;
        if (v[i].contains("label")) {
          if (!v[i]["label"].is_string()) errors.fields.push_back({ptr + "/label", "must be a string"});
          else label = v[i]["label"].get<std::string>().substr(0, 80);
        }
        r.cells.push_back(std::move(w));
        r.labels.push_back(label);
      }
    } else if (key == "columns") {
      double d = 0;
      if (!v.is_number_integer() || !Number(v, 1, 64, &d)) errors.fields.push_back({"/columns", "must be an integer in 1..64"});
      else r.columns = static_cast<int>(d);
    } else if (!MeshMember(key, v, r.base.mesh, false, errors) && !RenderMember(key, v, r.base, errors)) {
      UnknownMember(key, kSheetMembers, errors);
    }
  }
  FinishPose(r.base.mesh.pose, errors);
  if (errors.fields.empty() && r.cells.empty() && r.shape_cells.empty()) errors.fields.push_back({"/cells", "is required"});
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Status ExpandShapeCells(const Rig& rig, SheetRequest& r) {
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
    // Labels are drawn in ASCII: a name that is not takes its first ASCII alias, else its index.
    auto ascii = [](const std::string& t) { return std::all_of(t.begin(), t.end(), [](char c) { return c >= 0x20 && c < 0x7f; }); };
    std::string label = ascii(s.name) ? s.name : "";
    for (size_t k = 0; k < s.aliases.size() && label.empty(); ++k) {
      if (ascii(s.aliases[k])) label = s.aliases[k];
    }
    r.labels.push_back(label.empty() ? "shape " + std::to_string(&s - rig.shapes.data()) : label.substr(0, 80));
  }
  if (r.cells.empty()) {
    std::string list;
    for (const std::string& g : groups) list += (list.empty() ? "" : ", ") + g;
    Status errors = InvalidArgument("");
    errors.fields.push_back({"/cells", group.empty() ? "the rig has no shapes" : "no shape in group '" + group + "'; groups: " + list});
    return Finish(errors);
  }
  return Status::Ok();
}

std::string ApplyRenderSetting(const std::string& key, const std::string& value, RenderRequest& r, bool* known) {
  *known = true;
  if (key == "camera") {
    json c = json::parse(value, nullptr, false);
    if (c.is_discarded()) return "must be a JSON object";
    Status errors = InvalidArgument("");
    CameraFromJson(c, r.render.camera, errors);
    return errors.fields.empty() ? "" : errors.fields[0].pointer + ": " + errors.fields[0].message;
  }
  if (key == "frame") {
    // The camera's framing (all, shapes, auto), or else a time in MMD frames for the pose (ApplyPoseSetting).
    if (ParseFraming(std::string(value), r.render.camera)) return "";
    double d = 0;
    const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), d);
    if (ec != std::errc() || end != value.data() + value.size()) {
      return "must be all, shapes, auto or joint:NAME (the camera's framing) or a number of frames (30 a second)";
    }
    *known = false;
    return "";
  }
  const bool camera_key = key == "yaw" || key == "pitch" || key == "distance" || key == "zoom" || key == "fov";
  const bool string_key = key == "view" || key == "format" || key == "background";
  if (!camera_key && !string_key && key != "width" && key != "height" && key != "supersample" && key != "quality" &&
      key != "exposure") {
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
  if (camera_key) CameraFromJson(json{{key, v}}, r.render.camera, errors);
  else RenderMember(key, v, r, errors);
  return errors.fields.empty() ? "" : errors.fields[0].message;
}

std::string ApplyPoseSetting(const std::string& key, const std::string& value, MeshRequest& r, bool* known) {
  *known = key == "animation" || key == "motion" || key == "time" || key == "frame" || key == "loop" || key == "pose" || key == "blend" ||
           key == "skinning" || key == "lod";
  if (!*known) return "";
  json v;
  if (key == "skinning") {
    v = value;
  } else if (key == "animation" || key == "motion") {
    const bool digits = !value.empty() && value.find_first_not_of("0123456789") == std::string::npos && value.size() < 10;
    v = digits ? json(std::stoll(value)) : json(value);
  } else if (key == "lod") {
    if (value.size() != 1 || value[0] < '0' || value[0] > '9') return "must be an integer level of detail 0.." + std::to_string(kMaxLod);
    v = value[0] - '0';
  } else if (key == "loop") {
    if (value == "true" || value == "1") v = true;
    else if (value == "false" || value == "0") v = false;
    else return "must be true or false";
  } else {
    v = json::parse(value, nullptr, false);
    if (v.is_discarded()) return key == "time" ? "must be a number of seconds" : key == "frame" ? "must be a number of frames" : "must be JSON";
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

Result<SequenceRequest> ParseSequenceRequest(std::string_view body) {
  auto j = ParseObject(body, kSequenceBody);
  if (!j.ok()) return j.status();
  SequenceRequest r;
  Status errors = InvalidArgument("");
  auto number = [&](const json& v, const std::string& ptr, float* out, double lo, double hi) {
    double d = 0;
    if (!Number(v, lo, hi, &d)) errors.fields.push_back({ptr, "must be a number in [" + FormatNumber(lo) + ", " + FormatNumber(hi) + "]"});
    else *out = static_cast<float>(d);
  };
  auto transition = [&](const json& v, const std::string& ptr, Transition* out) {
    if (!v.is_string() || !ParseTransition(v.get<std::string>(), out)) {
      errors.fields.push_back({ptr, "must be step, linear, smoothstep, smootherstep, ease-in, ease-out, ease-in-out or "
                                    "cubic-bezier(x1, y1, x2, y2) with x1, x2 in [0, 1]"});
    }
  };
  for (auto it = j->begin(); it != j->end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    const std::string ptr = "/" + JsonPointerEscape(key);
    if (key == "motion" || key == "animation") {
      if (!r.clip.pointer.empty()) errors.fields.push_back({ptr, "give animation or motion, not both"});
      else if (!ClipRef(v, r.clip)) errors.fields.push_back({ptr, "must be " + std::string(key == "motion" ? "a motion" : "an animation") + " name or index"});
      r.clip.pointer = ptr;
    } else if (key == "keys") {
      if (!v.is_array() || v.empty()) {
        errors.fields.push_back({ptr, "must be a non-empty array of {time, weights | shape}"});
        continue;
      }
      if (v.size() > 100000) {
        errors.fields.push_back({ptr, "at most 100000 keys"});
        continue;
      }
      for (size_t k = 0; k < v.size(); ++k) {
        SequenceRequest::Key key_out;
        key_out.pointer = "/keys/" + std::to_string(k);
        const json& e = v[k];
        if (!e.is_object() || !e.contains("time")) {
          errors.fields.push_back({key_out.pointer, "needs a time"});
          continue;
        }
        for (auto m = e.begin(); m != e.end(); ++m) {
          const std::string mp = key_out.pointer + "/" + JsonPointerEscape(m.key());
          if (m.key() == "time") {
            number(*m, mp, &key_out.time, -1e9, 1e9);
          } else if (m.key() == "weights") {
            auto w = WeightsFromJson(*m, mp);
            if (w.ok()) key_out.weights = std::move(w.value());
            else errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
          } else if (m.key() == "shape") {
            if (!m->is_string()) errors.fields.push_back({mp, "must be a shape name"});
            else key_out.shape = m->get<std::string>();
          } else if (m.key() == "transition") {
            Transition t;
            transition(*m, mp, &t);
            key_out.transition = t;
          } else {
            errors.fields.push_back({mp, "unknown member (time, weights, shape, transition)"});
          }
        }
        if (!key_out.shape.empty() && !key_out.weights.empty()) errors.fields.push_back({key_out.pointer, "give weights or shape, not both"});
        r.keys.push_back(std::move(key_out));
      }
    } else if (key == "transition") {
      transition(v, ptr, &r.transition);
    } else if (key == "smooth") {
      if (!v.is_boolean()) errors.fields.push_back({ptr, "must be true or false"});
      else r.smooth = v.get<bool>();
    } else if (key == "times") {
      if (!v.is_array() || v.empty() || v.size() > 10000) {
        errors.fields.push_back({ptr, "must be an array of 1 to 10000 times"});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        float t = 0;
        number(v[i], ptr + "/" + std::to_string(i), &t, -1e9, 1e9);
        r.times.push_back(t);
      }
    } else if (key == "fps") {
      number(v, ptr, &r.fps, 0.1, 1000);
    } else if (key == "format") {
      if (!v.is_string() || (v != "json" && v != "ndjson" && v != "f32")) errors.fields.push_back({ptr, "must be json, ndjson or f32"});
      else r.format = v.get<std::string>();
    } else if (key == "tolerance") {
      number(v, ptr, &r.tolerance, 0, 1e9);
      r.has_tolerance = true;
    } else if (key == "mode") {
      if (!v.is_string() || !ParseBlendMode(v.get<std::string>(), &r.options.mode)) errors.fields.push_back({ptr, "must be relative or absolute"});
    } else if (key == "normals") {
      if (!v.is_string() || !ParseNormalMode(v.get<std::string>(), &r.options.normals)) errors.fields.push_back({ptr, "must be blend or recompute"});
    } else {
      UnknownMember(key, kSequenceMembers, errors);
    }
  }
  if (errors.fields.empty() && r.keys.empty() && r.clip.pointer.empty()) errors.fields.push_back({"/keys", "is required (or a motion: \"motion\" or \"animation\")"});
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

// A sequence played from a clip: the keys of its morph-weight channel (or none: the rest weights),
// spanning the whole clip, and the clip for the pose at each time.
Result<Sequence> ClipSequence(const Rig& rig, const SequenceRequest& request) {
  const ClipRequest& c = request.clip;
  Status errors = InvalidArgument("");
  if (!request.keys.empty()) {
    errors.fields.push_back({c.pointer, "give keys or " + c.pointer.substr(1) + ", not both"});
    return Finish(errors);
  }
  const int clip = FindClip(rig, c);
  if (clip < 0) {
    errors.fields.push_back({c.pointer, UnknownClipMessage(rig, c)});
    return Finish(errors);
  }
  const float duration = rig.animations[clip].duration;
  Result<Sequence> s = SequenceFromAnimation(rig, clip);
  if (!s.ok()) {
    Sequence rest;
    rest.keys.push_back({0.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt});
    s = std::move(rest);
  }
  std::vector<Keyframe>& keys = s->keys;
  if (keys.front().time > 0.0f) keys.insert(keys.begin(), Keyframe{0.0f, keys.front().weights, std::nullopt});
  if (keys.back().time < duration) keys.push_back(Keyframe{duration, keys.back().weights, std::nullopt});
  s->clip = clip;
  return s;
}

Result<Sequence> ResolveSequence(const Rig& rig, const SequenceRequest& request) {
  if (!request.clip.pointer.empty()) return ClipSequence(rig, request);
  Sequence s;
  s.transition = request.transition;
  s.smooth = request.smooth;
  Status errors = InvalidArgument("");
  for (const SequenceRequest::Key& k : request.keys) {
    Keyframe key;
    key.time = k.time;
    key.transition = k.transition;
    if (!k.shape.empty()) {
      const int shape = FindShape(rig, k.shape);
      if (shape < 0) {
        errors.fields.push_back({k.pointer + "/shape", "unknown shape '" + k.shape + "'"});
        continue;
      }
      key.weights.assign(rig.shapes.size(), 0.0f);
      key.weights[shape] = 1.0f;
    } else {
      auto w = ResolveWeights(rig, k.weights);
      if (!w.ok()) {
        errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
        continue;
      }
      key.weights = std::move(w.value());
    }
    s.keys.push_back(std::move(key));
  }
  if (!errors.fields.empty()) return Finish(errors);
  if (Status st = ValidateSequence(s, rig.shapes.size()); !st.ok()) return st;
  return s;
}

namespace {

Result<TargetMesh> TargetFromJson(const json& j, const std::string& ptr) {
  if (!j.is_object() || !j.contains("primitives") || !j["primitives"].is_array()) {
    return FieldStatus(ptr, "must be {\"primitives\": [{\"positions\": [...]}, ...]} as the mesh route returns");
  }
  TargetMesh target;
  if (j.contains("space")) {
    if (j["space"] != "world" && j["space"] != "mesh") return FieldStatus(ptr + "/space", "must be \"world\" (the default) or \"mesh\"");
    target.mesh_space = j["space"] == "mesh";
  }
  std::vector<std::vector<float>>& out = target.positions;
  for (size_t p = 0; p < j["primitives"].size(); ++p) {
    const json& prim = j["primitives"][p];
    const std::string pp = ptr + "/primitives/" + std::to_string(p) + "/positions";
    if (!prim.is_object() || !prim.contains("positions") || !prim["positions"].is_array() || prim["positions"].size() % 3) {
      return FieldStatus(pp, "must be an array of x, y, z numbers");
    }
    std::vector<float> pos;
    pos.reserve(prim["positions"].size());
    for (const json& v : prim["positions"]) {
      if (!v.is_number() || !std::isfinite(v.get<double>())) return FieldStatus(pp, "must hold finite numbers");
      pos.push_back(v.get<float>());
    }
    out.push_back(std::move(pos));
  }
  return target;
}

}  // namespace

Result<TargetMesh> ParseTargetJson(std::string_view text) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return WithReason(InvalidArgument(std::string(kMalformed) + ": the target is not valid JSON"), kMalformedJson);
  return TargetFromJson(j, "");
}

Result<FitRequest> ParseFitRequest(std::string_view body) {
  auto j = ParseObject(body, kFitBody);
  if (!j.ok()) return j.status();
  FitRequest r;
  Status errors = InvalidArgument("");
  bool has_target = false;
  for (auto it = j->begin(); it != j->end(); ++it) {
    const std::string ptr = "/" + JsonPointerEscape(it.key());
    if (it.key() == "target") {
      auto t = TargetFromJson(it.value(), "/target");
      if (!t.ok()) errors.fields.insert(errors.fields.end(), t.status().fields.begin(), t.status().fields.end());
      else r.target = std::move(t.value());
      has_target = true;
    } else if (it.key() == "bounded" || it.key() == "sum_at_most_one" || it.key() == "rigid_align") {
      if (!it->is_boolean()) {
        errors.fields.push_back({ptr, "must be true or false"});
        continue;
      }
      bool& dst = it.key() == "bounded" ? r.options.bounded : it.key() == "sum_at_most_one" ? r.options.sum_at_most_one : r.options.rigid_align;
      dst = it->get<bool>();
    } else {
      errors.fields.push_back({ptr, "unknown member (target, bounded, sum_at_most_one, rigid_align)"});
    }
  }
  if (!has_target && errors.fields.empty()) errors.fields.push_back({"/target", "is required"});
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

}  // namespace facespace::api

namespace facespace::api {

bool IsValidVariantId(const std::string& id) {
  if (id.empty() || id.size() > 64 || !std::isalnum(static_cast<unsigned char>(id[0]))) return false;
  if (id.find("..") != std::string::npos) return false;
  for (char c : id) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.') return false;
  }
  return true;
}

namespace {

void SampleFromJson(const json& s, BatchRequest& r, Status& errors) {
  if (!s.is_object()) {
    errors.fields.push_back({"/sample", "must be an object {\"method\", \"count\", \"seed\", ...}"});
    return;
  }
  r.sampled = true;
  bool has_method = false;
  auto add = [&](const Result<std::vector<WeightEntry>>& w, std::vector<WeightEntry>& dst) {
    if (w.ok()) dst = w.value();
    else errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
  };
  for (auto it = s.begin(); it != s.end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    const std::string ptr = "/sample/" + JsonPointerEscape(key);
    double d = 0;
    if (key == "method") {
      has_method = true;
      if (!v.is_string() || !ParseSampleMethod(v.get<std::string>(), &r.sample.method)) {
        errors.fields.push_back({ptr, "must be one of \"uniform\", \"gaussian\", \"grid\", \"convex\""});
      }
    } else if (key == "count" || key == "active") {
      if (!v.is_number_integer() || !Number(v, key == "count" ? 1 : 0, 1e9, &d)) {
        errors.fields.push_back({ptr, key == "count" ? "must be a positive integer" : "must be an integer >= 0"});
      } else {
        (key == "count" ? r.sample.count : r.sample.active) = static_cast<size_t>(d);
      }
    } else if (key == "seed") {
      if (v.is_number_unsigned()) r.sample.seed = v.get<uint64_t>();
      else if (v.is_number_integer() && v.get<long long>() >= 0) r.sample.seed = static_cast<uint64_t>(v.get<long long>());
      else errors.fields.push_back({ptr, "must be an integer in 0..2^64-1"});
    } else if (key == "spread") {
      if (!Number(v, 0, 1e6, &d)) errors.fields.push_back({ptr, "must be a number >= 0"});
      else r.sample.spread = static_cast<float>(d);
    } else if (key == "shapes") {
      if (!v.is_array()) {
        errors.fields.push_back({ptr, "must be an array of shape names"});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_string()) errors.fields.push_back({ptr + "/" + std::to_string(i), "must be a shape name"});
        else r.shapes.push_back(v[i].get<std::string>());
      }
    } else if (key == "fixed" || key == "center") {
      add(WeightsFromJson(v, ptr), key == "fixed" ? r.fixed : r.center);
    } else if (key == "points") {
      if (!v.is_array()) {
        errors.fields.push_back({ptr, "must be an array of weight vectors"});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        r.points.emplace_back();
        add(WeightsFromJson(v[i], ptr + "/" + std::to_string(i)), r.points.back());
      }
    } else if (key == "symmetric" || key == "sum_at_most_one") {
      if (!v.is_boolean()) errors.fields.push_back({ptr, "must be true or false"});
      else (key == "symmetric" ? r.sample.symmetric : r.sample.sum_at_most_one) = v.get<bool>();
    } else {
      errors.fields.push_back({ptr, "unknown member (method, count, seed, shapes, fixed, center, spread, points, "
                                    "active, symmetric, sum_at_most_one)"});
    }
  }
  if (!has_method) errors.fields.push_back({"/sample/method", "is required"});
}

}  // namespace

Result<BatchRequest> ParseBatchRequest(std::string_view body) {
  auto j = ParseObject(body, kBatchBody);
  if (!j.ok()) return j.status();
  BatchRequest r;
  Status errors = InvalidArgument("");
  for (auto it = j->begin(); it != j->end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    if (key == "variants") {
      if (!v.is_array() || v.empty()) {
        errors.fields.push_back({"/variants", "must be a non-empty array of {\"id\", \"weights\"}"});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        const std::string ptr = "/variants/" + std::to_string(i);
        BatchRequest::Variant variant;
        if (!v[i].is_object() || !v[i].contains("weights")) {
          errors.fields.push_back({ptr, "must be an object with \"weights\""});
          continue;
        }
        auto w = WeightsFromJson(v[i]["weights"], ptr + "/weights");
        if (w.ok()) variant.weights = std::move(w.value());
        else errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
        if (v[i].contains("id")) {
          if (!v[i]["id"].is_string() || !IsValidVariantId(v[i]["id"].get<std::string>())) {
            errors.fields.push_back({ptr + "/id", "must match [A-Za-z0-9][A-Za-z0-9_.-]{0,63} (it names a file)"});
          } else {
            variant.id = v[i]["id"].get<std::string>();
          }
        }
        r.variants.push_back(std::move(variant));
      }
    } else if (key == "sample") {
      SampleFromJson(v, r, errors);
    } else if (key == "format") {
      MeshFormat mf;
      render::ImageFormat imf;
      if (v.is_string() && ParseMeshFormat(v.get<std::string>(), &mf)) {
        r.mesh_format = mf;
        r.image = false;
        r.format = v.get<std::string>();
      } else if (v.is_string() && render::ParseImageFormat(v.get<std::string>(), &imf)) {
        r.image_format = imf;
        r.image = true;
        r.format = render::ImageFormatExtension(imf);
      } else {
        errors.fields.push_back({"/format", "must be one of \"glb\", \"obj\", \"json\", \"f32\", \"png\", \"jpeg\", \"exr\", \"tiff\", \"webp\""});
      }
    } else if (key == "space") {
      MeshMember(key, v, r.render.mesh, true, errors);
    } else if (key == "weights" || key == "strict" || key == "keep_targets") {
      errors.fields.push_back({"/" + key, "is not a batch member: give \"variants\" or \"sample\""});
    } else if (!MeshMember(key, v, r.render.mesh, false, errors) && !RenderMember(key, v, r.render, errors)) {
      UnknownMember(key, kBatchMembers, errors);
    }
  }
  FinishPose(r.render.mesh.pose, errors);
  if (errors.fields.empty()) {
    if (r.sampled == !r.variants.empty()) errors.fields.push_back({"/sample", "give exactly one of \"sample\" or \"variants\""});
  }
  if (errors.fields.empty()) {
    std::vector<std::string> ids;
    for (const auto& v : r.variants) {
      if (!v.id.empty()) ids.push_back(v.id);
    }
    std::sort(ids.begin(), ids.end());
    if (auto d = std::adjacent_find(ids.begin(), ids.end()); d != ids.end()) {
      errors.fields.push_back({"/variants", "id '" + *d + "' is given twice"});
    }
  }
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

Result<SampleSpec> ResolveSampleSpec(const Rig& rig, const BatchRequest& r) {
  SampleSpec spec = r.sample;
  Status errors = InvalidArgument("");
  auto merge = [&](const Status& s) { errors.fields.insert(errors.fields.end(), s.fields.begin(), s.fields.end()); };
  for (size_t i = 0; i < r.shapes.size(); ++i) {
    const int s = FindShape(rig, r.shapes[i]);
    if (s < 0) {
      std::string msg = "unknown shape '" + r.shapes[i] + "'";
      if (std::string c = ClosestShapeName(rig, r.shapes[i]); !c.empty()) msg += " (did you mean '" + c + "'?)";
      errors.fields.push_back({"/sample/shapes/" + std::to_string(i), msg});
    } else {
      spec.shapes.push_back(static_cast<uint32_t>(s));
    }
  }
  auto fixed = ResolveWeights(rig, r.fixed);
  if (!fixed.ok()) merge(fixed.status());
  else {
    for (const WeightEntry& e : r.fixed) {
      const int s = e.name.empty() ? static_cast<int>(e.index) : FindShape(rig, e.name);
      if (s >= 0) spec.fixed.emplace_back(static_cast<uint32_t>(s), fixed.value()[s]);
    }
  }
  if (!r.center.empty()) {
    auto c = ResolveWeights(rig, r.center);
    if (!c.ok()) merge(c.status());
    else spec.center = std::move(c.value());
  }
  for (const auto& p : r.points) {
    auto w = ResolveWeights(rig, p);
    if (!w.ok()) merge(w.status());
    else spec.points.push_back(std::move(w.value()));
  }
  if (!errors.fields.empty()) return Finish(errors);
  if (Status s = ValidateSampleSpec(rig, spec); !s.ok()) return s;
  return spec;
}

}  // namespace facespace::api
