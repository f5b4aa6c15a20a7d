// The manifest's sections, each read by its own function (manifest.cpp's table says in which
// order): the shapes' own (shapes.cpp), what makes them more than a sum (semantics.cpp), the face's
// (face.cpp). Each takes its member's value; errors name the member's JSON Pointer.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "facespace/engine/rig.h"
#include "facespace/engine/status.h"
#include "facespace/formats/io.h"

namespace facespace::formats::manifest {

using nlohmann::json;

// InvalidArgument "manifest: POINTER: MESSAGE", the field named.
inline Status Bad(const std::string& pointer, const std::string& message) {
  Status s = InvalidArgument("manifest: " + pointer + ": " + message);
  s.fields.push_back({pointer, message});
  return s;
}

// Each member of `section` (an object, else an error at `pointer` saying it `must_be`) applied to
// the rig: apply(rig, key, value, the member's pointer), in order, up to the first error.
using MemberReader = Status (*)(Rig& rig, const std::string& key, const json& value,
                                const std::string& pointer);
inline Status ForEachMember(const json& section, const std::string& pointer,
                            const std::string& must_be, Rig& rig, MemberReader apply) {
  if (!section.is_object()) return Bad(pointer, must_be);
  for (auto it = section.begin(); it != section.end(); ++it) {
    if (Status s = apply(rig, it.key(), it.value(), pointer + "/" + JsonPointerEscape(it.key()));
        !s.ok())
      return s;
  }
  return Status::Ok();
}

// The shape `v` names (a string), or an error at `ptr`.
Status ShapeAt(const Rig& rig, const json& v, const std::string& ptr, uint32_t* out);

// Left/right controls ("eyes/l-eye-bag-decr|incr" and "eyes/r-...") as partners.
void PairControls(Rig& rig);

Status ApplyMaterials(Rig& rig, const json& v);
Status ApplyDerived(Rig& rig, const json& v);
Status ApplyGroups(Rig& rig, const json& v);
Status ApplyShapes(Rig& rig, const json& v);
Status ApplyControls(Rig& rig, const json& v);
Status ApplyInBetweens(Rig& rig, const json& v);
Status ApplyCorrectives(Rig& rig, const json& v);
Status ApplyStatistics(Rig& rig, const json& v);
Status ApplyExpressions(Rig& rig, const json& v);
Status ApplyGaze(Rig& rig, const json& v);
Status ApplyVisemes(Rig& rig, const json& v);
Status ApplyTerms(Rig& rig, const json& v);      // terms.cpp
json TermsValue(const UsageTerms& t);            // The section as ApplyTerms reads it.
Status ApplyRegions(Rig& rig, const json& v);    // labels.cpp
Status ApplyLandmarks(Rig& rig, const json& v);  // labels.cpp
json RegionsValue(const Rig& rig);               // The sections as they read them.
json LandmarksValue(const Rig& rig);
Status ApplyDerivation(Rig& rig, const json& v);  // derivation.cpp
json DerivationValue(const Derivation& d);        // The section as ApplyDerivation reads it.

}  // namespace facespace::formats::manifest
