// Copyright Cairn authors.
//
// MultiLevelGrid and PlanPathMultiLevel on the built-in two-floor building (ground truth from the world's
// description in builtin_worlds.h) and on small hand-made maps.
#include "cairn/nav/multilevel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "cairn/nav/global_planner.h"
#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

std::shared_ptr<const core::VoxelGrid> Building() {
  static const auto world = std::make_shared<const core::VoxelGrid>(sim::MakeBuiltinWorld("building"));
  return world;
}

TraversabilityOptions Legged() { return GetPlatformProfile("legged").traversability; }

std::vector<double> SurfacesAt(const MultiLevelGrid& grid, double x, double y) {
  int ix = 0, iy = 0;
  EXPECT_TRUE(grid.CellOf(x, y, &ix, &iy));
  std::vector<double> z;
  const int column = grid.Column(ix, iy);
  for (int n = grid.FirstNode(column); n < grid.FirstNode(column + 1); ++n) z.push_back(grid.NodeZ(n));
  return z;
}

TEST(MultiLevelGridTest, KeepsEverySurfaceOfTheBuilding) {
  const MultiLevelGrid grid(Building(), Legged());
  EXPECT_GE(grid.max_levels(), 2);
  const std::vector<double> corridor = SurfacesAt(grid, 10.05, 7.05);  // floor 1 under floor 2
  ASSERT_EQ(corridor.size(), 2u);
  EXPECT_NEAR(corridor[0], 0.0, 1e-6);
  EXPECT_NEAR(corridor[1], 3.2, 1e-6);
  const std::vector<double> landing = SurfacesAt(grid, 22.55, 7.55);  // the pocket under the mid landing
  ASSERT_EQ(landing.size(), 2u);
  EXPECT_NEAR(landing[0], 0.0, 1e-6);
  EXPECT_NEAR(landing[1], 1.6, 1e-6);
  const std::vector<double> step = SurfacesAt(grid, 19.55, 6.55);  // first step of the lower flight
  ASSERT_GE(step.size(), 1u);
  EXPECT_NEAR(step[0], 0.2, 1e-6);

  // The body on each floor of the corridor, and against its wall.
  EXPECT_TRUE(grid.IsFootprintFreeNear(10.0, 7.1, 0.0, 0.3));
  EXPECT_TRUE(grid.IsFootprintFreeNear(10.0, 7.1, 3.2, 0.3));
  EXPECT_FALSE(grid.IsFootprintFreeNear(10.0, 6.2, 3.2, 0.3));
  EXPECT_NEAR(grid.GroundHeightNear(10.0, 7.1, 3.1).value_or(-1.0), 3.2, 1e-6);
  EXPECT_NEAR(grid.GroundHeightNear(10.0, 7.1, 0.1).value_or(-1.0), 0.0, 1e-6);
  EXPECT_FALSE(grid.GroundHeightNear(10.0, 7.1, 1.6).has_value());
}

