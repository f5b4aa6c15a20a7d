// The OpenAPI 3.1 document's parts (document.cpp puts them together): the schemas, one function per
// component (schemas.cpp), and the operations by path (operations.cpp).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/evaluator/members.h"

namespace facespace::http::openapi {

using nlohmann::json;

// components.schemas: {"MeshRequest": ..., "Rig": ..., ...}.
json Schemas();
// {PATH: {METHOD: operation, "parameters"?: [...]}} for every route there is.
json Operations();

// The document's tags, and each operation's tag, description and examples (guide.cpp) put into
// `paths`.
json Tags();
void AddGuides(json& paths);

// The query parameters the document declares for `method` (upper case) on `path` (the route table's
// spelling), built once from Operations(); a deepObject map ("w") stands for its w[NAME] and
// w.NAME.
struct QueryParameter {
  std::string name;
  bool map = false;
};
const std::vector<QueryParameter>& QueryParameters(std::string_view method, std::string_view path);

// A member of a request body (facespace/evaluator/members.h) as a JSON Schema: its kind and range,
// its documentation, its default in the description and x-facespace-default (not `default`:
// generated clients would make it required), its example.
json MemberSchema(const facespace::evaluator::Member& m);

// A response whose body is a problem (RFC 9457) described so.
json Problem(const std::string& description);

}  // namespace facespace::http::openapi
