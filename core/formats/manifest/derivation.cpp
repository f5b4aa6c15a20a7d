// The manifest's "derivation": where a rig's derived shapes came from (`facespace derive`): the
// source rig and its credit, the method, the fit, and the shapes it made.
#include <algorithm>
#include <tuple>

#include "facespace/formats/rig_json.h"
#include "sections.h"

namespace facespace::formats::manifest {

namespace {

Status ReadString(const json& v, const char* key, std::string& out, bool required) {
  if (!v.contains(key))
    return required ? Bad(std::string("/derivation/") + key, "is required") : Status::Ok();
  if (!v[key].is_string()) return Bad(std::string("/derivation/") + key, "must be a string");
  out = v[key].get<std::string>();
  return Status::Ok();
}

Status ReadFraction(const json& v, const char* key, double& out) {
  if (!v.contains(key)) return Status::Ok();
  if (!v[key].is_number() || !(v[key].get<double>() >= 0))
    return Bad(std::string("/derivation/fit/") + key,
               "must be a number of 0 or more (of the head's diagonal)");
  out = v[key].get<double>();
  return Status::Ok();
}

}  // namespace

Status ApplyDerivation(Rig& rig, const json& v) {
  if (!v.is_object())
    return Bad("/derivation", "must be an object: {source, credit, method, fit, shapes}");
  static constexpr std::string_view kKnown[] = {"source",    "credit", "method", "alignment",
                                                "landmarks", "fit",    "shapes"};
  for (auto it = v.begin(); it != v.end(); ++it) {
    if (std::find(std::begin(kKnown), std::end(kKnown), it.key()) == std::end(kKnown))
      return Bad("/derivation/" + JsonPointerEscape(it.key()),
                 "unknown member" + DidYouMean(it.key(), kKnown));
  }
  Derivation d;
  for (auto [key, out, required] : {std::tuple{"source", &d.source, true},
                                    {"credit", &d.credit, false},
                                    {"method", &d.method, false},
                                    {"alignment", &d.alignment, false}}) {
    if (Status s = ReadString(v, key, *out, required); !s.ok()) return s;
  }
  if (v.contains("landmarks")) {
    if (!v["landmarks"].is_number_unsigned())
      return Bad("/derivation/landmarks", "must be a count");
    d.landmarks = v["landmarks"].get<uint32_t>();
  }
  if (v.contains("fit")) {
    if (!v["fit"].is_object()) return Bad("/derivation/fit", "must be an object: {mean, p95}");
    if (Status s = ReadFraction(v["fit"], "mean", d.mean_residual); !s.ok()) return s;
    if (Status s = ReadFraction(v["fit"], "p95", d.p95_residual); !s.ok()) return s;
  }
  if (v.contains("shapes")) {
    if (!v["shapes"].is_array())
      return Bad("/derivation/shapes", "must be an array of shape names");
    for (size_t i = 0; i < v["shapes"].size(); ++i) {
      if (!v["shapes"][i].is_string())
        return Bad("/derivation/shapes/" + std::to_string(i), "must be a shape name");
      d.shapes.push_back(v["shapes"][i].get<std::string>());
    }
  }
  rig.derivation = std::move(d);
  return Status::Ok();
}

json DerivationValue(const Derivation& d) {
  json o = {{"source", d.source}};
  if (!d.credit.empty()) o["credit"] = d.credit;
  if (!d.method.empty()) o["method"] = d.method;
  if (!d.alignment.empty()) o["alignment"] = d.alignment;
  o["landmarks"] = d.landmarks;
  o["fit"] = {{"mean", d.mean_residual}, {"p95", d.p95_residual}};
  o["shapes"] = d.shapes;
  return o;
}

}  // namespace facespace::formats::manifest

namespace facespace::formats {

nlohmann::json DerivationValue(const Rig& rig) {
  return rig.derivation.source.empty() ? nlohmann::json()
                                       : manifest::DerivationValue(rig.derivation);
}

}  // namespace facespace::formats
