// The document's operations, by path, in groups of routes; document.cpp keeps those the route table
// lists (and stops the server if one is missing).
#include <cstdio>
#include <cstdlib>

#include "openapi.h"
#include "../http/query_params.h"
#include "facespace/engine/speech.h"
#include "facespace/evaluator/members.h"

namespace facespace::api::openapi {

json Problem(const std::string& description) {
  return {{"description", description},
          {"content", {{"application/problem+json", {{"schema", {{"$ref", "#/components/schemas/Problem"}}}}}}}};
}

namespace {

using facespace::api::Body;
using facespace::api::Kind;
using facespace::api::Member;
using facespace::api::FindMember;
using facespace::api::Members;

// The headers every answer of the mesh and image routes carries.
json CommonHeaders() {
  return {{"Cache-Control", {{"description", "GET: public, no-cache (revalidate with the ETag); POST: no-store"}, {"schema", {{"type", "string"}}}}},
          {"Server-Timing", {{"description", "Where the time went: blend, draw and encode, in ms (e.g. blend;dur=0.08, draw;dur=21.7, encode;dur=0.34)"},
                             {"schema", {{"type", "string"}}}}},
          {"Vary", {{"description", "Accept (and Accept-Encoding where bodies are compressed)"}, {"schema", {{"type", "string"}}}}}};
}

json MeshResponses() {
  json headers = {
      {"Facespace-Weight-Sum", {{"description", "Sum of the weights"}, {"schema", {{"type", "string"}}}}},
      {"Facespace-Warnings",
       {{"description", "Structured-field list (RFC 9651) of warnings, e.g. extrapolation;value=1.7"},
        {"schema", {{"type", "string"}}}}},
      {"ETag", {{"description", "Strong validator of rig version + canonical request"}, {"schema", {{"type", "string"}}}}}};
  headers.update(CommonHeaders());
  return {{"200",
           {{"description", "The blended mesh (warnings, if any, in headers and in the body where the format has room)"},
            {"headers", headers},
            {"content",
             {{"application/json", {{"schema", {{"$ref", "#/components/schemas/MeshJson"}}}}},
              {"model/gltf-binary", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
              {"model/obj", {{"schema", {{"type", "string"}}}}},
              {"application/octet-stream",
               {{"schema", {{"type", "string"}, {"contentEncoding", "binary"},
                            {"description", "float32 LE: world-space positions of every primitive, then normals"}}}}}}}}},
          {"304", {{"description", "Not modified (If-None-Match matched the ETag)"}}},
          {"400", Problem("Malformed JSON")},
          {"404", Problem("Unknown rig")},
          {"406", Problem("Unsupported Accept")},
          {"413", Problem("Body over the limit")},
          {"415", Problem("Unsupported Content-Type")},
          {"422", Problem("Invalid weights or options; or warnings with strict=true")}};
}

json RenderResponses() {
  json headers = {
      {"Facespace-Weight-Sum", {{"description", "Sum of the weights (sheet: the largest over its cells)"}, {"schema", {{"type", "string"}}}}},
      {"Facespace-Warnings", {{"description", "Structured-field list (RFC 9651) of warnings"}, {"schema", {{"type", "string"}}}}},
      {"ETag", {{"description", "Strong validator"}, {"schema", {{"type", "string"}}}}}};
  headers.update(CommonHeaders());
  json bin = {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}};
  return {{"200", {{"description", "The image"}, {"headers", headers},
                   {"content", {{"image/png", bin}, {"image/jpeg", bin}, {"image/x-exr", bin}, {"image/tiff", bin}, {"image/webp", bin}}}}},
          {"304", {{"description", "Not modified"}}},
          {"400", Problem("Malformed JSON")},
          {"404", Problem("Unknown rig")},
          {"406", Problem("Unsupported Accept")},
          {"413", Problem("A body over the limit, or a render whose working memory is over the render budget")},
          {"415", Problem("Unsupported Content-Type")},
          {"422", Problem("Invalid weights or settings, image over the size limit, too many cells; or warnings with strict=true")},
          {"503", Problem("The renders in flight use the render memory; see Retry-After")}};
}

json IdParam() {
  return {{"name", "id"}, {"in", "path"}, {"required", true},
          {"schema", {{"type", "string"}, {"pattern", "^[a-z0-9][a-z0-9_-]{0,63}$"}}}};
}

json JobParam() {
  return {{"name", "job"}, {"in", "path"}, {"required", true}, {"schema", {{"type", "string"}, {"pattern", "^[0-9a-f]{32}$"}}}};
}

// w[NAME]=VALUE or c[NAME]=VALUE: OpenAPI's deepObject style, which generated clients send; the
// server also reads the shorter w.NAME=VALUE of curl lines.
json MapParam(const char* name, const char* description) {
  return {{"name", name}, {"in", "query"}, {"style", "deepObject"}, {"explode", true}, {"description", description},
          {"schema", {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}}};
}

// One query parameter of GET mesh or render, by the name the route reads (http/query_params.h): the
// body's member of that name (the camera's, flat: yaw=20), from the member tables. Three read the query
// their own way: camera (the body's object as JSON), frame (a time in MMD frames, or the camera's
// framing) and gaze (short forms); other objects and arrays are the body's as JSON.
json QueryParam(std::string_view name, bool render) {
  if (name == "camera") {  // JSON in the query string: OpenAPI's content form, typed as the body's camera.
    return {{"name", "camera"}, {"in", "query"}, {"description", "The body's camera object as JSON (yaw, pitch, zoom, distance, fov, frame, eye, target, up)"},
            {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Camera"}}}}}}}};
  }
  const Member* m = FindMember(render ? Body::kRender : Body::kMesh, name);
  if (!m) m = FindMember(Body::kCamera, name);
  if (!m) {
    std::fprintf(stderr, "facespace: the OpenAPI document cannot describe the query parameter '%.*s'\n", static_cast<int>(name.size()), name.data());
    std::abort();
  }
  json schema = MemberSchema(*m);
  std::string description = schema.value("description", "");
  schema.erase("description");
  if (name == "frame" && render) {
    schema = {{"oneOf", json::array({json{{"type", "number"}}, json{{"type", "string"}, {"pattern", "^(all|shapes|auto|joint:.+)$"}}})}};
    description = "A time in MMD frames (30 a second), or the camera's framing: all, shapes, joint:NAME or auto (the default)";
  } else if (name == "gaze") {
    schema = {{"type", "string"}};
    description = "Where the eyes look: YAW,PITCH (degrees; yaw > 0 to the character's left, pitch > 0 up), X,Y,Z (a point of "
                  "the rig's world), or the body's gaze object as JSON";
  } else if (m->kind == Kind::kSchema) {
    schema = {{"type", "string"}};
    description += " (as in the body: a name or an index, a colour, or JSON)";
  }
  return {{"name", std::string(name)}, {"in", "query"}, {"schema", schema}, {"description", description}};
}

// The parameters of GET mesh or render: the path's id, the weights and controls, and each name
// of the route's list.
json QueryParams(bool render) {
  json params = json::array({IdParam(), MapParam("w", "Weights as w[NAME]=VALUE (or w.NAME=VALUE) by shape name, alias or index; "
                                                       "shapes not named are 0"),
                             MapParam("c", "Control values as c[NAME]=VALUE (or c.NAME=VALUE), for rigs with controls "
                                           "(e.g. c[nose/nose-trans-down|up]=-0.4)"),
                             MapParam("e", "Expressions as e[NAME]=VALUE (or e.NAME=VALUE): VRM's presets (happy, aa, blink, ...) or the rig's own")});
  for (std::string_view name : render ? std::span<const std::string_view>(http::kRenderQuery) : http::kMeshQuery) {
    params.push_back(QueryParam(name, render));
  }
  return params;
}

// The speech route's settings as query parameters, read with an audio/wav body (a JSON body takes
// them as members): the speech table's members but text and audio, objects as JSON text.
json SpeechQuery() {
  json params = json::array({IdParam()});
  for (const Member& m : Members(Body::kSpeech)) {
    if (m.name == "text" || m.name == "audio") continue;
    json schema = m.kind == Kind::kNumber ? json{{"type", "number"}}
                  : m.kind == Kind::kInteger ? json{{"type", "integer"}}
                  : m.kind == Kind::kBoolean ? json{{"type", "boolean"}} : json{{"type", "string"}};
    params.push_back({{"name", std::string(m.name)}, {"in", "query"}, {"schema", schema},
                      {"description", "With an audio/wav body: " + std::string(m.doc) + (m.kind == Kind::kSchema ? " (as JSON)" : "")}});
  }
  return params;
}

// What a job's files are: a variant's mesh or image, a labelled sample's EXR and PNG, a tar shard, the
// manifest's lines, batch.json (routes/batch.cpp, FileType).
json JobFileContent() {
  const json bin = {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}};
  const json text = {{"schema", {{"type", "string"}}}};
  return {{"model/gltf-binary", bin}, {"model/obj", text}, {"application/json", {{"schema", {{"type", "object"}, {"additionalProperties", true}}}}},
          {"application/octet-stream", bin}, {"image/png", bin}, {"image/jpeg", bin}, {"image/x-exr", bin}, {"image/tiff", bin},
          {"image/webp", bin}, {"application/x-tar", bin}, {"application/x-ndjson", text}};
}

json OkJson() { return {{"description", "OK"}, {"content", {{"application/json", {{"schema", {{"type", "object"}, {"additionalProperties", true}}}}}}}}; }

// A 200 whose JSON body is the component `name`.
json JsonOk(const char* name, const char* description = "OK") {
  return json{{"description", description}, {"content", {{"application/json", {{"schema", {{"$ref", std::string("#/components/schemas/") + name}}}}}}}};
}

json Auth() { return json::array({{{"bearer", json::array()}}}); }

// The service itself: health, readiness, metrics, this document, the voices.
json ServiceOperations() {
  return {
      {"/healthz", {{"get", {{"summary", "Liveness"}, {"operationId", "healthz"}, {"responses", {{"200", JsonOk("Health")}}}}}}},
      {"/readyz",
       {{"get", {{"summary", "Readiness: the rigs loaded and encoded (503 while warming)"}, {"operationId", "readyz"},
                 {"responses", {{"200", JsonOk("Health")}, {"503", JsonOk("Health", "Warming up")}}}}}}},
      {"/metrics",
       {{"get", {{"summary", "Prometheus metrics"}, {"operationId", "metrics"},
                 {"responses", {{"200", {{"description", "Prometheus text"}, {"content", {{"text/plain", {{"schema", {{"type", "string"}}}}}}}}}}}}}}},
      {"/openapi.json", {{"get", {{"summary", "This document"}, {"operationId", "openapi"}, {"responses", {{"200", OkJson()}}}}}}},
      {"/v1/voices",
       {{"get", {{"summary", "The voices text can be spoken with (espeak-ng's)"},
                 {"operationId", "listVoices"},
                 {"responses", {{"200", JsonOk("Voices")}}}}}}}};
}

// Rigs: list, read, upload, delete; manifests; topology.
json RigOperations() {
  return {
      {"/v1/rigs", {{"get", {{"summary", "List rigs"}, {"operationId", "listRigs"}, {"responses", {{"200", JsonOk("RigList")}}}}}}},
      {"/v1/rigs/{id}",
       {{"parameters", json::array({IdParam()})},
        {"get", {{"summary", "A rig: shapes, bounding box, primitives, skeleton"}, {"operationId", "getRig"},
                 {"responses", {{"200", JsonOk("Rig")}, {"404", Problem("Unknown rig")}}}}},
        {"put", {{"summary", "Upload or replace a rig (validated fully, stored atomically)"}, {"operationId", "putRig"},
                 {"security", Auth()},
                 {"parameters", json::array({IdParam(), {{"name", "filename"}, {"in", "query"}, {"schema", {{"type", "string"}}},
                                                         {"description", "A plain upload's file name (else Content-Disposition's), "
                                                                         "whose extension says its format"}}})},
                 {"requestBody", {{"required", true},
                                  {"description", "glb, glTF with embedded buffers, COLLADA, or (as application/octet-stream with a "
                                                   "file name in Content-Disposition or ?filename=, else told by its magic) FBX, .dae, .glb, .gltf"},
                                  {"content", {{"model/gltf-binary", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                               {"model/gltf+json", {{"schema", {{"type", "object"}, {"additionalProperties", true}, {"description", "glTF 2.0 JSON, buffers embedded"}}}}},
                                               {"model/vnd.collada+xml", {{"schema", {{"type", "string"}}}}},
                                               {"application/octet-stream", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                               {"multipart/form-data",
                                                {{"schema", {{"type", "object"}, {"required", {"rig"}},
                                                             {"properties", {{"rig", {{"type", "string"}, {"contentEncoding", "binary"},
                                                                                      {"description", "The rig file (its part's file name or type says the format)"}}},
                                                                             {"manifest", {{"$ref", "#/components/schemas/Manifest"}}}}}}},
                                                 {"encoding", {{"manifest", {{"contentType", "application/json"}}}}}}}}}}},
                 {"responses", {{"200", JsonOk("RigSummary", "Replaced")}, {"201", JsonOk("RigSummary", "Created")}, {"401", Problem("No API key")}, {"403", Problem("Wrong API key")},
                                {"413", Problem("Body over the limit")}, {"415", Problem("Not a rig media type (or an octet stream of no known rig format)")},
                                {"409", Problem("A bundled rig: read-only")},
                                {"422", Problem("Invalid rig, manifest or id")}, {"500", Problem("The store could not write the rig")},
                                {"507", Problem("The store's disk is full: nothing was written, the old rig is kept")}}}}},
        {"delete", {{"summary", "Delete a rig"}, {"operationId", "deleteRig"}, {"security", Auth()},
                    {"responses", {{"204", {{"description", "Deleted"}}}, {"401", Problem("No API key")},
                                   {"403", Problem("Wrong API key")}, {"404", Problem("Unknown rig")},
                                   {"409", Problem("A bundled rig: read-only")}}}}}}},
      {"/v1/rigs/{id}/manifest",
       {{"parameters", json::array({IdParam()})},
        {"get", {{"summary", "A rig's manifest: name, credit, shape groups, ranges, partners, controls, in-betweens (README \"Manifest\")"},
                 {"operationId", "getManifest"},
                 {"responses", {{"200", JsonOk("Manifest")}, {"404", Problem("Unknown rig")}}}}},
        {"put", {{"summary", "Replace an uploaded rig's manifest (validated against the rig first; the rig file unchanged)"},
                 {"operationId", "putManifest"}, {"security", Auth()},
                 {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Manifest"}}}}}}}}},
                 {"responses", {{"200", JsonOk("RigSummary")}, {"400", Problem("Malformed JSON")}, {"401", Problem("No API key")},
                                {"403", Problem("Wrong API key")}, {"404", Problem("Unknown rig")},
                                {"409", Problem("A bundled rig: read-only")}, {"415", Problem("Not application/json")},
                                {"422", Problem("The manifest does not apply to the rig (names the member)")},
                                {"507", Problem("The store's disk is full: nothing was written")}}}}}}},
      {"/v1/rigs/{id}/topology",
       {{"get", {{"summary", "Triangle lists per primitive (for clients that draw the f32 mesh), encoded once per rig version (br or gzip as accepted)"},
                 {"operationId", "getTopology"},
                 {"parameters", json::array({IdParam(), {{"name", "lod"}, {"in", "query"}, {"schema", {{"type", "integer"}, {"minimum", 0}, {"maximum", 4}}}},
                                             {{"name", "format"}, {"in", "query"},
                                              {"description", "json, or u32: every primitive's indices as little-endian uint32, one after the other"},
                                              {"schema", {{"type", "string"}, {"enum", {"json", "u32"}}, {"default", "json"}}}}})},
                 {"responses", {{"200", {{"description", "The triangle lists (JSON), or the indices alone (u32)"},
                                         {"headers", {{"Facespace-Index-Counts", {{"description", "u32: each primitive's index count, comma-separated"}, {"schema", {{"type", "string"}}}}},
                                                      {"Facespace-Vertex-Counts", {{"description", "u32: each primitive's vertex count"}, {"schema", {{"type", "string"}}}}}}},
                                         {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Topology"}}}}},
                                                      {"application/octet-stream", {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}},
                                {"304", {{"description", "Not modified (If-None-Match)"}}},
                                {"404", Problem("Unknown rig")}, {"422", Problem("Bad lod or format")}}}}}}},
      {"/v1/rigs/{id}/live",
       {{"get", {{"summary", "One face live over a WebSocket (RFC 6455): text messages set the state ({\"weights\": {...}}, \"expressions\", "
                             "\"gaze\", \"pose\", \"controls\", \"id\"), merged as the mesh route reads them; each change is answered, at most 60 "
                             "times a second (newest state wins), by a binary message: 16 bytes (\"mesh\", frame number, the newest id applied, "
                             "0; little-endian uint32) then the bytes of GET /mesh?format=f32 for that point. Events are text: ready, warnings, "
                             "error (the session goes on). Closes: 1002 broken framing, 1003 binary without listen, 1007 text not UTF-8, "
                             "1008 a flood, a client that does not read, or the session's CPU spent, 1009 a message over 64 KiB, 1001 the server stops "
                             "or the session's time is up."},
                 {"operationId", "getLive"},
                 {"parameters", json::array({IdParam()})},
                 // The socket's messages, declared as the bodies are (facespace/evaluator/members.h).
                 {"x-facespace-messages", {{"client", {{"text", {{"$ref", "#/components/schemas/LiveMessage"}}},
                                                       {"binary", "16 kHz 16-bit mono PCM, after {\"listen\": ...}"}}}}},
                 {"responses", {{"101", {{"description", "Switched to the WebSocket protocol; Facespace-Cost states a second of frames"}}},
                                {"400", Problem("Bad Sec-WebSocket-Key")}, {"404", Problem("Unknown rig")},
                                {"426", Problem("Not a WebSocket upgrade, or not version 13")},
                                {"503", Problem("As many live sessions as the server takes, in all or from this address")}}}}}}}};
}

// A point of face space: its mesh, render, contact sheet, check, and the fit that finds one.
json PointOperations() {
  return {
      {"/v1/rigs/{id}/mesh",
       {{"get", {{"summary", "Blended mesh from query weights (w[NAME]=VALUE or w.NAME=VALUE)"}, {"operationId", "getMesh"},
                 {"parameters", QueryParams(false)}, {"responses", MeshResponses()}}},
        {"post", {{"summary", "Blended mesh"}, {"operationId", "postMesh"}, {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/MeshRequest"}}}}}}}}},
                  {"responses", MeshResponses()}}}}},
      {"/v1/rigs/{id}/render",
       {{"get", {{"summary", "Offscreen render from query settings (w[NAME]=VALUE, width, height, view, yaw, pitch, zoom, ...)"},
                 {"operationId", "getRender"},
                 {"parameters", QueryParams(true)},
                 {"responses", RenderResponses()}}},
        {"post", {{"summary", "Offscreen render"}, {"operationId", "postRender"}, {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/RenderRequest"}}}}}}}}},
                  {"responses", RenderResponses()}}}}},
      {"/v1/rigs/{id}/sheet",
       {{"post", {{"summary", "Contact sheet: several weight vectors rendered into one labelled grid"}, {"operationId", "postSheet"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SheetRequest"}}}}}}}}},
                  {"responses", RenderResponses()}}}}},
      {"/v1/rigs/{id}/check",
       {{"post", {{"summary", "Validate weights only: sum and warnings"}, {"operationId", "checkWeights"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/MeshRequest"}}}}}}}}},
                  {"responses", {{"200", JsonOk("Check")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid weights")}}}}}}},
      {"/v1/rigs/{id}/fit",
       {{"post", {{"summary", "Weights that best reproduce a target mesh (least squares), with residual and warnings"},
                  {"operationId", "fit"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/FitRequest"}}}}}}}}},
                  {"responses", {{"200", JsonOk("Fit")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("A target that does not match the rig")}}}}}}}};
}

// Sequences and speech: sampled, streamed, reduced, spoken.
json SequenceOperations() {
  return {
      {"/v1/rigs/{id}/sequence/sample",
       {{"post", {{"summary", "Sample a keyframe sequence at given times: weights and meshes"}, {"operationId", "sampleSequence"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SequenceRequest"}}}}}}}}},
                  {"responses", {{"200", JsonOk("SequenceFrames")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid keys, transition or times")}}}}}}},
      {"/v1/rigs/{id}/sequence/stream",
       {{"post", {{"summary", "Stream frames at fps as they are computed: ndjson of weights, or uint32-length-prefixed float32 positions"},
                  {"operationId", "streamSequence"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SequenceRequest"}}}}}}}}},
                  {"responses", {{"200", {{"description", "Chunked frames"},
                                          {"content", {{"application/x-ndjson", {{"schema", {{"type", "string"}}}}},
                                                       {"application/octet-stream", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
                                 {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid keys, format or too many frames")}}}}}}},
      {"/v1/rigs/{id}/sequence/reduce",
       {{"post", {{"summary", "Remove keys while the largest vertex error stays under tolerance"}, {"operationId", "reduceSequence"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SequenceRequest"}}}}}}}}},
                  {"responses", {{"200", JsonOk("Reduced")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid keys or tolerance")}}}}}}},
      {"/v1/rigs/{id}/speech",
       {{"post",
         {{"summary", "Lip sync: text (espeak-ng) or recorded speech (PocketSphinx) to phonemes, visemes and keys on the rig, as JSON, a stream of frames, "
                      "the audio (WAV) or a video (WebM: VP9 + Opus)"},
          {"operationId", "speak"},
          {"parameters", SpeechQuery()},
          {"requestBody",
           {{"required", true},
            {"content",
             {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SpeechRequest"}}}}},
              {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
          {"responses",
           {{"200", {{"description", "json: phonemes, visemes ({viseme, start, end}) and keys; ndjson/weights/f32: the frames streamed; wav; webm"},
                     {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Speech"}}}}},
                                  {"application/x-ndjson", {{"schema", {{"type", "string"}}}}},
                                  {"application/octet-stream", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"},
                                                                            {"description", "format f32: uint32-length-prefixed float32 frames"}}}}},
                                  {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                  {"video/webm", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"413", Problem("Audio too long")},
            {"422", Problem("Empty or too long text, unknown voice, not audio, a rig without a mouth")},
            {"503", Problem("The speech engine is busy")}}}}}}}};
}

// Batch jobs and their files.
json JobOperations() {
  return {
      {"/v1/rigs/{id}/batch",
       {{"post", {{"summary", "Start a batch job: many variants (listed, or sampled uniform/gaussian/grid/convex with a seed) as files"},
                  {"operationId", "startBatch"},
                  {"security", Auth()},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/BatchRequest"}}}}}}}}},
                  {"responses", {{"202", {{"description", "Accepted; Location names the job"},
                                          {"headers", {{"Location", {{"schema", {{"type", "string"}}}}}}},
                                          {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Job"}}}}}}}}},
                                 {"400", Problem("Malformed JSON")}, {"401", Problem("No API key")}, {"403", Problem("Wrong API key")},
                                 {"404", Problem("Unknown rig")}, {"415", Problem("Not JSON")},
                                 {"422", Problem("Invalid request, or more variants than the server allows")},
                                 {"429", Problem("The job queue is full; see Retry-After")},
                                 {"507", Problem("The jobs folder's disk is full: no job was created")}}}}}}},
      {"/v1/jobs", {{"get", {{"summary", "List batch jobs, newest first"}, {"operationId", "listJobs"}, {"responses", {{"200", JsonOk("JobList")}}}}}}},
      {"/v1/jobs/{job}",
       {{"get", {{"summary", "A job's state and progress (queued, running, done, failed, cancelled, lost)"}, {"operationId", "getJob"},
                 {"parameters", json::array({JobParam()})},
                 {"responses", {{"200", {{"description", "OK"}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Job"}}}}}}}}},
                                {"404", Problem("Unknown job")}}}}},
        {"delete", {{"summary", "Cancel a job and delete its files"}, {"operationId", "deleteJob"}, {"security", Auth()},
                    {"parameters", json::array({JobParam()})},
                    {"responses", {{"204", {{"description", "Deleted"}}}, {"401", Problem("No API key")},
                                   {"403", Problem("Wrong API key")}, {"404", Problem("Unknown job")}}}}}}},
      {"/v1/jobs/{job}/manifest.jsonl",
       {{"get", {{"summary", "The manifest so far: one JSON line per complete variant (index, id, file, bytes, sha256, weights, warnings)"},
                 {"operationId", "getJobManifest"},
                 {"parameters", json::array({JobParam()})},
                 {"responses", {{"200", {{"description", "JSON lines"}, {"content", {{"application/x-ndjson", {{"schema", {{"type", "string"}}}}}}}}},
                                {"404", Problem("Unknown job")}}}}}}},
      {"/v1/jobs/{job}/files/{name}",
       {{"get", {{"summary", "One file of a job: a variant (as named in the manifest), sheet.png, batch.json"},
                 {"operationId", "getJobFile"},
                 {"parameters", json::array({JobParam(), {{"name", "name"}, {"in", "path"}, {"required", true}, {"schema", {{"type", "string"}}}}})},
                 {"responses", {{"200", {{"description", "The file, typed by its extension"}, {"content", JobFileContent()}}},
                                {"404", Problem("Unknown job or file")}}}}}}},
      {"/v1/jobs/{job}/results.zip",
       {{"get", {{"summary", "Every file of a finished job as one zip archive (streamed)"}, {"operationId", "getJobResults"},
                 {"parameters", json::array({JobParam()})},
                 {"responses", {{"200", {{"description", "Zip archive"}, {"content", {{"application/zip", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
                                {"404", Problem("Unknown job")}, {"409", Problem("The job is not done")}}}}}}}};
}

}  // namespace

json Operations() {
  json operations = json::object();
  for (json group : {ServiceOperations(), RigOperations(), PointOperations(), SequenceOperations(), JobOperations()}) operations.update(group);
  return operations;
}

}  // namespace facespace::api::openapi
