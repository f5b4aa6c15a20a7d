// What a rig describes of itself as JSON values (nlohmann), for documents built with nlohmann (GET
// /v1/rigs/{id}, `facespace info --json`, problem details, glb's asset.extras): the manifest's
// schema (README "Manifest"), and warnings as the text writers write them (WarningsToJson).
#pragma once

#include <nlohmann/json.hpp>
#include <span>

#include "facespace/engine/rig.h"

namespace facespace::formats {

// The rig's expressions: name -> {weights, binary, override_blink, override_look_at,
// override_mouth, derived}.
nlohmann::json ExpressionsValue(const Rig& rig);
// Its gaze: {type, eyes | shapes, head, neck, range_maps, origin}.
nlohmann::json GazeValue(const Rig& rig);
// The viseme map (core/speech.h): viseme -> {SHAPE: w} for all 15, "nolip", "jaw"; null when the
// rig cannot speak.
nlohmann::json VisemesValue(const Rig& rig);
// Where its derived shapes came from: {source, credit, method, alignment, landmarks, fit: {mean,
// p95}, shapes}; null when it has none.
nlohmann::json DerivationValue(const Rig& rig);

// A number as the text writers write it (FormatNumber, the shortest text that reads back as it): an
// integer when it is one, else that text's double; null when not finite.
nlohmann::json NumberValue(double value);
// [{"code", "message", "shape"?, "value"?}], what WarningsToJson writes as text, as a value.
nlohmann::json WarningsValue(std::span<const Warning> warnings);

}  // namespace facespace::formats
