// /v1/rigs/{id}/batch and /v1/jobs/...: batch jobs of variants, their files and archives.
#include <algorithm>
#include <filesystem>
#include <fstream>

#include "../zip.h"
#include "routes.h"

namespace facespace::http {

namespace {

using batch::JobState;
using nlohmann::json;

json JobJson(const batch::JobInfo& j) {
  const std::string self = "/v1/jobs/" + j.id;
  json o = {
      {"id", j.id},
      {"kind", "batch"},
      {"rig", j.rig},
      {"state", Name(j.state)},
      {"format", j.format},
      {"created", j.created},
      {"total", j.total},
      {"done", j.done},
      {"progress", j.total ? static_cast<double>(j.done) / static_cast<double>(j.total) : 1.0},
      {"rate", std::round(j.rate * 10.0) / 10.0},
      {"archive", j.archive}};
  if (!j.labels.empty()) o["labels"] = j.labels;
  if (j.state == JobState::kRunning && j.rate > 0)
    o["eta_seconds"] = std::ceil(static_cast<double>(j.total - j.done) / j.rate);
  if (!j.error.empty()) o["error"] = j.error;
  o["links"] = {{"self", self},
                {"manifest", self + "/manifest.jsonl"},
                {"files", self + "/files/"},
                {"sheet", self + "/files/sheet.png"}};
  if (j.state == JobState::kDone) o["links"]["results"] = self + "/results.zip";
  return o;
}

bool JobsEnabled(const ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (ctx.jobs) return true;
  SendProblem(req, res, Problem::kJobsDisabled, "this server runs no batch jobs");
  return false;
}

// The job named by the path, or nullopt with 503 or 404 sent.
std::optional<batch::JobInfo> FindJob(ServerState& ctx, const httplib::Request& req,
                                      httplib::Response& res) {
  if (!JobsEnabled(ctx, req, res)) return std::nullopt;
  const std::string id = req.matches[1];
  std::optional<batch::JobInfo> j = batch::IsValidJobId(id) ? ctx.jobs->Get(id) : std::nullopt;
  if (!j) SendProblem(req, res, Problem::kJobNotFound, "no job with id '" + id.substr(0, 80) + "'");
  return j;
}

// The media type of a job's file: the formats' own tables, and JSON lines for the manifest.
const char* FileType(const std::string& name) {
  const std::string ext = name.substr(name.rfind('.') + 1);
  formats::MeshFormat mesh;
  picture::ImageFormat image;
  if (ext == "jsonl") return "application/x-ndjson";
  if (ext == "tar") return "application/x-tar";
  if (ParseMeshFormat(ext, &mesh)) return MeshFormatMimeType(mesh);
  if (picture::ParseImageFormat(ext, &image)) return picture::ImageFormatMimeType(image);
  return "application/octet-stream";
}

// The files a manifest line vouches for, as a results archive holds them: a folder's (the variant's
// and its labels'), or the tar shard holding an archived sample.
std::vector<std::string> ManifestFiles(const json& l) {
  std::vector<std::string> names;
  if (l.is_discarded() || !l.is_object()) return names;
  if (l.contains("shard") && l["shard"].is_string()) return {l["shard"].get<std::string>()};
  if (l.contains("file") && l["file"].is_string()) names.push_back(l["file"]);
  for (const json& f : l.value("files", json::array())) {
    if (f.is_object() && f.contains("file") && f["file"].is_string()) names.push_back(f["file"]);
  }
  return names;
}

// A job's file, read as it is sent (a tar shard of labelled samples runs to hundreds of megabytes).
void SendJobFile(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                 const std::string& name) {
  auto job = FindJob(ctx, req, res);
  if (!job) return;
  const std::filesystem::path path = std::filesystem::path(ctx.jobs->Folder(job->id)) / name;
  auto f = std::make_shared<std::ifstream>(path, std::ios::binary);
  std::error_code ec;
  const uint64_t size = std::filesystem::file_size(path, ec);
  if (!evaluator::IsValidVariantId(name) || !*f || ec) {
    SendProblem(req, res, Problem::kFileNotFound,
                "job " + job->id + " has no file '" + name.substr(0, 80) + "'" +
                    (job->state == JobState::kDone
                         ? ""
                         : std::string(" (yet: the job is ") + Name(job->state) + ")"));
    return;
  }
  res.set_header("Cache-Control", name == "manifest.jsonl" ? "no-cache" : "private, max-age=86400");
  res.set_content_provider(static_cast<size_t>(size), FileType(name),
                           [f](size_t offset, size_t length, httplib::DataSink& sink) {
                             std::vector<char> chunk(std::min<size_t>(length, 1 << 20));
                             f->seekg(static_cast<std::streamoff>(offset));
                             if (!f->read(chunk.data(), static_cast<std::streamsize>(chunk.size())))
                               return false;  // Deleted or cut short under us.
                             return sink.write(chunk.data(), chunk.size());
                           });
}

}  // namespace

void PostBatch(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  // It writes to the disk: a mutating route.
  if (!JobsEnabled(ctx, req, res) || !Authorized(ctx, req, res)) return;
  auto stored = FindRig(ctx, req, res, req.matches[1]);
  if (!stored || !AcceptsJsonBody(req, res)) return;
  auto plan = batch::MakeBatchPlan(stored, req.body);
  if (!plan.ok()) return SendStatus(req, res, plan.status());
  if (!plan->request.dataset.randomize.background_images
           .empty()) {  // A path on the server: never the client's to name.
    return SendProblem(req, res, Problem::kInvalidRequest,
                       "/randomize/background/images: the service reads no folder a client names; "
                       "`facespace batch` takes one, "
                       "or give colours (\"random\" or [\"#rrggbb\", ...])",
                       {{"/randomize/background/images", "not taken by the service"}});
  }
  int retry_after = 0;
  auto job = ctx.jobs->Submit(std::make_shared<const batch::BatchPlan>(std::move(plan.value())),
                              req.body, &retry_after);
  if (!job.ok()) {
    Status s = job.status();
    if (s.reason == batch::kJobQueueFull)
      res.set_header("Retry-After", std::to_string(retry_after));
    else if (s.reason.empty() && s.code == StatusCode::kInternal)
      s.reason = "storage-failed";  // A full disk is storage-full by its code.
    return SendStatus(req, res, s);
  }
  res.set_header("Location", "/v1/jobs/" + job->id);
  SendJson(res, 202, JobJson(job.value()));
}

// Batch jobs need a jobs folder; derive jobs (routes/derive.cpp) are listed beside them either way.
void ListJobs(ServerState& ctx, const httplib::Request&, httplib::Response& res) {
  json list = json::array();
  for (const DeriveJobInfo& j : ctx.derives.List()) list.push_back(DeriveJobJson(j));
  if (ctx.jobs) {
    for (const batch::JobInfo& j : ctx.jobs->List()) list.push_back(JobJson(j));
  }
  SendJson(res, 200, {{"jobs", list}});
}

void GetJob(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (auto d = ctx.derives.Get(req.matches[1])) {
    res.set_header("Cache-Control", "no-cache");
    return SendJson(res, 200, DeriveJobJson(*d));
  }
  if (auto j = FindJob(ctx, req, res)) {
    res.set_header("Cache-Control", "no-cache");
    SendJson(res, 200, JobJson(*j));
  }
}

void DeleteJob(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  if (!Authorized(ctx, req, res)) return;
  const std::string id = req.matches[1];
  if (ctx.derives.Remove(id)) {
    res.status = 204;
    return;
  }
  if (!JobsEnabled(ctx, req, res)) return;
  Status s = batch::IsValidJobId(id) ? ctx.jobs->Remove(id) : NotFound("");
  if (!s.ok())
    SendProblem(req, res, Problem::kJobNotFound, "no job with id '" + id.substr(0, 80) + "'");
  else
    res.status = 204;
}

void GetJobManifest(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  SendJobFile(ctx, req, res, "manifest.jsonl");
}

void GetJobFile(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  SendJobFile(ctx, req, res, req.matches[2]);
}

void GetJobResults(ServerState& ctx, const httplib::Request& req, httplib::Response& res) {
  auto job = FindJob(ctx, req, res);
  if (!job) return;
  if (job->state != JobState::kDone) {
    SendProblem(req, res, Problem::kJobNotDone,
                "job " + job->id + " is " + Name(job->state) + " (" + std::to_string(job->done) +
                    " of " + std::to_string(job->total) +
                    " variants): its archive exists once it is done; finished files are at " +
                    "/v1/jobs/" + job->id + "/files/NAME");
    return;
  }
  // Entries: the manifest, batch.json, the sheet, then every variant in manifest order.
  const std::filesystem::path dir = ctx.jobs->Folder(job->id);
  auto names = std::make_shared<std::vector<std::string>>();
  for (const char* n : {"manifest.jsonl", "batch.json", "sheet.png"}) {
    if (std::filesystem::exists(dir / n)) names->push_back(n);
  }
  std::ifstream manifest(dir / "manifest.jsonl");
  for (std::string line; std::getline(manifest, line);) {
    for (std::string& name : ManifestFiles(json::parse(line, nullptr, false))) {
      if (std::find(names->begin(), names->end(), name) == names->end())
        names->push_back(std::move(name));
    }
  }
  auto zip = std::make_shared<ZipStream>();
  auto next = std::make_shared<size_t>(0);
  res.set_header("Content-Disposition",
                 "attachment; filename=\"facespace-batch-" + job->id + ".zip\"");
  res.set_chunked_content_provider("application/zip", [dir, names, zip, next](
                                                          size_t, httplib::DataSink& sink) {
    if (*next == names->size()) {
      const std::string end = zip->Finish();
      sink.write(end.data(), end.size());
      sink.done();
      return true;
    }
    const std::string& name = (*names)[(*next)++];
    std::ifstream f(dir / name, std::ios::binary);
    const std::string data((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    const std::string ext = name.substr(name.rfind('.') + 1);
    const std::string entry =
        zip->Entry(name, data, ext == "obj" || ext == "json" || ext == "jsonl");
    if (!f || zip->failed())
      return false;  // A file vanished (job deleted) or the archive would pass 4 GiB.
    return sink.write(entry.data(), entry.size());
  });
}

}  // namespace facespace::http
