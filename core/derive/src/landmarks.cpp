// The landmarks document a derive takes (derive.h, ReadLandmarks).
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "facespace/derive/derive.h"

namespace facespace::derive {

namespace {

constexpr size_t kMaxPoints = 4096;
constexpr size_t kMaxText = 1u << 20;

Status ReadPoint(const nlohmann::json& v, const std::string& at, TargetLandmark& out) {
  if (!v.is_object())
    return InvalidField(at,
                        "must be {\"name\", \"vertex\"} or {\"name\", \"position\": [x, y, z]}");
  if (!v.contains("name") || !v["name"].is_string() || v["name"].get<std::string>().empty() ||
      v["name"].get<std::string>().size() > 128)
    return InvalidField(at + "/name", "must be a name (1 to 128 bytes)");
  out.name = v["name"].get<std::string>();
  if (v.contains("vertex")) {
    if (!v["vertex"].is_number_unsigned())
      return InvalidField(at + "/vertex", "must be a vertex number (0 or more)");
    out.vertex =
        static_cast<long long>(std::min<uint64_t>(v["vertex"].get<uint64_t>(), 1ull << 40));
    return Status::Ok();
  }
  const auto& p = v.value("position", nlohmann::json());
  if (!p.is_array() || p.size() != 3)
    return InvalidField(at, "needs \"vertex\" or \"position\": [x, y, z]");
  for (int k = 0; k < 3; ++k) {
    if (!p[k].is_number() || !std::isfinite(p[k].get<double>()))
      return InvalidField(at + "/position/" + std::to_string(k), "must be a finite number");
    out.position[k] = p[k].get<double>();
  }
  return Status::Ok();
}

}  // namespace

Result<std::vector<TargetLandmark>> ReadLandmarks(std::string_view text) {
  if (text.size() > kMaxText) return InvalidField("", "a landmarks document is at most 1 MiB");
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) return InvalidField("", "is not JSON");
  if (!j.is_object() || !j.contains("points") || !j["points"].is_array())
    return InvalidField("/points", "must be an array of {\"name\", \"vertex\" | \"position\"}");
  const auto& points = j["points"];
  if (points.size() > kMaxPoints) return InvalidField("/points", "at most 4096 points");
  std::vector<TargetLandmark> out(points.size());
  std::set<std::string> names;
  for (size_t i = 0; i < points.size(); ++i) {
    const std::string at = "/points/" + std::to_string(i);
    if (Status s = ReadPoint(points[i], at, out[i]); !s.ok()) return s;
    if (!names.insert(out[i].name).second)
      return InvalidField(at + "/name", "'" + out[i].name + "' is given twice");
  }
  return out;
}

}  // namespace facespace::derive
