// The route handlers, one file per resource; each is a short function from the request to the
// evaluator to the response. The table in http/route_table.cpp binds them to paths and methods.
#pragma once

#include <httplib.h>

#include "../http/context.h"

namespace facespace::http {

using Handler = void (*)(ServerState& ctx, const httplib::Request& req, httplib::Response& res);

// routes/service.cpp
void GetHealth(ServerState&, const httplib::Request&, httplib::Response&);
void GetReady(ServerState&, const httplib::Request&, httplib::Response&);
// The Prometheus text of /metrics.
std::string MetricsText(ServerState& ctx);
void GetMetrics(ServerState&, const httplib::Request&, httplib::Response&);
void GetOpenApi(ServerState&, const httplib::Request&, httplib::Response&);
// routes/rigs.cpp
void ListRigs(ServerState&, const httplib::Request&, httplib::Response&);
void GetRig(ServerState&, const httplib::Request&, httplib::Response&);
void PutRig(ServerState&, const httplib::Request&, httplib::Response&);
void DeleteRig(ServerState&, const httplib::Request&, httplib::Response&);
void GetManifest(ServerState&, const httplib::Request&, httplib::Response&);
void PutManifest(ServerState&, const httplib::Request&, httplib::Response&);
void GetTopology(ServerState&, const httplib::Request&, httplib::Response&);
// Encodes what does not change of a rig (its description, its topology) into the response cache and
// bakes its occlusion, so that a client's first request for them, or first picture, does not wait
// (uka's topology: 70 ms in brotli; her occlusion: about 0.25 s).
void WarmRig(ServerState& ctx, const std::shared_ptr<const evaluator::StoredRig>& stored);
// routes/mesh.cpp
void GetOrPostMesh(ServerState&, const httplib::Request&, httplib::Response&);
void PostCheck(ServerState&, const httplib::Request&, httplib::Response&);
void PostFit(ServerState&, const httplib::Request&, httplib::Response&);
// routes/render.cpp
void GetOrPostRender(ServerState&, const httplib::Request&, httplib::Response&);
void PostSheet(ServerState&, const httplib::Request&, httplib::Response&);
// routes/sequence.cpp
void PostSequenceSample(ServerState&, const httplib::Request&, httplib::Response&);
void PostSequenceStream(ServerState&, const httplib::Request&, httplib::Response&);
void PostSequenceReduce(ServerState&, const httplib::Request&, httplib::Response&);
// False, with a 422 too-many-frames sent at /fps, for more frames than --max-frames: "the WHAT
// would be N frames ...", "at most M frames over OVER duration".
bool WithinFrameLimit(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                      size_t frames, const char* what, const char* over);
// A sequence's frames streamed as the client reads them (ndjson, weights or f32); 422 for another
// format or more frames than --max-frames.
void SendSequenceStream(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                        std::shared_ptr<const evaluator::StoredRig> stored,
                        std::shared_ptr<const Sequence> seq, float fps,
                        evaluator::FrameFormat format, const BlendOptions& options);
// routes/speech.cpp
void PostSpeech(ServerState&, const httplib::Request&, httplib::Response&);
void GetVoices(ServerState&, const httplib::Request&, httplib::Response&);
// routes/live.cpp: the WebSocket of one face.
void GetLive(ServerState&, const httplib::Request&, httplib::Response&);
// routes/capture.cpp
void PostCapture(ServerState&, const httplib::Request&, httplib::Response&);
// routes/derive.cpp
void PostDerive(ServerState&, const httplib::Request&, httplib::Response&);
// A derive job as GET /v1/jobs/{id} shows it.
nlohmann::json DeriveJobJson(const DeriveJobInfo& j);
// routes/batch.cpp
void PostBatch(ServerState&, const httplib::Request&, httplib::Response&);
void ListJobs(ServerState&, const httplib::Request&, httplib::Response&);
void GetJob(ServerState&, const httplib::Request&, httplib::Response&);
void DeleteJob(ServerState&, const httplib::Request&, httplib::Response&);
void GetJobManifest(ServerState&, const httplib::Request&, httplib::Response&);
void GetJobFile(ServerState&, const httplib::Request&, httplib::Response&);
void GetJobResults(ServerState&, const httplib::Request&, httplib::Response&);

// Query parameters the mesh and render routes share (routes/mesh.cpp): w.NAME, c.NAME, mode,
// normals, strict and the skeleton settings. False when `key` is none of them.
bool MeshQueryParam(const std::string& key, const std::string& value, evaluator::MeshRequest& r,
                    std::vector<FieldError>& errors);

// "unknown parameter" with the closest known one of the mesh (or render) query.
std::string UnknownParameter(const std::string& key, bool render);

// True when the query gives `it`'s parameter more than once (the error is added at its first).
bool Repeated(const httplib::Request& req, httplib::Params::const_iterator it,
              std::vector<FieldError>& errors);
// Ends query parsing: the skeleton settings' cross-checks; false with a 422 sent for any error.
bool FinishQuery(const httplib::Request& req, httplib::Response& res, evaluator::MeshRequest& r,
                 std::vector<FieldError>& errors);

}  // namespace facespace::http
