// The document's schemas (components.schemas), each a function named as its component; the operations
// (operations.cpp) refer to them by $ref.
#include "openapi.h"

namespace facespace::api::openapi {

namespace {


// ---- plain types ----

json Number() { return {{"type", "number"}}; }
json Integer() { return {{"type", "integer"}}; }
json String() { return {{"type", "string"}}; }
json Boolean() { return {{"type", "boolean"}}; }
json Vec3() { return {{"type", "array"}, {"items", Number()}, {"minItems", 3}, {"maxItems", 3}}; }
json Box() { return {{"type", "object"}, {"properties", {{"min", Vec3()}, {"max", Vec3()}}}}; }
json ArrayOf(json items) { return json{{"type", "array"}, {"items", std::move(items)}}; }
json Ref(const char* name) { return json{{"$ref", std::string("#/components/schemas/") + name}}; }
json WeightsObject() { return {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}}; }

// ---- a point of face space: weights, controls, the skeleton's settings ----

json Weights() {
  return {{"oneOf", json::array({json{{"type", "array"}, {"items", {{"type", "number"}}},
                                        {"description", "Dense, in shape order"}},
                                   json{{"type", "object"}, {"additionalProperties", {{"type", "number"}}},
                                        {"description", "By shape name, alias or index"}}})}};
}

json Pose() {
  return {{"type", "object"},
          {"description", "Joint name -> local transform parts that replace the rest values"},
          {"additionalProperties",
           {{"type", "object"},
            {"properties", {{"rotation", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 4}, {"maxItems", 4}}},
                            {"euler", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}},
                            {"translation", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}},
                            {"scale", {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}}}}}}}};
}

json ClipRef() {
  return {{"oneOf", json::array({json{{"type", "string"}}, json{{"type", "integer"}, {"minimum", 0}}})}};
}

json Blend() {
  return {{"type", "array"},
          {"items", {{"type", "object"},
                     {"required", {"animation"}},
                     {"properties", {{"animation", ClipRef()}, {"time", {{"type", "number"}}}, {"weight", {{"type", "number"}}},
                                     {"loop", {{"type", "boolean"}}},
                                     {"mask", {{"type", "array"}, {"items", {{"type", "string"}}}}}}}}}};
}

json Layers() {
  return {{"type", "array"},
          {"minItems", 1},
          {"maxItems", 16},
          {"description", "Motions stacked: the first the base, each later one an overlay replacing, by its weight, only the "
                          "joints and shapes its clip moves"},
          {"items", {{"type", "object"},
                     {"properties", {{"motion", ClipRef()}, {"animation", ClipRef()}, {"time", {{"type", "number"}}},
                                     {"frame", {{"type", "number"}}}, {"weight", {{"type", "number"}, {"minimum", 0}}},
                                     {"loop", {{"type", "boolean"}}}, {"fade_in", {{"type", "number"}, {"minimum", 0}}},
                                     {"fade_out", {{"type", "number"}, {"minimum", 0}}},
                                     {"mask", {{"type", "array"}, {"items", {{"type", "string"}}}}}}}}}};
}

json Point3() {
  return {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 3}, {"maxItems", 3}};
}

json Gaze() {
  return {{"type", "object"},
          {"description", "Where the eyes look (GET /v1/rigs/{id} says how: eye bones, eye shapes or look expressions): a target "
                          "point of the rig's world, or angles from straight ahead. A rig with no eyes warns gaze_unsupported"},
          {"properties", {{"target", Point3()},
                          {"yaw", {{"type", "number"}, {"minimum", -180}, {"maximum", 180}, {"description", "Degrees, > 0 to the character's left"}}},
                          {"pitch", {{"type", "number"}, {"minimum", -180}, {"maximum", 180}, {"description", "Degrees, > 0 up"}}}}}};
}

