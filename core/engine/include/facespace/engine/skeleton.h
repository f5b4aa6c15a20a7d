// Skeletons, all of it: transforms, the node hierarchy, skinning, animation clips and pose
// requests. Morph first, then skin (glTF's order). Include the part you need where you can.
#pragma once

#include "facespace/engine/animation.h"
#include "facespace/engine/hierarchy.h"
#include "facespace/engine/pose_request.h"
#include "facespace/engine/skinning.h"
#include "facespace/engine/transform.h"
