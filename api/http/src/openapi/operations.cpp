// The document's operations, by path, in groups of routes; document.cpp keeps those the route table
// lists (and stops the server if one is missing).
#include "openapi.h"
#include "parts.h"

namespace facespace::http::openapi {

namespace {

// The service itself: health, readiness, metrics, this document, the voices.
json ServiceOperations() {
  return {
      {"/healthz",
       {{"get",
         {{"summary", "Liveness"},
          {"operationId", "healthz"},
          {"responses", {{"200", JsonOk("Health")}}}}}}},
      {"/readyz",
       {{"get",
         {{"summary", "Readiness: the rigs loaded and encoded (503 while warming)"},
          {"operationId", "readyz"},
          {"responses", {{"200", JsonOk("Health")}, {"503", JsonOk("Health", "Warming up")}}}}}}},
      {"/metrics",
       {{"get",
         {{"summary", "Prometheus metrics"},
          {"operationId", "metrics"},
          {"responses",
           {{"200",
             {{"description", "Prometheus text"},
              {"content", {{"text/plain", {{"schema", {{"type", "string"}}}}}}}}}}}}}}},
      {"/openapi.json",
       {{"get",
         {{"summary", "This document"},
          {"operationId", "openapi"},
          {"responses", {{"200", OkJson()}}}}}}},
      {"/v1/voices",
       {{"get",
         {{"summary", "The voices text can be spoken with (espeak-ng's)"},
          {"operationId", "listVoices"},
          {"responses", {{"200", JsonOk("Voices")}}}}}}}};
}

// Rigs: list, read, upload, delete; manifests; topology.
json RigOperations() {
  return {
      {"/v1/rigs",
       {{"get",
         {{"summary", "List rigs"},
          {"operationId", "listRigs"},
          {"responses", {{"200", JsonOk("RigList")}}}}}}},
      {"/v1/rigs/{id}",
       {{"parameters", json::array({IdParam()})},
        {"get",
         {{"summary", "A rig: shapes, bounding box, primitives, skeleton"},
          {"operationId", "getRig"},
          {"responses", {{"200", JsonOk("Rig")}, {"404", Problem("Unknown rig")}}}}},
        {"put",
         {{"summary", "Upload or replace a rig (validated fully, stored atomically)"},
          {"operationId", "putRig"},
          {"security", Auth()},
          {"parameters", json::array({IdParam(),
                                      {{"name", "filename"},
                                       {"in", "query"},
                                       {"schema", {{"type", "string"}}},
                                       {"description",
                                        "A plain upload's file name (else Content-Disposition's), "
                                        "whose extension says its format"}}})},
          {"requestBody",
           {{"required", true},
            {"description",
             "glb, glTF with embedded buffers, COLLADA, or (as application/octet-stream with a "
             "file name in Content-Disposition or ?filename=, else told by its magic) FBX, .dae, "
             ".glb, .gltf"},
            {"content",
             {{"model/gltf-binary",
               {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
              {"model/gltf+json",
               {{"schema",
                 {{"type", "object"},
                  {"additionalProperties", true},
                  {"description", "glTF 2.0 JSON, buffers embedded"}}}}},
              {"model/vnd.collada+xml", {{"schema", {{"type", "string"}}}}},
              {"application/octet-stream",
               {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
              {"multipart/form-data",
               {{"schema",
                 {{"type", "object"},
                  {"required", {"rig"}},
                  {"properties",
                   {{"rig",
                     {{"type", "string"},
                      {"contentEncoding", "binary"},
                      {"description",
                       "The rig file (its part's file name or type says the format)"}}},
                    {"manifest", {{"$ref", "#/components/schemas/Manifest"}}}}}}},
                {"encoding", {{"manifest", {{"contentType", "application/json"}}}}}}}}}}},
          {"responses",
           {{"200", JsonOk("RigSummary", "Replaced")},
            {"201", JsonOk("RigSummary", "Created")},
            {"401", Problem("No API key")},
            {"403", Problem("Wrong API key")},
            {"413", Problem("Body over the limit")},
            {"415", Problem("Not a rig media type (or an octet stream of no known rig format)")},
            {"409", Problem("A bundled rig: read-only")},
            {"422", Problem("Invalid rig, manifest or id")},
            {"500", Problem("The store could not write the rig")},
            {"507",
             Problem("The store's disk is full: nothing was written, the old rig is kept")}}}}},
        {"delete",
         {{"summary", "Delete a rig"},
          {"operationId", "deleteRig"},
          {"security", Auth()},
          {"responses",
           {{"204", {{"description", "Deleted"}}},
            {"401", Problem("No API key")},
            {"403", Problem("Wrong API key")},
            {"404", Problem("Unknown rig")},
            {"409", Problem("A bundled rig: read-only")}}}}}}},
      {"/v1/rigs/{id}/manifest",
       {{"parameters", json::array({IdParam()})},
        {"get",
         {{"summary",
           "A rig's manifest: name, credit, shape groups, ranges, partners, controls, in-betweens "
           "(README \"Manifest\")"},
          {"operationId", "getManifest"},
          {"responses", {{"200", JsonOk("Manifest")}, {"404", Problem("Unknown rig")}}}}},
        {"put",
         {{"summary",
           "Replace an uploaded rig's manifest (validated against the rig first; the rig file "
           "unchanged)"},
          {"operationId", "putManifest"},
          {"security", Auth()},
          {"requestBody", JsonBody("Manifest")},
          {"responses",
           {{"200", JsonOk("RigSummary")},
            {"400", Problem("Malformed JSON")},
            {"401", Problem("No API key")},
            {"403", Problem("Wrong API key")},
            {"404", Problem("Unknown rig")},
            {"409", Problem("A bundled rig: read-only")},
            {"415", Problem("Not application/json")},
            {"422", Problem("The manifest does not apply to the rig (names the member)")},
            {"507", Problem("The store's disk is full: nothing was written")}}}}}}}};
}

// A rig's triangles for clients that draw it themselves, and its live channel.
json RigDataOperations() {
  return {
      {"/v1/rigs/{id}/topology",
       {{"get",
         {{"summary",
           "Triangle lists per primitive (for clients that draw the f32 mesh), encoded once per "
           "rig version (br or gzip as accepted)"},
          {"operationId", "getTopology"},
          {"parameters",
           json::array({IdParam(),
                        {{"name", "lod"},
                         {"in", "query"},
                         {"schema", {{"type", "integer"}, {"minimum", 0}, {"maximum", 4}}}},
                        {{"name", "format"},
                         {"in", "query"},
                         {"description",
                          "json, or u32: every primitive's indices as little-endian uint32, one "
                          "after the other"},
                         {"schema",
                          {{"type", "string"}, {"enum", {"json", "u32"}}, {"default", "json"}}}}})},
          {"responses",
           {{"200",
             {{"description", "The triangle lists (JSON), or the indices alone (u32)"},
              {"headers",
               {{"Facespace-Index-Counts",
                 {{"description", "u32: each primitive's index count, comma-separated"},
                  {"schema", {{"type", "string"}}}}},
                {"Facespace-Vertex-Counts",
                 {{"description", "u32: each primitive's vertex count"},
                  {"schema", {{"type", "string"}}}}}}},
              {"content",
               {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Topology"}}}}},
                {"application/octet-stream",
                 {{"schema", {{"type", "string"}, {"format", "binary"}}}}}}}}},
            {"304", {{"description", "Not modified (If-None-Match)"}}},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Bad lod or format")}}}}}}},
      {"/v1/rigs/{id}/live",
       {{"get",
         {{"summary",
           "One face live over a WebSocket (RFC 6455): text messages set the state ({\"weights\": "
           "{...}}, \"expressions\", "
           "\"gaze\", \"pose\", \"controls\", \"id\"), merged as the mesh route reads them; each "
           "change is answered, at most 60 "
           "times a second (newest state wins), by a binary message: 16 bytes (\"mesh\", frame "
           "number, the newest id applied, "
           "0; little-endian uint32) then the bytes of GET /mesh?format=f32 for that point. Events "
           "are text: ready, warnings, "
           "error (the session goes on). Closes: 1002 broken framing, 1003 binary without listen, "
           "1007 text not UTF-8, "
           "1008 a flood, a client that does not read, or the session's CPU spent, 1009 a message "
           "over 64 KiB, 1001 the server stops "
           "or the session's time is up."},
          {"operationId", "getLive"},
          {"parameters", json::array({IdParam()})},
          // The socket's messages, declared as the bodies are (facespace/evaluator/members.h).
          {"x-facespace-messages",
           {{"client",
             {{"text", {{"$ref", "#/components/schemas/LiveMessage"}}},
              {"binary", "16 kHz 16-bit mono PCM, after {\"listen\": ...}"}}}}},
          {"responses",
           {{"101",
             {{"description",
               "Switched to the WebSocket protocol; Facespace-Cost states a second of frames"}}},
            {"400", Problem("Bad Sec-WebSocket-Key")},
            {"404", Problem("Unknown rig")},
            {"426", Problem("Not a WebSocket upgrade, or not version 13")},
            {"503",
             Problem(
                 "As many live sessions as the server takes, in all or from this address")}}}}}}}};
}

// A point of face space: its mesh, render, contact sheet, check, and the fit that finds one.
json PointOperations() {
  return {
      {"/v1/rigs/{id}/mesh",
       {{"get",
         {{"summary", "Blended mesh from query weights (w[NAME]=VALUE or w.NAME=VALUE)"},
          {"operationId", "getMesh"},
          {"parameters", QueryParams(false)},
          {"responses", MeshResponses()}}},
        {"post",
         {{"summary", "Blended mesh"},
          {"operationId", "postMesh"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("MeshRequest")},
          {"responses", MeshResponses()}}}}},
      {"/v1/rigs/{id}/render",
       {{"get",
         {{"summary",
           "Offscreen render from query settings (w[NAME]=VALUE, width, height, view, yaw, "
           "pitch, "
           "zoom, ...)"},
          {"operationId", "getRender"},
          {"parameters", QueryParams(true)},
          {"responses", RenderResponses()}}},
        {"post",
         {{"summary", "Offscreen render"},
          {"operationId", "postRender"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("RenderRequest")},
          {"responses", RenderResponses()}}}}},
      {"/v1/rigs/{id}/sheet",
       {{"post",
         {{"summary", "Contact sheet: several weight vectors rendered into one labelled grid"},
          {"operationId", "postSheet"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("SheetRequest")},
          {"responses", RenderResponses()}}}}},
      {"/v1/rigs/{id}/check",
       {{"post",
         {{"summary", "Validate weights only: sum and warnings"},
          {"operationId", "checkWeights"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("MeshRequest")},
          {"responses",
           {{"200", JsonOk("Check")},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Invalid weights")}}}}}}},
      {"/v1/rigs/{id}/fit",
       {{"post",
         {{"summary",
           "Weights that best reproduce a target mesh (least squares), with residual and "
           "warnings"},
          {"operationId", "fit"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("FitRequest")},
          {"responses",
           {{"200", JsonOk("Fit")},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("A target that does not match the rig")}}}}}}},
      {"/v1/rigs/{id}/capture",
       {{"post",
         {{"summary",
           "A face tracker's landmarks over frames (MediaPipe's face mesh) as this rig's "
           "weights: "
           "the keys of a sequence"},
          {"description",
           "MediaPipe's canonical face is registered onto the rig once per rig version (as a "
           "derive registers a face); each frame's points, the head's motion taken out, less "
           "the "
           "performer's neutral frame, are fitted by the rig's expression shapes (bounded least "
           "squares) and smoothed (One Euro). Server-Timing names the solve's time per frame."},
          {"operationId", "capture"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("CaptureRequest")},
          {"responses",
           {{"200", JsonOk("Captured")},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Invalid frames; a rig with no face the landmarks fit, or no "
                            "expression shapes; over the cost budget")}}}}}}}};
}

// Sequences and speech: sampled, streamed, reduced, spoken.
json SequenceOperations() {
  return {
      {"/v1/rigs/{id}/sequence/sample",
       {{"post",
         {{"summary", "Sample a keyframe sequence at given times: weights and meshes"},
          {"operationId", "sampleSequence"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("SequenceRequest")},
          {"responses",
           {{"200", JsonOk("SequenceFrames")},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Invalid keys, transition or times")}}}}}}},
      {"/v1/rigs/{id}/sequence/stream",
       {{"post",
         {{"summary",
           "Stream frames at fps as they are computed: ndjson of weights, or "
           "uint32-length-prefixed float32 positions"},
          {"operationId", "streamSequence"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("SequenceRequest")},
          {"responses",
           {{"200",
             {{"description", "Chunked frames"},
              {"content",
               {{"application/x-ndjson",
                 {{"schema", {{"type", "string"}}},
                  // Each line's JSON (OpenAPI 3.2 names this itemSchema).
                  {"x-facespace-line", {{"$ref", "#/components/schemas/StreamFrame"}}}}},
                {"application/octet-stream",
                 {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Invalid keys, format or too many frames")}}}}}}},
      {"/v1/rigs/{id}/sequence/reduce",
       {{"post",
         {{"summary", "Remove keys while the largest vertex error stays under tolerance"},
          {"operationId", "reduceSequence"},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("SequenceRequest")},
          {"responses",
           {{"200", JsonOk("Reduced")},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"422", Problem("Invalid keys or tolerance")}}}}}}},
      {"/v1/rigs/{id}/speech",
       {{"post",
         {{"summary",
           "Lip sync: text (espeak-ng) or recorded speech (PocketSphinx) to phonemes, visemes "
           "and "
           "keys on the rig, as JSON, a stream of frames, "
           "the audio (WAV) or a video (WebM: VP9 + Opus)"},
          {"operationId", "speak"},
          {"parameters", SpeechQuery()},
          {"requestBody",
           {{"required", true},
            {"content",
             {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SpeechRequest"}}}}},
              {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
          {"responses",
           {{"200",
             {{"description",
               "json: phonemes, visemes ({viseme, start, end}) and keys; ndjson/weights/f32: the "
               "frames streamed; wav; webm"},
              {"content",
               {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Speech"}}}}},
                {"application/x-ndjson", {{"schema", {{"type", "string"}}}}},
                {"application/octet-stream",
                 {{"schema",
                   {{"type", "string"},
                    {"contentEncoding", "binary"},
                    {"description", "format f32: uint32-length-prefixed float32 frames"}}}}},
                {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                {"video/webm",
                 {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"413", Problem("Audio too long")},
            {"422",
             Problem("Empty or too long text, unknown voice, not audio, a rig without a mouth")},
            {"503", Problem("The speech engine is busy")}}}}}}}};
}

// A job's start (a batch, a derive): 202 with the job, Location naming it, and the refusals both
// share; `own` adds the route's.
json JobStarted(json own) {
  json r = {
      {"202",
       {{"description", "Accepted; Location names the job"},
        {"headers", {{"Location", {{"schema", {{"type", "string"}}}}}}},
        {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Job"}}}}}}}}},
      {"400", Problem("Malformed JSON")},
      {"401", Problem("No API key")},
      {"403", Problem("Wrong API key")},
      {"404", Problem("Unknown rig")},
      {"415", Problem("Not JSON")}};
  r.update(own);
  return r;
}

// Batch jobs and their files.
json JobOperations() {
  return {
      {"/v1/rigs/{id}/batch",
       {{"post",
         {{"summary",
           "Start a batch job: many variants (listed, or sampled uniform/gaussian/grid/convex "
           "with "
           "a seed) as files"},
          {"operationId", "startBatch"},
          {"security", Auth()},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("BatchRequest")},
          {"responses",
           JobStarted(
               {{"422", Problem("Invalid request, or more variants than the server allows")},
                {"429", Problem("The job queue is full; see Retry-After")},
                {"507", Problem("The jobs folder's disk is full: no job was created")}})}}}}},
      {"/v1/rigs/{id}/derive",
       {{"post",
         {{"summary",
           "Start a derive: another rig's shapes (default FaceCap's ARKit 52, and the 15 visemes "
           "baked from them) transferred onto this rig's neutral, written as a rig"},
          {"description",
           "A job (GET /v1/jobs/{job} follows it): the source's face registered onto this one "
           "(landmarks, or the heads' own shape, then non-rigid ICP) and each shape's "
           "deformation "
           "carried over. Done, the rig `as` (default this one, its own shapes kept) is stored "
           "with the shapes and its manifest's `derivation`; a fit that does not match fails the "
           "job with a poor-fit or no-face problem, and nothing is written."},
          {"operationId", "startDerive"},
          {"security", Auth()},
          {"parameters", json::array({IdParam()})},
          {"requestBody", JsonBody("DeriveRequest")},
          {"responses",
           JobStarted(
               {{"422", Problem("Unknown source rig, shape set or landmark; over the cost budget")},
                {"429", Problem("Two derives are queued or running; see Retry-After")}})}}}}},
      {"/v1/jobs",
       {{"get",
         {{"summary", "List jobs (batches and derives), newest first"},
          {"operationId", "listJobs"},
          {"responses", {{"200", JsonOk("JobList")}}}}}}},
      {"/v1/jobs/{job}",
       {{"get",
         {{"summary",
           "A job's state and progress (queued, running, done, failed, cancelled, lost)"},
          {"operationId", "getJob"},
          {"parameters", json::array({JobParam()})},
          {"responses",
           {{"200",
             {{"description", "OK"},
              {"content",
               {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Job"}}}}}}}}},
            {"404", Problem("Unknown job")}}}}},
        {"delete",
         {{"summary", "Cancel a job and delete its files"},
          {"operationId", "deleteJob"},
          {"security", Auth()},
          {"parameters", json::array({JobParam()})},
          {"responses",
           {{"204", {{"description", "Deleted"}}},
            {"401", Problem("No API key")},
            {"403", Problem("Wrong API key")},
            {"404", Problem("Unknown job")}}}}}}},
      {"/v1/jobs/{job}/manifest.jsonl",
       {{"get",
         {{"summary",
           "The manifest so far: one JSON line per complete variant (index, id, file, bytes, "
           "sha256, weights, warnings)"},
          {"operationId", "getJobManifest"},
          {"parameters", json::array({JobParam()})},
          {"responses",
           {{"200",
             {{"description", "JSON lines"},
              {"content", {{"application/x-ndjson", {{"schema", {{"type", "string"}}}}}}}}},
            {"404", Problem("Unknown job")}}}}}}},
      {"/v1/jobs/{job}/files/{name}",
       {{"get",
         {{"summary",
           "One file of a job: a variant (as named in the manifest), sheet.png, batch.json"},
          {"operationId", "getJobFile"},
          {"parameters", json::array({JobParam(),
                                      {{"name", "name"},
                                       {"in", "path"},
                                       {"required", true},
                                       {"schema", {{"type", "string"}}}}})},
          {"responses",
           {{"200",
             {{"description", "The file, typed by its extension"}, {"content", JobFileContent()}}},
            {"404", Problem("Unknown job or file")}}}}}}},
      {"/v1/jobs/{job}/results.zip",
       {{"get",
         {{"summary", "Every file of a finished job as one zip archive (streamed)"},
          {"operationId", "getJobResults"},
          {"parameters", json::array({JobParam()})},
          {"responses",
           {{"200",
             {{"description", "Zip archive"},
              {"content",
               {{"application/zip",
                 {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
            {"404", Problem("Unknown job")},
            {"409", Problem("The job is not done")}}}}}}}};
}

}  // namespace

json Operations() {
  json operations = json::object();
  for (json group : {ServiceOperations(), RigOperations(), RigDataOperations(), PointOperations(),
                     SequenceOperations(), JobOperations()})
    operations.update(group);
  return operations;
}

}  // namespace facespace::http::openapi
