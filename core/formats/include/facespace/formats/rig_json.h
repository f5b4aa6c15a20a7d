// What a rig describes of itself as JSON values (nlohmann), for documents built with nlohmann (GET
// /v1/rigs/{id}, `facespace info --json`): the manifest's schema (README "Manifest").
#pragma once

#include <nlohmann/json.hpp>

#include "facespace/core/rig.h"

namespace facespace {

// The rig's expressions: name -> {weights, binary, override_blink, override_look_at, override_mouth, derived}.
nlohmann::json ExpressionsValue(const Rig& rig);
// Its gaze: {type, eyes | shapes, head, neck, range_maps, origin}.
nlohmann::json GazeValue(const Rig& rig);
// The viseme map (core/speech.h): viseme -> {SHAPE: w} for all 15, "nolip", "jaw"; null when the rig cannot speak.
nlohmann::json VisemesValue(const Rig& rig);

}  // namespace facespace
