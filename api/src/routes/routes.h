// The route handlers, one file per resource; each is a short function from the request to the
// pipeline to the response. The table in http/route_table.cpp binds them to paths and methods.
#pragma once

#include <httplib.h>

#include "../http/context.h"

namespace facespace::api::http {

using Handler = void (*)(Context& ctx, const httplib::Request& req, httplib::Response& res);

// routes/service.cpp
void GetHealth(Context&, const httplib::Request&, httplib::Response&);
void GetReady(Context&, const httplib::Request&, httplib::Response&);
// The Prometheus text of /metrics.
std::string MetricsText(Context& ctx);
void GetMetrics(Context&, const httplib::Request&, httplib::Response&);
void GetOpenApi(Context&, const httplib::Request&, httplib::Response&);
// routes/rigs.cpp
void ListRigs(Context&, const httplib::Request&, httplib::Response&);
void GetRig(Context&, const httplib::Request&, httplib::Response&);
void PutRig(Context&, const httplib::Request&, httplib::Response&);
void DeleteRig(Context&, const httplib::Request&, httplib::Response&);
void GetManifest(Context&, const httplib::Request&, httplib::Response&);
void PutManifest(Context&, const httplib::Request&, httplib::Response&);
void GetTopology(Context&, const httplib::Request&, httplib::Response&);
// routes/mesh.cpp
void GetOrPostMesh(Context&, const httplib::Request&, httplib::Response&);
void PostCheck(Context&, const httplib::Request&, httplib::Response&);
void PostFit(Context&, const httplib::Request&, httplib::Response&);
// routes/render.cpp
void GetOrPostRender(Context&, const httplib::Request&, httplib::Response&);
void PostSheet(Context&, const httplib::Request&, httplib::Response&);
// routes/sequence.cpp
void PostSequenceSample(Context&, const httplib::Request&, httplib::Response&);
void PostSequenceStream(Context&, const httplib::Request&, httplib::Response&);
void PostSequenceReduce(Context&, const httplib::Request&, httplib::Response&);
// routes/jobs.cpp
void PostBatch(Context&, const httplib::Request&, httplib::Response&);
void ListJobs(Context&, const httplib::Request&, httplib::Response&);
void GetJob(Context&, const httplib::Request&, httplib::Response&);
void DeleteJob(Context&, const httplib::Request&, httplib::Response&);
void GetJobManifest(Context&, const httplib::Request&, httplib::Response&);
void GetJobFile(Context&, const httplib::Request&, httplib::Response&);
void GetJobResults(Context&, const httplib::Request&, httplib::Response&);

// Query parameters the mesh and render routes share (routes/mesh.cpp): w.NAME, c.NAME, mode,
// normals, strict and the skeleton settings. False when `key` is none of them.
bool MeshQueryParam(const std::string& key, const std::string& value, MeshRequest& r, std::vector<FieldError>& errors);

// "unknown parameter" with the closest known one of the mesh (or render) query.
std::string UnknownParameter(const std::string& key, bool render);

// True when the query gives `it`'s parameter more than once (the error is added at its first).
bool Repeated(const httplib::Request& req, httplib::Params::const_iterator it, std::vector<FieldError>& errors);
// Ends query parsing: the skeleton settings' cross-checks; false with a 422 sent for any error.
bool FinishQuery(const httplib::Request& req, httplib::Response& res, MeshRequest& r, std::vector<FieldError>& errors);

}  // namespace facespace::api::http
