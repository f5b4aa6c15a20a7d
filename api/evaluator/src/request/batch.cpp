// The batch request schema and its sampling.
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

bool IsValidVariantId(const std::string& id) {
  if (id.empty() || id.size() > 64 || !std::isalnum(static_cast<unsigned char>(id[0])))
    return false;
  if (id.find("..") != std::string::npos) return false;
  for (char c : id) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-' && c != '.')
      return false;
  }
  return true;
}

namespace {

void SampleFromJson(const json& s, BatchRequest& r, Status& errors) {
  if (!s.is_object()) {
    errors.fields.push_back(
        {"/sample", "must be an object {\"method\", \"count\", \"seed\", ...}"});
    return;
  }
  r.sampled = true;
  bool has_method = false;
  auto add = [&](const Result<std::vector<WeightEntry>>& w, std::vector<WeightEntry>& dst) {
    if (w.ok())
      dst = w.value();
    else
      errors.fields.insert(errors.fields.end(), w.status().fields.begin(), w.status().fields.end());
  };
  for (auto it = s.begin(); it != s.end(); ++it) {
    const std::string& key = it.key();
    const json& v = it.value();
    const std::string ptr = "/sample/" + JsonPointerEscape(key);
    double d = 0;
    if (key == "method") {
      has_method = true;
      if (!v.is_string() || !ParseSampleMethod(v.get<std::string>(), &r.sample.method)) {
        errors.fields.push_back(
            {ptr, "must be one of \"uniform\", \"gaussian\", \"grid\", \"convex\""});
      }
    } else if (key == "count" || key == "active") {
      if (!v.is_number_integer() || !Number(v, key == "count" ? 1 : 0, 1e9, &d)) {
        errors.fields.push_back(
            {ptr, key == "count" ? "must be a positive integer" : "must be an integer >= 0"});
      } else {
        (key == "count" ? r.sample.count : r.sample.active) = static_cast<size_t>(d);
      }
    } else if (key == "seed") {
      if (v.is_number_unsigned())
        r.sample.seed = v.get<uint64_t>();
      else if (v.is_number_integer() && v.get<long long>() >= 0)
        r.sample.seed = static_cast<uint64_t>(v.get<long long>());
      else
        errors.fields.push_back({ptr, "must be an integer in 0..2^64-1"});
    } else if (key == "spread") {
      if (!Number(v, 0, 1e6, &d))
        errors.fields.push_back({ptr, "must be a number >= 0"});
      else
        r.sample.spread = static_cast<float>(d);
    } else if (key == "shapes") {
      if (!v.is_array()) {
        errors.fields.push_back({ptr, "must be an array of shape names"});
        continue;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        if (!v[i].is_string())
          errors.fields.push_back({ptr + "/" + std::to_string(i), "must be a shape name"});
        else
          r.shapes.push_back(v[i].get<std::string>());
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
      if (!v.is_boolean())
        errors.fields.push_back({ptr, "must be true or false"});
      else
        (key == "symmetric" ? r.sample.symmetric : r.sample.sum_at_most_one) = v.get<bool>();
    } else {
      UnknownMember("/sample", key, Body::kSample, errors);
    }
  }
  if (!has_method) errors.fields.push_back({"/sample/method", "is required"});
}

}  // namespace

Result<BatchRequest> ParseBatchRequest(std::string_view body) {
  BatchRequest r;
  Status errors = InvalidArgument("");
  const Status parsed = ReadMembers(body, kBatchBody, [&](const std::string& key, const json& v) {
    if (key == "variants") {
      if (!v.is_array() || v.empty()) {
        errors.fields.push_back(
            {"/variants", "must be a non-empty array of {\"id\", \"weights\"}"});
        return;
      }
      for (size_t i = 0; i < v.size(); ++i) {
        const std::string ptr = "/variants/" + std::to_string(i);
        BatchRequest::Variant variant;
        if (!v[i].is_object() || !v[i].contains("weights")) {
          errors.fields.push_back({ptr, "must be an object with \"weights\""});
          continue;
        }
        RefuseUnknown(v[i], ptr, Body::kVariant, errors);
        auto w = WeightsFromJson(v[i]["weights"], ptr + "/weights");
        if (w.ok())
          variant.weights = std::move(w.value());
        else
          errors.fields.insert(errors.fields.end(), w.status().fields.begin(),
                               w.status().fields.end());
        if (v[i].contains("id")) {
          if (!v[i]["id"].is_string() || !IsValidVariantId(v[i]["id"].get<std::string>())) {
            errors.fields.push_back(
                {ptr + "/id", "must match [A-Za-z0-9][A-Za-z0-9_.-]{0,63} (it names a file)"});
          } else {
            variant.id = v[i]["id"].get<std::string>();
          }
        }
        r.variants.push_back(std::move(variant));
      }
    } else if (key == "sample") {
      SampleFromJson(v, r, errors);
    } else if (DatasetMember(key, v, r.dataset, errors)) {
    } else if (key == "format") {
      r.format_given = true;
      formats::MeshFormat mf;
      picture::ImageFormat imf;
      if (v.is_string() && ParseMeshFormat(v.get<std::string>(), &mf)) {
        r.mesh_format = mf;
        r.image = false;
        r.format = v.get<std::string>();
      } else if (v.is_string() && picture::ParseImageFormat(v.get<std::string>(), &imf)) {
        r.image_format = imf;
        r.image = true;
        r.format = picture::ImageFormatExtension(imf);
      } else {
        errors.fields.push_back({"/format",
                                 "must be one of \"glb\", \"obj\", \"json\", \"f32\", \"vrm\", "
                                 "\"png\", \"jpeg\", \"exr\", \"tiff\", \"webp\""});
      }
    } else if (key == "space") {
      MeshMember(key, v, r.render.mesh, true, errors);
    } else if (key == "weights" || key == "strict" || key == "keep_targets") {
      errors.fields.push_back(
          {"/" + key, "is not a batch member: give \"variants\" or \"sample\""});
    } else if (!MeshMember(key, v, r.render.mesh, false, errors) &&
               !RenderMember(key, v, r.render, errors)) {
      UnknownMember("", key, Body::kBatch, errors);
    }
  });
  if (!parsed.ok()) return parsed;
  FinishPose(r.render.mesh.pose, errors);
  if (errors.fields.empty()) {
    if (r.sampled == !r.variants.empty())
      errors.fields.push_back({"/sample", "give exactly one of \"sample\" or \"variants\""});
  }
  if (r.dataset.labelled() && !r.format_given) {  // A labelled sample's picture: PNG unless told.
    r.image = true;
    r.image_format = picture::ImageFormat::kPng;
    r.format = "png";
  }
  if (r.dataset.labelled() && !r.image) {
    errors.fields.push_back({"/format",
                             "labels and randomisation go with a render: give an image format "
                             "(\"png\", \"jpeg\", \"exr\", \"tiff\", \"webp\")"});
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
  auto merge = [&](const Status& s) {
    errors.fields.insert(errors.fields.end(), s.fields.begin(), s.fields.end());
  };
  for (size_t i = 0; i < r.shapes.size(); ++i) {
    const int s = FindShape(rig, r.shapes[i]);
    if (s < 0) {
      std::string msg = "unknown shape '" + r.shapes[i] + "'";
      if (std::string c = ClosestShapeName(rig, r.shapes[i]); !c.empty())
        msg += " (did you mean '" + c + "'?)";
      errors.fields.push_back({"/sample/shapes/" + std::to_string(i), msg});
    } else {
      spec.shapes.push_back(static_cast<uint32_t>(s));
    }
  }
  auto fixed = ResolveWeights(rig, r.fixed);
  if (!fixed.ok())
    merge(fixed.status());
  else {
    for (const WeightEntry& e : r.fixed) {
      const int s = e.name.empty() ? static_cast<int>(e.index) : FindShape(rig, e.name);
      if (s >= 0) spec.fixed.emplace_back(static_cast<uint32_t>(s), fixed.value()[s]);
    }
  }
  if (!r.center.empty()) {
    auto c = ResolveWeights(rig, r.center);
    if (!c.ok())
      merge(c.status());
    else
      spec.center = std::move(c.value());
  }
  for (const auto& p : r.points) {
    auto w = ResolveWeights(rig, p);
    if (!w.ok())
      merge(w.status());
    else
      spec.points.push_back(std::move(w.value()));
  }
  if (!errors.fields.empty()) return Finish(errors);
  if (Status s = ValidateSampleSpec(rig, spec); !s.ok()) return s;
  return spec;
}

}  // namespace facespace::evaluator
