// /v1/rigs/{id}/render and /sheet: offscreen renders of points of face space.
#include "../http/cost.h"
#include "routes.h"

namespace facespace::http {

namespace {

// The render request from a POST body or GET query; false when an error was sent.
bool ReadRenderRequest(const ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                       evaluator::RenderRequest& r) {
  if (req.method == "POST") {
    if (!ReadJsonBody(req, res, evaluator::ParseRenderRequest, r)) return false;
    AttachVocabulary(ctx, r.mesh);
    return true;
  }
  std::vector<FieldError> errors;
  for (auto it = req.params.begin(); it != req.params.end(); ++it) {
    const auto& [key, value] = *it;
    if (Repeated(req, it, errors)) continue;
    bool known = false;
    if (std::string e = ApplyRenderSetting(key, value, r, &known); known) {
      if (!e.empty()) errors.push_back({"?" + key, e});
    } else if (!MeshQueryParam(key, value, r.mesh, errors)) {
      errors.push_back({"?" + key, UnknownParameter(key, true)});
    }
  }
  if (!FinishQuery(req, res, r.mesh, errors)) return false;
  AttachVocabulary(ctx, r.mesh);
  return true;
}

// The server's size limit; false with a 422 sent.
bool CheckSize(const ServerState& ctx, const httplib::Request& req, httplib::Response& res,
               const picture::RenderOptions& o) {
  const int max = ctx.options.max_render_size;
  if (o.width <= max && o.height <= max) return true;
  SendProblem(req, res, Problem::kImageTooLarge,
              "width and height are limited to " + std::to_string(max) + " pixels",
              {{std::string(req.method == "GET" ? "?" : "/") + (o.width > max ? "width" : "height"),
                "at most " + std::to_string(max)}});
  return false;
}

}  // namespace

void GetOrPostRender(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::RenderRequest r;
  if (!stored || !ReadRenderRequest(ctx, req, res, r) || !CheckSize(ctx, req, res, r.render) ||
      !CheckRenderBudget(ctx, req, res, r.render, 1))
    return;
  const auto format = NegotiateImage(req, res, r.format);
  if (!format ||
      !WithinBudget(ctx, req, res, RenderCost(stored->rig, r.render, req.method == "GET", *format)))
    return;
  evaluator::ResolvedPoint point;
  const Status s = ResolvePoint(stored->rig, r.mesh, point);
  if (!ReportPoint(ctx, req, res, s, point.report.sum, point.report.warnings)) return;
  const evaluator::OutputSpec spec = evaluator::OutputSpec::Image(r, *format);
  const std::string key = CacheKey(*stored, {&point, 1}, spec);
  if (NotModified(req, res, key)) return;
  SendCached(ctx, req, res, key, spec.content_type(), Admit::kFirstRequest,
             [&](evaluator::Workspace& ws) -> Result<evaluator::Encoded> {
               ctx.metrics.CountBlends(1);
               return WithinRenderBudget(ctx, RenderBudget::Estimate(r.render, 1), [&] {
                 return ctx.evaluator.Run(stored, point, spec, ws);
               });
             });
}

void PostSheet(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  evaluator::SheetRequest r;
  if (!stored || !ReadJsonBody(req, res, evaluator::ParseSheetRequest, r) ||
      !CheckSize(ctx, req, res, r.base.render))
    return;
  AttachVocabulary(ctx, r.base.mesh);
  if (Status s = ExpandShapeCells(stored->rig, ctx.evaluator.renderer(), r); !s.ok())
    return SendStatus(req, res, s);
  const auto format = NegotiateImage(req, res, r.base.format);
  if (!format) return;
  const size_t max_cells = static_cast<size_t>(ctx.options.max_sheet_cells);
  if (r.cells.size() > max_cells) {
    SendProblem(req, res, Problem::kTooManyCells,
                "a sheet has at most " + std::to_string(max_cells) + " cells",
                {{"/cells", "at most " + std::to_string(max_cells)}});
    return;
  }
  if (!CheckRenderBudget(ctx, req, res, r.base.render, r.cells.size()) ||
      !WithinBudget(ctx, req, res,
                    SheetCost(stored->rig, r.base.render, r.cells.size(), *format))) {
    return;
  }
  evaluator::SheetPoints points;
  const Status s = ResolveSheet(stored->rig, r, points);
  if (!ReportPoint(ctx, req, res, s, points.max_sum, points.warnings)) return;
  const evaluator::OutputSpec spec = evaluator::OutputSpec::Sheet(r, *format);
  const std::string key = CacheKey(*stored, points.cells, spec);
  if (NotModified(req, res, key)) return;
  SendCached(ctx, req, res, key, spec.content_type(), Admit::kFirstRequest,
             [&](evaluator::Workspace& ws) -> Result<evaluator::Encoded> {
               ctx.metrics.CountBlends(points.cells.size());
               return WithinRenderBudget(
                   ctx, RenderBudget::Estimate(r.base.render, points.cells.size()),
                   [&] { return ctx.evaluator.Run(stored, points.cells, spec, ws); });
             });
}

}  // namespace facespace::http
