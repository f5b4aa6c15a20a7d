// The OpenAPI 3.1 description of every route of the route table (http/route_table.cpp): the
// operations below are looked up by path and method for each route the table lists, so the
// document names exactly the routes the server answers; a route without an operation here stops
// the server at its first request for the document (every service test would fail).
#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "facespace/api/http.h"
#include "http/query_params.h"
#include "http/route_table.h"

namespace facespace::api {

namespace {

using nlohmann::json;

json Problem(const std::string& description) {
  return {{"description", description},
          {"content", {{"application/problem+json", {{"schema", {{"$ref", "#/components/schemas/Problem"}}}}}}}};
}

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

// The document's paths: one operation per route of the table, taken from `operations`; path-level
// parameters are copied into each operation.
json PathsOfRoutes(const json& operations) {
  json paths = json::object();
  for (const http::Route& route : http::Routes()) {
    std::string method = route.method;
    for (char& c : method) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto item = operations.find(route.path);
    if (item == operations.end() || !item->contains(method)) {
      std::fprintf(stderr, "facespace: the OpenAPI document has no operation for %s %s\n", route.method, route.path);
      std::abort();
    }
    json op = (*item)[method];
    if (item->contains("parameters") && !op.contains("parameters")) op["parameters"] = (*item)["parameters"];
    // Public operations say so (an empty requirement), beside the keyed ones' bearer.
    if (!op.contains("security")) op["security"] = json::array();
    // Every body is bounded (--max-body) and must be JSON unless the operation says otherwise.
    if (op.contains("requestBody")) {
      if (!op["responses"].contains("413")) op["responses"]["413"] = Problem("The body is over the server's limit (--max-body)");
      if (!op["responses"].contains("415")) op["responses"]["415"] = Problem("The body is not of a type the operation takes");
    }
    paths[route.path][method] = op;
  }
  return paths;
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

// One query parameter of GET mesh or render, by the name the route reads (http/query_params.h).
json QueryParam(std::string_view name, bool render) {
  auto param = [&](json schema, const char* description = nullptr) {
    json p = {{"name", std::string(name)}, {"in", "query"}, {"schema", std::move(schema)}};
    if (description) p["description"] = description;
    return p;
  };
  const json number = {{"type", "number"}}, boolean = {{"type", "boolean"}};
  if (name == "format") {
    return render ? param({{"enum", {"png", "jpeg", "exr", "tiff", "webp"}}, {"default", "png"}})
                  : param({{"enum", {"glb", "obj", "json", "f32", "vrm"}}, {"default", "glb"}});
  }
  if (name == "space") {
    return param({{"enum", {"world", "mesh"}}, {"default", "world"}},
                 "json, obj, f32: world space (each primitive placed by its node, dequantized) or each mesh's own");
  }
  if (name == "keep_targets") return param(boolean, "glb: keep the morph targets, with the blend as the mesh's weights");
  if (name == "mode") return param({{"enum", {"relative", "absolute"}}, {"default", "relative"}});
  if (name == "normals") return param({{"enum", {"blend", "recompute"}}, {"default", "blend"}});
  if (name == "strict") return param(boolean, "Refuse (422) a point with warnings instead of answering with them");
  if (name == "skinning") return param({{"enum", {"linear", "dual_quaternion"}}, {"default", "linear"}});
  if (name == "lod") {
    return param({{"type", "integer"}, {"minimum", 0}, {"maximum", 4}, {"default", 0}},
                 "Level of detail: 0 full, L about 1/2^L of the triangles");
  }
  if (name == "pose") return param({{"type", "string"}}, "The body's pose object (joint -> rotation, euler, translation, scale) as JSON");
  if (name == "gaze") {
    return param({{"type", "string"}}, "Where the eyes look: YAW,PITCH (degrees; yaw > 0 to the character's left, pitch > 0 up), X,Y,Z (a point of "
                                       "the rig's world), or the body's gaze object as JSON");
  }
  if (name == "blend") return param({{"type", "string"}}, "The body's blend array (several clips at their times and weights) as JSON");
  if (name == "layers") return param({{"type", "string"}}, "The body's layers array (a base motion, then overlays) as JSON");
  if (name == "animation") return param({{"type", "string"}}, "A clip by name or index, posed at time");
  if (name == "motion") return param({{"type", "string"}}, "A clip by MMD's word (a .vmd motion): as animation");
  if (name == "time") return param(number, "Seconds into the animation");
  if (name == "loop") return param(boolean, "Wrap time into the clip's length");
  if (name == "frame") {
    if (!render) return param(number, "The time in MMD frames, 30 a second");
    return param({{"oneOf", json::array({number, json{{"type", "string"}, {"pattern", "^(all|shapes|auto|joint:.+)$"}}})}},
                 "A time in MMD frames (30 a second), or the camera's framing: all (the rest shape unless posed, so the camera "
                 "stays still while weights change), shapes, joint:NAME (the vertices a joint carries, under the pose), auto (the "
                 "default: the shapes when they act on a small part of the rig, through the joint carrying them on a skinned one, else all)");
  }
  if (name == "width" || name == "height") return param({{"type", "integer"}, {"minimum", 1}, {"default", 512}});
  if (name == "view") return param({{"enum", {"shaded", "wireframe", "heatmap", "normals", "clay"}}, {"default", "shaded"}});
  if (name == "background") return param({{"type", "string"}}, "#rrggbb, #rrggbbaa or transparent");
  if (name == "supersample") return param({{"type", "integer"}, {"minimum", 1}, {"maximum", 4}});
  if (name == "exposure") return param({{"type", "number"}, {"minimum", -10}, {"maximum", 10}, {"default", 0}}, "Stops of light before tone mapping (+1: twice the light)");
  if (name == "quality") return param({{"type", "integer"}, {"minimum", 1}, {"maximum", 100}}, "jpeg and webp");
  if (name == "camera") {  // JSON in the query string: OpenAPI's content form, typed as the body's camera.
    return {{"name", "camera"}, {"in", "query"}, {"description", "The body's camera object as JSON (yaw, pitch, zoom, distance, fov, frame, eye, target, up)"},
            {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Camera"}}}}}}}};
  }
  if (name == "yaw" || name == "pitch") return param(number, "Degrees");
  if (name == "distance" || name == "zoom") return param(number);
  if (name == "fov") return param(number, "Vertical field of view, degrees (1 to 170)");
  std::fprintf(stderr, "facespace: the OpenAPI document cannot describe the query parameter '%.*s'\n", static_cast<int>(name.size()), name.data());
  std::abort();
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

json WeightsObject() { return {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}; }

json Build() {
  json weights = {{"oneOf", json::array({json{{"type", "array"}, {"items", {{"type", "number"}}},
                                                {"description", "Dense, in shape order"}},
                                           json{{"type", "object"}, {"additionalProperties", {{"type", "number"}}},
                                                {"description", "By shape name, alias or index"}}})}};
  json pose = {{"type", "object"},
               {"description", "Joint name -> local transform parts that replace the rest values"},
               {"additionalProperties",
                {{"type", "object"},
                 {"properties", {{"rotation", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 4}, {"maxItems", 4}}},
                                 {"euler", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}},
                                 {"translation", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}},
                                 {"scale", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}}}}}}};
  json clip_ref = {{"oneOf", json::array({json{{"type", "string"}}, json{{"type", "integer"}, {"minimum", 0}}})}};
  json blend = {{"type", "array"},
                {"items", {{"type", "object"},
                           {"required", {"animation"}},
                           {"properties", {{"animation", clip_ref}, {"time", {{"type", "number"}}}, {"weight", {{"type", "number"}}},
                                           {"loop", {{"type", "boolean"}}},
                                           {"mask", {{"type", "array"}, {"items", {{"type", "string"}}}}}}}}}};
  json layers = {{"type", "array"},
                 {"minItems", 1},
                 {"maxItems", 16},
                 {"description", "Motions stacked: the first the base, each later one an overlay replacing, by its weight, only the "
                                 "joints and shapes its clip moves"},
                 {"items", {{"type", "object"},
                            {"properties", {{"motion", clip_ref}, {"animation", clip_ref}, {"time", {{"type", "number"}}},
                                            {"frame", {{"type", "number"}}}, {"weight", {{"type", "number"}, {"minimum", 0}}},
                                            {"loop", {{"type", "boolean"}}}, {"fade_in", {{"type", "number"}, {"minimum", 0}}},
                                            {"fade_out", {{"type", "number"}, {"minimum", 0}}},
                                            {"mask", {{"type", "array"}, {"items", {{"type", "string"}}}}}}}}}};
  json point3 = {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}};
  json gaze = {{"type", "object"},
               {"description", "Where the eyes look (GET /v1/rigs/{id} says how: eye bones, eye shapes or look expressions): a target "
                               "point of the rig's world, or angles from straight ahead. A rig with no eyes warns gaze_unsupported"},
               {"properties", {{"target", point3},
                               {"yaw", {{"type", "number"}, {"minimum", -180}, {"maximum", 180}, {"description", "Degrees, > 0 to the character's left"}}},
                               {"pitch", {{"type", "number"}, {"minimum", -180}, {"maximum", 180}, {"description", "Degrees, > 0 up"}}}}}};
  json expressions = {{"type", "object"},
                      {"additionalProperties", {{"type", "number"}}},
                      {"description", "Expressions by name: VRM 1.0's presets (happy, angry, sad, relaxed, surprised, aa, ih, ou, ee, oh, "
                                      "blink, blinkLeft, blinkRight, lookUp, lookDown, lookLeft, lookRight, neutral) or the rig's own, "
                                      "each a value in [0, 1] added to the weights of the shapes it maps (GET /v1/rigs/{id}, "
                                      "\"expressions\"), with VRM's override rules; a preset the rig does not map warns expression_unmapped"}};
  json skeleton_props = {{"pose", pose},
                         {"expressions", expressions},
                         {"gaze", gaze},
                         {"animation", clip_ref},
                         {"time", {{"type", "number"}, {"description", "Seconds into the animation"}}},
                         {"motion", clip_ref},
                         {"frame", {{"type", "number"}, {"description", "The time in MMD frames, 30 a second (instead of time)"}}},
                         {"loop", {{"type", "boolean"}, {"default", false}}},
                         {"blend", blend},
                         {"layers", layers},
                         {"skinning", {{"enum", {"linear", "dual_quaternion"}}, {"default", "linear"}}},
                         {"lod", {{"type", "integer"}, {"minimum", 0}, {"maximum", 4}, {"default", 0},
                                  {"description", "Level of detail: 0 full, L about 1/2^L of the triangles (a subset of the vertices)"}}}};
  json controls_schema = {{"type", "object"}, {"additionalProperties", {{"type", "number"}}},
                          {"description", "Control values by name (the rig route lists controls): a two-sided control v < 0 "
                                          "drives its negative shape with -v, v > 0 its positive shape"}};
  json mesh_request = {{"type", "object"},
                       {"properties",
                        {{"weights", weights},
                         {"controls", controls_schema},
                         {"mode", {{"enum", {"relative", "absolute"}}, {"default", "relative"}}},
                         {"normals", {{"enum", {"blend", "recompute"}}, {"default", "blend"}}},
                         {"format", {{"enum", {"glb", "obj", "json", "f32", "vrm"}}}},
                         {"space", {{"enum", {"world", "mesh"}}, {"default", "world"}}},
                         {"strict", {{"type", "boolean"}, {"default", false}}},
                         {"keep_targets", {{"type", "boolean"}, {"default", false}}}}}};
  json warning = {{"type", "object"},
                  {"required", {"code", "message"}},
                  {"properties",
                   {{"code", {{"type", "string"}}},
                    {"message", {{"type", "string"}}},
                    {"shape", {{"type", "string"}}},
                    {"value", {{"type", "number"}}}}}};
  json problem = {{"type", "object"},
                  {"required", {"type", "title", "status", "detail"}},
                  {"properties",
                   {{"type", {{"type", "string"}}},
                    {"title", {{"type", "string"}}},
                    {"status", {{"type", "integer"}}},
                    {"detail", {{"type", "string"}}},
                    {"instance", {{"type", "string"}}},
                    {"errors",
                     {{"type", "array"},
                      {"items", {{"type", "object"},
                                 {"properties", {{"pointer", {{"type", "string"}}},
                                                 {"parameter", {{"type", "string"}}},
                                                 {"detail", {{"type", "string"}}}}}}}}},
                    {"warnings", {{"type", "array"}, {"items", {{"$ref", "#/components/schemas/Warning"}}}}}}}};
  json camera = {{"type", "object"},
                 {"additionalProperties", false},
                 {"properties", {{"yaw", {{"type", "number"}, {"minimum", -3600}, {"maximum", 3600}, {"default", 0}, {"description", "Degrees around the vertical axis; 0 looks at the front"}}},
                                 {"pitch", {{"type", "number"}, {"minimum", -3600}, {"maximum", 3600}, {"default", 0}, {"description", "Degrees up (positive) or down"}}},
                                 {"distance", {{"type", "number"}, {"minimum", 0}, {"default", 0}, {"description", "From the framed centre, scene units; 0 fits the framed part"}}},
                                 {"zoom", {{"type", "number"}, {"minimum", 0.01}, {"maximum", 100}, {"default", 1}, {"description", "Divides the distance"}}},
                                 {"fov", {{"type", "number"}, {"minimum", 1}, {"maximum", 170}, {"default", 30}, {"description", "Vertical field of view, degrees"}}},
                                 {"frame", {{"type", "string"}, {"pattern", "^(all|shapes|auto|joint:.+)$"}, {"default", "auto"},
                                            {"description", "Orbit around every vertex (of the rest shape unless posed: still while weights "
                                                            "change), around those the shapes move, around those a joint carries "
                                                            "(joint:NAME), or (auto) around the shapes' when they are a small part of the rig "
                                                            "(a face on a body; on a skinned body the joint carrying them, which a pose "
                                                            "carries along), else every vertex"}}},
                                 {"eye", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}, {"description", "Look-at camera: where it stands (with target)"}}},
                                 {"target", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}, {"description", "Look-at camera: what it looks at"}}},
                                 {"up", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}, {"default", json::array({0, 1, 0})}}}}}};
  json render_props = {{"weights", weights},
                       {"controls", controls_schema},
                       {"mode", {{"enum", {"relative", "absolute"}}}},
                       {"normals", {{"enum", {"blend", "recompute"}}}},
                       {"strict", {{"type", "boolean"}}},
                       {"camera", {{"$ref", "#/components/schemas/Camera"}}},
                       {"width", {{"type", "integer"}, {"minimum", 1}, {"default", 512}}},
                       {"height", {{"type", "integer"}, {"minimum", 1}, {"default", 512}}},
                       {"view", {{"enum", {"shaded", "wireframe", "heatmap", "normals", "clay"}}, {"default", "shaded"}}},
                       {"background", {{"oneOf", json::array({json{{"type", "string"}}, json{{"type", "array"}, {"items", {{"type", "number"}}}}})}}},
                       {"supersample", {{"type", "integer"}, {"minimum", 1}, {"maximum", 4}}},
                       {"format", {{"enum", {"png", "jpeg", "exr", "tiff", "webp"}}}},
                       {"quality", {{"type", "integer"}, {"minimum", 1}, {"maximum", 100}}},
                       {"exposure", {{"type", "number"}, {"minimum", -10}, {"maximum", 10}, {"default", 0}}}};
  for (auto it = skeleton_props.begin(); it != skeleton_props.end(); ++it) {
    mesh_request["properties"][it.key()] = it.value();
    render_props[it.key()] = it.value();
  }
  json render_request = {{"type", "object"}, {"properties", render_props}};
  json sheet_props = render_props;
  sheet_props.erase("weights");
  sheet_props["columns"] = {{"type", "integer"}, {"minimum", 1}, {"maximum", 64}};
  sheet_props["cells"] = {{"oneOf", json::array({json{{"type", "array"},
                                                        {"items", {{"type", "object"}, {"properties", {{"weights", weights}, {"label", {{"type", "string"}}}}}}}},
                                                   json{{"type", "string"}, {"pattern", "^shapes(:.+)?$"},
                                                        {"description", "One cell per shape (of a group) at 1"}}})}};
  json sheet_request = {{"type", "object"}, {"required", {"cells"}}, {"properties", sheet_props}};
  json sequence_request = {
      {"type", "object"},
      {"properties",
       {{"motion", clip_ref},
        {"animation", clip_ref},
        {"keys", {{"type", "array"},
                  {"items", {{"type", "object"},
                             {"required", {"time"}},
                             {"properties", {{"time", {{"type", "number"}}}, {"weights", weights}, {"shape", {{"type", "string"}}},
                                             {"expressions", expressions}, {"transition", {{"type", "string"}}}}}}}}},
        {"gaze", {{"oneOf", json::array({gaze, json{{"type", "object"},
                                                    {"required", {"keys"}},
                                                    {"description", "A gaze track: linear between its keys, held past its ends"},
                                                    {"properties", {{"keys", {{"type", "array"}, {"items", {{"type", "object"}, {"required", {"time"}},
                                                                                                             {"properties", {{"time", {{"type", "number"}}}, {"target", point3},
                                                                                                                             {"yaw", {{"type", "number"}}}, {"pitch", {{"type", "number"}}}}}}}}}}}}})}}},
        {"blink", {{"type", "object"},
                   {"description", "Natural blinks through the rig's blink expression: one at a random moment of each 60 / per_minute "
                                   "seconds, closing fast and opening slower; the same seed gives the same blinks"},
                   {"properties", {{"per_minute", {{"type", "number"}, {"exclusiveMinimum", 0}, {"maximum", 60}, {"default", 15}}},
                                   {"seed", {{"type", "integer"}, {"minimum", 0}, {"default", 1}}}}}}},
        {"transition", {{"type", "string"}, {"description", "step, linear, smoothstep, smootherstep, ease-in, ease-out, ease-in-out, cubic-bezier(x1, y1, x2, y2)"}}},
        {"smooth", {{"type", "boolean"}, {"description", "Catmull-Rom through the keys"}}},
        {"physics", {{"type", "boolean"}, {"default", true}, {"description", "simulate the rig's rigid bodies (MMD hair, ears, skirts) over a sequence that plays a motion or layers; false: they follow their bones"}}},
        {"times", {{"type", "array"}, {"items", {{"type", "number"}}}}},
        {"fps", {{"type", "number"}}},
        {"format", {{"enum", {"json", "weights", "ndjson", "f32"}},
                    {"description", "sample: json (each frame's mesh) or weights (each frame's weights, sum and pose, no mesh); stream: ndjson (= weights) or f32"}}},
        {"tolerance", {{"type", "number"}, {"minimum", 0}}},
        {"mode", {{"enum", {"relative", "absolute"}}}},
        {"normals", {{"enum", {"blend", "recompute"}}}}}}};
  json mesh_json = {{"type", "object"},
                    {"properties",
                     {{"space", {{"enum", {"world", "mesh"}}}},
                      {"primitives",
                       {{"type", "array"},
                        {"items", {{"type", "object"},
                                   {"properties", {{"mesh", {{"type", "integer"}}},
                                                   {"primitive", {{"type", "integer"}}},
                                                   {"name", {{"type", "string"}}},
                                                   {"positions", {{"type", "array"}, {"items", {{"type", "number"}}}}},
                                                   {"normals", {{"type", "array"}, {"items", {{"type", "number"}}}}}}}}}}},
                      {"warnings", {{"type", "array"}, {"items", {{"$ref", "#/components/schemas/Warning"}}}}}}}};
  json weights_object = {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}};
  json variant_item = {{"type", "object"},
                       {"required", {"weights"}},
                       {"properties", {{"id", {{"type", "string"}, {"pattern", "^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"}}},
                                       {"weights", {{"oneOf", {weights_object, {{"type", "array"}, {"items", {{"type", "number"}}}}}}}}}}};
  json sample = {{"type", "object"},
                 {"required", {"method"}},
                 {"properties", {{"method", {{"enum", {"uniform", "gaussian", "grid", "convex"}}}},
                                 {"count", {{"type", "integer"}, {"minimum", 1}}},
                                 {"seed", {{"type", "integer"}, {"minimum", 0}}},
                                 {"shapes", {{"type", "array"}, {"items", {{"type", "string"}}}}},
                                 {"fixed", weights_object},
                                 {"center", weights_object},
                                 {"spread", {{"type", "number"}, {"minimum", 0}}},
                                 {"points", {{"type", "array"}, {"items", weights_object}, {"minItems", 2}, {"maxItems", 3}}},
                                 {"active", {{"type", "integer"}, {"minimum", 0}}},
                                 {"symmetric", {{"type", "boolean"}}},
                                 {"sum_at_most_one", {{"type", "boolean"}}}}}};
  json batch_request = {
      {"type", "object"},
      {"description", "Exactly one of variants or sample. Also takes mode, normals, skinning, pose, animation/time, and the "
                      "render settings (width, height, view, camera, background, supersample, quality) for image formats."},
      {"properties", {{"variants", {{"type", "array"}, {"items", variant_item}}},
                      {"sample", sample},
                      {"format", {{"enum", {"glb", "obj", "json", "f32", "vrm", "png", "jpeg", "exr", "tiff", "webp"}}}}}}};
  const json number = {{"type", "number"}}, integer = {{"type", "integer"}}, string = {{"type", "string"}}, boolean = {{"type", "boolean"}};
  const json vec3 = {{"type", "array"}, {"items", number}, {"minItems", 3}, {"maxItems", 3}};
  const json box = {{"type", "object"}, {"properties", {{"min", vec3}, {"max", vec3}}}};
  auto array_of = [](json items) { return json{{"type", "array"}, {"items", std::move(items)}}; };
  auto ref = [](const char* name) { return json{{"$ref", std::string("#/components/schemas/") + name}}; };
  json rig_summary = {{"type", "object"},
                      {"required", {"id", "name", "vertices", "triangles", "shapes", "primitives", "has_skeleton", "version"}},
                      {"properties", {{"id", string}, {"name", string}, {"vertices", integer}, {"triangles", integer},
                                      {"shapes", integer}, {"primitives", integer}, {"has_skeleton", boolean},
                                      {"version", {{"type", "string"}, {"description", "Changes with the rig file or its manifest (the ETag)"}}},
                                      {"credit", {{"type", "string"}, {"description", "The credit the rig's license asks for: show it with the rig"}}}}}};
  json shape = {{"type", "object"},
                {"properties", {{"index", integer}, {"name", string}, {"group", string}, {"min", number}, {"max", number},
                                {"default", number}, {"vertices_moved", integer}, {"partner", {{"type", {"string", "null"}}}},
                                {"aliases", array_of(string)}, {"driven", boolean}}}};
  json rig = {{"type", "object"},
              {"properties",
               {{"id", string}, {"name", string}, {"version", string}, {"credit", string}, {"vertices", integer}, {"triangles", integer},
                {"has_skeleton", boolean}, {"start", {{"enum", {"neutral", "defaults"}}}},
                {"shapes", array_of(shape)},
                {"bounding_box", box},
                {"primitives", array_of({{"type", "object"},
                                         {"properties", {{"mesh", integer}, {"primitive", integer}, {"name", string}, {"vertices", integer},
                                                         {"triangles", integer}, {"material", integer}, {"has_normals", boolean},
                                                         {"has_tangents", boolean}}}})},
                {"skeleton", {{"type", {"object", "null"}}}},
                {"animations", array_of({{"type", "object"},
                                         {"properties", {{"index", integer}, {"name", string}, {"duration", number}, {"channels", integer},
                                                         {"morph_weights", boolean}}}})},
                {"controls", array_of({{"type", "object"}})},
                {"inbetweens", array_of({{"type", "object"}})},
                {"correctives", array_of({{"type", "object"}})},
                {"statistics", {{"type", {"object", "null"}}}},
                {"expressions", {{"type", "object"},
                                 {"description", "Name -> what it maps (the manifest's, else derived from ARKit or MMD shape names)"},
                                 {"additionalProperties", {{"type", "object"},
                                                           {"properties", {{"weights", WeightsObject()}, {"binary", boolean},
                                                                           {"override_blink", {{"enum", {"none", "block", "blend"}}}},
                                                                           {"override_look_at", {{"enum", {"none", "block", "blend"}}}},
                                                                           {"override_mouth", {{"enum", {"none", "block", "blend"}}}},
                                                                           {"derived", boolean}}}}}}},
                {"gaze", {{"type", "object"},
                          {"properties", {{"type", {{"enum", {"bones", "shapes", "expressions", "none"}}}}, {"eyes", {{"type", "object"}}},
                                          {"shapes", {{"type", "object"}}}, {"head", {{"type", "object"}}}, {"neck", {{"type", "object"}}},
                                          {"range_maps", {{"type", "object"}}}, {"origin", array_of(number)}}}}},
                {"load_warnings", array_of(ref("Warning"))}}}};
  json manifest = {{"type", "object"},
                   {"additionalProperties", false},
                   {"description", "What a rig file does not say (core/README.md, \"Manifest\"); an unknown member is refused"},
                   {"properties", {{"name", string}, {"credit", string}, {"start", {{"enum", {"neutral", "defaults"}}}},
                                   {"shapes", {{"type", "object"}, {"additionalProperties", {{"type", "object"}}}}},
                                   {"groups", {{"type", "object"}, {"additionalProperties", array_of(string)}}},
                                   {"controls", {{"type", "object"}}}, {"derived", {{"type", "object"}}},
                                   {"inbetweens", {{"type", "object"}}}, {"correctives", {{"type", "object"}}},
                                   {"statistics", {{"type", "object"}}}, {"expressions", {{"type", "object"}}}, {"gaze", {{"type", "object"}}},
                                   {"base_motion", string}, {"materials", {{"type", "object"}}}}}};
  json check = {{"type", "object"},
                {"required", {"sum", "weights", "warnings"}},
                {"properties", {{"sum", number}, {"weights", WeightsObject()}, {"warnings", array_of(ref("Warning"))},
                                {"mahalanobis", {{"type", "number"}, {"description", "With manifest statistics: distance from the mean in standard deviations"}}}}}};
  json fit = {{"type", "object"},
              {"required", {"weights", "residual", "warnings"}},
              {"properties", {{"weights", WeightsObject()},
                              {"residual", {{"type", "object"}, {"properties", {{"rms", number}, {"max", number}}}}},
                              {"warnings", array_of(ref("Warning"))}}}};
  json topology = {{"type", "object"},
                   {"required", {"primitives"}},
                   {"properties", {{"primitives", array_of({{"type", "object"},
                                                            {"properties", {{"mesh", integer}, {"primitive", integer}, {"vertices", integer},
                                                                            {"mode", integer}, {"indices", array_of(integer)},
                                                                            {"color", {{"type", "array"}, {"items", number}, {"minItems", 4}, {"maxItems", 4},
                                                                                       {"description", "Linear RGBA a client drawing no textures shows: the material's base colour times its texture's mean; alpha 0 is see-through (a material morph shows it)"}}}}}})},
                                   {"focus", box}}}};
  json frames = {{"type", "object"},
                 {"required", {"frames"}},
                 {"properties", {{"space", {{"enum", {"world"}}}},
                                 {"format", {{"enum", {"weights"}}, {"description", "Present when the frames are weights alone"}}},
                                 {"frames", array_of({{"type", "object"},
                                                      {"properties", {{"time", number}, {"weights", WeightsObject()}, {"sum", number},
                                                                      {"pose", {{"type", "object"},
                                                                                {"description", "format weights, posed frames: the nodes moved from rest, by name"},
                                                                                {"additionalProperties", {{"type", "object"},
                                                                                                          {"properties", {{"translation", array_of(number)},
                                                                                                                          {"rotation", array_of(number)},
                                                                                                                          {"scale", array_of(number)}}}}}}},
                                                                      {"primitives", {{"type", "array"}}}}}})},
                                 {"warnings", array_of(ref("Warning"))}}}};
  json reduced = {{"type", "object"},
                  {"properties", {{"keys", {{"type", "array"}}}, {"transition", string}, {"kept", integer}, {"removed", integer},
                                  {"max_error", number}, {"tolerance", number}}}};
  json health = {{"type", "object"}, {"required", {"status"}}, {"properties", {{"status", string}, {"rigs", integer}}}};
  json job = {{"type", "object"},
              {"properties", {{"id", {{"type", "string"}}}, {"rig", {{"type", "string"}}},
                              {"state", {{"enum", {"queued", "running", "done", "failed", "cancelled", "lost"}}}},
                              {"format", {{"type", "string"}}}, {"created", {{"type", "string"}, {"format", "date-time"}}},
                              {"total", {{"type", "integer"}}}, {"done", {{"type", "integer"}}}, {"progress", {{"type", "number"}}},
                              {"rate", {{"type", "number"}}}, {"eta_seconds", {{"type", "number"}}}, {"error", {{"type", "string"}}},
                              {"links", {{"type", "object"}}}}}};
  json ok_json = {{"description", "OK"}, {"content", {{"application/json", {{"schema", {{"type", "object"}}}}}}}};
  // A 200 (or `code`) whose JSON body is the component `name`.
  auto json_ok = [](const char* name, const char* description = "OK") {
    return json{{"description", description},
                {"content", {{"application/json", {{"schema", {{"$ref", std::string("#/components/schemas/") + name}}}}}}}};
  };
  json auth = json::array({{{"bearer", json::array()}}});
  json operations = {
      {"/healthz", {{"get", {{"summary", "Liveness"}, {"operationId", "healthz"}, {"responses", {{"200", json_ok("Health")}}}}}}},
      {"/readyz", {{"get", {{"summary", "Readiness (rigs loaded)"}, {"operationId", "readyz"}, {"responses", {{"200", json_ok("Health")}}}}}}},
      {"/metrics",
       {{"get", {{"summary", "Prometheus metrics"}, {"operationId", "metrics"},
                 {"responses", {{"200", {{"description", "Prometheus text"}, {"content", {{"text/plain", {{"schema", {{"type", "string"}}}}}}}}}}}}}}},
      {"/openapi.json", {{"get", {{"summary", "This document"}, {"operationId", "openapi"}, {"responses", {{"200", ok_json}}}}}}},
      {"/v1/rigs", {{"get", {{"summary", "List rigs"}, {"operationId", "listRigs"}, {"responses", {{"200", json_ok("RigList")}}}}}}},
      {"/v1/rigs/{id}",
       {{"parameters", json::array({IdParam()})},
        {"get", {{"summary", "A rig: shapes, bounding box, primitives, skeleton"}, {"operationId", "getRig"},
                 {"responses", {{"200", json_ok("Rig")}, {"404", Problem("Unknown rig")}}}}},
        {"put", {{"summary", "Upload or replace a rig (validated fully, stored atomically)"}, {"operationId", "putRig"},
                 {"security", auth},
                 {"requestBody", {{"required", true},
                                  {"description", "glb, glTF with embedded buffers, COLLADA, or (as application/octet-stream with a "
                                                   "file name in Content-Disposition or ?filename=, else told by its magic) FBX, .dae, .glb, .gltf"},
                                  {"content", {{"model/gltf-binary", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                               {"model/gltf+json", {{"schema", {{"type", "object"}}}}},
                                               {"model/vnd.collada+xml", {{"schema", {{"type", "string"}}}}},
                                               {"application/octet-stream", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                               {"multipart/form-data",
                                                {{"schema", {{"type", "object"}, {"required", {"rig"}},
                                                             {"properties", {{"rig", {{"type", "string"}, {"contentEncoding", "binary"},
                                                                                      {"description", "The rig file (its part's file name or type says the format)"}}},
                                                                             {"manifest", {{"$ref", "#/components/schemas/Manifest"}}}}}}},
                                                 {"encoding", {{"manifest", {{"contentType", "application/json"}}}}}}}}}}},
                 {"responses", {{"200", json_ok("RigSummary", "Replaced")}, {"201", json_ok("RigSummary", "Created")}, {"401", Problem("No API key")}, {"403", Problem("Wrong API key")},
                                {"413", Problem("Body over the limit")}, {"415", Problem("Not a rig media type (or an octet stream of no known rig format)")},
                                {"409", Problem("A bundled rig: read-only")},
                                {"422", Problem("Invalid rig, manifest or id")}, {"500", Problem("The store could not write the rig")},
                                {"507", Problem("The store's disk is full: nothing was written, the old rig is kept")}}}}},
        {"delete", {{"summary", "Delete a rig"}, {"operationId", "deleteRig"}, {"security", auth},
                    {"responses", {{"204", {{"description", "Deleted"}}}, {"401", Problem("No API key")},
                                   {"403", Problem("Wrong API key")}, {"404", Problem("Unknown rig")},
                                   {"409", Problem("A bundled rig: read-only")}}}}}}},
      {"/v1/rigs/{id}/manifest",
       {{"parameters", json::array({IdParam()})},
        {"get", {{"summary", "A rig's manifest: name, credit, shape groups, ranges, partners, controls, in-betweens (README \"Manifest\")"},
                 {"operationId", "getManifest"},
                 {"responses", {{"200", json_ok("Manifest")}, {"404", Problem("Unknown rig")}}}}},
        {"put", {{"summary", "Replace an uploaded rig's manifest (validated against the rig first; the rig file unchanged)"},
                 {"operationId", "putManifest"}, {"security", auth},
                 {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Manifest"}}}}}}}}},
                 {"responses", {{"200", json_ok("RigSummary")}, {"400", Problem("Malformed JSON")}, {"401", Problem("No API key")},
                                {"403", Problem("Wrong API key")}, {"404", Problem("Unknown rig")},
                                {"409", Problem("A bundled rig: read-only")}, {"415", Problem("Not application/json")},
                                {"422", Problem("The manifest does not apply to the rig (names the member)")},
                                {"507", Problem("The store's disk is full: nothing was written")}}}}}}},
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
      {"/v1/rigs/{id}/sequence/sample",
       {{"post", {{"summary", "Sample a keyframe sequence at given times: weights and meshes"}, {"operationId", "sampleSequence"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/SequenceRequest"}}}}}}}}},
                  {"responses", {{"200", json_ok("SequenceFrames")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
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
                  {"responses", {{"200", json_ok("Reduced")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid keys or tolerance")}}}}}}},
      {"/v1/rigs/{id}/speech",
       {{"post",
         {{"summary", "Lip sync: text (espeak-ng) or recorded speech (PocketSphinx) to phonemes, visemes and keys on the rig, as JSON, a stream of frames, "
                      "the audio (WAV) or a video (WebM: VP9 + Opus)"},
          {"operationId", "speak"},
          {"parameters", json::array({IdParam()})},
          {"requestBody",
           {{"required", true},
            {"content",
             {{"application/json",
               {{"schema",
                 {{"type", "object"},
                  {"properties",
                   {{"text", {{"type", "string"}, {"maxLength", 2000}, {"description", "Words to say (espeak-ng); or audio"}}},
                    {"audio", {{"type", "string"}, {"contentEncoding", "base64"}, {"description", "A WAV file (at most 60 s) to lip-sync"}}},
                    {"transcript", {{"type", "string"}, {"description", "With audio: the words said, to align to"}}},
                    {"voice", {{"type", "string"}, {"default", kDefaultVoice}, {"description", "An espeak-ng voice (GET /v1/voices)"}}},
                    {"rate", {{"type", "integer"}, {"minimum", 80}, {"maximum", 450}, {"default", 175}}},
                    {"fps", {{"type", "number"}, {"minimum", 1}, {"maximum", 120}, {"default", 30}}},
                    {"strength", {{"type", "number"}, {"minimum", 0}, {"maximum", 2}, {"default", 1}}},
                    {"format", {{"type", "string"}, {"enum", {"json", "ndjson", "f32", "weights", "wav", "webm"}}, {"default", "json"}}},
                    {"with_audio", {{"type", "boolean"}, {"description", "json: the audio too, as audio_wav (base64 WAV)"}}},
                    {"weights", {{"description", "The face under the speech, as on the mesh route"}}},
                    {"expressions", {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}},
                    {"gaze", {{"type", "object"}}},
                    {"blink", {{"type", "object"}}},
                    {"width", {{"type", "integer"}}},
                    {"height", {{"type", "integer"}}},
                    {"camera", {{"type", "object"}}}}}}}}},
              {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
          {"responses",
           {{"200", {{"description", "json: phonemes, visemes ({viseme, start, end}) and keys; ndjson/weights/f32: the frames streamed; wav; webm"},
                     {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Speech"}}}}},
                                  {"application/x-ndjson", {{"schema", {{"type", "string"}}}}},
                                  {"audio/wav", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}},
                                  {"video/webm", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
            {"400", Problem("Malformed JSON")},
            {"404", Problem("Unknown rig")},
            {"413", Problem("Audio too long")},
            {"422", Problem("Empty or too long text, unknown voice, not audio, a rig without a mouth")},
            {"503", Problem("The speech engine is busy")}}}}}}},
      {"/v1/voices",
       {{"get", {{"summary", "The voices text can be spoken with (espeak-ng's)"},
                 {"operationId", "listVoices"},
                 {"responses", {{"200", json_ok("Voices")}}}}}}},
      {"/v1/rigs/{id}/fit",
       {{"post", {{"summary", "Weights that best reproduce a target mesh (least squares), with residual and warnings"},
                  {"operationId", "fit"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true},
                                   {"content", {{"application/json",
                                                 {{"schema", {{"type", "object"},
                                                              {"required", {"target"}},
                                                              {"properties", {{"target", {{"$ref", "#/components/schemas/MeshJson"}}},
                                                                              {"bounded", {{"type", "boolean"}}},
                                                                              {"sum_at_most_one", {{"type", "boolean"}}},
                                                                              {"rigid_align", {{"type", "boolean"}}}}}}}}}}}}},
                  {"responses", {{"200", json_ok("Fit")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("A target that does not match the rig")}}}}}}},
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
      {"/v1/rigs/{id}/batch",
       {{"post", {{"summary", "Start a batch job: many variants (listed, or sampled uniform/gaussian/grid/convex with a seed) as files"},
                  {"operationId", "startBatch"},
                  {"security", auth},
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
      {"/v1/jobs", {{"get", {{"summary", "List batch jobs, newest first"}, {"operationId", "listJobs"}, {"responses", {{"200", json_ok("JobList")}}}}}}},
      {"/v1/jobs/{job}",
       {{"get", {{"summary", "A job's state and progress (queued, running, done, failed, cancelled, lost)"}, {"operationId", "getJob"},
                 {"parameters", json::array({JobParam()})},
                 {"responses", {{"200", {{"description", "OK"}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/Job"}}}}}}}}},
                                {"404", Problem("Unknown job")}}}}},
        {"delete", {{"summary", "Cancel a job and delete its files"}, {"operationId", "deleteJob"}, {"security", auth},
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
                 {"responses", {{"200", {{"description", "The file"}}}, {"404", Problem("Unknown job or file")}}}}}}},
      {"/v1/jobs/{job}/results.zip",
       {{"get", {{"summary", "Every file of a finished job as one zip archive (streamed)"}, {"operationId", "getJobResults"},
                 {"parameters", json::array({JobParam()})},
                 {"responses", {{"200", {{"description", "Zip archive"}, {"content", {{"application/zip", {{"schema", {{"type", "string"}, {"contentEncoding", "binary"}}}}}}}}},
                                {"404", Problem("Unknown job")}, {"409", Problem("The job is not done")}}}}}}},
      {"/v1/rigs/{id}/check",
       {{"post", {{"summary", "Validate weights only: sum and warnings"}, {"operationId", "checkWeights"},
                  {"parameters", json::array({IdParam()})},
                  {"requestBody", {{"required", true}, {"content", {{"application/json", {{"schema", {{"$ref", "#/components/schemas/MeshRequest"}}}}}}}}},
                  {"responses", {{"200", json_ok("Check")}, {"400", Problem("Malformed JSON")}, {"404", Problem("Unknown rig")},
                                 {"422", Problem("Invalid weights")}}}}}}},
  };
  return {{"openapi", "3.1.0"},
          {"info", {{"title", "facespace"}, {"version", FACESPACE_VERSION},
                    {"description", "Blend-shape rigs over HTTP: blended meshes with warnings when a point leaves the authored space. "
                                    "Errors are RFC 9457 problem details. A method a path does not list answers 405 with an Allow "
                                    "header; too many connections (from one address or in all) answer 503 with Retry-After."}}},
          {"paths", PathsOfRoutes(operations)},
          {"components",
           {{"schemas", {{"MeshRequest", mesh_request}, {"RenderRequest", render_request}, {"SheetRequest", sheet_request},
                        {"SequenceRequest", sequence_request}, {"BatchRequest", batch_request}, {"Job", job},
                        {"Warning", warning}, {"Problem", problem}, {"MeshJson", mesh_json}, {"RigSummary", rig_summary},
                        {"RigList", {{"type", "object"}, {"required", {"rigs"}}, {"properties", {{"rigs", array_of(ref("RigSummary"))}}}}},
                        {"Rig", rig}, {"Manifest", manifest}, {"Check", check}, {"Fit", fit}, {"Topology", topology},
                        {"SequenceFrames", frames}, {"Reduced", reduced}, {"Health", health}, {"Camera", camera},
                        {"JobList", {{"type", "object"}, {"required", {"jobs"}}, {"properties", {{"jobs", array_of(ref("Job"))}}}}},
                        {"Voices", {{"type", "object"}, {"required", {"voices"}},
                                    {"properties", {{"voices", array_of(json{{"type", "object"}, {"properties", {{"name", {{"type", "string"}}}, {"language", {{"type", "string"}}}}}})},
                                                    {"default", {{"type", "string"}}}}}}},
                        {"Speech", {{"type", "object"}, {"required", {"phonemes", "visemes", "keys", "duration"}},
                                    {"properties", {{"source", {{"type", "string"}, {"enum", {"espeak-ng", "pocketsphinx", "pocketsphinx-aligned"}}}},
                                                    {"voice", {{"type", "string"}}},
                                                    {"duration", {{"type", "number"}}},
                                                    {"phonemes", array_of(json{{"type", "object"}, {"required", {"name", "start", "end"}}})},
                                                    {"visemes", array_of(json{{"type", "object"}, {"required", {"viseme", "start", "end"}},
                                                                          {"properties", {{"viseme", {{"type", "string"}, {"enum", {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"}}}}}}})},
                                                    {"keys", {{"type", "array"}}},
                                                    {"warnings", array_of(ref("Warning"))}}}}}}},
            {"securitySchemes", {{"bearer", {{"type", "http"}, {"scheme", "bearer"}}}}}}}};
}

}  // namespace

std::string OpenApiJson(const ApiOptions& limits) {
  json doc = Build();
  const std::string body = std::to_string(limits.max_body), response = std::to_string(limits.max_response);
  const std::string render = std::to_string(limits.max_render_size), cells = std::to_string(limits.max_sheet_cells);
  const std::string frames = std::to_string(limits.max_frames);
  doc["info"]["description"] = doc["info"]["description"].get<std::string>() +
                               "\n\nLimits of this server (its flags): request bodies up to " + body + " bytes (--max-body; over: 413), "
                               "renders up to " + render + " pixels a side (--max-render; over: 422 image-too-large), contact sheets up to " +
                               cells + " cells (--max-sheet-cells; 422), sequence/sample bodies up to " + response +
                               " bytes (--max-response; over: 422 response-too-large, judged before the work), sequence streams up to " +
                               frames + " frames (--max-frames; 422 too-many-frames). Every answer states its estimated CPU-seconds in "
                               "Facespace-Cost; work over --anonymous-cpu without the API key (--keyed-cpu with it) is 422 over-budget, "
                               "before any of it is done.";
  doc["info"]["x-facespace-limits"] = {{"max_body", limits.max_body}, {"max_render", limits.max_render_size},
                                       {"max_sheet_cells", limits.max_sheet_cells}, {"max_response", limits.max_response},
                                       {"max_frames", limits.max_frames}, {"anonymous_cpu_seconds", limits.anonymous_cpu},
                                       {"keyed_cpu_seconds", limits.keyed_cpu}};
  json& schemas = doc["components"]["schemas"];
  for (const char* schema : {"RenderRequest", "SheetRequest"}) {
    for (const char* side : {"width", "height"}) schemas[schema]["properties"][side]["maximum"] = limits.max_render_size;
  }
  schemas["SheetRequest"]["properties"]["cells"]["oneOf"][0]["maxItems"] = limits.max_sheet_cells;
  return doc.dump(1);
}

}  // namespace facespace::api