TEST(MultiLevelGridTest, LeggedRobotPlansUpTheStairwellToTheUpperFloor) {
  const MultiLevelGrid grid(Building(), Legged());
  const PlanResult r = PlanPathMultiLevel(grid, {2.0, 7.1, 0.0}, {15.1, 3.0}, 3.2);
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.path_W.back().z(), 3.2, 1e-6);
  bool on_landing = false;
  double max_x = 0.0;
  for (std::size_t i = 1; i < r.path_W.size(); ++i) {
    EXPECT_LE(std::abs(r.path_W[i].z() - r.path_W[i - 1].z()), 0.25 + 1e-6) << i;
    on_landing = on_landing || std::abs(r.path_W[i].z() - 1.6) < 1e-6;
    max_x = std::max(max_x, r.path_W[i].x());
  }
  EXPECT_TRUE(on_landing) << r.message;
  EXPECT_GT(max_x, 21.5);  // through the stairwell to the mid landing
  // Every segment is walkable on the levels.
  for (std::size_t i = 1; i < r.path_W.size(); ++i) {
    EXPECT_TRUE(SegmentTraversableMultiLevel(grid, r.path_W[i - 1], r.path_W[i])) << i;
  }

  // Without a level the goal is on the start's floor; a level between the floors names the surfaces.
  const PlanResult same_floor = PlanPathMultiLevel(grid, {2.0, 7.1, 0.0}, {15.1, 3.0}, std::nan(""));
  ASSERT_TRUE(same_floor.IsUsable()) << same_floor.message;
  EXPECT_NEAR(same_floor.path_W.back().z(), 0.0, 1e-6);
  EXPECT_LT(same_floor.length_m, r.length_m);
  const PlanResult between = PlanPathMultiLevel(grid, {2.0, 7.1, 0.0}, {15.1, 3.0}, 1.7);
  EXPECT_EQ(between.status, PlanResult::Status::kGoalBlocked);
  EXPECT_NE(between.message.find("surfaces at z 0.00, 3.20"), std::string::npos) << between.message;

  // And back down from the upper floor.
  const PlanResult down = PlanPathMultiLevel(grid, {4.0, 7.1, 3.2}, {9.1, 11.0}, 0.0);
  ASSERT_TRUE(down.IsUsable()) << down.message;
  EXPECT_NEAR(down.path_W.back().z(), 0.0, 1e-6);
}

TEST(MultiLevelGridTest, PlannerRefusesAWheeledRobotNamingTheStairs) {
  GlobalPlanner planner(Building(), {GetPlatformProfile("wheeled"), GetPlatformProfile("legged")});
  GlobalPlanRequest request;
  request.start_W = {2.0, 7.1};
  request.start_z_m = 0.0;
  request.goal_W = {15.1, 3.0};
  request.goal_z_m = 3.2;
  request.platform = "wheeled";
  const GlobalPlan wheeled = planner.Plan(request);
  EXPECT_FALSE(wheeled.IsUsable());
  EXPECT_NE(wheeled.reason.find("climbs a 0.20 m step"), std::string::npos) << wheeled.reason;
  EXPECT_NE(wheeled.reason.find("platform legged climbs up to 0.30 m"), std::string::npos) << wheeled.reason;
  request.platform = "legged";
  const GlobalPlan legged = planner.Plan(request);
  ASSERT_TRUE(legged.IsUsable()) << legged.reason;
  EXPECT_NEAR(legged.result.path_W.back().z(), 3.2, 1e-6);
  EXPECT_TRUE(planner.CheckPath(legged.result.path_W, "legged").valid);
  // The same goal on the start's floor is a 2.5D plan for both.
  request.goal_z_m = std::nan("");
  request.platform = "wheeled";
  EXPECT_TRUE(planner.Plan(request).IsUsable());
  // A robot standing on the upper floor plans there without naming a level.
  request.start_W = {4.0, 7.1};
  request.start_z_m = 3.2;
  request.goal_W = {9.1, 11.0};
  const GlobalPlan upstairs = planner.Plan(request);
  ASSERT_TRUE(upstairs.IsUsable()) << upstairs.reason;
  EXPECT_NEAR(upstairs.result.path_W.back().z(), 3.2, 1e-6);
}

