// The query parameters of GET /v1/rigs/{id}/mesh and /render besides the weights (w[NAME] or
// w.NAME), control values (c[NAME] or c.NAME) and expressions (e[NAME] or e.NAME): one list, read
// by the routes (did-you-mean for an unknown one) and declared by /openapi.json (openapi.cpp aborts
// on a name it cannot describe; api_test checks the routes read every name).
#pragma once

#include <string_view>

namespace facespace::http {

inline constexpr std::string_view kMeshQuery[] = {
    "format", "space",  "keep_targets", "mode",   "normals", "strict", "skinning", "lod", "pose",
    "blend",  "layers", "animation",    "motion", "time",    "frame",  "loop",     "gaze"};
inline constexpr std::string_view kRenderQuery[] = {
    "format", "mode",  "normals", "strict",    "skinning",   "lod",         "pose",
    "blend",  "gaze",  "layers",  "animation", "motion",     "time",        "frame",
    "loop",   "width", "height",  "view",      "background", "supersample", "quality",
    "camera", "yaw",   "pitch",   "distance",  "zoom",       "fov",         "exposure"};

}  // namespace facespace::http
