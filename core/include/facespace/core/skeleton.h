// Skeletons, all of it: transforms, the node hierarchy, skinning, animation clips and pose
// requests. Morph first, then skin (glTF's order). Include the part you need where you can.
#pragma once

#include "facespace/core/animation.h"
#include "facespace/core/hierarchy.h"
#include "facespace/core/pose_request.h"
#include "facespace/core/skinning.h"
#include "facespace/core/transform.h"
