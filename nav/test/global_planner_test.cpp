// Copyright Cairn authors.
#include "cairn/nav/global_planner.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

std::vector<PlatformProfile> BothPlatforms() {
  return {GetPlatformProfile("wheeled"), GetPlatformProfile("legged")};
}

TEST(PlatformProfileTest, BuiltInProfilesAreValidAndDiffer) {
  for (const auto& name : PlatformNames()) {
    std::string why;
    EXPECT_TRUE(GetPlatformProfile(name).IsValid(&why)) << name << ": " << why;
  }
  EXPECT_LT(GetPlatformProfile("wheeled").traversability.max_step_m, 0.2);  // no stairs
  EXPECT_GE(GetPlatformProfile("legged").traversability.max_step_m, 0.2);   // stairs of 0.2 m rise
}

TEST(PlatformProfileTest, UnknownNameListsValidOnes) {
  try {
    GetPlatformProfile("hovercraft");
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'hovercraft'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("wheeled, legged"), std::string::npos) << e.what();
  }
}

TEST(PlatformProfileTest, InvalidFieldIsNamed) {
  PlatformProfile p = GetPlatformProfile("legged");
  p.cruise_speed_mps = 2.0;  // above max_speed_mps 0.6
  std::string why;
  EXPECT_FALSE(p.IsValid(&why));
  EXPECT_NE(why.find("legged: cruise_speed_mps = 2"), std::string::npos) << why;
}

TEST(GlobalPlannerTest, RejectsBadConstruction) {
  auto world = std::make_shared<const sim::World>(FlatWorld(4, 4));
  EXPECT_THROW(GlobalPlanner(nullptr, BothPlatforms()), std::invalid_argument);
  EXPECT_THROW(GlobalPlanner(world, {}), std::invalid_argument);
  EXPECT_THROW(GlobalPlanner(world, {GetPlatformProfile("legged"), GetPlatformProfile("legged")}),
               std::invalid_argument);
  GlobalPlannerOptions options;
  options.diagnose_max_step_m = -1;
  try {
    [[maybe_unused]] const GlobalPlanner planner(world, BothPlatforms(), options);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("diagnose_max_step_m = -1"), std::string::npos) << e.what();
  }
}

TEST(GlobalPlannerTest, StraightPathOnOpenGroundIsShortest) {
  auto world = std::make_shared<const sim::World>(FlatWorld(10, 6));
  GlobalPlanner planner(world, BothPlatforms());
  const GlobalPlan plan = planner.Plan({{1.05, 3.05}, {8.95, 3.05}, "wheeled"});
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  EXPECT_NEAR(plan.result.length_m, 7.9, 0.05);
  EXPECT_TRUE(plan.reason.empty());
  EXPECT_EQ(plan.map_version, 0u);
}

TEST(GlobalPlannerTest, DetoursAroundAWallByTheKnownShortestRoute) {
  // A wall across x = 5 from y = 0 to y = 4.5 leaves a gap at the top (y in [4.5, 6]): the path must go
  // through the gap. With no clearance cost the shortest route hugs the inflated wall end.
  sim::World w = FlatWorld(10, 6);
  FillBox(&w, {4.8, 0.0, 0.0}, {5.2, 4.5, 1.6});
  GlobalPlannerOptions options;
  options.astar.clearance_cost = 0.0;
  GlobalPlanner planner(std::make_shared<const sim::World>(std::move(w)), BothPlatforms(), options);
  const GlobalPlan plan = planner.Plan({{2.0, 1.0}, {8.0, 1.0}, "wheeled"});
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  // Lower bound: the straight lines through the corner of the inflated wall end at about (5, 4.8).
  const double lower = 2 * std::hypot(3.0, 3.8);
  EXPECT_GE(plan.result.length_m, lower - 0.1);
  EXPECT_LE(plan.result.length_m, lower + 0.6);
  double max_y = 0;
  for (const auto& p : plan.result.path_W) max_y = std::max(max_y, p.y());
  EXPECT_GT(max_y, 4.7);
}

TEST(GlobalPlannerTest, UnreachableAndBadGoalsHaveReasons) {
  sim::World w = FlatWorld(10, 6);
  FillBox(&w, {4.8, 0.0, 0.0}, {5.2, 6.0, 1.6});  // a full wall: the east half is cut off
  GlobalPlanner planner(std::make_shared<const sim::World>(std::move(w)), BothPlatforms());
  GlobalPlan plan = planner.Plan({{2.0, 3.0}, {8.0, 3.0}, "legged"});
  EXPECT_FALSE(plan.IsUsable());
  EXPECT_EQ(plan.result.status, PlanResult::Status::kUnreachable);
  EXPECT_FALSE(plan.reason.empty());
  plan = planner.Plan({{2.0, 3.0}, {std::numeric_limits<double>::quiet_NaN(), 3.0}, "legged"});
  EXPECT_EQ(plan.result.status, PlanResult::Status::kInvalidGoal);
  EXPECT_NE(plan.reason.find("nan"), std::string::npos) << plan.reason;
  plan = planner.Plan({{2.0, 3.0}, {80.0, 3.0}, "legged"});
  EXPECT_EQ(plan.result.status, PlanResult::Status::kOutOfMap);
  EXPECT_NE(plan.reason.find("80.00"), std::string::npos) << plan.reason;
  plan = planner.Plan({{2.0, 3.0}, {5.0, 3.0}, "legged"});  // inside the wall
  EXPECT_EQ(plan.result.status, PlanResult::Status::kGoalBlocked);
  plan = planner.Plan({{2.0, 3.0}, {3.0, 3.0}, "tracked"});
  EXPECT_FALSE(plan.platform_known);
  EXPECT_NE(plan.reason.find("'tracked'"), std::string::npos) << plan.reason;
  EXPECT_NE(plan.reason.find("wheeled, legged"), std::string::npos) << plan.reason;
}

