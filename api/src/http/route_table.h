// The one route table: registration (server.cpp), the route labels of /metrics and the paths of
// the OpenAPI document (openapi.cpp) all come from it, so they cannot drift apart.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "../routes/routes.h"

namespace facespace::api::http {

struct Route {
  const char* method;  // GET, POST, PUT or DELETE.
  const char* path;    // As the OpenAPI document writes it: /v1/rigs/{id}/mesh.
  const char* metric;  // Its label in /metrics (some routes share one).
  Handler handler;
};

std::span<const Route> Routes();

// The path as a regular expression for cpp-httplib: each {name} captures one segment, in order.
std::string PathPattern(std::string_view path);

// The distinct metric labels in table order.
std::vector<std::string> MetricLabels();

}  // namespace facespace::api::http

