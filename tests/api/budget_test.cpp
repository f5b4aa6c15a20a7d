// The render memory budget (api/http/src/http/context.h): estimates, and room shared by renders in
// flight.
#include <gtest/gtest.h>

#include <thread>

#include "http/context.h"

namespace facespace::http {
namespace budget_test {  // Named: the target is a unity build, its files share one unit.

TEST(RenderBudget, EstimatesSamplesAndOutputPixels) {
  picture::RenderOptions o;
  o.width = 2048;
  o.height = 2048;
  o.supersample = 4;
  // 8192² samples at 36 bytes (float colour, depth, read-back) + 2048² output pixels at 36 bytes.
  EXPECT_EQ(http::RenderBudget::Estimate(o, 1),
            size_t{8192} * 8192 * 36 + size_t{2048} * 2048 * 36);
  o.supersample = 1;
  EXPECT_EQ(http::RenderBudget::Estimate(o, 64),
            size_t{2048} * 2048 * 36 * 65);  // A sheet: every cell's image.
}

TEST(RenderBudget, RendersInFlightShareTheRoomAndOneAloneMayTakeItAll) {
  http::RenderBudget budget(100, 100);
  ASSERT_TRUE(budget.Acquire(60));
  EXPECT_EQ(budget.InFlight(), 60u);
  // 60 + 60 does not fit: the second waits, and gets the room once the first is done.
  std::thread release([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    budget.Release(60);
  });
  EXPECT_TRUE(budget.Acquire(60));
  release.join();
  EXPECT_EQ(budget.InFlight(), 60u);
  // No room within the wait: refused (the route answers 503), nothing taken.
  EXPECT_FALSE(budget.Acquire(50));
  EXPECT_EQ(budget.InFlight(), 60u);
  budget.Release(60);
  // More than the whole budget, alone: allowed (the per-request check is the route's), counted as
  // all of it.
  EXPECT_TRUE(budget.Acquire(500));
  EXPECT_EQ(budget.InFlight(), 100u);
  budget.Release(500);
  EXPECT_EQ(budget.InFlight(), 0u);
}

}  // namespace budget_test
}  // namespace facespace::http