TEST(MultiLevelGridTest, UpdateMatchesAFreshBuild) {
  auto changed = std::make_shared<core::VoxelGrid>(*Building());
  MultiLevelGrid grid(Building(), Legged());
  // A crate on the upper floor's corridor, and one under the landing.
  const Eigen::AlignedBox2d crate_up(Eigen::Vector2d(9.0, 6.6), Eigen::Vector2d(9.6, 7.2));
  const Eigen::AlignedBox2d crate_down(Eigen::Vector2d(22.0, 7.0), Eigen::Vector2d(22.4, 7.6));
  for (double x = 9.05; x < 9.6; x += 0.1) {
    for (double y = 6.65; y < 7.2; y += 0.1) {
      for (double z = 3.25; z < 3.8; z += 0.1) changed->SetOccupiedAt({x, y, z});
    }
  }
  for (double x = 22.05; x < 22.4; x += 0.1) {
    for (double y = 7.05; y < 7.6; y += 0.1) {
      for (double z = 0.05; z < 0.5; z += 0.1) changed->SetOccupiedAt({x, y, z});
    }
  }
  grid.Update(changed, nullptr, {crate_up, crate_down});
  const MultiLevelGrid fresh(changed, Legged());
  ASSERT_EQ(grid.node_count(), fresh.node_count());
  int differ = 0;
  for (int n = 0; n < fresh.node_count(); ++n) {
    const double a = std::min(grid.ClearanceM(n), 2.0);
    const double b = std::min(fresh.ClearanceM(n), 2.0);
    differ += std::abs(grid.NodeZ(n) - fresh.NodeZ(n)) > 1e-6 || std::abs(a - b) > 1e-4;
  }
  EXPECT_EQ(differ, 0);
  EXPECT_FALSE(grid.IsFootprintFreeNear(9.3, 7.3, 3.2, 0.3));  // the crate upstairs
  EXPECT_TRUE(grid.IsFootprintFreeNear(9.3, 7.3, 0.0, 0.3));   // nothing changed below it
}

// A robot-built map: a floor seen from above over x in [0, 4] (seen-free space above it), nothing seen
// beyond; a plan is optimistic through the unseen part, but not across a strip where a ray went through the
// floor's height (a known drop).
TEST(MultiLevelGridTest, OwnMapIsOptimisticInUnseenSpaceOnly) {
  const Eigen::Vector3d p_min(0.0, 0.0, -0.5);
  auto world = std::make_shared<core::VoxelGrid>("own", p_min, 0.1, Eigen::Vector3i(100, 30, 30));
  auto seen_free = std::make_shared<core::VoxelGrid>("seen", p_min, 0.1, Eigen::Vector3i(100, 30, 30));
  for (int ix = 0; ix < 40; ++ix) {
    for (int iy = 0; iy < 30; ++iy) {
      world->SetOccupied({ix, iy, 4});  // floor top at z = 0
      for (int iz = 5; iz < 15; ++iz) seen_free->SetOccupied({ix, iy, iz});
    }
  }
  TraversabilityOptions options = Legged();
  options.unknown_is_lethal = false;
  const auto optimistic = std::make_shared<MultiLevelGrid>(world, options, seen_free);
  PlanResult r = PlanPathMultiLevel(*optimistic, {1.0, 1.5, 0.0}, {8.0, 1.5}, 0.0);
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.path_W.back().z(), 0.0, 1e-6);
  // Rays crossed the floor's height at x in [6, 7], and the voxel below: no floor there. (One voxel seen free
  // is not enough: a floor on a voxel boundary reads a voxel low in some columns.)
  for (int ix = 60; ix < 70; ++ix) {
    for (int iy = 0; iy < 30; ++iy) seen_free->SetOccupied({ix, iy, 4});
  }
  const MultiLevelGrid one_voxel(world, options, seen_free);
  EXPECT_TRUE(PlanPathMultiLevel(one_voxel, {1.0, 1.5, 0.0}, {8.0, 1.5}, 0.0).IsUsable());
  for (int ix = 60; ix < 70; ++ix) {
    for (int iy = 0; iy < 30; ++iy) seen_free->SetOccupied({ix, iy, 3});
  }
  const MultiLevelGrid drop(world, options, seen_free);
  r = PlanPathMultiLevel(drop, {1.0, 1.5, 0.0}, {8.0, 1.5}, 0.0);
  EXPECT_EQ(r.status, PlanResult::Status::kUnreachable) << r.message;
  // The same map read as complete: unseen space is not ground.
  options.unknown_is_lethal = true;
  const MultiLevelGrid complete(world, options, seen_free);
  EXPECT_EQ(PlanPathMultiLevel(complete, {1.0, 1.5, 0.0}, {8.0, 1.5}, 0.0).status,
            PlanResult::Status::kGoalBlocked);
}

