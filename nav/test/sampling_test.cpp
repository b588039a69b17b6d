// Copyright Cairn authors.
#include "cairn/nav/sampling.h"

#include <gtest/gtest.h>

#include "cairn/nav/astar.h"
#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

TEST(SamplingTest, SeededSpacedTraversableAndConnected) {
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("tunnels"));
  const std::vector<Eigen::Vector3d> a = SampleFreeStarts(grid, 6, 2.0, 42);
  const std::vector<Eigen::Vector3d> b = SampleFreeStarts(grid, 6, 2.0, 42);
  const std::vector<Eigen::Vector3d> c = SampleFreeStarts(grid, 6, 2.0, 43);
  ASSERT_EQ(a.size(), 6u);
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(grid.IsTraversableAt(a[i].x(), a[i].y()));
    EXPECT_NEAR(a[i].z(), 0.0, 1e-9);
    for (std::size_t j = i + 1; j < a.size(); ++j) EXPECT_GE((a[i] - a[j]).head<2>().norm(), 2.0);
    // All in one region: planning between them succeeds.
    const PlanResult r = PlanPath(grid, a[0].head<2>(), a[i].head<2>());
    EXPECT_TRUE(r.IsUsable()) << r.message;
  }
}

TEST(SamplingTest, UsesTheLargestRegionAndStopsWhenFull) {
  // Two rooms split by a wall: west 2 m wide, east 7 m wide.
  sim::World world = FlatWorld(10.0, 4.0);
  FillBox(&world, {2.5, 0.0, 0.0}, {2.7, 4.0, 1.5});
  const TraversabilityGrid grid(world);
  const std::vector<std::size_t> region = LargestTraversableComponent(grid);
  ASSERT_FALSE(region.empty());
  for (const std::size_t i : region) EXPECT_GT(grid.CellCenter(static_cast<int>(i % grid.nx()), 0).x(), 2.7);
  const std::vector<Eigen::Vector3d> starts = SampleFreeStarts(grid, 100, 1.0, 1);
  EXPECT_GT(starts.size(), 4u);
  EXPECT_LT(starts.size(), 100u);  // The region holds far fewer than 100 points 1 m apart.
  for (const Eigen::Vector3d& s : starts) EXPECT_GT(s.x(), 2.7);
  EXPECT_TRUE(SampleFreeStarts(grid, 0, 1.0, 1).empty());
  EXPECT_THROW(SampleFreeStarts(grid, -1, 1.0, 1), std::invalid_argument);
  EXPECT_THROW(SampleFreeStarts(grid, 1, std::nan(""), 1), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::nav
