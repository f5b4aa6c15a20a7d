// Request schemas of sequences and fitting.
#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <span>
#include <unordered_set>

#include "facespace/engine/enum_table.h"
#include "facespace/formats/lod.h"
#include "json_body.h"

namespace facespace::evaluator {

using namespace body;  // The shared readers of json_body.h.

namespace {

// A number of `v` in [lo, hi] into *out, or an error at `ptr`.
void NumberMember(const json& v, const std::string& ptr, float* out, double lo, double hi,
                  Status& errors) {
  double d = 0;
  if (!Number(v, lo, hi, &d))
    errors.fields.push_back(
        {ptr, "must be a number in [" + FormatNumber(lo) + ", " + FormatNumber(hi) + "]"});
  else
    *out = static_cast<float>(d);
}

void TransitionMember(const json& v, const std::string& ptr, Transition* out, Status& errors) {
  if (!v.is_string() || !ParseTransition(v.get<std::string>(), out)) {
    errors.fields.push_back(
        {ptr,
         "must be step, linear, smoothstep, smootherstep, ease-in, ease-out, ease-in-out or "
         "cubic-bezier(x1, y1, x2, y2) with x1, x2 in [0, 1]"});
  }
}

// Key k of "keys": {time, weights | shape, expressions, transition}; its errors added to `errors`.
SequenceRequest::Key ParseKey(const json& e, size_t k, Status& errors) {
  SequenceRequest::Key key_out;
  key_out.pointer = "/keys/" + std::to_string(k);
  if (!e.is_object() || !e.contains("time")) {
    errors.fields.push_back({key_out.pointer, "needs a time"});
    return key_out;
  }
  for (auto m = e.begin(); m != e.end(); ++m) {
    const std::string mp = key_out.pointer + "/" + JsonPointerEscape(m.key());
    if (m.key() == "time") {
      NumberMember(*m, mp, &key_out.time, -1e9, 1e9, errors);
    } else if (m.key() == "weights" || m.key() == "expressions") {
      if (m.key() == "expressions" && !m->is_object()) {
        errors.fields.push_back({mp, "must be an object of expression name -> value"});
        continue;
      }
      auto w = WeightsFromJson(*m, mp);
      if (w.ok())
        (m.key() == "weights" ? key_out.weights : key_out.expressions) = std::move(w.value());
      else
        errors.fields.insert(errors.fields.end(), w.status().fields.begin(),
                             w.status().fields.end());
    } else if (m.key() == "shape") {
      if (!m->is_string())
        errors.fields.push_back({mp, "must be a shape name"});
      else
        key_out.shape = m->get<std::string>();
    } else if (m.key() == "transition") {
      Transition t;
      TransitionMember(*m, mp, &t, errors);
      key_out.transition = t;
    } else {
      UnknownMember(key_out.pointer, m.key(), Body::kKey, errors);
    }
  }
  if (!key_out.shape.empty() && !key_out.weights.empty())
    errors.fields.push_back({key_out.pointer, "give weights or shape, not both"});
  return key_out;
}

}  // namespace

Result<SequenceRequest> ParseSequenceRequest(std::string_view body) {
  SequenceRequest r;
  Status errors = InvalidArgument("");
  auto number = [&](const json& v, const std::string& ptr, float* out, double lo, double hi) {
    NumberMember(v, ptr, out, lo, hi, errors);
  };
  const Status parsed =
      ReadMembers(body, kSequenceBody, [&](const std::string& key, const json& v) {
        const std::string ptr = "/" + JsonPointerEscape(key);
        if (key == "motion" || key == "animation") {
          if (!r.clip.pointer.empty())
            errors.fields.push_back({ptr, "give animation or motion, not both"});
          else if (!ClipRef(v, r.clip))
            errors.fields.push_back(
                {ptr, "must be " + std::string(key == "motion" ? "a motion" : "an animation") +
                          " name or index"});
          r.clip.pointer = ptr;
        } else if (key == "keys") {
          if (!v.is_array() || v.empty()) {
            errors.fields.push_back({ptr, "must be a non-empty array of {time, weights | shape}"});
            return;
          }
          if (v.size() > 100000) {
            errors.fields.push_back({ptr, "at most 100000 keys"});
            return;
          }
          for (size_t k = 0; k < v.size(); ++k) r.keys.push_back(ParseKey(v[k], k, errors));
        } else if (key == "layers") {
          PoseRequest pose;
          LayersFromJson(v, pose, errors);
          r.layers = std::move(pose.clips);
        } else if (key == "gaze") {
          GazeTrackFromJson(v, ptr, r.gaze, errors);
        } else if (key == "blink") {
          r.blink = true;
          BlinkFromJson(v, ptr, r.blink_per_minute, r.blink_seed, errors);
        } else if (key == "transition") {
          TransitionMember(v, ptr, &r.transition, errors);
        } else if (key == "smooth") {
          if (!v.is_boolean())
            errors.fields.push_back({ptr, "must be true or false"});
          else
            r.smooth = v.get<bool>();
        } else if (key == "physics") {
          if (!v.is_boolean())
            errors.fields.push_back({ptr, "must be true or false"});
          else
            r.physics = v.get<bool>();
        } else if (key == "times") {
          if (!v.is_array() || v.empty() || v.size() > 10000) {
            errors.fields.push_back({ptr, "must be an array of 1 to 10000 times"});
            return;
          }
          for (size_t i = 0; i < v.size(); ++i) {
            float t = 0;
            number(v[i], ptr + "/" + std::to_string(i), &t, -1e9, 1e9);
            r.times.push_back(t);
          }
        } else if (key == "fps") {
          number(v, ptr, &r.fps, 0.1, 1000);
        } else if (key == "format") {
          FrameFormat f;  // Not wav or webm: those are speech's.
          if (v.is_string() && ParseEnum(kFrameFormats, v.get<std::string>(), &f) &&
              f != FrameFormat::kWav && f != FrameFormat::kWebm)
            r.format = f;
          else
            errors.fields.push_back(
                {ptr, "must be json or weights (sample), ndjson or f32 (stream)"});
        } else if (key == "tolerance") {
          number(v, ptr, &r.tolerance, 0, 1e9);
          r.has_tolerance = true;
        } else if (key == "mode") {
          if (!v.is_string() || !ParseBlendMode(v.get<std::string>(), &r.options.mode))
            errors.fields.push_back({ptr, "must be relative or absolute"});
        } else if (key == "normals") {
          if (!v.is_string() || !ParseNormalMode(v.get<std::string>(), &r.options.normals))
            errors.fields.push_back({ptr, "must be blend or recompute"});
        } else {
          UnknownMember("", key, Body::kSequence, errors);
        }
      });
  if (!parsed.ok()) return parsed;
  if (!r.layers.empty() && (!r.keys.empty() || !r.clip.pointer.empty()))
    errors.fields.push_back({"/layers", "give keys, a motion or layers: one of them"});
  if (errors.fields.empty() && r.keys.empty() && r.clip.pointer.empty() && r.layers.empty()) {
    errors.fields.push_back(
        {"/keys", "is required (or a motion: \"motion\" or \"animation\", or \"layers\")"});
  }
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
  return SequenceOfClip(rig, clip);
}

// A sequence of layered motions: each layer starts at its time and plays its clip (the first the
// base, the others overlays); the sequence spans from 0 to the end of the last layer that ends (or
// of the longest looping one), its keys the rest weights (the layers give the weights).
Result<Sequence> LayeredSequence(const Rig& rig, const SequenceRequest& request) {
  Status errors = InvalidArgument("");
  float end = 0.0f;
  for (const ClipRequest& c : request.layers) {
    const int clip = FindClip(rig, c);
    if (clip < 0) {
      errors.fields.push_back({c.pointer, UnknownClipMessage(rig, c)});
      continue;
    }
    end = std::max(end, (c.loop ? 0.0f : c.time) + rig.animations[clip].duration);
  }
  if (!errors.fields.empty()) return Finish(errors);
  Sequence s;
  s.keys.push_back({0.0f, std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.keys.push_back(
      {std::max(end, 1.0f / 30.0f), std::vector<float>(rig.shapes.size(), 0.0f), std::nullopt, {}});
  s.layers = request.layers;
  return s;
}

void AttachFace(const Rig& rig, std::span<const GazeKey> gaze, bool blink, float per_minute,
                uint64_t seed, Sequence& s) {
  if (!gaze.empty()) {
    if (rig.gaze.kind == GazeSetup::Kind::kNone) {
      s.warnings.push_back(GazeUnsupported());
    } else {
      s.gaze.assign(gaze.begin(), gaze.end());
    }
  }
  if (blink && !s.keys.empty()) {
    if (!CanBlink(rig)) {
      s.warnings.push_back({"blink_unsupported",
                            "this rig has no blink expression (no eyeBlink_L/R, まばたき, or "
                            "\"blink\" in its manifest's expressions): no blinks",
                            "", 0.0, false});
    } else {
      s.blinks = NaturalBlinks(s.keys.front().time, s.keys.back().time, per_minute, seed);
    }
  }
}

Result<Sequence> ResolveSequence(const Rig& rig, const SequenceRequest& request) {
  if (!request.clip.pointer.empty() || !request.layers.empty()) {
    Result<Sequence> posed =
        !request.clip.pointer.empty() ? ClipSequence(rig, request) : LayeredSequence(rig, request);
    if (posed.ok()) {
      posed->physics = request.physics;
      AttachFace(rig, request.gaze, request.blink, request.blink_per_minute, request.blink_seed,
                 posed.value());
    }
    return posed;
  }
  Sequence s;
  s.transition = request.transition;
  s.smooth = request.smooth;
  Status errors = InvalidArgument("");
  // Expressions on any key: every key gets one value per rig expression (0 where it names none).
  const bool any_expressions =
      std::any_of(request.keys.begin(), request.keys.end(),
                  [](const SequenceRequest::Key& k) { return !k.expressions.empty(); });
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
        errors.fields.insert(errors.fields.end(), w.status().fields.begin(),
                             w.status().fields.end());
        continue;
      }
      key.weights = std::move(w.value());
    }
    if (any_expressions) {
      std::vector<Warning> unmapped;
      if (Status st = ResolveExpressions(rig, k.expressions, key.expressions, unmapped); !st.ok()) {
        errors.fields.insert(errors.fields.end(), st.fields.begin(), st.fields.end());
        continue;
      }
      for (Warning& w : unmapped) {
        if (std::none_of(s.warnings.begin(), s.warnings.end(), [&](const Warning& x) {
              return x.code == w.code && x.shape == w.shape;
            })) {
          s.warnings.push_back(std::move(w));
        }
      }
    }
    s.keys.push_back(std::move(key));
  }
  if (!errors.fields.empty()) return Finish(errors);
  if (Status st = ValidateSequence(s, rig.shapes.size()); !st.ok()) return st;
  AttachFace(rig, request.gaze, request.blink, request.blink_per_minute, request.blink_seed, s);
  return s;
}