// The building as a robot on floor 1 has seen it: everything below 2.0 m observed, nothing above. A goal on
// floor 2 is not connected yet: a partial plan climbs as far as the map shows (the upper flight's known
// steps); a wheeled robot is refused naming the stairs' step instead. A partial plan's end is scored by its
// planar distance and 30 x its height off the goal's level, but a voxel off counts as on the level: floor 2
// at 3.2 m read 3.3 m along its corridor and 3.2 m at the top of the stairs, and a robot on floor 2 was sent
// back to the stairs. A robot-built map of a room under a 0.2 m slab (z 1.4-1.6) it saw only from below: the
// slab's underside voxel, with unseen space above it, is no surface even once the robot's lidar has been
// higher (on a landing, sensor 2.2 m); a floor seen from above at a grazing angle (no free voxel observed
// right above it) still is. Seen from above too (free space observed over it), the slab is a surface.
TEST(MultiLevelGridTest, AnUndersideSeenFromBelowIsNoSurface) {
  sim::World truth = testing::FlatWorld(6.0, 6.0, 0.1, 3.0);
  sim::World world("own", truth.p_W_min(), truth.resolution_m(), truth.dims());
  sim::World seen("seen", truth.p_W_min(), truth.resolution_m(), truth.dims());
  testing::FillBox(&world, {0.0, 0.0, -0.1}, {6.0, 6.0, 0.0});  // the floor's top voxels, hit from above
  testing::FillBox(&world, {2.0, 2.0, 1.4}, {4.0, 4.0, 1.5});   // the slab's underside voxels, hit from below
  testing::FillBox(&seen, {0.0, 0.0, 0.0},
                   {6.0, 6.0, 1.4});  // rays below the slab (none right over the floor
  testing::FillBox(&seen, {0.0, 0.0, 0.0}, {6.0, 6.0, 0.2}, false);  // at a grazing angle)
  testing::FillBox(&seen, {0.0, 0.0, 1.6}, {2.0, 6.0, 3.0});         // around the slab, not over it
  auto own = std::make_shared<const core::VoxelGrid>(world);
  auto seen_free = std::make_shared<const core::VoxelGrid>(seen);
  TraversabilityOptions options = Legged();
  options.unknown_is_lethal = false;
  const MultiLevelGrid grid(own, options, seen_free, /*sensor_max_z_m=*/2.2);
  int ix = 0, iy = 0;
  ASSERT_TRUE(grid.CellOf(3.0, 3.0, &ix, &iy));
  EXPECT_LT(grid.NodeNear(ix, iy, 1.5, 0.3), 0) << "the underside at 1.4 is no surface";
  EXPECT_GE(grid.NodeNear(ix, iy, 0.0, 0.1), 0) << "the floor under it is";
  testing::FillBox(&seen, {2.0, 2.0, 1.6},
                   {4.0, 4.0, 1.8});  // then seen from above: free space right over the slab
  testing::FillBox(&world, {2.0, 2.0, 1.5}, {4.0, 4.0, 1.6});
  const MultiLevelGrid seen_twice(std::make_shared<const core::VoxelGrid>(world), options,
                                  std::make_shared<const core::VoxelGrid>(seen), 2.2);
  EXPECT_GE(seen_twice.NodeNear(ix, iy, 1.6, 0.1), 0) << "the slab's top, seen from above";
}

// Sight across the building's stairwell: along the corridor it is clear, through the wall between the two
// flights it is not, and an end outside the map sees nothing.
TEST(MultiLevelGridTest, SightIsClearAlongTheCorridorAndBlockedByTheWallBetweenTheFlights) {
  const MultiLevelGrid grid(Building(), Legged());
  EXPECT_TRUE(grid.IsSightClear({2.0, 7.1, 0.4}, {16.0, 7.1, 0.4}));
  EXPECT_TRUE(grid.IsSightClear({16.0, 7.1, 0.4}, {2.0, 7.1, 0.4}));
  // From the lower flight's fifth tread (z 1.0) to the upper flight beside it, through the wall at y 7.0-7.2.
  EXPECT_FALSE(grid.IsSightClear({20.75, 6.5, 1.4}, {20.75, 7.7, 2.4}));
  // From the mid landing up the upper flight: clear over its treads.
  EXPECT_TRUE(grid.IsSightClear({22.0, 7.7, 2.0}, {20.75, 7.7, 2.6}));
  EXPECT_FALSE(grid.IsSightClear({2.0, 7.1, 0.4}, {-5.0, 7.1, 0.4}));
  EXPECT_FALSE(grid.IsSightClear({2.0, 7.1, 0.4}, {std::nan(""), 7.1, 0.4}));
}

