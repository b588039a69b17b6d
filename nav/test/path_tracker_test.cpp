// Copyright Cairn authors.
#include "cairn/nav/path_tracker.h"

#include <gtest/gtest.h>

#include <cmath>

#include "cairn/nav/astar.h"
#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::DriveClosedLoop;
using testing::DriveResult;

constexpr double kPi = 3.14159265358979323846;

sim::UnicycleState StateAt(double x_m, double y_m, double yaw_rad) {
  sim::UnicycleState state;
  state.x_m = x_m;
  state.y_m = y_m;
  state.yaw_rad = yaw_rad;
  return state;
}

TEST(PathTrackerOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(PathTrackerOptions{}.IsValid(&why)) << why;
  PathTrackerOptions options;
  options.lookahead_m = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "PathTrackerOptions::lookahead_m = 0 must be finite and in [0.05, 5]");
  EXPECT_THROW(PathTracker tracker(options), std::invalid_argument);
  options = PathTrackerOptions{};
  options.min_speed_mps = 1.0;  // Above cruise_speed_mps.
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "min_speed_mps");
}

TEST(PathTrackerTest, RejectsBadPathsAndIdlesWithoutOne) {
  PathTracker tracker;
  EXPECT_THROW(tracker.SetPath({}), std::invalid_argument);
  EXPECT_THROW(tracker.SetPath({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(std::nan(""), 0, 0)}),
               std::invalid_argument);
  EXPECT_FALSE(tracker.has_path());
  const TrackerCommand cmd = tracker.Compute(0.0, 0.0, 0.0);
  EXPECT_TRUE(cmd.arrived);
  EXPECT_EQ(cmd.vx_mps, 0.0);
  EXPECT_EQ(cmd.wz_radps, 0.0);
}

TEST(PathTrackerTest, CommandsFollowTheGeometry) {
  PathTracker tracker;
  tracker.SetPath({Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(5, 0, 0)});
  TrackerCommand cmd = tracker.Compute(0.0, 0.0, 0.0);  // On the path, facing along it.
  EXPECT_NEAR(cmd.vx_mps, 0.6, 1e-9);
  EXPECT_NEAR(cmd.wz_radps, 0.0, 1e-9);
  EXPECT_NEAR(cmd.distance_left_m, 5.0, 1e-9);
  EXPECT_FALSE(cmd.arrived);
  cmd = tracker.Compute(1.0, -0.2, 0.0);  // Right of the path: turn left.
  EXPECT_GT(cmd.wz_radps, 0.0);
  cmd = tracker.Compute(1.0, 0.0, kPi);  // Facing backwards: turn in place.
  EXPECT_TRUE(cmd.turning_in_place);
  EXPECT_EQ(cmd.vx_mps, 0.0);
  EXPECT_NEAR(std::abs(cmd.wz_radps), 1.2, 1e-9);
  cmd = tracker.Compute(4.7, 0.0, 0.0);  // Near the end: slower.
  EXPECT_LT(cmd.vx_mps, 0.6);
  EXPECT_GE(cmd.vx_mps, 0.1);
  cmd = tracker.Compute(4.9, 0.05, 0.0);  // Within goal_tolerance_m.
  EXPECT_TRUE(cmd.arrived);
  EXPECT_EQ(cmd.vx_mps, 0.0);
  EXPECT_TRUE(tracker.Compute(0.0, 0.0, 0.0).arrived);  // Stays arrived until the next SetPath().
}

TEST(PathTrackerTest, DrivesAStraightPathInTheArena) {
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("arena"));
  const std::vector<Eigen::Vector3d> path = {{2.0, 7.0, 0.0}, {8.0, 7.0, 0.0}};
  const DriveResult r = DriveClosedLoop(grid, path, StateAt(2.0, 7.0, 0.0));
  EXPECT_TRUE(r.arrived);
  EXPECT_EQ(r.contacts, 0);
  EXPECT_LE(r.final_distance_m, 0.2 + 1e-9);
  EXPECT_LT(r.time_s, 6.0 / 0.6 + 5.0);
}

TEST(PathTrackerTest, DrivesAnLPathInTheTunnelsStartingBackwards) {
  // Down the south branch and round the L bend at (30, 5), starting while facing north (away from the path).
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("tunnels"));
  const std::vector<Eigen::Vector3d> path = {{30.0, 12.0, 0.0}, {30.0, 5.0, 0.0}, {40.0, 5.0, 0.0}};
  const DriveResult r = DriveClosedLoop(grid, path, StateAt(30.0, 12.0, kPi / 2));
  EXPECT_TRUE(r.arrived);
  EXPECT_EQ(r.contacts, 0);
  EXPECT_LE(r.final_distance_m, 0.2 + 1e-9);
  EXPECT_NEAR(r.final_state.z_m, 0.0, 1e-9);
}

TEST(PathTrackerTest, DrivesPlannedPathsFromEverySuggestedStart) {
  for (const std::string& name : sim::BuiltinWorldNames()) {
    const TraversabilityGrid grid(sim::MakeBuiltinWorld(name));
    const sim::BuiltinWorldInfo& info = sim::GetBuiltinWorldInfo(name);
    for (const sim::PlanarPose& start : info.suggested_starts) {
      const PlanResult plan = PlanPath(grid, {start.x_m, start.y_m}, {info.far_goal.x_m, info.far_goal.y_m});
      ASSERT_TRUE(plan.IsUsable()) << name << ": " << plan.message;
      const DriveResult r = DriveClosedLoop(grid, plan.path_W, StateAt(start.x_m, start.y_m, start.yaw_rad));
      EXPECT_TRUE(r.arrived) << name << " from " << start.x_m << ", " << start.y_m;
      EXPECT_EQ(r.contacts, 0) << name << " from " << start.x_m << ", " << start.y_m;
      EXPECT_LE(r.final_distance_m, 0.2 + 1e-9) << name;
    }
  }
}

TEST(PathTrackerTest, ClimbsThePlateInTheArena) {
  // Across the 0.1 m plate (x in [3, 6], y in [2, 5]): z follows the ground.
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("arena"));
  PathTracker tracker;
  tracker.SetPath({{1.5, 3.5, 0.0}, {8.0, 3.5, 0.0}});
  sim::Unicycle robot(sim::UnicycleLimits::Wheeled(), 0.25, StateAt(1.5, 3.5, 0.0));
  double max_z = 0.0;
  for (int i = 0; i < 1000; ++i) {
    const TrackerCommand cmd = tracker.Compute(robot.state().x_m, robot.state().y_m, robot.state().yaw_rad);
    if (cmd.arrived) break;
    EXPECT_FALSE(robot.Step(cmd.vx_mps, cmd.wz_radps, 0.05, grid).contact);
    max_z = std::max(max_z, robot.state().z_m);
  }
  EXPECT_NEAR(max_z, 0.1, 1e-9);
  EXPECT_NEAR(robot.state().z_m, 0.0, 1e-9);
}

}  // namespace
}  // namespace cairn::nav
