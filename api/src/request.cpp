#include "facespace/api/request.h"

#include <nlohmann/json.hpp>

namespace facespace::api {

namespace {

using nlohmann::json;

constexpr char kMalformed[] = "malformed JSON";

std::string Escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '~') r += "~0";
    else if (c == '/') r += "~1";
    else r += c;
  }
  return r;
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
      errors.fields.push_back({ptr, std::string("must be a number, not ") + v.type_name()});
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
      e.pointer = pointer + "/" + Escape(it.key());
      if (e.name.empty()) {
        errors.fields.push_back({e.pointer, "empty shape name"});
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

bool IsMalformedJson(const Status& status) { return status.message.rfind(kMalformed, 0) == 0; }

bool ParseBlendMode(std::string_view s, BlendMode* mode) {
  if (s == "relative") *mode = BlendMode::kRelative;
  else if (s == "absolute") *mode = BlendMode::kAbsolute;
  else return false;
  return true;
}

bool ParseNormalMode(std::string_view s, NormalMode* mode) {
  if (s == "blend") *mode = NormalMode::kBlend;
  else if (s == "recompute") *mode = NormalMode::kRecompute;
  else return false;
  return true;
}

Result<std::vector<WeightEntry>> ParseWeightsJson(std::string_view text, const std::string& pointer) {
  json j = json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidArgument(std::string(kMalformed) + ": weights are not valid JSON");
  return WeightsFromJson(j, pointer);
}

Result<MeshRequest> ParseMeshRequest(std::string_view body) {
  json j = json::parse(body, nullptr, false);
  if (j.is_discarded()) return InvalidArgument(std::string(kMalformed) + ": the body is not valid JSON");
  if (!j.is_object()) return FieldStatus("", std::string("the body must be a JSON object, not ") + j.type_name());
  MeshRequest r;
  Status errors = InvalidArgument("");
  auto add = [&](const Status& s) { errors.fields.insert(errors.fields.end(), s.fields.begin(), s.fields.end()); };
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    const std::string ptr = "/" + Escape(key);
    auto string_field = [&](auto parse, auto* dst, const char* allowed) {
      if (!v.is_string() || !parse(v.get<std::string>(), dst)) {
        errors.fields.push_back({ptr, std::string("must be one of ") + allowed});
      }
    };
    if (key == "weights") {
      auto w = WeightsFromJson(v, "/weights");
      if (w.ok()) r.weights = std::move(w.value());
      else add(w.status());
    } else if (key == "mode") {
      string_field(ParseBlendMode, &r.options.mode, "\"relative\", \"absolute\"");
    } else if (key == "normals") {
      string_field(ParseNormalMode, &r.options.normals, "\"blend\", \"recompute\"");
    } else if (key == "format") {
      MeshFormat f;
      if (!v.is_string() || !ParseMeshFormat(v.get<std::string>(), &f)) {
        errors.fields.push_back({ptr, "must be one of \"glb\", \"obj\", \"json\", \"f32\""});
      } else {
        r.format = f;
      }
    } else if (key == "strict" || key == "keep_targets") {
      if (!v.is_boolean()) errors.fields.push_back({ptr, "must be true or false"});
      else (key == "strict" ? r.strict : r.keep_targets) = v.get<bool>();
    }
    // Other members are left for the routes that extend this body (render, pose, ...).
  }
  if (!errors.fields.empty()) {
    errors.message = errors.fields[0].pointer + ": " + errors.fields[0].message;
    return errors;
  }
  return r;
}

}  // namespace facespace::api
