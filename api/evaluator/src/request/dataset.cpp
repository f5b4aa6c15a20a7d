// The dataset members of a batch body: the labels beside each render, the archive, what is
// randomised.
#include <nlohmann/json.hpp>

#include "json_body.h"

namespace facespace::evaluator {

using namespace body;  // The shared readers of json_body.h.

namespace {

void LabelsFromJson(const json& v, DatasetRequest& r, Status& errors) {
  std::vector<std::string> names;
  if (v.is_string()) {
    const std::string text = v.get<std::string>();
    for (size_t start = 0; start <= text.size();) {
      const size_t comma = std::min(text.find(',', start), text.size());
      names.push_back(text.substr(start, comma - start));
      start = comma + 1;
    }
  } else if (v.is_array()) {
    for (const json& n : v)
      names.push_back(n.is_string() ? n.get<std::string>() : std::string("?"));
  } else {
    errors.fields.push_back({"/labels", "must be an array of label names: " + EnumNames(kLabels)});
    return;
  }
  for (size_t i = 0; i < names.size(); ++i) {
    Label l;
    if (!ParseEnum(kLabels, names[i], &l)) {
      errors.fields.push_back(
          {"/labels/" + std::to_string(i),
           "unknown label '" + names[i].substr(0, 40) + "': the labels are " + EnumNames(kLabels)});
    } else if (!r.has(l)) {
      r.labels.push_back(l);
    }
  }
  std::sort(r.labels.begin(), r.labels.end());
}

// [lo, hi] with lo <= hi, each within [min, max].
void IntervalFrom(const json& v, const std::string& ptr, double min, double max,
                  std::optional<Interval>& out, Status& errors) {
  double lo = 0, hi = 0;
  if (!v.is_array() || v.size() != 2 || !Number(v[0], min, max, &lo) ||
      !Number(v[1], min, max, &hi) || lo > hi) {
    errors.fields.push_back({ptr, "must be [lo, hi] with " + FormatNumber(min) +
                                      " <= lo <= hi <= " + FormatNumber(max)});
    return;
  }
  out = Interval{static_cast<float>(lo), static_cast<float>(hi)};
}

// An object of intervals: {"yaw": [lo, hi], ...}, each member's bounds and target from `members`.
struct IntervalMember {
  const char* name;
  double min, max;
  std::optional<Interval> Randomization::*target;
};
void IntervalsFrom(const json& v, const std::string& ptr,
                   std::initializer_list<IntervalMember> members, Randomization& r,
                   Status& errors) {
  std::string known;
  for (const IntervalMember& m : members) known += std::string(known.empty() ? "" : ", ") + m.name;
  if (!v.is_object())
    return errors.fields.push_back(
        {ptr, "must be an object of [lo, hi] intervals (" + known + ")"});
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string at = ptr + "/" + JsonPointerEscape(it.key());
    const IntervalMember* m = nullptr;
    for (const IntervalMember& c : members) m = it.key() == c.name ? &c : m;
    if (!m)
      errors.fields.push_back({at, "unknown member (" + known + ")"});
    else
      IntervalFrom(*it, at, m->min, m->max, r.*(m->target), errors);
  }
}

void BackgroundsFrom(const json& v, Randomization& r, Status& errors) {
  if (v.is_string() && v.get<std::string>() == "random") {
    r.random_background = true;
    return;
  }
  if (v.is_object()) {
    if (v.size() != 1 || !v.contains("images") || !v["images"].is_string() ||
        v["images"].get<std::string>().empty()) {
      errors.fields.push_back(
          {"/randomize/background",
           "an object is {\"images\": \"FOLDER\"}: pictures, one behind each sample"});
    } else {
      r.background_images = v["images"].get<std::string>();
    }
    return;
  }
  for (size_t i = 0; v.is_array() && i < v.size(); ++i) {
    r.backgrounds.emplace_back();
    if (!ParseBackground(v[i], r.backgrounds.back()))
      errors.fields.push_back(
          {"/randomize/background/" + std::to_string(i), "must be \"#rrggbb\" or [r, g, b]"});
  }
  if (!v.is_array() || v.empty()) {
    errors.fields.push_back(
        {"/randomize/background",
         "must be \"random\", a non-empty array of colours or {\"images\": \"FOLDER\"}"});
  }
}

void RandomizeFromJson(const json& v, Randomization& r, Status& errors) {
  if (!v.is_object())
    return errors.fields.push_back(
        {"/randomize", "must be an object (seed, camera, light, background, expressions, gaze)"});
  using R = Randomization;
  for (auto it = v.begin(); it != v.end(); ++it) {
    const std::string& key = it.key();
    const std::string ptr = "/randomize/" + JsonPointerEscape(key);
    if (key == "seed") {
      if (it->is_number_unsigned())
        r.seed = it->get<uint64_t>(), r.seeded = true;
      else
        errors.fields.push_back({ptr, "must be an integer in 0..2^64-1"});
    } else if (key == "camera") {
      IntervalsFrom(*it, ptr,
                    {{"yaw", -180, 180, &R::yaw},
                     {"pitch", -89, 89, &R::pitch},
                     {"zoom", 0.05, 20, &R::zoom}},
                    r, errors);
    } else if (key == "light") {
      IntervalsFrom(*it, ptr,
                    {{"yaw", -180, 180, &R::light_yaw},
                     {"pitch", -89, 89, &R::light_pitch},
                     {"exposure", -10, 10, &R::exposure}},
                    r, errors);
    } else if (key == "gaze") {
      IntervalsFrom(*it, ptr, {{"yaw", -90, 90, &R::gaze_yaw}, {"pitch", -90, 90, &R::gaze_pitch}},
                    r, errors);
    } else if (key == "background") {
      BackgroundsFrom(*it, r, errors);
    } else if (key == "expressions") {
      if (!it->is_object())
        errors.fields.push_back({ptr, "must be an object {NAME: [lo, hi]} of strengths"});
      for (auto e = it->begin(); it->is_object() && e != it->end(); ++e) {
        std::optional<Interval> strength;
        IntervalFrom(*e, ptr + "/" + JsonPointerEscape(e.key()), 0, 2, strength, errors);
        if (strength) r.expressions.emplace_back(e.key(), *strength);
      }
    } else {
      UnknownMember("/randomize", key, Body::kRandomize, errors);
    }
  }
}

}  // namespace

bool DatasetMember(const std::string& key, const json& v, DatasetRequest& r, Status& errors) {
  double d = 0;
  if (key == "labels") {
    LabelsFromJson(v, r, errors);
  } else if (key == "archive") {
    if (!v.is_string() || !ParseEnum(kArchives, v.get<std::string>(), &r.archive)) {
      errors.fields.push_back(
          {"/archive", "unknown archive: the archives are " + EnumNames(kArchives)});
    }
  } else if (key == "shard_samples") {
    if (ReadNumber(Body::kBatch, key, v, "/shard_samples", &d, errors))
      r.shard_samples = static_cast<size_t>(d);
  } else if (key == "randomize") {
    RandomizeFromJson(v, r.randomize, errors);
  } else {
    return false;
  }
  return true;
}

}  // namespace facespace::evaluator
