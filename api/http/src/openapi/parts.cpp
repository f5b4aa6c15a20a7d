// The operations' shared parts (parts.h).
#include "parts.h"

#include "../http/query_params.h"
#include "facespace/engine/speech.h"
#include "facespace/evaluator/members.h"

namespace facespace::http::openapi {

json Problem(const std::string& description) {
  return {
      {"description", description},
      {"content",
       {{"application/problem+json", {{"schema", {{"$ref", "#/components/schemas/Problem"}}}}}}}};
}

using facespace::evaluator::Body;
using facespace::evaluator::FindMember;
using facespace::evaluator::Kind;
using facespace::evaluator::Member;
using facespace::evaluator::Members;

// The headers every answer of the mesh and image routes carries.
json CommonHeaders() {
  return {{"Cache-Control",
           {{"description", "GET: public, no-cache (revalidate with the ETag); POST: no-store"},
            {"schema", {{"type", "string"}}}}},
          {"Server-Timing",
           {{"description",
             "Where the time went: blend, draw and encode, in ms (e.g. blend;dur=0.08, "
             "draw;dur=21.7, encode;dur=0.34)"},
            {"schema", {{"type", "string"}}}}},
          {"Vary",
           {{"description", "Accept (and Accept-Encoding where bodies are compressed)"},
            {"schema", {{"type", "string"}}}}}};
}

json MeshResponses() {
  json headers = {{"Facespace-Weight-Sum",
                   {{"description", "Sum of the weights"}, {"schema", {{"type", "string"}}}}},
                  {"Facespace-Warnings",
                   {{"description",
                     "Structured-field list (RFC 9651) of warnings, e.g. extrapolation;value=1.7"},
                    {"schema", {{"type", "string"}}}}},
                  {"ETag",
                   {{"description", "Strong validator of rig version + canonical request"},
                    {"schema", {{"type", "string"}}}}}};
  headers.update(CommonHeaders());
  return {
      {"200",
       {{"description",
         "The blended mesh (warnings, if any, in headers and in the body where the format has "
         "room)"},
        {"headers", headers},
        {"content",
         {{"application/json", {{"schema", {{"$ref", "#/components/schemas/MeshJson"}}}}},
          {"model/gltf-binary", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
          {"model/obj", {{"schema", {{"type", "string"}}}}},
          {"application/octet-stream",
           {{"schema",
             {{"type", "string"},
              {"contentEncoding", "binary"},
              {"description",
               "float32 LE: world-space positions of every primitive, then normals"}}}}}}}}},
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
      {"Facespace-Weight-Sum",
       {{"description", "Sum of the weights (sheet: the largest over its cells)"},
        {"schema", {{"type", "string"}}}}},
      {"Facespace-Warnings",
       {{"description", "Structured-field list (RFC 9651) of warnings"},
        {"schema", {{"type", "string"}}}}},
      {"ETag", {{"description", "Strong validator"}, {"schema", {{"type", "string"}}}}}};
  headers.update(CommonHeaders());
  json bin = {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}};
  return {
      {"200",
       {{"description", "The image"},
        {"headers", headers},
        {"content",
         {{"image/png", bin},
          {"image/jpeg", bin},
          {"image/x-exr", bin},
          {"image/tiff", bin},
          {"image/webp", bin}}}}},
      {"304", {{"description", "Not modified"}}},
      {"400", Problem("Malformed JSON")},
      {"404", Problem("Unknown rig")},
      {"406", Problem("Unsupported Accept")},
      {"413",
       Problem(
           "A body over the limit, or a render whose working memory is over the render budget")},
      {"415", Problem("Unsupported Content-Type")},
      {"422", Problem("Invalid weights or settings, image over the size limit, too many cells; or "
                      "warnings with strict=true")},
      {"503", Problem("The renders in flight use the render memory; see Retry-After")}};
}

json IdParam() {
  return {{"name", "id"},
          {"in", "path"},
          {"required", true},
          {"schema", {{"type", "string"}, {"pattern", "^[a-z0-9][a-z0-9_-]{0,63}$"}}}};
}

json JobParam() {
  return {{"name", "job"},
          {"in", "path"},
          {"required", true},
          {"schema", {{"type", "string"}, {"pattern", "^[0-9a-f]{32}$"}}}};
}

// w[NAME]=VALUE or c[NAME]=VALUE: OpenAPI's deepObject style, which generated clients send; the
// server also reads the shorter w.NAME=VALUE of curl lines.
json MapParam(const char* name, const char* description) {
  return {{"name", name},
          {"in", "query"},
          {"style", "deepObject"},
          {"explode", true},
          {"description", description},
          {"schema", {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}}};
}

// One query parameter of GET mesh or render, by the name the route reads (http/query_params.h): the
// body's member of that name (the camera's, flat: yaw=20), from the member tables. Three read the
// query their own way: camera (the body's object as JSON), frame (a time in MMD frames, or the
// camera's framing) and gaze (short forms); other objects and arrays are the body's as JSON.
json QueryParam(std::string_view name, bool render) {
  if (name ==
      "camera") {  // JSON in the query string: OpenAPI's content form, typed as the body's camera.
    return {{"name", "camera"},
            {"in", "query"},
            {"description",
             "The body's camera object as JSON (yaw, pitch, zoom, distance, fov, frame, eye, "
             "target, up)"},
            {"content",
             {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Camera"}}}}}}}};
  }
  const Member* m = FindMember(render ? Body::kRender : Body::kMesh, name);
  if (!m) m = FindMember(Body::kCamera, name);
  if (!m) {
    std::fprintf(stderr,
                 "facespace: the OpenAPI document cannot describe the query parameter '%.*s'\n",
                 static_cast<int>(name.size()), name.data());
    std::abort();
  }
  json schema = MemberSchema(*m);
  std::string description = schema.value("description", "");
  schema.erase("description");
  if (name == "frame" && render) {
    schema = {{"oneOf", json::array({json{{"type", "number"}},
                                     json{{"type", "string"},
                                          {"pattern", "^(all|shapes|auto|joint:.+)$"}}})}};
    description =
        "A time in MMD frames (30 a second), or the camera's framing: all, shapes, joint:NAME or "
        "auto (the default)";
  } else if (name == "gaze") {
    schema = {{"type", "string"}};
    description =
        "Where the eyes look: YAW,PITCH (degrees; yaw > 0 to the character's left, pitch > 0 up), "
        "X,Y,Z (a point of "
        "the rig's world), or the body's gaze object as JSON";
  } else if (m->kind == Kind::kSchema) {
    schema = {{"type", "string"}};
    description += " (as in the body: a name or an index, a colour, or JSON)";
  }
  return {{"name", std::string(name)},
          {"in", "query"},
          {"schema", schema},
          {"description", description}};
}

// The parameters of GET mesh or render: the path's id, the weights and controls, and each name
// of the route's list.
json QueryParams(bool render) {
  json params = json::array(
      {IdParam(),
       MapParam("w",
                "Weights as w[NAME]=VALUE (or w.NAME=VALUE) by shape name, alias or index; "
                "shapes not named are 0"),
       MapParam("c",
                "Control values as c[NAME]=VALUE (or c.NAME=VALUE), for rigs with controls "
                "(e.g. c[nose/nose-trans-down|up]=-0.4)"),
       MapParam("e",
                "Expressions as e[NAME]=VALUE (or e.NAME=VALUE): VRM's presets (happy, aa, blink, "
                "...) or the rig's own")});
  for (std::string_view name :
       render ? std::span<const std::string_view>(http::kRenderQuery) : http::kMeshQuery) {
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
    json schema = m.kind == Kind::kNumber    ? json{{"type", "number"}}
                  : m.kind == Kind::kInteger ? json{{"type", "integer"}}
                  : m.kind == Kind::kBoolean ? json{{"type", "boolean"}}
                                             : json{{"type", "string"}};
    params.push_back({{"name", std::string(m.name)},
                      {"in", "query"},
                      {"schema", schema},
                      {"description", "With an audio/wav body: " + std::string(m.doc) +
                                          (m.kind == Kind::kSchema ? " (as JSON)" : "")}});
  }
  return params;
}

// What a job's files are: a variant's mesh or image, a labelled sample's EXR and PNG, a tar shard,
// the manifest's lines, batch.json (routes/batch.cpp, FileType).
json JobFileContent() {
  const json bin = {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}};
  const json text = {{"schema", {{"type", "string"}}}};
  return {{"model/gltf-binary", bin},
          {"model/obj", text},
          {"application/json", {{"schema", {{"type", "object"}, {"additionalProperties", true}}}}},
          {"application/octet-stream", bin},
          {"image/png", bin},
          {"image/jpeg", bin},
          {"image/x-exr", bin},
          {"image/tiff", bin},
          {"image/webp", bin},
          {"application/x-tar", bin},
          {"application/x-ndjson", text}};
}

json OkJson() {
  return {
      {"description", "OK"},
      {"content",
       {{"application/json", {{"schema", {{"type", "object"}, {"additionalProperties", true}}}}}}}};
}

// A 200 whose JSON body is the component `name`.
json JsonOk(const char* name, const char* description) {
  return json{{"description", description},
              {"content",
               {{"application/json",
                 {{"schema", {{"$ref", std::string("#/components/schemas/") + name}}}}}}}};
}

json JsonBody(const char* name) {
  return {{"required", true},
          {"content",
           {{"application/json",
             {{"schema", {{"$ref", std::string("#/components/schemas/") + name}}}}}}}};
}

json Auth() { return json::array({{{"bearer", json::array()}}}); }

}  // namespace facespace::http::openapi
