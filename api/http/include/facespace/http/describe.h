// The description of a rig as JSON: its shapes (ranges, groups, partners, aliases), in-betweens,
// correctives, controls, primitives, bounding box, skeleton, animations and load warnings. The rig
// route and `facespace info --json` answer with it.
#pragma once

#include <nlohmann/json.hpp>

#include "facespace/engine/rig.h"

namespace facespace::http {

nlohmann::json DescribeRig(const Rig& rig);

}  // namespace facespace::http