namespace {

Result<TargetMesh> TargetFromJson(const json& j, const std::string& ptr) {
  if (!j.is_object() || !j.contains("primitives") || !j["primitives"].is_array()) {
    return FieldStatus(
        ptr, "must be {\"primitives\": [{\"positions\": [...]}, ...]} as the mesh route returns");
  }
  TargetMesh target;
  if (j.contains("space")) {
    if (j["space"] != "world" && j["space"] != "mesh")
      return FieldStatus(ptr + "/space", "must be \"world\" (the default) or \"mesh\"");
    target.mesh_space = j["space"] == "mesh";
  }
  std::vector<std::vector<float>>& out = target.positions;
  for (size_t p = 0; p < j["primitives"].size(); ++p) {
    const json& prim = j["primitives"][p];
    const std::string pp = ptr + "/primitives/" + std::to_string(p) + "/positions";
    if (!prim.is_object() || !prim.contains("positions") || !prim["positions"].is_array() ||
        prim["positions"].size() % 3) {
      return FieldStatus(pp, "must be an array of x, y, z numbers");
    }
    std::vector<float> pos;
    pos.reserve(prim["positions"].size());
    for (const json& v : prim["positions"]) {
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        return FieldStatus(pp, "must hold finite numbers");
      pos.push_back(v.get<float>());
    }
    out.push_back(std::move(pos));
  }
  return target;
}

}  // namespace

