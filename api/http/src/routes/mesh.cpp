// /v1/rigs/{id}/mesh, /check and /fit: a point of face space as a mesh, its checks, and the point
// that best reproduces a mesh.
#include <charconv>

#include "../http/cost.h"
#include "http/query_params.h"
#include "routes.h"

namespace facespace::http {

namespace {

// A decimal number as JSON writes one (from_chars: no hex "0x10", no leading space or '+').
bool ParseNumber(const std::string& s, double* out) {
  if (s.empty() || s.size() > 64) return false;
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return false;
  *out = v;
  return true;
}

bool ParseBool(const std::string& s, bool* out) {
  if (s == "true" || s == "1")
    *out = true;
  else if (s == "false" || s == "0")
    *out = false;
  else
    return false;
  return true;
}

// The mesh request from a POST body or GET query; false when an error was sent.
bool ReadMeshRequest(const ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                     evaluator::MeshRequest& r) {
  if (req.method == "POST") {
    if (!ReadJsonBody(req, res, evaluator::ParseMeshRequest, r)) return false;
    AttachVocabulary(ctx, r);
    return true;
  }
  std::vector<FieldError> errors;
  for (auto it = req.params.begin(); it != req.params.end(); ++it) {
    const auto& [key, value] = *it;
    const std::string where = "?" + key;
    if (Repeated(req, it, errors)) continue;
    if (key == "format") {
      formats::MeshFormat f;
      if (ParseMeshFormat(value, &f))
        r.format = f;
      else
        errors.push_back({where, "must be one of glb, obj, json, f32"});
    } else if (key == "space") {
      if (value == "world" || value == "mesh")
        r.mesh_space = value == "mesh";
      else
        errors.push_back({where, "must be world (the default) or mesh"});
    } else if (key == "keep_targets") {
      if (!ParseBool(value, &r.keep_targets)) errors.push_back({where, "must be true or false"});
    } else if (!MeshQueryParam(key, value, r, errors)) {
      errors.push_back({where, UnknownParameter(key, false)});
    }
  }
  if (!FinishQuery(req, res, r, errors)) return false;
  AttachVocabulary(ctx, r);
  return true;
}

}  // namespace

std::string UnknownParameter(const std::string& key, bool render) {
  std::string hint =
      DidYouMean(key, render ? std::span<const std::string_view>(kRenderQuery) : kMeshQuery);
  return "unknown parameter" + (hint.empty() ? " (weights are w.NAME=VALUE or w[NAME]=VALUE, "
                                               "controls c.NAME=VALUE, expressions e.NAME=VALUE)"
                                             : hint);
}

bool Repeated(const httplib::Request& req, httplib::Params::const_iterator it,
              std::vector<FieldError>& errors) {
  if (it != req.params.begin() && std::prev(it)->first == it->first)
    return true;  // Said at its first.
  const size_t n = req.params.count(it->first);
  if (n < 2) return false;
  errors.push_back({"?" + it->first, "is given " + std::to_string(n) + " times; give it once"});
  return true;
}

bool MeshQueryParam(const std::string& key, const std::string& value, evaluator::MeshRequest& r,
                    std::vector<FieldError>& errors) {
  const std::string where = "?" + key;
  // A shape weight, or a control value: w.NAME, or w[NAME] (OpenAPI's deepObject style, what
  // generated clients send).
  const bool dotted = key.rfind("w.", 0) == 0 || key.rfind("c.", 0) == 0 || key.rfind("e.", 0) == 0;
  const bool bracketed =
      (key.rfind("w[", 0) == 0 || key.rfind("c[", 0) == 0 || key.rfind("e[", 0) == 0) &&
      key.size() >= 3 && key.back() == ']';
  if (dotted || bracketed) {
    WeightEntry e;
    e.name = bracketed ? key.substr(2, key.size() - 3) : key.substr(2);
    e.pointer = where;
    if (e.name.empty())
      errors.push_back({where, key.substr(0, 2) +
                                   " needs a name: w.SHAPE=0.5, c.CONTROL=-0.4 or e.EXPRESSION=1"});
    else if (!ParseNumber(value, &e.value))
      errors.push_back({where, "'" + value.substr(0, 40) + "' is not a number"});
    else
      (key[0] == 'w' ? r.weights : key[0] == 'c' ? r.controls : r.pose.expressions).push_back(e);
  } else if (key == "mode") {
    if (!evaluator::ParseBlendMode(value, &r.options.mode))
      errors.push_back({where, "must be relative or absolute"});
  } else if (key == "normals") {
    if (!evaluator::ParseNormalMode(value, &r.options.normals))
      errors.push_back({where, "must be blend or recompute"});
  } else if (key == "strict") {
    if (!ParseBool(value, &r.strict)) errors.push_back({where, "must be true or false"});
  } else if (key == "vocabulary") {
    if (!evaluator::ParseVocabulary(value, r))
      errors.push_back({where, "must be arkit, vrm, mmd or a rig's id"});
  } else {
    bool known = false;
    const std::string e = ApplyPoseSetting(key, value, r, &known);
    if (!known) return false;
    if (!e.empty()) errors.push_back({where, e});
  }
  return true;
}

bool FinishQuery(const httplib::Request& req, httplib::Response& res, evaluator::MeshRequest& r,
                 std::vector<FieldError>& errors) {
  if (std::string e = FinishPoseSettings(r); !e.empty()) errors.push_back({"?animation", e});
  if (errors.empty()) return true;
  SendProblem(req, res, Problem::kInvalidRequest,
              errors[0].pointer.substr(1) + ": " + errors[0].message, errors);
  return false;
}

void GetOrPostMesh(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::MeshRequest r;
  if (!stored || !ReadMeshRequest(ctx, req, res, r) ||
      !WithinBudget(ctx, req, res, MeshCost(stored->rig, r.format, WeightedShapes(r))))
    return;
  const auto format = NegotiateMesh(req, res, r.format);
  if (!format) return;
  evaluator::ResolvedPoint point;
  const Status s = ResolvePoint(stored->rig, r, point);
  if (!ReportPoint(ctx, req, res, s, point.report.sum, point.report.warnings)) return;
  const evaluator::OutputSpec spec = evaluator::OutputSpec::Mesh(r, *format);
  const std::string key = CacheKey(*stored, {&point, 1}, spec);
  if (NotModified(req, res, key)) return;
  SendCached(ctx, req, res, key, spec.content_type(), Admit::kSecondRequest,
             [&](evaluator::Workspace& ws) -> Result<evaluator::Encoded> {
               ctx.metrics.CountBlends(1);
               if (ws.body.capacity() == 0 && *format == formats::MeshFormat::kF32)
                 ws.body = ctx.bodies->Take();  // Written over, not allocated.
               return ctx.evaluator.Run(stored, point, spec, ws);
             });
}

void PostCheck(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::MeshRequest r;
  if (!stored || !ReadMeshRequest(ctx, req, res, r) ||
      !WithinBudget(ctx, req, res, MeshCost(stored->rig, std::nullopt, WeightedShapes(r))))
    return;
  evaluator::ResolvedPoint point;
  const Status s = ResolvePoint(stored->rig, r, point);
  if (!ReportPoint(ctx, req, res, s, point.report.sum, point.report.warnings)) return;
  res.status = 200;
  res.set_content(CheckJson(stored->rig, point), "application/json");
}

void PostFit(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::FitRequest r;
  if (!stored || !ReadJsonBody(req, res, evaluator::ParseFitRequest, r) ||
      !WithinBudget(ctx, req, res, FitCost(stored->rig, r)))
    return;
  r.options.stop = net::StopOf(req);
  auto out = ProduceFit(stored->rig, r);
  if (!out.ok()) return SendStatus(req, res, out.status());
  if (!out->warnings.empty()) res.set_header("Facespace-Warnings", WarningsHeader(out->warnings));
  res.status = 200;
  res.set_content(std::move(out->bytes), out->content_type);
}

}  // namespace facespace::http
