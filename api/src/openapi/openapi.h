// The OpenAPI 3.1 document's parts (document.cpp puts them together): the schemas, one function per
// component (schemas.cpp), and the operations by path (operations.cpp).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace facespace::api::openapi {

using nlohmann::json;

// components.schemas: {"MeshRequest": ..., "Rig": ..., ...}.
json Schemas();
// {PATH: {METHOD: operation, "parameters"?: [...]}} for every route there is.
json Operations();

// A response whose body is a problem (RFC 9457) described so.
json Problem(const std::string& description);

}  // namespace facespace::api::openapi
