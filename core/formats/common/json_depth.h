// JSON from outside (glTF, VRM extensions, manifests) is nested at most kMaxJsonDepth deep before a
// recursive reader sees it: tinygltf's reader and nlohmann's dump recurse once a level, and 20,000
// nested arrays overflowed the stack (a crash that any shared store would spread to every
// instance).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "facespace/engine/status.h"

namespace facespace::formats {

// glTF's own schema nests about 8 deep; extras and extensions a few more.
inline constexpr size_t kMaxJsonDepth = 128;

// The deepest nesting of arrays and objects in `text`, counting no further than `limit` + 1. One
// linear pass: brackets inside strings (with their escapes) do not count; validity is the parser's.
inline size_t JsonDepth(std::string_view text, size_t limit = kMaxJsonDepth) {
  size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > deepest && (deepest = depth) > limit) return deepest;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

// InvalidArgument naming `what` when `text` nests deeper than kMaxJsonDepth.
inline Status CheckJsonDepth(std::string_view text, const char* what) {
  if (JsonDepth(text) <= kMaxJsonDepth) return Status::Ok();
  return WithReason(InvalidArgument(std::string(what) + ": JSON nested deeper than " +
                                    std::to_string(kMaxJsonDepth) + " levels"),
                    "too-deep");
}

}  // namespace facespace::formats