Result<TargetMesh> ParseTargetJson(std::string_view text) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded())
    return WithReason(InvalidArgument(std::string(kMalformed) + ": the target is not valid JSON"),
                      kMalformedJson);
  return TargetFromJson(j, "");
}

Result<FitRequest> ParseFitRequest(std::string_view body) {
  auto j = ParseObject(body, kFitBody);
  if (!j.ok()) return j.status();
  FitRequest r;
  Status errors = InvalidArgument("");
  bool has_target = false;
  // The mesh route's own JSON ({"space", "primitives", "warnings"}) is a target as it is.
  const json& doc = j.value();
  const bool whole = doc.contains("primitives") && !doc.contains("target");
  if (whole) {
    json mesh{{"primitives", doc["primitives"]}};
    if (doc.contains("space")) mesh["space"] = doc["space"];
    auto t = TargetFromJson(mesh, "");
    if (!t.ok())
      errors.fields.insert(errors.fields.end(), t.status().fields.begin(), t.status().fields.end());
    else
      r.target = std::move(t.value());
    has_target = true;
  }
  for (auto it = j->begin(); it != j->end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    const std::string ptr = "/" + JsonPointerEscape(key);
    if (whole && (key == "primitives" || key == "space" || key == "warnings")) continue;
    if (key == "target") {
      auto t = TargetFromJson(v, "/target");
      if (!t.ok())
        errors.fields.insert(errors.fields.end(), t.status().fields.begin(),
                             t.status().fields.end());
      else
        r.target = std::move(t.value());
      has_target = true;
    } else if (key == "bounded" || key == "sum_at_most_one" || key == "rigid_align") {
      if (!it->is_boolean()) {
        errors.fields.push_back({ptr, "must be true or false"});
        continue;
      }
      bool& dst = key == "bounded"           ? r.options.bounded
                  : key == "sum_at_most_one" ? r.options.sum_at_most_one
                                             : r.options.rigid_align;
      dst = it->get<bool>();
    } else if (key == "primitives" || key == "space" || key == "warnings") {
      errors.fields.push_back(
          {ptr,
           "is read with \"primitives\" (the mesh route's JSON as it is), not with \"target\""});
    } else {
      UnknownMember("", key, Body::kFit, errors);
    }
  }
  if (!has_target && errors.fields.empty()) errors.fields.push_back({"/target", "is required"});
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

}  // namespace facespace::evaluator
