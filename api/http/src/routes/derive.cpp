// /v1/rigs/{id}/derive: another rig's shapes (FaceCap's ARKit 52 and the visemes baked from them)
// transferred onto this one, as a job (http/derive_jobs.h) that writes a rig to the store.
#include "facespace/derive/derive.h"

#include "facespace/engine/speech.h"
#include "facespace/formats/io.h"
#include "facespace/formats/rig_json.h"
#include "routes.h"

namespace facespace::http {

using nlohmann::json;

namespace {

// `s`'s fields (and message) moved under the body's `member`: a landmarks document's "/points/0"
// is the request's "/landmarks/points/0".
Status UnderMember(Status s, const std::string& member) {
  for (FieldError& f : s.fields) f.pointer = member + f.pointer;
  s.message = member + (s.message.starts_with("/") ? "" : ": ") + s.message;
  return s;
}

// The derive's settings from the request, checked against both rigs now, before the job.
Result<derive::Options> DeriveOptionsOf(const evaluator::DeriveRequest& r, const Rig& source) {
  derive::Options options;
  options.visemes = r.shapes.empty();
  if (!r.shapes.empty()) {
    Status s = derive::ParseShapeSets(source, r.shapes, options);
    if (!s.ok()) return InvalidField("/shapes", s.message);
  }
  if (!r.landmarks.empty()) {
    auto l = derive::ReadLandmarks(r.landmarks);
    if (!l.ok()) return UnderMember(l.status(), "/landmarks");
    options.landmarks = std::move(l.value());
  }
  return options;
}

// The job's work: the derive on a copy of the target, then its glb and manifest stored as `as`;
// the target itself is written only if unchanged since the request (else rig-changed, 409).
DeriveWork DeriveJob(ServerState& ctx, std::shared_ptr<const evaluator::StoredRig> target,
                     std::shared_ptr<const evaluator::StoredRig> source, derive::Options options,
                     std::string as) {
  return [&ctx, target, source, options, as](
             std::stop_token stop,
             const std::function<void(double, const char*)>& progress) mutable -> Result<json> {
    options.stop = stop;
    options.progress = progress;
    Rig rig = target->rig;
    auto report = derive::DeriveShapes(rig, source->rig, options);
    if (!report.ok()) {
      // The target is this route's path; where the source's face was laid is the landmarks'.
      Status s = report.status();
      for (FieldError& f : s.fields)
        if (f.pointer == "/target") f.pointer = "/landmarks";
      return s;
    }
    const auto stored = evaluator::Unstored(std::move(rig));
    auto glb = evaluator::RigGlb(ctx.evaluator, stored);
    if (!glb.ok()) return glb.status();
    if (stop.stop_requested()) return Cancelled("the derive was stopped");
    if (auto now = ctx.store.Get(as); as == target->id && (!now || now->version != target->version))
      return WithReason(FailedPrecondition("rig '" + as +
                                           "' changed while its shapes were derived; "
                                           "derive again"),
                        "rig-changed");
    bool created = false;
    const auto* data = reinterpret_cast<const unsigned char*>(glb->data());
    Status put =
        ctx.store.Put(as, std::span<const unsigned char>(data, glb->size()),
                      formats::RigFormat::kGlb, formats::ManifestJson(stored->rig), &created);
    if (!put.ok()) return put;
    const derive::Report& r = report.value();
    return json{{"rig", as},
                {"created", created},
                {"derived", r.derived.size()},
                {"kept", r.kept},
                {"matched_triangles", r.matched_triangles},
                {"distorted", r.distorted},
                {"seconds", r.seconds},
                {"derivation", formats::DerivationValue(stored->rig)}};
  };
}

}  // namespace

json DeriveJobJson(const DeriveJobInfo& j) {
  const std::string self = "/v1/jobs/" + j.id;
  json o = {{"id", j.id},
            {"kind", "derive"},
            {"rig", j.rig},
            {"from", j.from},
            {"as", j.as},
            {"state", Name(j.state)},
            {"created", j.created},
            {"total", j.total},
            {"progress", std::round(j.progress * 1000.0) / 1000.0},
            {"links", {{"self", self}}}};
  if (!j.step.empty()) o["step"] = j.step;
  if (j.state == batch::JobState::kDone) {
    o["result"] = j.result;
    o["links"]["rig"] = "/v1/rigs/" + j.as;
  }
  if (!j.error.ok()) {
    o["error"] = j.error.message;
    o["problem"] = ProblemJson(j.error, "/v1/rigs/" + j.rig + "/derive");
  }
  return o;
}

void PostDerive(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res)) return;  // It writes a rig: a mutating route.
  auto target = FindRig(ctx, req, res, req.matches[1]);
  evaluator::DeriveRequest r;
  if (!target || !ReadJsonBody(req, res, evaluator::ParseDeriveRequest, r)) return;
  auto source = ctx.store.Get(r.from);
  if (!source) {
    return SendProblem(req, res, Problem::kInvalidRequest,
                       "no rig '" + r.from + "' to derive from (GET /v1/rigs lists them)",
                       {{"/from", "no such rig"}});
  }
  auto options = DeriveOptionsOf(r, source->rig);
  if (!options.ok()) return SendStatus(req, res, options.status());
  const std::string as = r.as.empty() ? target->id : r.as;
  DeriveJobInfo info;
  info.rig = target->id;
  info.from = source->id;
  info.as = as;
  info.total = options->shapes.empty() ? source->rig.shapes.size() : options->shapes.size();
  if (options->visemes) info.total += kVisemeCount;
  if (!WithinBudget(ctx, req, res, DeriveCost(target->rig, source->rig, info.total))) return;
  auto job = ctx.derives.Submit(std::move(info),
                                DeriveJob(ctx, target, source, std::move(options.value()), as));
  if (!job.ok()) {
    res.set_header("Retry-After", "10");
    return SendStatus(req, res, job.status());
  }
  res.set_header("Location", "/v1/jobs/" + job->id);
  SendJson(res, 202, DeriveJobJson(job.value()));
}

}  // namespace facespace::http
