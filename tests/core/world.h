// The core tests' posed blend: world positions of every vertex of a rig blended with `weights`
// under `pose` (null: the rest pose), as the exporters place them.
#pragma once

#include <gtest/gtest.h>

#include <span>
#include <vector>

#include "facespace/engine/blend.h"
#include "facespace/formats/io.h"

namespace facespace::test {

inline std::vector<float> WorldOf(const Rig& rig, std::span<const float> weights,
                                  const Pose* pose) {
  BlendedRig blended;
  BlendContext context;
  BlendOptions options;
  options.pose = pose;
  EXPECT_TRUE(EvaluateRig(rig, weights, options, blended, context).ok());
  std::vector<float> out;
  formats::WorldPositions(blended, out);
  return out;
}

}  // namespace facespace::test