json Expressions() {
  return {{"type", "object"},
          {"additionalProperties", {{"type", "number"}}},
          {"description", "Expressions by name: VRM 1.0's presets (happy, angry, sad, relaxed, surprised, aa, ih, ou, ee, oh, "
                          "blink, blinkLeft, blinkRight, lookUp, lookDown, lookLeft, lookRight, neutral) or the rig's own, "
                          "each a value in [0, 1] added to the weights of the shapes it maps (GET /v1/rigs/{id}, "
                          "\"expressions\"), with VRM's override rules; a preset the rig does not map warns expression_unmapped"}};
}

json SkeletonProperties() {
  return {{"pose", Pose()},
          {"expressions", Expressions()},
          {"gaze", Gaze()},
          {"animation", ClipRef()},
          {"time", {{"type", "number"}, {"description", "Seconds into the animation"}}},
          {"motion", ClipRef()},
          {"frame", {{"type", "number"}, {"description", "The time in MMD frames, 30 a second (instead of time)"}}},
          {"loop", {{"type", "boolean"}, {"default", false}}},
          {"blend", Blend()},
          {"layers", Layers()},
          {"skinning", {{"enum", {"linear", "dual_quaternion"}}, {"default", "linear"}}},
          {"lod", {{"type", "integer"}, {"minimum", 0}, {"maximum", 4}, {"default", 0},
                   {"description", "Level of detail: 0 full, L about 1/2^L of the triangles (a subset of the vertices)"}}}};
}

json Controls() {
  return {{"type", "object"}, {"additionalProperties", {{"type", "number"}}},
          {"description", "Control values by name (the rig route lists controls): a two-sided control v < 0 "
                          "drives its negative shape with -v, v > 0 its positive shape"}};
}

// ---- requests ----

json MeshRequest() {
  json request = {{"type", "object"},
          {"properties",
           {{"weights", Weights()},
            {"controls", Controls()},
            {"mode", {{"enum", {"relative", "absolute"}}, {"default", "relative"}}},
            {"normals", {{"enum", {"blend", "recompute"}}, {"default", "blend"}}},
            {"format", {{"enum", {"glb", "obj", "json", "f32", "vrm", "vrm0"}}}},
            {"space", {{"enum", {"world", "mesh"}}, {"default", "world"}}},
            {"strict", {{"type", "boolean"}, {"default", false}}},
            {"keep_targets", {{"type", "boolean"}, {"default", false}}}}}};
  const json skeleton = SkeletonProperties();
  for (auto& [key, value] : skeleton.items()) request["properties"][key] = value;
  return request;
}

json RenderProperties() {
  json properties = {{"weights", Weights()},
          {"controls", Controls()},
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
          {"exposure", {{"type", "number"}, {"minimum", -10}, {"maximum", 10}, {"default", 0}}},
          {"light", {{"type", "object"},
                     {"description", "The studio's lights turned about the camera: yaw (degrees, to the right), then pitch (up)."},
                     {"properties", {{"yaw", {{"type", "number"}}}, {"pitch", {{"type", "number"}}}}},
                     {"additionalProperties", false}}}};
  const json skeleton = SkeletonProperties();
  for (auto& [key, value] : skeleton.items()) properties[key] = value;
  return properties;
}

json SheetProperties() {
  json properties = RenderProperties();
  properties.erase("weights");
  properties["columns"] = {{"type", "integer"}, {"minimum", 1}, {"maximum", 64}};
  properties["cells"] = {{"oneOf", json::array({json{{"type", "array"},
                                                     {"items", {{"type", "object"}, {"properties", {{"weights", Weights()}, {"label", {{"type", "string"}}}}}}}},
                                                json{{"type", "string"}, {"pattern", "^shapes(:.+)?$"},
                                                     {"description", "One cell per shape (of a group) at 1"}}})}};
  return properties;
}