TEST(PartialRemainingTest, AFloorReadAVoxelOffIsOnTheGoalsLevel) {
  const Eigen::Vector2d goal(15.1, 11.0);
  const Eigen::Vector3d corridor(18.35, 7.55, 3.3), stairs_top(19.15, 7.85, 3.2), landing(21.8, 7.6, 1.7);
  EXPECT_DOUBLE_EQ(PartialRemainingM(corridor, goal, 3.2), (corridor.head<2>() - goal).norm());
  EXPECT_LT(PartialRemainingM(corridor, goal, 3.2), PartialRemainingM(stairs_top, goal, 3.2));
  EXPECT_NEAR(PartialRemainingM(landing, goal, 3.2), (landing.head<2>() - goal).norm() + 30.0 * 1.4, 1e-4);
  EXPECT_DOUBLE_EQ(PartialRemainingM(corridor, goal, std::nan("")), (corridor.head<2>() - goal).norm());
  EXPECT_NEAR(PartialRemainingM(corridor, goal, 3.2, 0.0), (corridor.head<2>() - goal).norm() + 3.0, 1e-4);
}

TEST(MultiLevelGridTest, PartialPlanClimbsAsFarAsTheMapShows) {
  std::shared_ptr<core::VoxelGrid> world, seen_free;
  testing::SeenBelow(*Building(), 2.0, &world, &seen_free);
  TraversabilityOptions options = Legged();
  options.unknown_is_lethal = false;
  const MultiLevelGrid grid(world, options, seen_free);
  AStarOptions astar;
  PlanResult r = PlanPathMultiLevel(grid, {2.0, 7.1, 0.0}, {15.1, 3.0}, 3.2, astar);
  EXPECT_EQ(r.status, PlanResult::Status::kUnreachable) << r.message;
  astar.allow_partial = true;
  r = PlanPathMultiLevel(grid, {2.0, 7.1, 0.0}, {15.1, 3.0}, 3.2, astar);
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_TRUE(r.partial);
  EXPECT_NEAR(r.path_W.back().z(), 1.8, 1e-6) << r.message;  // the upper flight's first known step
  EXPECT_NE(r.message.find("partial: the map connects no route to the goal at z 3.20 yet"), std::string::npos)
      << r.message;

  GlobalPlannerOptions planner_options;
  planner_options.reading.unknown_is_lethal = false;
  GlobalPlanner planner(world, {GetPlatformProfile("wheeled"), GetPlatformProfile("legged")},
                        planner_options);
  planner.UpdateMap(world, "legged",
                    std::make_shared<const TraversabilityGrid>(
                        *world, planner.TerrainOptionsFor(GetPlatformProfile("legged")), seen_free.get()),
                    seen_free);
  GlobalPlanRequest request;
  request.start_W = {2.0, 7.1};
  request.start_z_m = 0.0;
  request.goal_W = {15.1, 3.0};
  request.goal_z_m = 3.2;
  request.allow_partial = true;
  request.platform = "legged";
  const GlobalPlan legged = planner.Plan(request);
  ASSERT_TRUE(legged.IsUsable()) << legged.reason;
  EXPECT_TRUE(legged.result.partial);
  request.platform = "wheeled";
  const GlobalPlan wheeled = planner.Plan(request);
  EXPECT_FALSE(wheeled.IsUsable());
  EXPECT_NE(wheeled.reason.find("climbs a 0.20 m step"), std::string::npos) << wheeled.reason;
}

}  // namespace
}  // namespace cairn::nav
