// The OpenAPI 3.1 description of every route of the route table (http/route_table.cpp): the
// operations (operations.cpp) are looked up by path and method for each route the table lists, so
// the document names exactly the routes the server answers; a route without an operation here stops
// the server at its first request for the document (every service test would fail).
#include <algorithm>
#include <cstdio>
#include <cstdlib>

#include "../http/problems.h"
#include "../http/route_table.h"
#include "facespace/formats/rig_json.h"
#include "facespace/http/http.h"
#include "openapi.h"

namespace facespace::http {

namespace {

using openapi::json;
using openapi::Problem;

// The document's paths: one operation per route of the table, taken from `operations`; path-level
// parameters are copied into each operation.
json PathsOfRoutes(const json& operations) {
  json paths = json::object();
  for (const http::Route& route : http::Routes()) {
    std::string method = route.method;
    for (char& c : method) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto item = operations.find(route.path);
    if (item == operations.end() || !item->contains(method)) {
      std::fprintf(stderr, "facespace: the OpenAPI document has no operation for %s %s\n",
                   route.method, route.path);
      std::abort();
    }
    json op = (*item)[method];
    if (item->contains("parameters") && !op.contains("parameters"))
      op["parameters"] = (*item)["parameters"];
    // Public operations say so (an empty requirement), beside the keyed ones' bearer.
    if (!op.contains("security")) op["security"] = json::array();
    // A query parameter it does not declare is refused (http/access.cpp, RefusedQuery; the JSON
    // body readers).
    if (!op["responses"].contains("422"))
      op["responses"]["422"] = Problem("A query parameter the operation does not declare");
    // Every body is bounded (--max-body) and must be JSON unless the operation says otherwise.
    if (op.contains("requestBody")) {
      if (!op["responses"].contains("413"))
        op["responses"]["413"] = Problem("The body is over the server's limit (--max-body)");
      if (!op["responses"].contains("415"))
        op["responses"]["415"] = Problem("The body is not of a type the operation takes");
    }
    paths[route.path][method] = op;
  }
  return paths;
}

// The headers answers carry beside their body, each declared once (components.headers).
json HeaderComponents() {
  const auto h = [](const char* description) {
    return json{{"description", description}, {"schema", {{"type", "string"}}}};
  };
  return {{"Facespace-Cost",
           h("The request's estimated CPU-seconds, stated before its work; on every answer")},
          {"ETag",
           h("Strong validator of what the answer holds: send it back as If-None-Match for a 304")},
          {"Location", h("The resource created or changed")},
          {"Facespace-Frames", h("How many frames the answer holds")},
          {"Facespace-Duration", h("The speech's length, in seconds")},
          {"Facespace-Weight-Sum", h("The sum of the weights")},
          {"Retry-After", h("Seconds to wait before trying again")},
          {"WWW-Authenticate", h("Bearer: the API key this request needs")}};
}

// Which operations' successful answers carry which headers beyond Facespace-Cost (by operationId).
const std::vector<std::pair<const char*, std::vector<const char*>>>& SuccessHeaders() {
  static const std::vector<std::pair<const char*, std::vector<const char*>>> table = {
      {"openapi", {"ETag"}},
      {"listRigs", {"ETag"}},
      {"checkWeights", {"Facespace-Weight-Sum"}},
      {"getRig", {"ETag"}},
      {"getManifest", {"ETag"}},
      {"getTopology", {"ETag"}},
      {"putRig", {"Location"}},
      {"putManifest", {"Location"}},
      {"sampleSequence", {"Facespace-Frames"}},
      {"streamSequence", {"Facespace-Frames"}},
      {"speak", {"Facespace-Duration"}}};
  return table;
}

// Every answer of every operation names Facespace-Cost; 401 names WWW-Authenticate, 429 and 503
// Retry-After; a success the headers SuccessHeaders lists.
void DeclareHeaders(json& doc) {
  doc["components"]["headers"] = HeaderComponents();
  const auto ref = [](const char* name) {
    return json{{"$ref", std::string("#/components/headers/") + name}};
  };
  for (auto& [path, item] : doc["paths"].items()) {
    for (auto& [method, op] : item.items()) {
      if (!op.is_object() || !op.contains("responses")) continue;
      const std::string id = op.value("operationId", "");
      // A GET whose answer carries an ETag answers 304 to an If-None-Match that names it.
      for (const auto& [operation, names] : SuccessHeaders()) {
        const bool etag = id == operation && std::find(names.begin(), names.end(),
                                                       std::string_view("ETag")) != names.end();
        if (etag && method == "get" && !op["responses"].contains("304")) {
          op["responses"]["304"] = {{"description", "Not modified: If-None-Match named the ETag"}};
        }
      }
      for (auto& [status, response] : op["responses"].items()) {
        json& headers = response["headers"];
        headers["Facespace-Cost"] = ref("Facespace-Cost");
        if (status == "401") headers["WWW-Authenticate"] = ref("WWW-Authenticate");
        if (status == "429" || status == "503") headers["Retry-After"] = ref("Retry-After");
        if (status == "304" && headers.find("ETag") == headers.end()) headers["ETag"] = ref("ETag");
        if (status[0] != '2') continue;
        for (const auto& [operation, names] : SuccessHeaders()) {
          if (id != operation) continue;
          for (const char* name : names) {
            if (!headers.contains(name)) headers[name] = ref(name);
          }
        }
      }
    }
  }
}

json Build() {
  return {{"openapi", "3.1.0"},
          {"info",
           {{"title", "facespace"},
            {"version", FACESPACE_VERSION},
            {"license", {{"name", "MIT"}, {"identifier", "MIT"}}},
            {"description",
             "Blend-shape rigs over HTTP: blended meshes with warnings when a point leaves the "
             "authored space. "
             "Errors are RFC 9457 problem details. A method a path does not list answers 405 with "
             "an Allow "
             "header; too many connections (from one address or in all) answer 503 with "
             "Retry-After."}}},
          {"servers",
           json::array({{{"url", "/"}, {"description", "The server that answers this document"}}})},
          {"tags", openapi::Tags()},
          {"paths", PathsOfRoutes(openapi::Operations())},
          {"components",
           {{"schemas", openapi::Schemas()},
            {"securitySchemes", {{"bearer", {{"type", "http"}, {"scheme", "bearer"}}}}}}}};
}

}  // namespace

std::string OpenApiJson(const ApiOptions& limits) {
  json doc = Build();
  const std::string body = std::to_string(limits.max_body),
                    response = std::to_string(limits.max_response);
  const std::string render = std::to_string(limits.max_render_size),
                    cells = std::to_string(limits.max_sheet_cells);
  const std::string frames = std::to_string(limits.max_frames);
  doc["info"]["description"] =
      doc["info"]["description"].get<std::string>() +
      "\n\nLimits of this server (its flags): request bodies up to " + body +
      " bytes (--max-body; over: 413), "
      "renders up to " +
      render + " pixels a side (--max-render; over: 422 image-too-large), contact sheets up to " +
      cells + " cells (--max-sheet-cells; 422), sequence/sample bodies up to " + response +
      " bytes (--max-response; over: 422 response-too-large, judged before the work), sequence "
      "streams up to " +
      frames +
      " frames (--max-frames; 422 too-many-frames). Every answer states its estimated CPU-seconds "
      "in "
      "Facespace-Cost; work over --anonymous-cpu without the API key (--keyed-cpu with it) is 422 "
      "over-budget, "
      "before any of it is done.";
  doc["info"]["x-facespace-limits"] = {{"max_body", limits.max_body},
                                       {"max_render", limits.max_render_size},
                                       {"max_sheet_cells", limits.max_sheet_cells},
                                       {"max_response", limits.max_response},
                                       {"max_frames", limits.max_frames},
                                       {"anonymous_cpu_seconds", limits.anonymous_cpu},
                                       {"keyed_cpu_seconds", limits.keyed_cpu}};
  for (const auto& [name, value] : limits.limits) {
    json& at = doc["info"]["x-facespace-limits"][name];
    if (at.is_null())
      at = formats::NumberValue(value);  // Whole numbers as integers (formats' rig_json.h).
  }
  json& schemas = doc["components"]["schemas"];
  for (const char* schema : {"RenderRequest", "SheetRequest"}) {
    for (const char* side : {"width", "height"})
      schemas[schema]["properties"][side]["maximum"] = limits.max_render_size;
  }
  schemas["SheetRequest"]["properties"]["cells"]["oneOf"][0]["maxItems"] = limits.max_sheet_cells;
  openapi::AddGuides(doc["paths"]);
  DeclareHeaders(doc);
  // Every problem type the server answers (http/problems.h): the type's values, and each with its
  // status and title.
  json types = json::array(), problems = json::array();
  for (const http::ProblemType& t : http::Problems()) {
    const std::string type = "urn:facespace:problem:" + std::string(t.name);
    types.push_back(type);
    problems.push_back({{"type", type}, {"status", t.status}, {"title", std::string(t.title)}});
  }
  schemas["Problem"]["properties"]["type"]["enum"] = types;
  doc["x-facespace-problems"] = problems;
  return doc.dump(1);
}

}  // namespace facespace::http
