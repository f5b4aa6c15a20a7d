#include "route_table.h"

#include <algorithm>

namespace facespace::http {

namespace {

constexpr char kRig[] = "/v1/rigs/{id}";
constexpr char kSequence[] = "/v1/rigs/{id}/sequence/*";
constexpr char kJobFiles[] = "/v1/jobs/{job}/*";

constexpr Route kRoutes[] = {
    {"GET", "/healthz", "/healthz", GetHealth},
    {"GET", "/readyz", "/readyz", GetReady},
    {"GET", "/metrics", "/metrics", GetMetrics},
    {"GET", "/openapi.json", "/openapi.json", GetOpenApi},
    {"GET", "/v1/rigs", "/v1/rigs", ListRigs},
    {"GET", "/v1/rigs/{id}", kRig, GetRig},
    {"PUT", "/v1/rigs/{id}", kRig, PutRig, true},
    {"DELETE", "/v1/rigs/{id}", kRig, DeleteRig, true},
    {"GET", "/v1/rigs/{id}/manifest", "/v1/rigs/{id}/manifest", GetManifest},
    {"PUT", "/v1/rigs/{id}/manifest", "/v1/rigs/{id}/manifest", PutManifest, true},
    {"GET", "/v1/rigs/{id}/topology", kRig, GetTopology},
    {"GET", "/v1/rigs/{id}/mesh", "/v1/rigs/{id}/mesh", GetOrPostMesh},
    {"POST", "/v1/rigs/{id}/mesh", "/v1/rigs/{id}/mesh", GetOrPostMesh},
    {"POST", "/v1/rigs/{id}/check", "/v1/rigs/{id}/check", PostCheck},
    {"GET", "/v1/rigs/{id}/render", "/v1/rigs/{id}/render", GetOrPostRender},
    {"POST", "/v1/rigs/{id}/render", "/v1/rigs/{id}/render", GetOrPostRender},
    {"POST", "/v1/rigs/{id}/sheet", "/v1/rigs/{id}/sheet", PostSheet},
    {"POST", "/v1/rigs/{id}/sequence/sample", kSequence, PostSequenceSample},
    {"POST", "/v1/rigs/{id}/sequence/stream", kSequence, PostSequenceStream},
    {"POST", "/v1/rigs/{id}/sequence/reduce", kSequence, PostSequenceReduce},
    {"POST", "/v1/rigs/{id}/speech", "/v1/rigs/{id}/speech", PostSpeech},
    {"GET", "/v1/rigs/{id}/live", "/v1/rigs/{id}/live", GetLive},
    {"GET", "/v1/voices", "/v1/voices", GetVoices},
    {"POST", "/v1/rigs/{id}/fit", "/v1/rigs/{id}/fit", PostFit},
    {"POST", "/v1/rigs/{id}/capture", "/v1/rigs/{id}/capture", PostCapture},
    {"POST", "/v1/rigs/{id}/batch", "/v1/rigs/{id}/batch", PostBatch, true},
    {"POST", "/v1/rigs/{id}/derive", "/v1/rigs/{id}/derive", PostDerive, true},
    {"GET", "/v1/jobs", "/v1/jobs", ListJobs},
    {"GET", "/v1/jobs/{job}", "/v1/jobs/{job}", GetJob},
    {"DELETE", "/v1/jobs/{job}", "/v1/jobs/{job}", DeleteJob, true},
    {"GET", "/v1/jobs/{job}/manifest.jsonl", kJobFiles, GetJobManifest},
    {"GET", "/v1/jobs/{job}/files/{name}", kJobFiles, GetJobFile},
    {"GET", "/v1/jobs/{job}/results.zip", kJobFiles, GetJobResults},
};

}  // namespace

std::span<const Route> Routes() { return kRoutes; }

namespace {

bool PathMatches(std::string_view pattern, std::string_view path) {
  size_t i = 0, j = 0;
  while (i < pattern.size()) {
    if (pattern[i] == '{') {
      const size_t close = pattern.find('}', i);
      const size_t end = std::min(path.find('/', j), path.size());
      if (close == std::string_view::npos || end == j) return false;
      i = close + 1;
      j = end;
    } else {
      if (j >= path.size() || path[j] != pattern[i]) return false;
      ++i;
      ++j;
    }
  }
  return j == path.size();
}

}  // namespace

PathRoutes MatchPath(std::string_view path) {
  for (const Route& r : kRoutes) {
    if (PathMatches(r.path, path)) return PathRoutes{kRoutes, r.path};
  }
  return PathRoutes{kRoutes, nullptr};
}

const Route* PathRoutes::Find(std::string_view method) const {
  if (!path) return nullptr;
  for (const Route& r : all) {
    if (std::string_view(r.path) == path && method == r.method) return &r;
  }
  return nullptr;
}

bool PathRoutes::Allows(std::string_view method) const {
  return Find(method) || (method == "HEAD" && Find("GET"));
}

std::string PathRoutes::Allow() const {
  std::string allow;
  if (!path) return allow;
  for (const char* method : {"GET", "HEAD", "POST", "PUT", "DELETE", "OPTIONS"}) {
    if (!Allows(method) && std::string_view(method) != "OPTIONS") continue;
    allow += std::string(allow.empty() ? "" : ", ") + method;
  }
  return allow;
}

std::string PathPattern(std::string_view path) {
  std::string out;
  for (size_t i = 0; i < path.size(); ++i) {
    const char c = path[i];
    if (c == '{') {
      i = path.find('}', i);
      out += "([^/]+)";
    } else if (c == '.') {
      out += "\\.";
    } else {
      out += c;
    }
  }
  return out;
}

std::vector<std::string> MetricLabels() {
  std::vector<std::string> labels;
  for (const Route& r : kRoutes) {
    if (std::find(labels.begin(), labels.end(), r.metric) == labels.end())
      labels.push_back(r.metric);
  }
  return labels;
}

}  // namespace facespace::http
