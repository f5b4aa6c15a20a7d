// The document's schemas (components.schemas), each a function named as its component; the
// operations (operations.cpp) refer to them by $ref.
#include <cmath>

#include "facespace/evaluator/answers.h"
#include "facespace/evaluator/members.h"
#include "openapi.h"

namespace facespace::http::openapi {

namespace {

using facespace::evaluator::Answer;
using facespace::evaluator::Body;
using facespace::evaluator::Kind;
using facespace::evaluator::Member;

// ---- plain types ----

json Number() { return {{"type", "number"}}; }
json Integer() { return {{"type", "integer"}}; }
json String() { return {{"type", "string"}}; }
json Boolean() { return {{"type", "boolean"}}; }
json Vec3() { return {{"type", "array"}, {"items", Number()}, {"minItems", 3}, {"maxItems", 3}}; }
json Box() { return {{"type", "object"}, {"properties", {{"min", Vec3()}, {"max", Vec3()}}}}; }
json ArrayOf(json items) { return json{{"type", "array"}, {"items", std::move(items)}}; }
json Ref(const char* name) { return json{{"$ref", std::string("#/components/schemas/") + name}}; }
// An object whose members the document does not list (a manifest's sections: core/README.md).
json Open() { return {{"type", "object"}, {"additionalProperties", true}}; }
json WeightsObject() {
  return {{"type", "object"}, {"additionalProperties", {{"type", "number"}}}};
}

// ---- a point of face space: weights, controls, the skeleton's settings ----

json Weights() {
  return {{"oneOf", json::array({json{{"type", "array"},
                                      {"items", {{"type", "number"}}},
                                      {"description", "Dense, in shape order"}},
                                 json{{"type", "object"},
                                      {"additionalProperties", {{"type", "number"}}},
                                      {"description", "By shape name, alias or index"}}})}};
}

// A closed object of the members of a table, request body's or answer's alike: a member the table
// does not declare is neither read nor written.
json TableSchema(std::span<const Member> members, std::string_view doc) {
  json properties = json::object(), required = json::array();
  for (const Member& m : members) {
    properties[std::string(m.name)] = MemberSchema(m);
    if (m.required) required.push_back(std::string(m.name));
  }
  json s = {{"type", "object"},
            {"description", std::string(doc)},
            {"properties", properties},
            {"additionalProperties", false}};
  if (!required.empty()) s["required"] = required;
  return s;
}

// The value shapes the tables refer to by "#Name".
json ValueSchemas() {
  return {{"Weights", Weights()},
          {"Landmarks",
           {{"type", "object"},
            {"required", {"points"}},
            {"description",
             "Named points on a mesh, as the manifests write them (a point's other members are "
             "ignored)"},
            {"properties",
             {{"scheme", {{"type", "string"}}},
              {"points",
               {{"type", "array"},
                {"maxItems", 4096},
                {"items",
                 {{"type", "object"},
                  {"required", {"name"}},
                  {"properties",
                   {{"name", {{"type", "string"}, {"minLength", 1}}},
                    {"vertex",
                     {{"type", "integer"},
                      {"minimum", 0},
                      {"description", "In the file's own numbering"}}},
                    {"position",
                     {{"type", "array"},
                      {"items", {{"type", "number"}}},
                      {"minItems", 3},
                      {"maxItems", 3}}}}}}}}}}}}},
          {"ClipRef",
           {{"oneOf", json::array({json{{"type", "string"}, {"minLength", 1}},
                                   json{{"type", "integer"}, {"minimum", 0}}})},
            {"description", "A clip by name or index"}}},
          {"Pose",
           {{"type", "object"},
            {"description", "Joint name -> local transform parts that replace the rest values"},
            {"additionalProperties", Ref("JointPose")}}},
          {"Blend",
           {{"type", "array"},
            {"items", Ref("BlendClip")},
            {"description", "Clips at their times and weights"}}},
          {"Layers",
           {{"type", "array"},
            {"minItems", 1},
            {"maxItems", 16},
            {"items", Ref("Layer")},
            {"description", "The first the base, each later one an overlay"}}},
          {"Colour",
           {{"oneOf",
             json::array({json{{"type", "string"},
                               {"pattern", "^(#[0-9a-fA-F]{6}([0-9a-fA-F]{2})?|transparent)$"}},
                          json{{"type", "array"},
                               {"items", {{"type", "number"}, {"minimum", 0}, {"maximum", 1}}},
                               {"minItems", 3},
                               {"maxItems", 4}}})}}},
          {"Interval",
           {{"type", "array"},
            {"items", Number()},
            {"minItems", 2},
            {"maxItems", 2},
            {"description", "[lo, hi]: an interval a randomised setting is drawn from"}}}};
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
  return {
      {"type", "object"},
      {"required", {"type", "title", "status", "detail"}},
      {"properties",
       {{"type", {{"type", "string"}}},
        {"title", {{"type", "string"}}},
        {"status", {{"type", "integer"}}},
        {"detail", {{"type", "string"}}},
        {"instance", {{"type", "string"}}},
        {"errors",
         {{"type", "array"},
          {"items",
           {{"type", "object"},
            {"properties",
             {{"pointer", {{"type", "string"}}},
              {"parameter", {{"type", "string"}}},
              {"detail", {{"type", "string"}}}}}}}}},
        {"warnings", {{"type", "array"}, {"items", {{"$ref", "#/components/schemas/Warning"}}}}}}}};
}

json MeshJson() {
  return {
      {"type", "object"},
      {"properties",
       {{"space", {{"enum", {"world", "mesh"}}}},
        {"primitives",
         {{"type", "array"},
          {"items",
           {{"type", "object"},
            {"properties",
             {{"mesh", {{"type", "integer"}}},
              {"primitive", {{"type", "integer"}}},
              {"name", {{"type", "string"}}},
              {"positions", {{"type", "array"}, {"items", {{"type", "number"}}}}},
              {"normals", {{"type", "array"}, {"items", {{"type", "number"}}}}}}}}}}},
        {"warnings", {{"type", "array"}, {"items", {{"$ref", "#/components/schemas/Warning"}}}}}}}};
}

json RigSummary() {
  return {
      {"type", "object"},
      {"required",
       {"id", "name", "vertices", "triangles", "shapes", "primitives", "has_skeleton", "version"}},
      {"properties",
       {{"id", String()},
        {"name", String()},
        {"vertices", Integer()},
        {"triangles", Integer()},
        {"shapes", Integer()},
        {"primitives", Integer()},
        {"has_skeleton", Boolean()},
        {"version",
         {{"type", "string"},
          {"description", "Changes with the rig file or its manifest (the ETag)"}}},
        {"credit",
         {{"type", "string"},
          {"description", "The credit the rig's license asks for: show it with the rig"}}}}}};
}

// Where a rig's derived shapes came from (the manifest's "derivation"; null in a rig without).
json Derivation(bool nullable) {
  return {{"type", nullable ? json({"object", "null"}) : json("object")},
          {"description",
           "Where the rig's derived shapes came from (facespace derive): the source rig, its "
           "credit, the "
           "method, the fit as fractions of the head's diagonal, the shapes made"},
          {"properties",
           {{"source", String()},
            {"credit", String()},
            {"method", String()},
            {"alignment", {{"enum", {"landmarks", "shape"}}}},
            {"landmarks", Integer()},
            {"fit", {{"type", "object"}, {"properties", {{"mean", Number()}, {"p95", Number()}}}}},
            {"shapes", ArrayOf(String())}}}};
}

json Shape() {
  return {{"type", "object"},
          {"properties",
           {{"index", Integer()},
            {"name", String()},
            {"group", String()},
            {"min", Number()},
            {"max", Number()},
            {"default", Number()},
            {"vertices_moved", Integer()},
            {"partner", {{"type", {"string", "null"}}}},
            {"aliases", ArrayOf(String())},
            {"driven", Boolean()}}}};
}

json Rig() {
  return {{"type", "object"},
          {"properties",
           {{"id", String()},
            {"name", String()},
            {"version", String()},
            {"credit", String()},
            {"vertices", Integer()},
            {"triangles", Integer()},
            {"has_skeleton", Boolean()},
            {"start", {{"enum", {"neutral", "defaults"}}}},
            {"shapes", ArrayOf(Shape())},
            {"derivation", Derivation(true)},
            {"bounding_box", Box()},
            {"primitives", ArrayOf({{"type", "object"},
                                    {"properties",
                                     {{"mesh", Integer()},
                                      {"primitive", Integer()},
                                      {"name", String()},
                                      {"vertices", Integer()},
                                      {"triangles", Integer()},
                                      {"material", Integer()},
                                      {"has_normals", Boolean()},
                                      {"has_tangents", Boolean()}}}})},
            {"skeleton", {{"type", {"object", "null"}}, {"additionalProperties", true}}},
            {"animations", ArrayOf({{"type", "object"},
                                    {"properties",
                                     {{"index", Integer()},
                                      {"name", String()},
                                      {"duration", Number()},
                                      {"channels", Integer()},
                                      {"morph_weights", Boolean()}}}})},
            {"controls", ArrayOf(Open())},
            {"inbetweens", ArrayOf(Open())},
            {"correctives", ArrayOf(Open())},
            {"statistics", {{"type", {"object", "null"}}, {"additionalProperties", true}}},
            {"expressions",
             {{"type", "object"},
              {"description",
               "Name -> what it maps (the manifest's, else derived from ARKit or MMD shape names)"},
              {"additionalProperties",
               {{"type", "object"},
                {"properties",
                 {{"weights", WeightsObject()},
                  {"binary", Boolean()},
                  {"override_blink", {{"enum", {"none", "block", "blend"}}}},
                  {"override_look_at", {{"enum", {"none", "block", "blend"}}}},
                  {"override_mouth", {{"enum", {"none", "block", "blend"}}}},
                  {"derived", Boolean()}}}}}}},
            {"gaze",
             {{"type", "object"},
              {"properties",
               {{"type", {{"enum", {"bones", "shapes", "expressions", "none"}}}},
                {"eyes", Open()},
                {"shapes", Open()},
                {"head", Open()},
                {"neck", Open()},
                {"range_maps", Open()},
                {"origin", ArrayOf(Number())}}}}},
            {"visemes",
             {{"type", "object"},
              {"properties",
               {{"jaw",
                 {{"type", "array"},
                  {"items", String()},
                  {"description", "The shapes that open the jaw"}}},
                {"nolip",
                 {{"type", "array"},
                  {"items", String()},
                  {"description", "Shapes held at 0 while speaking (MMDAgent's NOLIP)"}}}}},
              {"additionalProperties",
               {{"type", {"object", "null"}}, {"additionalProperties", {{"type", "number"}}}}},
              {"description",
               "Each viseme (sil, PP, FF, ... ou) -> the shapes and weights that say it"}}},
            {"load_warnings", ArrayOf(Ref("Warning"))}}}};
}

json Manifest() {
  return {
      {"type", "object"},
      {"additionalProperties", false},
      {"description",
       "What a rig file does not say (core/README.md, \"Manifest\"); an unknown member is refused"},
      {"properties",
       {{"name", String()},
        {"credit", String()},
        {"license_url", {{"type", "string"}, {"format", "uri"}}},
        {"start", {{"enum", {"neutral", "defaults"}}}},
        {"shapes", {{"type", "object"}, {"additionalProperties", Open()}}},
        {"groups", {{"type", "object"}, {"additionalProperties", ArrayOf(String())}}},
        {"controls", Open()},
        {"derived", Open()},
        {"inbetweens", Open()},
        {"correctives", Open()},
        {"statistics", Open()},
        {"expressions", Open()},
        {"gaze", Open()},
        {"base_motion", String()},
        {"materials", Open()},
        {"visemes",
         {{"type", "object"},
          {"additionalProperties", true},
          {"description", "Each viseme's shapes and weights"}}},
        {"terms",
         {{"type", "object"},
          {"additionalProperties", true},
          {"description", "The rig's licence terms (VRM's)"}}},
        {"regions",
         {{"type", "object"},
          {"additionalProperties", true},
          {"description", "Named parts of the mesh (skin, eyes, teeth...)"}}},
        {"landmarks",
         {{"type", "object"},
          {"additionalProperties", true},
          {"description", "A landmark scheme's points on the mesh"}}},
        {"derivation", Derivation(false)}}}};
}

json Captured() {
  return {{"type", "object"},
          {"required", {"keys", "fps", "frames", "head"}},
          {"properties",
           {{"scheme", String()},
            {"fps", Number()},
            {"frames", Integer()},
            {"shapes", Integer()},
            {"keys", ArrayOf(Ref("Key"))},
            {"head", ArrayOf({{"type", "array"},
                              {"items", Number()},
                              {"minItems", 4},
                              {"maxItems", 4},
                              {"description",
                               "The head's turn from the neutral frame's, a quaternion (x, y, z, "
                               "w) in the rig's frame"}})}}}};
}

json Health() {
  return {{"type", "object"},
          {"required", {"status"}},
          {"properties", {{"status", String()}, {"rigs", Integer()}}}};
}

json Job() {
  return {{"type", "object"},
          {"properties",
           {{"id", {{"type", "string"}}},
            {"kind",
             {{"enum", {"batch", "derive"}},
              {"description", "A batch of variants, or a derive (POST /v1/rigs/{id}/derive)"}}},
            {"rig", {{"type", "string"}}},
            {"state", {{"enum", {"queued", "running", "done", "failed", "cancelled", "lost"}}}},
            {"from", {{"type", "string"}, {"description", "A derive's source rig"}}},
            {"as", {{"type", "string"}, {"description", "The rig a derive writes"}}},
            {"step", {{"type", "string"}, {"description", "What a running derive does now"}}},
            {"result",
             {{"type", "object"},
              {"description", "A finished derive's: the rig it wrote and how the fit went"},
              {"properties",
               {{"rig", {{"type", "string"}}},
                {"created", {{"type", "boolean"}}},
                {"derived", {{"type", "integer"}, {"description", "Shapes added"}}},
                {"kept", ArrayOf(json{{"type", "string"}})},
                {"matched_triangles", {{"type", "integer"}}},
                {"distorted", {{"type", "number"}}},
                {"seconds", {{"type", "number"}, {"description", "CPU time"}}},
                {"derivation", Derivation(false)}}}}},
            {"problem", Ref("Problem")},
            {"format", {{"type", "string"}}},
            {"created", {{"type", "string"}, {"format", "date-time"}}},
            {"total", {{"type", "integer"}}},
            {"done", {{"type", "integer"}}},
            {"progress", {{"type", "number"}}},
            {"rate", {{"type", "number"}}},
            {"eta_seconds", {{"type", "number"}}},
            {"error", {{"type", "string"}}},
            {"links", Open()}}}};
}

}  // namespace

// The request bodies, from their member tables (evaluator/members.h): a member's default is in its
// description and x-facespace-default, not `default`, so that generated clients keep it optional.
json MemberSchema(const facespace::evaluator::Member& m) {
  json s;
  switch (m.kind) {
    case facespace::evaluator::Kind::kNumber:
    case facespace::evaluator::Kind::kInteger:
      s = {{"type", m.kind == facespace::evaluator::Kind::kInteger ? "integer" : "number"}};
      if (std::isfinite(m.lo)) s["minimum"] = m.lo;
      if (std::isfinite(m.hi)) s["maximum"] = m.hi;
      break;
    case facespace::evaluator::Kind::kBoolean: s = {{"type", "boolean"}}; break;
    case facespace::evaluator::Kind::kString:
      s = {{"type", "string"}};
      if (!m.schema.empty()) s["pattern"] = m.schema;
      break;
    case facespace::evaluator::Kind::kChoice: {
      json choices = json::array();
      for (std::string_view c : facespace::evaluator::Choices(m)) choices.push_back(std::string(c));
      s = {{"type", "string"}, {"enum", choices}};
      break;
    }
    case facespace::evaluator::Kind::kSchema:
      s = m.schema.starts_with('#') ? Ref(std::string(m.schema.substr(1)).c_str())
                                    : json::parse(m.schema);
      break;
  }
  std::string doc(m.doc);
  if (!m.fallback.empty()) {
    doc += ". Default: " + std::string(m.fallback);
    s["x-facespace-default"] = json::parse(m.fallback);
  }
  s["description"] = doc;
  if (!m.example.empty()) s["examples"] = json::array({json::parse(m.example)});
  return s;
}

json Schemas() {
  json schemas = {
      {"Job", Job()},
      {"Warning", Warning()},
      {"Problem", ProblemSchema()},
      {"MeshJson", MeshJson()},
      {"RigSummary", RigSummary()},
      {"RigList",
       {{"type", "object"},
        {"required", {"rigs"}},
        {"properties", {{"rigs", ArrayOf(Ref("RigSummary"))}}}}},
      {"Rig", Rig()},
      {"Manifest", Manifest()},
      {"Captured", Captured()},
      {"Health", Health()},
      {"JobList",
       {{"type", "object"},
        {"required", {"jobs"}},
        {"properties", {{"jobs", ArrayOf(Ref("Job"))}}}}},
      {"Voices",
       {{"type", "object"},
        {"required", {"voices"}},
        {"properties",
         {{"voices",
           ArrayOf(json{{"type", "object"},
                        {"properties",
                         {{"name", {{"type", "string"}}}, {"language", {{"type", "string"}}}}}})},
          {"default", {{"type", "string"}}}}}}}};

  schemas.update(ValueSchemas());
  for (Body body : facespace::evaluator::kBodies)
    schemas[std::string(facespace::evaluator::SchemaName(body))] =
        TableSchema(Members(body), facespace::evaluator::Describe(body));
  for (const auto& answer : facespace::evaluator::kAnswerTables)
    schemas[std::string(answer.name)] = TableSchema(answer.members, answer.doc);
  return schemas;
}

}  // namespace facespace::http::openapi