// A goal inside a wall block is refused with the nearest traversable cell: seen floor beside the block, not
// the unknown space a robot's optimistic map also calls traversable; a goal on unseen ground is marked
// unmapped, one on seen floor is not.
TEST(GlobalPlannerTest, ABlockedGoalNamesTheNearestTraversablePointAndAnUnseenOneIsUnmapped) {
  sim::World w = FlatWorld(12, 8);
  FillBox(&w, {5.0, 2.0, 0.0}, {7.0, 6.0, 1.6});                        // a 2 x 4 m block of rock
  FillBox(&w, {9.0, 0.0, -0.2}, {12.0, 8.0, 1.6}, /*occupied=*/false);  // nothing seen east of x = 9
  GlobalPlannerOptions options;
  options.reading.unknown_is_lethal = false;  // read as a robot reads its own map
  GlobalPlanner planner(std::make_shared<const sim::World>(std::move(w)), BothPlatforms(), options);
  GlobalPlan plan = planner.Plan({{1.0, 4.0}, {6.0, 4.3}, "wheeled"});
  ASSERT_EQ(plan.result.status, PlanResult::Status::kGoalBlocked) << plan.reason;
  EXPECT_FALSE(plan.goal_unmapped);
  ASSERT_TRUE(plan.nearest_free_W.allFinite());
  // The block's west face is at x = 5, its east face at x = 7: with the 0.3 m radius, free from x < 4.7.
  EXPECT_NEAR(plan.nearest_free_W.x(), 4.65, 0.11);
  EXPECT_NEAR(plan.nearest_free_W.y(), 4.3, 0.11);
  const auto grid = planner.Grid("wheeled");
  EXPECT_TRUE(grid->IsTraversableAt(plan.nearest_free_W.x(), plan.nearest_free_W.y()));

  plan = planner.Plan({{1.0, 4.0}, {10.5, 4.0}, "wheeled"});  // unseen ground: planned, optimistically
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  EXPECT_TRUE(plan.goal_unmapped);
  EXPECT_FALSE(plan.nearest_free_W.allFinite());
  plan = planner.Plan({{1.0, 4.0}, {8.0, 1.0}, "wheeled"});  // seen floor
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  EXPECT_FALSE(plan.goal_unmapped);

  EXPECT_FALSE(NearestTraversable(*grid, {6.0, 4.0}, 0.3, 0.5)) << "1.3 m from the block's faces";
  const auto seen = NearestTraversable(*grid, {9.3, 4.0}, 0.3, 1.0);
  ASSERT_TRUE(seen);
  EXPECT_LT(seen->x(), 9.0) << "seen floor 0.35 m away before unknown space under the point";
  const auto unknown = NearestTraversable(*grid, {10.5, 4.0}, 0.3, 0.5);
  ASSERT_TRUE(unknown) << "no seen floor within 0.5 m: unknown space";
  EXPECT_LE((*unknown - Eigen::Vector2d(10.5, 4.0)).norm(), 0.1);
  EXPECT_FALSE(NearestTraversable(*grid, {std::nan(""), 4.0}, 0.3, 5.0));
}

// The built-in tunnels world has a staircase (5 steps of 0.2 m rise, 0.5 m run) from the room floor to a
// 1 m platform at x in [52.5, 56], y in [22.5, 25].
class StaircaseTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    planner_ = new GlobalPlanner(std::make_shared<const sim::World>(sim::LoadWorld("builtin:tunnels")),
                                 BothPlatforms());
  }
  static void TearDownTestSuite() {
    delete planner_;
    planner_ = nullptr;
  }
  static GlobalPlanner* planner_;
};
GlobalPlanner* StaircaseTest::planner_ = nullptr;

TEST_F(StaircaseTest, LeggedRobotPlansUpTheStairs) {
  const GlobalPlan plan = planner_->Plan({{48.0, 20.0}, {54.5, 23.8}, "legged"});
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  EXPECT_NEAR(plan.result.path_W.back().z(), 1.0, 0.11);  // on the platform
  // It climbs: heights along the path rise from the floor to the platform over the stairs.
  EXPECT_NEAR(plan.result.path_W.front().z(), 0.0, 0.11);
  const auto grid = planner_->Grid("legged");
  ASSERT_NE(grid, nullptr);
  const PathCheck check = planner_->CheckPath(plan.result.path_W, "legged");
  EXPECT_TRUE(check.valid) << check.message;
}

