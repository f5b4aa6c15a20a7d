// Request schema of derive (another rig's shapes transferred onto this one).
#include "facespace/evaluator/store.h"
#include "json_body.h"

namespace facespace::evaluator {

using namespace body;

namespace {

constexpr BodyLimits kDeriveBody{40000};  // Landmarks: up to 4096 points of five values.

// shapes: ["arkit", "visemes"] as the CLI's "arkit,visemes".
bool ReadShapeSets(const json& v, std::string& out, Status& errors) {
  if (!v.is_array() || v.empty() || v.size() > 2) {
    errors.fields.push_back({"/shapes", "must be a list of one or two of arkit, visemes"});
    return false;
  }
  for (size_t i = 0; i < v.size(); ++i) {
    if (!v[i].is_string() || (v[i] != "arkit" && v[i] != "visemes")) {
      errors.fields.push_back({"/shapes/" + std::to_string(i),
                               "must be arkit (the source's ARKit-named shapes) or "
                               "visemes (the 15 baked from them)"});
      return false;
    }
    out += (out.empty() ? "" : ",") + v[i].get<std::string>();
  }
  return true;
}

}  // namespace

Result<DeriveRequest> ParseDeriveRequest(std::string_view body) {
  DeriveRequest r;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(body, kDeriveBody, [&](const std::string& key, const json& v) {
    const std::string ptr = "/" + JsonPointerEscape(key);
    if (key == "from" || key == "as") {
      if (!v.is_string() || !IsValidRigId(v.get<std::string>()))
        errors.fields.push_back({ptr, "must be a rig id: 1 to 64 characters of [a-z0-9_-]"});
      else
        (key == "from" ? r.from : r.as) = v.get<std::string>();
    } else if (key == "shapes") {
      ReadShapeSets(v, r.shapes, errors);
    } else if (key == "landmarks") {
      if (!v.is_object())
        errors.fields.push_back({ptr, "must be {\"scheme\", \"points\": [...]}"});
      else
        r.landmarks = v.dump();
    } else {
      UnknownMember("", key, Body::kDerive, errors);
    }
  });
  if (!parsed.ok()) return parsed;
  if (!errors.fields.empty()) return Finish(errors);
  return r;
}

}  // namespace facespace::evaluator
