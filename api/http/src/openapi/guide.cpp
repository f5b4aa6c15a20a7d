// Each operation's tag, description and example (its parameters and body), which document.cpp puts
// into the document. The examples are the requests tests/integration/openapi_client_test.mjs sends
// to the real server, so every example here is one the server answers as its test says.
#include <cstdio>
#include <cstdlib>
#include <map>

#include "openapi.h"

namespace facespace::http::openapi {

namespace {

struct Guide {
  const char* operation;
  const char* tag;
  const char* description;
  const char* parameters;  // JSON object: parameter name -> example value; "" none.
  const char* body;        // JSON text of the example body; "" none (or not JSON).
};

constexpr char kFacecap[] = R"({"id": "facecap"})";

// In the order of the document's tags.
constexpr Guide kGuides[] = {
    {"healthz", "service", "Answers 200 while the process serves; it loads nothing.", "", ""},
    {"readyz", "service", "200 once every rig is loaded and its encodings kept; 503 while warming.",
     "", ""},
    {"metrics", "service", "Requests, latencies, costs and refusals in Prometheus' text format.",
     "", ""},
    {"openapi", "service", "This document, with this server's limits in info.x-facespace-limits.",
     "", ""},
    {"listVoices", "service", "The espeak-ng voices the speech route takes, and the default.", "",
     ""},
    {"listRigs", "rigs",
     "Every rig of the store: id, name, counts, version (its ETag) and the credit its license asks "
     "for.",
     "", ""},
    {"getRig", "rigs",
     "A rig's shapes (names, groups, ranges, aliases), primitives, skeleton, clips, controls and "
     "expressions.",
     kFacecap, ""},
    {"putRig", "rigs",
     "Stores a rig after validating it fully; the old one serves until the new one is in place.",
     R"({"id": "client-upload"})", ""},
    {"deleteRig", "rigs", "Removes a rig and its manifest.", R"({"id": "client-upload"})", ""},
    {"getManifest", "rigs",
     "What the rig file does not say: names, groups, ranges, controls, expressions, regions, "
     "landmarks.",
     kFacecap, ""},
    {"putManifest", "rigs",
     "Replaces a rig's manifest; the rig is loaded again with it, or the manifest is refused "
     "(422).",
     R"({"id": "client-upload"})",
     R"({"name": "From the client", "shapes": {"jawOpen": {"max": 2}}})"},
    {"getTopology", "rigs",
     "What stays the same under any weights: each primitive's triangles and colour, at a level of "
     "detail.",
     R"({"id": "facecap", "lod": 1})", ""},
    {"getLive", "live",
     "A WebSocket: weights in, meshes or pictures out at display rate. A plain HTTP client is told "
     "426.",
     kFacecap, ""},
    {"getMesh", "meshes",
     "The blended mesh of a point given in the query (w[NAME]=VALUE), cacheable by its ETag.",
     R"({"id": "facecap", "w": {"jawOpen": 0.5}, "format": "json"})", ""},
    {"postMesh", "meshes",
     "The blended mesh of a point, posed; warnings when the point leaves the authored space.",
     kFacecap, R"({"weights": {"jawOpen": 1.5}, "format": "json"})"},
    {"checkWeights", "meshes", "A point's sum and warnings, without the mesh.", kFacecap,
     R"({"weights": {"jawOpen": 0.4, "mouthSmile_L": 0.2}})"},
    {"fit", "meshes",
     "The weights (least squares, in range) whose blend is nearest a target mesh, with the "
     "residual. The "
     "example's target is the mesh route's JSON of the same rig.",
     kFacecap, R"({"target": {"primitives": []}, "bounded": true})"},
    {"capture", "sequences",
     "A face tracker's landmarks over frames (a recorded video's) as the rig's weights, the "
     "keys of a sequence; the frames are 468 or 478 points each, so no example is written here.",
     kFacecap, ""},
    {"getRender", "images", "A picture of a point given in the query.",
     R"({"id": "facecap", "w": {"jawOpen": 1}, "width": 64, "height": 64, "frame": "shapes", "yaw": 20})",
     ""},
    {"postRender", "images", "A picture of a point, posed, from a camera, in a studio's light.",
     kFacecap, R"({"weights": {"jawOpen": 1}, "width": 64, "height": 64, "format": "webp"})"},
    {"postSheet", "images", "Several points drawn side by side, each labelled: a contact sheet.",
     kFacecap,
     R"({"cells": [{}, {"weights": {"jawOpen": 1}, "label": "open"}], "width": 32, "height": 32})"},
    {"sampleSequence", "sequences",
     "Keys (or a clip) sampled at times: each frame's weights and mesh.", kFacecap,
     R"({"keys": [{"time": 0}, {"time": 1, "shape": "jawOpen"}], "times": [0.5]})"},
    {"streamSequence", "sequences", "Frames streamed as they are computed, at fps.", kFacecap,
     R"({"keys": [{"time": 0}, {"time": 0.1, "shape": "jawOpen"}], "fps": 1000, "format": "ndjson"})"},
    {"reduceSequence", "sequences",
     "The fewest keys whose sequence stays within tolerance of the one given.", kFacecap,
     R"({"keys": [{"time": 0}, {"time": 0.5, "weights": {"jawOpen": 0.5}}, {"time": 1, "shape": "jawOpen"}], "tolerance": 0.001})"},
    {"speak", "sequences",
     "Lip sync: phonemes, visemes and keys on the rig from text or a recording.", kFacecap,
     R"({"text": "Hello there.", "format": "json"})"},
    {"startBatch", "batch",
     "A job writing many variants as files; 202 with the job, which runs in the background.",
     kFacecap, R"({"sample": {"method": "uniform", "count": 3, "seed": 2}, "format": "obj"})"},
    {"startDerive", "batch",
     "A job deriving shapes onto the rig from another (default FaceCap's ARKit 52 and the "
     "visemes); 202 with the job, whose result names the rig written.",
     kFacecap, R"({"as": "facecap-derived", "shapes": ["visemes"]})"},
    {"listJobs", "batch", "Every job, newest first.", "", ""},
    {"getJob", "batch", "A job's state, progress, rate and estimated time left.", "", ""},
    {"deleteJob", "batch", "Cancels a job and deletes its files.", "", ""},
    {"getJobManifest", "batch", "One JSON line per file written, in order.", "", ""},
    {"getJobFile", "batch", "One file of a job.", "", ""},
    {"getJobResults", "batch", "Every file of a finished job as one zip, streamed.", "", ""},
};

constexpr const char* kTags[][2] = {
    {"service", "Health, metrics, this document"},
    {"rigs", "Rigs and their manifests: upload, read, delete"},
    {"meshes", "Points of face space as meshes, checked and fitted"},
    {"images", "Points of face space drawn"},
    {"sequences", "Points over time: keys, clips, speech"},
    {"batch", "Work in the background: many variants as files, shapes derived onto a head"},
    {"live", "A socket at display rate"},
};

}  // namespace

json Tags() {
  json tags = json::array();
  for (const auto& [name, description] : kTags)
    tags.push_back({{"name", name}, {"description", description}});
  return tags;
}

void AddGuides(json& paths) {
  for (auto& [path, item] : paths.items()) {
    for (auto& [method, op] : item.items()) {
      const std::string id = op.value("operationId", "");
      const Guide* guide = nullptr;
      for (const Guide& g : kGuides) guide = id == g.operation ? &g : guide;
      if (!guide) {
        std::fprintf(stderr, "facespace: the OpenAPI document has no guide for %s\n", id.c_str());
        std::abort();
      }
      op["tags"] = json::array({guide->tag});
      op["description"] = guide->description;
      const json parameters = *guide->parameters ? json::parse(guide->parameters) : json::object();
      if (op.contains("parameters")) {
        for (json& p : op["parameters"]) {
          if (parameters.contains(p["name"].get<std::string>()))
            p["example"] = parameters[p["name"].get<std::string>()];
        }
      }
      if (*guide->body) {
        op["requestBody"]["content"]["application/json"]["examples"] = {
            {"example",
             {{"summary", "What the service's tests send"}, {"value", json::parse(guide->body)}}}};
      }
    }
  }
}

const std::vector<QueryParameter>& QueryParameters(std::string_view method, std::string_view path) {
  static const std::map<std::string, std::vector<QueryParameter>, std::less<>> declared = [] {
    std::map<std::string, std::vector<QueryParameter>, std::less<>> out;
    const json operations = Operations();
    for (const auto& [route, item] : operations.items()) {
      for (const auto& [verb, op] : item.items()) {
        if (verb == "parameters") continue;
        std::string key = verb;
        for (char& c : key) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
        std::vector<QueryParameter>& names = out[key + " " + route];
        for (const json* list : {&op, &item}) {
          for (const json& p : list->value("parameters", json::array())) {
            if (p.value("in", "") == "query")
              names.push_back({p["name"].get<std::string>(), p.value("style", "") == "deepObject"});
          }
        }
      }
    }
    return out;
  }();
  static const std::vector<QueryParameter> none;
  const auto it = declared.find(std::string(method) + " " + std::string(path));
  return it == declared.end() ? none : it->second;
}

}  // namespace facespace::http::openapi
