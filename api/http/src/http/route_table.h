// The one route table: registration (server.cpp), the route labels of /metrics and the paths of
// the OpenAPI document (openapi.cpp) all come from it, so they cannot drift apart.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "../routes/routes.h"

namespace facespace::http {

struct Route {
  const char* method;  // GET, POST, PUT or DELETE.
  const char* path;    // As the OpenAPI document writes it: /v1/rigs/{id}/mesh.
  const char* metric;  // Its label in /metrics (some routes share one).
  Handler handler;
  bool key = false;  // Writes: needs the API key (checked from the headers, before the body).
};

std::span<const Route> Routes();

// The routes of one path (in table order), or none when no route has that path; a path is matched
// segment by segment, each {name} matching one non-empty segment. No allocation.
struct PathRoutes {
  std::span<const Route> all;  // The table, to be filtered by `path`.
  const char* path = nullptr;  // The table's spelling of the path; null: unknown.
  bool Allows(std::string_view method) const;
  const Route* Find(std::string_view method) const;
  // The Allow header of the path, the same for OPTIONS and 405: its methods, HEAD with GET, and
  // OPTIONS.
  std::string Allow() const;
};
PathRoutes MatchPath(std::string_view path);

// The path as a regular expression for cpp-httplib: each {name} captures one segment, in order.
std::string PathPattern(std::string_view path);

// The distinct metric labels in table order.
std::vector<std::string> MetricLabels();

}  // namespace facespace::http