json Camera() {
  return {{"type", "object"},
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
}

json RenderRequest() {
  return {{"type", "object"}, {"properties", RenderProperties()}};
}

json SheetRequest() {
  return {{"type", "object"}, {"required", {"cells"}}, {"properties", SheetProperties()}};
}

json SequenceRequest() {
  return {
  {"type", "object"},
  {"properties",
  {{"motion", ClipRef()},
  {"animation", ClipRef()},
  {"keys", {{"type", "array"},
  {"items", {{"type", "object"},
            {"required", {"time"}},
            {"properties", {{"time", {{"type", "number"}}}, {"weights", Weights()}, {"shape", {{"type", "string"}}},
                            {"expressions", Expressions()}, {"transition", {{"type", "string"}}}}}}}}},
  {"gaze", {{"oneOf", json::array({Gaze(), json{{"type", "object"},
                                   {"required", {"keys"}},
                                   {"description", "A gaze track: linear between its keys, held past its ends"},
                                   {"properties", {{"keys", {{"type", "array"}, {"items", {{"type", "object"}, {"required", {"time"}},
                                                                                            {"properties", {{"time", {{"type", "number"}}}, {"target", Point3()},
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
}

json VariantItem() {
  return {{"type", "object"},
          {"required", {"weights"}},
          {"properties", {{"id", {{"type", "string"}, {"pattern", "^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$"}}},
                          {"weights", {{"oneOf", {WeightsObject(), {{"type", "array"}, {"items", {{"type", "number"}}}}}}}}}}};
}

json Sample() {
  return {{"type", "object"},
          {"required", {"method"}},
          {"properties", {{"method", {{"enum", {"uniform", "gaussian", "grid", "convex"}}}},
                          {"count", {{"type", "integer"}, {"minimum", 1}}},
                          {"seed", {{"type", "integer"}, {"minimum", 0}}},
                          {"shapes", {{"type", "array"}, {"items", {{"type", "string"}}}}},
                          {"fixed", WeightsObject()},
                          {"center", WeightsObject()},
                          {"spread", {{"type", "number"}, {"minimum", 0}}},
                          {"points", {{"type", "array"}, {"items", WeightsObject()}, {"minItems", 2}, {"maxItems", 3}}},
                          {"active", {{"type", "integer"}, {"minimum", 0}}},
                          {"symmetric", {{"type", "boolean"}}},
                          {"sum_at_most_one", {{"type", "boolean"}}}}}};
}

// [lo, hi]: an interval a randomised setting is drawn from.
json Interval() { return {{"type", "array"}, {"items", {{"type", "number"}}}, {"minItems", 2}, {"maxItems", 2}}; }

json Randomize() {
  auto intervals = [](std::initializer_list<const char*> names) {
    json props = json::object();
    for (const char* n : names) props[n] = Interval();
    return json{{"type", "object"}, {"properties", props}, {"additionalProperties", false}};
  };
  json props = json::object();
  props["seed"] = {{"type", "integer"}, {"minimum", 0}};
  props["camera"] = intervals({"yaw", "pitch", "zoom"});
  props["light"] = intervals({"yaw", "pitch", "exposure"});
  props["gaze"] = intervals({"yaw", "pitch"});
  props["background"] = {{"oneOf", json::array({json{{"const", "random"}}, json{{"type", "array"}, {"items", {{"type", "string"}}}, {"minItems", 1}}})},
                         {"description", "A random colour, or one of these colours; `facespace batch` also takes {\"images\": FOLDER} (pictures behind "
                                         "the samples), which the service refuses (422): it reads no folder a client names"}};
  props["expressions"] = {{"type", "object"}, {"additionalProperties", Interval()}};
  return {{"type", "object"},
          {"description", "What varies per sample, drawn from the sample's own seeded stream: the same seed and index, the same draw."},
          {"properties", props},
          {"additionalProperties", false}};
}

json BatchRequest() {
  return {
  {"type", "object"},
  {"description", "Exactly one of variants or sample. Also takes mode, normals, skinning, pose, animation/time, and the "
        "render settings (width, height, view, camera, background, supersample, quality, light) for image formats. "
        "labels make each variant a training sample: KEY.png with KEY.depth.exr, KEY.normals.exr, KEY.seg.png and KEY.json "
        "(camera K and world_to_camera, landmarks, the point); archive tar writes WebDataset shards of shard_samples each."},
  {"properties", {{"variants", {{"type", "array"}, {"items", VariantItem()}}},
        {"sample", Sample()},
        {"format", {{"enum", {"glb", "obj", "json", "f32", "vrm", "vrm0", "png", "jpeg", "exr", "tiff", "webp"}}}},
        {"labels", {{"type", "array"}, {"items", {{"enum", {"depth", "normals", "segmentation", "landmarks"}}}}}},
        {"archive", {{"enum", {"folder", "tar"}}, {"default", "folder"}}},
        {"shard_samples", {{"type", "integer"}, {"minimum", 1}, {"maximum", 1000000}, {"default", 1000}}},
        {"randomize", Randomize()}}}};
}

// ---- answers ----

json Warning() {
  return {{"type", "object"},
          {"required", {"code", "message"}},
          {"properties",
           {{"code", {{"type", "string"}}},
            {"message", {{"type", "string"}}},
            {"shape", {{"type", "string"}}},
            {"value", {{"type", "number"}}}}}};
}

json ProblemSchema() {
  return {{"type", "object"},
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
}

json MeshJson() {
  return {{"type", "object"},
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
}

json RigSummary() {
  return {{"type", "object"},
          {"required", {"id", "name", "vertices", "triangles", "shapes", "primitives", "has_skeleton", "version"}},
          {"properties", {{"id", String()}, {"name", String()}, {"vertices", Integer()}, {"triangles", Integer()},
                          {"shapes", Integer()}, {"primitives", Integer()}, {"has_skeleton", Boolean()},
                          {"version", {{"type", "string"}, {"description", "Changes with the rig file or its manifest (the ETag)"}}},
                          {"credit", {{"type", "string"}, {"description", "The credit the rig's license asks for: show it with the rig"}}}}}};
}

json Shape() {
  return {{"type", "object"},
          {"properties", {{"index", Integer()}, {"name", String()}, {"group", String()}, {"min", Number()}, {"max", Number()},
                          {"default", Number()}, {"vertices_moved", Integer()}, {"partner", {{"type", {"string", "null"}}}},
                          {"aliases", ArrayOf(String())}, {"driven", Boolean()}}}};
}

json Rig() {
  return {{"type", "object"},
          {"properties",
           {{"id", String()}, {"name", String()}, {"version", String()}, {"credit", String()}, {"vertices", Integer()}, {"triangles", Integer()},
            {"has_skeleton", Boolean()}, {"start", {{"enum", {"neutral", "defaults"}}}},
            {"shapes", ArrayOf(Shape())},
            {"bounding_box", Box()},
            {"primitives", ArrayOf({{"type", "object"},
                                     {"properties", {{"mesh", Integer()}, {"primitive", Integer()}, {"name", String()}, {"vertices", Integer()},
                                                     {"triangles", Integer()}, {"material", Integer()}, {"has_normals", Boolean()},
                                                     {"has_tangents", Boolean()}}}})},
            {"skeleton", {{"type", {"object", "null"}}}},
            {"animations", ArrayOf({{"type", "object"},
                                     {"properties", {{"index", Integer()}, {"name", String()}, {"duration", Number()}, {"channels", Integer()},
                                                     {"morph_weights", Boolean()}}}})},
            {"controls", ArrayOf({{"type", "object"}})},
            {"inbetweens", ArrayOf({{"type", "object"}})},
            {"correctives", ArrayOf({{"type", "object"}})},
            {"statistics", {{"type", {"object", "null"}}}},
            {"expressions", {{"type", "object"},
                             {"description", "Name -> what it maps (the manifest's, else derived from ARKit or MMD shape names)"},
                             {"additionalProperties", {{"type", "object"},
                                                       {"properties", {{"weights", WeightsObject()}, {"binary", Boolean()},
                                                                       {"override_blink", {{"enum", {"none", "block", "blend"}}}},
                                                                       {"override_look_at", {{"enum", {"none", "block", "blend"}}}},
                                                                       {"override_mouth", {{"enum", {"none", "block", "blend"}}}},
                                                                       {"derived", Boolean()}}}}}}},
            {"gaze", {{"type", "object"},
                      {"properties", {{"type", {{"enum", {"bones", "shapes", "expressions", "none"}}}}, {"eyes", {{"type", "object"}}},
                                      {"shapes", {{"type", "object"}}}, {"head", {{"type", "object"}}}, {"neck", {{"type", "object"}}},
                                      {"range_maps", {{"type", "object"}}}, {"origin", ArrayOf(Number())}}}}},
            {"load_warnings", ArrayOf(Ref("Warning"))}}}};
}

json Manifest() {
  return {{"type", "object"},
          {"additionalProperties", false},
          {"description", "What a rig file does not say (core/README.md, \"Manifest\"); an unknown member is refused"},
          {"properties", {{"name", String()}, {"credit", String()}, {"license_url", {{"type", "string"}, {"format", "uri"}}},
                          {"start", {{"enum", {"neutral", "defaults"}}}},
                          {"shapes", {{"type", "object"}, {"additionalProperties", {{"type", "object"}}}}},
                          {"groups", {{"type", "object"}, {"additionalProperties", ArrayOf(String())}}},
                          {"controls", {{"type", "object"}}}, {"derived", {{"type", "object"}}},
                          {"inbetweens", {{"type", "object"}}}, {"correctives", {{"type", "object"}}},
                          {"statistics", {{"type", "object"}}}, {"expressions", {{"type", "object"}}}, {"gaze", {{"type", "object"}}},
                          {"base_motion", String()}, {"materials", {{"type", "object"}}},
                          {"visemes", {{"type", "object"}, {"description", "Each viseme's shapes and weights"}}},
                          {"terms", {{"type", "object"}, {"description", "The rig's licence terms (VRM's)"}}},
                          {"regions", {{"type", "object"}, {"description", "Named parts of the mesh (skin, eyes, teeth...)"}}},
                          {"landmarks", {{"type", "object"}, {"description", "A landmark scheme's points on the mesh"}}}}}};
}

json Check() {
  return {{"type", "object"},
          {"required", {"sum", "weights", "warnings"}},
          {"properties", {{"sum", Number()}, {"weights", WeightsObject()}, {"warnings", ArrayOf(Ref("Warning"))},
                          {"mahalanobis", {{"type", "number"}, {"description", "With manifest statistics: distance from the mean in standard deviations"}}}}}};
}

json Fit() {
  return {{"type", "object"},
          {"required", {"weights", "residual", "warnings"}},
          {"properties", {{"weights", WeightsObject()},
                          {"residual", {{"type", "object"}, {"properties", {{"rms", Number()}, {"max", Number()}}}}},
                          {"warnings", ArrayOf(Ref("Warning"))}}}};
}

json Topology() {
  return {{"type", "object"},
          {"required", {"primitives"}},
          {"properties", {{"primitives", ArrayOf({{"type", "object"},
                                                   {"properties", {{"mesh", Integer()}, {"primitive", Integer()}, {"vertices", Integer()},
                                                                   {"mode", Integer()}, {"indices", ArrayOf(Integer())},
                                                                   {"color", {{"type", "array"}, {"items", Number()}, {"minItems", 4}, {"maxItems", 4},
                                                                              {"description", "Linear RGBA a client drawing no textures shows: the material's base colour times its texture's mean; alpha 0 is see-through (a material morph shows it)"}}}}}})},
                          {"focus", Box()}}}};
}

json SequenceFrames() {
  return {{"type", "object"},
          {"required", {"frames"}},
          {"properties", {{"space", {{"enum", {"world"}}}},
                          {"format", {{"enum", {"weights"}}, {"description", "Present when the frames are weights alone"}}},
                          {"frames", ArrayOf({{"type", "object"},
                                               {"properties", {{"time", Number()}, {"weights", WeightsObject()}, {"sum", Number()},
                                                               {"pose", {{"type", "object"},
                                                                         {"description", "format weights, posed frames: the nodes moved from rest, by name"},
                                                                         {"additionalProperties", {{"type", "object"},
                                                                                                   {"properties", {{"translation", ArrayOf(Number())},
                                                                                                                   {"rotation", ArrayOf(Number())},
                                                                                                                   {"scale", ArrayOf(Number())}}}}}}},
                                                               {"primitives", {{"type", "array"}}}}}})},
                          {"warnings", ArrayOf(Ref("Warning"))}}}};
}

json Reduced() {
  return {{"type", "object"},
          {"properties", {{"keys", {{"type", "array"}}}, {"transition", String()}, {"kept", Integer()}, {"removed", Integer()},
                          {"max_error", Number()}, {"tolerance", Number()}}}};
}

json Health() {
  return {{"type", "object"}, {"required", {"status"}}, {"properties", {{"status", String()}, {"rigs", Integer()}}}};
}

json Job() {
  return {{"type", "object"},
          {"properties", {{"id", {{"type", "string"}}}, {"rig", {{"type", "string"}}},
                          {"state", {{"enum", {"queued", "running", "done", "failed", "cancelled", "lost"}}}},
                          {"format", {{"type", "string"}}}, {"created", {{"type", "string"}, {"format", "date-time"}}},
                          {"total", {{"type", "integer"}}}, {"done", {{"type", "integer"}}}, {"progress", {{"type", "number"}}},
                          {"rate", {{"type", "number"}}}, {"eta_seconds", {{"type", "number"}}}, {"error", {{"type", "string"}}},
                          {"links", {{"type", "object"}}}}}};
}

}  // namespace

json Schemas() {
  return {{"MeshRequest", MeshRequest()}, {"RenderRequest", RenderRequest()}, {"SheetRequest", SheetRequest()},
          {"SequenceRequest", SequenceRequest()}, {"BatchRequest", BatchRequest()}, {"Job", Job()},
          {"Warning", Warning()}, {"Problem", ProblemSchema()}, {"MeshJson", MeshJson()}, {"RigSummary", RigSummary()},
          {"RigList", {{"type", "object"}, {"required", {"rigs"}}, {"properties", {{"rigs", ArrayOf(Ref("RigSummary"))}}}}},
          {"Rig", Rig()}, {"Manifest", Manifest()}, {"Check", Check()}, {"Fit", Fit()}, {"Topology", Topology()},
          {"SequenceFrames", SequenceFrames()}, {"Reduced", Reduced()}, {"Health", Health()}, {"Camera", Camera()},
          {"JobList", {{"type", "object"}, {"required", {"jobs"}}, {"properties", {{"jobs", ArrayOf(Ref("Job"))}}}}},
          {"Voices", {{"type", "object"}, {"required", {"voices"}},
                      {"properties", {{"voices", ArrayOf(json{{"type", "object"}, {"properties", {{"name", {{"type", "string"}}}, {"language", {{"type", "string"}}}}}})},
                                      {"default", {{"type", "string"}}}}}}},
          {"Speech", {{"type", "object"}, {"required", {"phonemes", "visemes", "keys", "duration"}},
                      {"properties", {{"source", {{"type", "string"}, {"enum", {"espeak-ng", "pocketsphinx", "pocketsphinx-aligned"}}}},
                                      {"voice", {{"type", "string"}}},
                                      {"duration", {{"type", "number"}}},
                                      {"phonemes", ArrayOf(json{{"type", "object"}, {"required", {"name", "start", "end"}}})},
                                      {"visemes", ArrayOf(json{{"type", "object"}, {"required", {"viseme", "start", "end"}},
                                                            {"properties", {{"viseme", {{"type", "string"}, {"enum", {"sil", "PP", "FF", "TH", "DD", "kk", "CH", "SS", "nn", "RR", "aa", "E", "ih", "oh", "ou"}}}}}}})},
                                      {"keys", {{"type", "array"}}},
                                      {"warnings", ArrayOf(Ref("Warning"))}}}}}};
}

}  // namespace facespace::api::openapi
