// One table per enum for its names, and where it has them its media type and file extension;
// parsing and naming are lookups in that table, so a new value is one line in one place.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace facespace {
inline namespace engine {

template <typename E>
struct EnumName {
  E value;
  const char* name;                  // Canonical: what Name() gives.
  const char* alias = nullptr;       // Another accepted spelling ("jpg").
  const char* media_type = nullptr;  // "model/gltf-binary".
  const char* extension = nullptr;   // Without the dot: "glb".
};

// The value named `name` (canonical or alias); false when none.
template <typename E, size_t N>
bool ParseEnum(const EnumName<E> (&table)[N], std::string_view name, E* out) {
  for (const EnumName<E>& e : table) {
    if (name == e.name || (e.alias && name == e.alias)) {
      *out = e.value;
      return true;
    }
  }
  return false;
}

// The entry of `value`; the first entry for a value the table lacks.
template <typename E, size_t N>
const EnumName<E>& EnumEntry(const EnumName<E> (&table)[N], E value) {
  for (const EnumName<E>& e : table) {
    if (e.value == value) return e;
  }
  return table[0];
}

// Every canonical name, quoted, for an error naming the valid values: "\"depth\", \"normals\",
// ...".
template <typename E, size_t N>
std::string EnumNames(const EnumName<E> (&table)[N]) {
  std::string names;
  for (const EnumName<E>& e : table)
    names += (names.empty() ? "\"" : ", \"") + std::string(e.name) + "\"";
  return names;
}

}  // namespace engine
}  // namespace facespace
