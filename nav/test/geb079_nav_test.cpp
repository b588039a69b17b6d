// Copyright Cairn authors.
//
// Navigation on the real scan geb079.bt (a building floor, OctoMap sample data): traversability, sampling,
// planning and closed-loop driving. Skipped when data/geb079.bt is absent.
//
// The scan was taken from the corridor: the corridor floor (about 39 x 2.4 m, along x, y ~ 0) is well
// covered; the offices beside it were seen through their doors, so most of their floor is missing
// (unknown) and they are not planned into. Defaults work unchanged: the automatic reference height finds the
// floor at z = 0, walls reach the ceiling at the top of the map and are obstacles.
#include <gtest/gtest.h>

#include "cairn/nav/astar.h"
#include "cairn/nav/sampling.h"
#include "cairn/sim/world.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

// Starts and goal used by the integration tests (keep in sync with the report to the integrators).
const Eigen::Vector2d kStartA(-4.0, 0.0);
const Eigen::Vector2d kStartB(2.0, 0.0);
const Eigen::Vector2d kGoal(24.0, 0.0);

class Geb079NavTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!sim::testing::FileExists(sim::testing::Geb079Path())) return;
    grid_ = new TraversabilityGrid(sim::LoadWorld(sim::testing::Geb079Path()));
  }
  static void TearDownTestSuite() {
    delete grid_;
    grid_ = nullptr;
  }
  void SetUp() override { CAIRN_SKIP_WITHOUT_GEB079(); }
  static TraversabilityGrid* grid_;
};

TraversabilityGrid* Geb079NavTest::grid_ = nullptr;

TEST_F(Geb079NavTest, TraversabilityFindsTheCorridorFloor) {
  const TraversabilitySummary& s = grid_->summary();
  // The map's extent over 0.08 m cells: a bound that falls on a cell edge rounds either way with the
  // compiler's floating-point code (a sanitized build reads 188 rows).
  EXPECT_NEAR(grid_->nx(), 487, 1);
  EXPECT_NEAR(grid_->ny(), 187, 1);
  EXPECT_NEAR(s.reference_height_m, 0.0, 1e-6);   // Top of the floor voxels.
  EXPECT_GT(s.cells_traversable, 5000);           // ~9300 cells of 0.08 m: ~60 m^2.
  EXPECT_GT(s.cells_unknown, s.cells_total / 3);  // Unseen office floors.
  EXPECT_GT(s.cells_inferred, 0);                 // Holes in the corridor floor filled.
  for (double x = -4.0; x <= 26.0; x += 2.0) {    // Along the corridor.
    EXPECT_TRUE(grid_->IsTraversableAt(x, 0.0)) << x;
    EXPECT_NEAR(grid_->GroundHeight(x, 0.0).value_or(-1.0), 0.0, 0.08 + 1e-6) << x;  // Within a voxel.
  }
}

TEST_F(Geb079NavTest, SampledStartsAreConnected) {
  const std::vector<Eigen::Vector3d> starts = SampleFreeStarts(*grid_, 3, 2.0, 7);
  ASSERT_EQ(starts.size(), 3u);
  for (const Eigen::Vector3d& s : starts) {
    const PlanResult r = PlanPath(*grid_, s.head<2>(), kGoal);
    EXPECT_TRUE(r.IsUsable()) << r.message;
  }
}

// Driving these paths closed loop (local planner + iLQR) is tested in robot_agent/test/navigation_test.cpp.
TEST_F(Geb079NavTest, PlansToAFarGoal) {
  for (const Eigen::Vector2d& start : {kStartA, kStartB}) {
    ASSERT_TRUE(grid_->IsTraversableAt(start.x(), start.y()));
    const PlanResult plan = PlanPath(*grid_, start, kGoal);
    ASSERT_TRUE(plan.IsUsable()) << plan.message;
    EXPECT_GE((kGoal - start).norm(), 10.0);
    EXPECT_GE(plan.length_m, (kGoal - start).norm() - 1e-9);
    EXPECT_LT(plan.length_m, (kGoal - start).norm() + 1.0);
  }
}

}  // namespace
}  // namespace cairn::nav
