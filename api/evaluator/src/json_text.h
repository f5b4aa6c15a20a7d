// A string as JSON text (invalid UTF-8 replaced), for bodies written by hand.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace facespace::api {

inline std::string JsonString(const std::string& s) {
  return nlohmann::json(s).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace facespace::api
