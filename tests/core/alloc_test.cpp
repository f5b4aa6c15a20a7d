// Steady-state evaluation allocates nothing: every operator new in this test binary is counted,
// and a warm EvaluateRig (morphs, recomputed normals, a posed skin) must not call it.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "facespace/engine/blend.h"
#include "facespace/engine/skeleton.h"
#include "facespace/formats/io.h"
#include "test_util.h"

namespace {
std::atomic<size_t> g_allocations{0};
}  // namespace

void* operator new(size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size ? size : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, size_t) noexcept { std::free(p); }

namespace facespace {
namespace {

size_t AllocationsOf(const Rig& rig, std::span<const float> weights, const BlendOptions& options,
                     BlendedRig& out, BlendContext& context) {
  EXPECT_TRUE(
      EvaluateRig(rig, weights, options, out, context).ok());  // Warm: buffers grow to the rig.
  EXPECT_TRUE(EvaluateRig(rig, weights, options, out, context).ok());
  const size_t before = g_allocations.load();
  const Status s = EvaluateRig(rig, weights, options, out, context);
  const size_t after = g_allocations.load();
  EXPECT_TRUE(s.ok());
  return after - before;
}

TEST(SteadyState, MorphsAndRecomputedNormalsAllocateNothing) {
  const Rig rig = formats::LoadRigFile(test::Bundled("facecap/facecap.glb")).value();
  std::vector<float> w(rig.shapes.size(), 0.0f);
  w[24] = 0.7f;
  w[3] = 0.4f;
  BlendedRig out;
  BlendContext context;
  EXPECT_EQ(AllocationsOf(rig, w, {}, out, context), 0u);
  BlendOptions recompute;
  recompute.normals = NormalMode::kRecompute;
  EXPECT_EQ(AllocationsOf(rig, w, recompute, out, context), 0u);
}

TEST(SteadyState, APosedSkinAllocatesNothing) {
  const Rig rig = formats::LoadRigFile(test::RealAsset("Fox/Fox.glb")).value();
  Pose pose = RestPose(rig);
  pose.local[5].rotation = EulerToQuaternion(20, 10, 0);
  BlendOptions options;
  options.pose = &pose;
  BlendedRig out;
  BlendContext context;
  EXPECT_EQ(AllocationsOf(rig, {}, options, out, context), 0u);
  options.dual_quaternion = true;
  EXPECT_EQ(AllocationsOf(rig, {}, options, out, context), 0u);
}

}  // namespace
}  // namespace facespace