TEST_F(StaircaseTest, WheeledRobotIsRefusedWithTheStep) {
  const GlobalPlan plan = planner_->Plan({{48.0, 20.0}, {54.5, 23.8}, "wheeled"});
  EXPECT_FALSE(plan.IsUsable());
  EXPECT_NE(plan.reason.find("unreachable for platform wheeled"), std::string::npos) << plan.reason;
  EXPECT_NE(plan.reason.find("0.20 m step"), std::string::npos) << plan.reason;
  EXPECT_NE(plan.reason.find("max_step_m 0.15"), std::string::npos) << plan.reason;
  EXPECT_NE(plan.reason.find("platform legged climbs up to 0.30 m"), std::string::npos) << plan.reason;
}

// map_memory_bytes() counts the world and every grid the planner caches, as they are built and replaced.
TEST(GlobalPlannerTest, MapMemoryCountsTheWorldAndTheGridsItHolds) {
  const sim::World w = FlatWorld(12, 8);
  const auto world = std::make_shared<const sim::World>(w);
  GlobalPlanner planner(world, BothPlatforms());
  EXPECT_EQ(planner.map_memory_bytes(), world->MemoryBytes());
  EXPECT_GE(world->MemoryBytes(), static_cast<std::size_t>(world->num_voxels() / 8));
  const auto wheeled = planner.Grid("wheeled");
  ASSERT_NE(wheeled, nullptr);
  EXPECT_GE(wheeled->MemoryBytes(), static_cast<std::size_t>(wheeled->nx() * wheeled->ny()) * 18u);
  EXPECT_EQ(planner.map_memory_bytes(), world->MemoryBytes() + wheeled->MemoryBytes());
  const auto legged = planner.Grid("legged");
  EXPECT_EQ(planner.map_memory_bytes(),
            world->MemoryBytes() + wheeled->MemoryBytes() + legged->MemoryBytes());
  // A new map drops the old grids; a larger one is counted whole.
  const auto larger = std::make_shared<const sim::World>(FlatWorld(24, 16));
  planner.UpdateWorld(larger);
  EXPECT_EQ(planner.map_memory_bytes(), larger->MemoryBytes());
  EXPECT_GE(larger->MemoryBytes(), 3 * world->MemoryBytes());
}

TEST(GlobalPlannerTest, MapChangeUnderThePathIsDetectedAndReplanned) {
  sim::World w = FlatWorld(12, 8);
  GlobalPlanner planner(std::make_shared<const sim::World>(w), BothPlatforms());
  const GlobalPlan first = planner.Plan({{1.0, 4.0}, {11.0, 4.0}, "wheeled"});
  ASSERT_TRUE(first.IsUsable()) << first.reason;
  EXPECT_TRUE(planner.CheckPath(first.result.path_W, "wheeled").valid);
  // A rockfall across the straight route.
  FillBox(&w, {5.8, 2.0, 0.0}, {6.2, 6.0, 1.6});
  planner.UpdateWorld(std::make_shared<const sim::World>(w));
  EXPECT_EQ(planner.map_version(), 1u);
  const PathCheck check = planner.CheckPath(first.result.path_W, "wheeled");
  EXPECT_FALSE(check.valid);
  EXPECT_GE(check.first_blocked_segment, 0);
  EXPECT_NE(check.message.find("no longer traversable"), std::string::npos) << check.message;
  const GlobalPlan second = planner.Plan({{1.0, 4.0}, {11.0, 4.0}, "wheeled"});
  ASSERT_TRUE(second.IsUsable()) << second.reason;
  EXPECT_EQ(second.map_version, 1u);
  EXPECT_GT(second.result.length_m, first.result.length_m + 0.5);
  EXPECT_TRUE(planner.CheckPath(second.result.path_W, "wheeled").valid);
}

TEST(LethalCellsNearTest, ReportsWallsInTheBodyFrame) {
  sim::World w = FlatWorld(10, 6);
  FillBox(&w, {6.0, 0.0, 0.0}, {6.2, 6.0, 1.6});  // a wall at x in [6, 6.2]
  const TraversabilityGrid grid(w);
  std::vector<Eigen::Vector3f> points;
  // Robot at (5, 3) facing +y: the wall is 1 m to its right, i.e. at y_B = -1.
  LethalCellsNear(grid, 5.0, 3.0, 3.14159265358979 / 2, 2.0, &points);
  ASSERT_FALSE(points.empty());
  for (const auto& p : points) {
    EXPECT_LE(p.head<2>().norm(), 2.0 + 1e-5);
    EXPECT_LT(p.y(), -0.99);  // everything lethal nearby is the wall (or outside the map further right)
  }
  // NaN pose: nothing, no crash.
  LethalCellsNear(grid, std::nan(""), 3.0, 0.0, 2.0, &points);
  EXPECT_TRUE(points.empty());
}

}  // namespace
}  // namespace cairn::nav
