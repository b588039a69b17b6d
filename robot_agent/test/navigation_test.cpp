// Closed-loop tests of the navigation component (global planner -> FALCO local planner -> iLQR) on the
// simulated platform, faster than real time and without DDS: waypoint missions on the real scan geb079.bt and
// the built-in tunnels, the staircase for legged and wheeled robots, smart joystick at a wall and an
// off-centre doorway, and replanning when the map changes under the path.
#include "cairn/nav/navigation.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <thread>

#include "../../nav/test/nav_test_util.h"
#include "../../sim/test/test_util.h"
#include "agent_team.h"
#include "cairn/agent/modes/waypoint_recovery.h"
#include "cairn/agent/services/planning_service.h"
#include "cairn/core/build_paths.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using nav::testing::FillBox;
using nav::testing::FlatWorld;

constexpr double kDt = 0.02;  // the agent's 50 Hz control loop

// Library per heading range, built once per process (about a second each).
std::shared_ptr<const nav::TrajectoryLibrary> LibraryFor(const nav::PlatformProfile& platform) {
  static std::map<double, std::shared_ptr<const nav::TrajectoryLibrary>> cache;
  auto& entry = cache[platform.local_heading_range_rad];
  if (!entry) {
    nav::TrajectoryLibraryOptions o;
    o.heading_range_rad = platform.local_heading_range_rad;
    o.collision_radius_m = platform.footprint_radius_m + 0.03;
    o.voxel_size_m = 0.05;
    entry = std::make_shared<const nav::TrajectoryLibrary>(o);
  }
  return entry;
}

// One robot: navigation + platform + stand-in obstacle sensor on the planner's grid.
struct SimRobot {
  SimRobot(const std::shared_ptr<const sim::World>& world, const std::string& platform_name, double x,
           double y, double yaw, double blocked_timeout_s = nav::NavigationOptions{}.blocked_timeout_s,
           double stall_timeout_s = nav::NavigationOptions{}.stall_timeout_s)
      : planner(std::make_shared<nav::GlobalPlanner>(
            world, std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled"),
                                                     nav::GetPlatformProfile("legged")})),
        options(MakeOptions(platform_name, blocked_timeout_s, stall_timeout_s)),
        navigation(options, planner, LibraryFor(options.platform)),
        platform(options.platform.limits, options.platform.footprint_radius_m) {
    sim::UnicycleState s;
    s.x_m = x;
    s.y_m = y;
    s.yaw_rad = yaw;
    s.z_m = planner->Grid(platform_name)->GroundHeight(x, y).value_or(0.0);
    platform.set_state(s);
  }

  static nav::NavigationOptions MakeOptions(
      const std::string& platform_name, double blocked_timeout_s = nav::NavigationOptions{}.blocked_timeout_s,
      double stall_timeout_s = nav::NavigationOptions{}.stall_timeout_s) {
    nav::NavigationOptions o;
    o.platform = nav::GetPlatformProfile(platform_name);
    o.blocked_timeout_s = blocked_timeout_s;
    o.stall_timeout_s = stall_timeout_s;
    return o;
  }

  // Senses every 0.1 s, then runs one control step of `step` and the platform.
  template <class StepFn>
  nav::NavigationStep Tick(StepFn&& step) {
    const auto grid = planner->Grid(options.platform.name);
    if (std::fmod(t_s + 1e-9, 0.1) < kDt) {
      const auto& s = platform.state();
      nav::LethalCellsNear(*grid, s.x_m, s.y_m, s.yaw_rad, options.sensor_range_m, &points_B);
      navigation.SetObstacles(points_B, s, t_s);
    }
    nav::NavigationStep out = step();
    const sim::UnicycleStepResult r = platform.Step(out.linear_x_mps, out.angular_z_radps, kDt, *grid);
    contacts += r.contact ? 1 : 0;
    const auto& s = platform.state();
    min_clearance_m = std::min(min_clearance_m, ClearanceOf(*grid, s.x_m, s.y_m));
    max_speed_mps = std::max(max_speed_mps, std::abs(s.v_mps));
    t_s += kDt;
    return out;
  }

  // Distance from (x, y) to the nearest lethal cell centre (searched within 1 m), metres.
  static double ClearanceOf(const nav::TraversabilityGrid& grid, double x, double y) {
    double best = 1.0;
    int ix = 0, iy = 0;
    if (!grid.CellOf(x, y, &ix, &iy)) return 0.0;
    const int r = static_cast<int>(std::ceil(1.0 / grid.cell_size_m()));
    for (int dx = -r; dx <= r; ++dx) {
      for (int dy = -r; dy <= r; ++dy) {
        if (grid.InGrid(ix + dx, iy + dy) && !grid.IsLethal(ix + dx, iy + dy)) continue;
        best = std::min(best, (grid.CellCenter(ix + dx, iy + dy) - Eigen::Vector2d(x, y)).norm());
      }
    }
    return best;
  }

  // Drives to (x, y) in waypoint mode; returns the final step (arrived or failed) or a timeout step.
  nav::NavigationStep DriveTo(double x, double y, double max_time_s) {
    const nav::GlobalPlan plan = navigation.SetGoal(platform.state(), x, y, 0.0, t_s);
    EXPECT_TRUE(plan.IsUsable()) << plan.reason;
    if (!plan.IsUsable()) return {};
    while (t_s < max_time_s) {
      nav::NavigationStep out = Tick([&] { return navigation.StepWaypoint(platform.state(), t_s); });
      if (out.arrived || out.failed) return out;
    }
    nav::NavigationStep timeout;
    timeout.failed = true;
    timeout.reason = "test timeout; distance left " + std::to_string(navigation.distance_left_m()) +
                     ", local: " + navigation.local_status();
    return timeout;
  }

  std::shared_ptr<nav::GlobalPlanner> planner;
  nav::NavigationOptions options;
  nav::Navigation navigation;
  sim::Unicycle platform;
  std::vector<Eigen::Vector3f> points_B;
  double t_s = 0.0;
  int contacts = 0;
  double min_clearance_m = 1.0;
  double max_speed_mps = 0.0;
};

TEST(NavigationOptionsTest, DefaultsAreValidAndBadValuesAreNamed) {
  std::string why;
  EXPECT_TRUE(nav::NavigationOptions{}.IsValid(&why)) << why;
  nav::NavigationOptions o;
  o.carrot_distance_m = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.carrot_distance_m = -1"), std::string::npos) << why;
  o = nav::NavigationOptions{};
  o.controller.horizon_steps = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("controller: "), std::string::npos) << why;
  EXPECT_NE(why.find("horizon_steps"), std::string::npos) << why;
  o = nav::NavigationOptions{};
  o.unmapped_goal_max_replans = 1001;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.unmapped_goal_max_replans = 1001 must be in [1, 1000]"), std::string::npos)
      << why;
  o = nav::NavigationOptions{};
  o.unmapped_goal_timeout_s = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.unmapped_goal_timeout_s = 0"), std::string::npos) << why;
  o = nav::NavigationOptions{};
  o.max_hold_s = 4000;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.max_hold_s = 4000"), std::string::npos) << why;
}

TEST(NavigationTest, WaypointMissionInTheTunnelsArrivesWithoutContact) {
  auto world = std::make_shared<const sim::World>(sim::LoadWorld("builtin:tunnels"));
  SimRobot robot(world, "wheeled", 4.0, 20.0, 0.0);
  // Along the main tunnel, through the X junction, down the south branch.
  const nav::NavigationStep out = robot.DriveTo(30.0, 8.0, 120.0);
  EXPECT_TRUE(out.arrived) << out.reason;
  EXPECT_EQ(robot.contacts, 0);
  EXPECT_GT(robot.min_clearance_m, robot.options.platform.footprint_radius_m);
  EXPECT_GT(robot.max_speed_mps, 0.8);  // cruises at ~1 m/s
  EXPECT_LE(robot.max_speed_mps, robot.options.platform.limits.max_speed_mps + 1e-9);
  std::printf("FIGURE tunnels_mission_time_s %.1f min_clearance_m %.2f max_speed_mps %.2f\n", robot.t_s,
              robot.min_clearance_m, robot.max_speed_mps);
}

TEST(NavigationTest, WaypointMissionsAcrossGeb079ArriveWithoutContact) {
  CAIRN_SKIP_WITHOUT_GEB079();
  auto world = std::make_shared<const sim::World>(sim::LoadWorld(sim::testing::Geb079Path()));
  SimRobot robot(world, "wheeled", -4.0, 0.0, 0.0);
  nav::NavigationStep out = robot.DriveTo(24.0, 0.0, 120.0);
  EXPECT_TRUE(out.arrived) << out.reason;
  out = robot.DriveTo(2.0, 0.0, 240.0);
  EXPECT_TRUE(out.arrived) << out.reason;
  EXPECT_EQ(robot.contacts, 0);
  EXPECT_GT(robot.min_clearance_m, robot.options.platform.footprint_radius_m);
  std::printf("FIGURE geb079_missions_time_s %.1f min_clearance_m %.2f\n", robot.t_s, robot.min_clearance_m);
}

TEST(NavigationTest, WheeledRobotTurnsAroundAtADeadEnd) {
  // A 2.4 m wide dead-end corridor; the robot faces the dead end and its goal is behind it. Its
  // forward-looking library has no path that way: it must turn in place, then drive.
  sim::World w = FlatWorld(12, 4, 0.1, 1.5);
  FillBox(&w, {0.0, 0.0, 0.0}, {12.0, 0.8, 1.6});
  FillBox(&w, {0.0, 3.2, 0.0}, {12.0, 4.0, 1.6});
  FillBox(&w, {11.0, 0.0, 0.0}, {12.0, 4.0, 1.6});
  SimRobot robot(std::make_shared<const sim::World>(std::move(w)), "wheeled", 10.0, 2.0, 0.0);
  const nav::NavigationStep out = robot.DriveTo(2.0, 2.0, 60.0);
  EXPECT_TRUE(out.arrived) << out.reason;
  EXPECT_EQ(robot.contacts, 0);
}

TEST(NavigationTest, LeggedRobotClimbsTheStaircaseAndWheeledIsRefused) {
  auto world = std::make_shared<const sim::World>(sim::LoadWorld("builtin:tunnels"));
  SimRobot legged(world, "legged", 48.0, 20.0, 0.0);
  const nav::NavigationStep out = legged.DriveTo(54.5, 23.8, 120.0);
  EXPECT_TRUE(out.arrived) << out.reason;
  EXPECT_NEAR(legged.platform.state().z_m, 1.0, 0.11);  // on top of the 1 m platform
  EXPECT_EQ(legged.contacts, 0);

  SimRobot wheeled(world, "wheeled", 48.0, 20.0, 0.0);
  const nav::GlobalPlan plan = wheeled.navigation.SetGoal(wheeled.platform.state(), 54.5, 23.8, 0.0, 0.0);
  EXPECT_FALSE(plan.IsUsable());
  EXPECT_NE(plan.reason.find("unreachable for platform wheeled"), std::string::npos) << plan.reason;
  EXPECT_FALSE(wheeled.navigation.has_goal());
}

// A 10 x 8 m yard with a wall across x in [5, 5.2].
sim::World WallWorld(bool with_doorway) {
  sim::World w = FlatWorld(10, 8, 0.1, 1.5);
  FillBox(&w, {5.0, 0.0, 0.0}, {5.2, 8.0, 1.6});
  if (with_doorway) FillBox(&w, {5.0, 4.3, 0.0}, {5.2, 5.5, 1.6}, false);  // 1.2 m door, centre y = 4.9
  return w;
}

TEST(NavigationTest, WaypointThroughAOneMetreDoorwayWithoutContact) {
  // A 0.6 m wheeled robot passes a 1.0 m doorway (0.2 m each side) to a goal behind the wall.
  sim::World w = FlatWorld(10, 8, 0.1, 1.5);
  FillBox(&w, {5.0, 0.0, 0.0}, {5.2, 8.0, 1.6});
  FillBox(&w, {5.0, 4.4, 0.0}, {5.2, 5.4, 1.6}, false);  // 1.0 m door, centre y = 4.9
  SimRobot robot(std::make_shared<const sim::World>(std::move(w)), "wheeled", 2.0, 3.0, 0.0);
  const nav::NavigationStep out = robot.DriveTo(8.5, 4.9, 60.0);
  EXPECT_TRUE(out.arrived) << out.reason << "; local: " << robot.navigation.local_status();
  EXPECT_EQ(robot.contacts, 0);
  EXPECT_GT(robot.platform.state().x_m, 8.0);
  std::printf("FIGURE doorway_1m time_s %.1f min_clearance_m %.2f\n", robot.t_s, robot.min_clearance_m);
}

// A wheeled robot that overshot a doorway in the side wall of a corridor (it saw the door too late to turn)
// stands 0.9 m past it. Its carrot, 2.5 m along the path, lay in the room behind the door jamb, where no
// local path led and whose bearing disagreed with the path's: the robot turned back and forth past the door
// for a minute (builtin:building on its own map: 74 s to a goal 7 m away). The carrot stops where the
// straight line to it would pass the jamb closer than the footprint.
TEST(NavigationTest, TheCarrotStaysInSightOfTheRobotAtADoorwayItOvershot) {
  sim::World w = FlatWorld(10, 8, 0.1, 1.5);
  FillBox(&w, {0.0, 3.8, 0.0}, {10.0, 4.0, 1.6});        // the corridor's side wall, y 3.8-4.0
  FillBox(&w, {2.6, 3.8, 0.0}, {3.6, 4.0, 1.6}, false);  // a 1.0 m doorway, x 2.6-3.6
  auto world = std::make_shared<const sim::World>(std::move(w));
  SimRobot robot(world, "wheeled", 4.5, 4.6, -2.8);  // 0.9 m past the door's far jamb, facing back
  ASSERT_TRUE(robot.navigation.SetGoal(robot.platform.state(), 3.1, 1.5, 0.0, 0.0).IsUsable());
  const auto& s = robot.platform.state();
  // No obstacle seen yet: the carrot lies 2.5 m along the path, in the room.
  std::vector<Eigen::Vector3f> none;
  robot.navigation.SetObstacles(none, s, 0.0);
  robot.navigation.StepWaypoint(s, 0.0);
  EXPECT_LT(robot.navigation.carrot_W().y(), 3.8)
      << "carrot (" << robot.navigation.carrot_W().transpose() << ")";
  // The jamb (x 3.6, y 3.8-4.0) seen: the carrot stays on the corridor's side, near the turn's corner.
  std::vector<Eigen::Vector3f> points_B;
  nav::LethalCellsNear(*robot.planner->Grid("wheeled"), s.x_m, s.y_m, s.yaw_rad, 3.5, &points_B);
  robot.navigation.SetObstacles(points_B, s, 0.1);
  robot.navigation.StepWaypoint(s, 0.1);
  const Eigen::Vector2d carrot = robot.navigation.carrot_W();
  EXPECT_GT(carrot.y(), 4.0) << "carrot (" << carrot.transpose() << ") behind the jamb";
  EXPECT_GE((carrot - Eigen::Vector2d(s.x_m, s.y_m)).norm(), 0.5 - 1e-6);
  // ... and the robot drives there and through the door.
  const nav::NavigationStep out = robot.DriveTo(3.1, 1.5, 40.0);
  EXPECT_TRUE(out.arrived) << out.reason << "; local: " << robot.navigation.local_status();
  EXPECT_EQ(robot.contacts, 0);
}

TEST(NavigationTest, SmartJoystickStraightAtAWallNeverTouchesIt) {
  auto world = std::make_shared<const sim::World>(WallWorld(false));
  SimRobot robot(world, "wheeled", 2.0, 4.0, 0.0);
  double max_x = 0;
  for (int i = 0; i < 500; ++i) {  // 10 s of full stick straight at the wall
    robot.Tick(
        [&] { return robot.navigation.StepJoystick(robot.platform.state(), 1.0, 0.0, 0.0, robot.t_s); });
    max_x = std::max(max_x, robot.platform.state().x_m);
  }
  EXPECT_EQ(robot.contacts, 0);
  EXPECT_LT(max_x, 5.0 - robot.options.platform.footprint_radius_m);
  EXPECT_GT(robot.min_clearance_m, robot.options.platform.footprint_radius_m);
  EXPECT_GT(max_x, 3.5);  // it did drive toward the wall
  std::printf("FIGURE joystick_wall_min_clearance_m %.2f closest_x %.2f\n", robot.min_clearance_m, max_x);
}

TEST(NavigationTest, SmartJoystickTakesAnOffCentreDoorway) {
  auto world = std::make_shared<const sim::World>(WallWorld(true));
  // Aimed straight ahead, 0.6 m to the side of the doorway centre: plain teleop would hit the frame.
  SimRobot robot(world, "wheeled", 2.0, 4.3, 0.0);
  for (int i = 0; i < 400 && robot.platform.state().x_m < 7.0; ++i) {
    robot.Tick(
        [&] { return robot.navigation.StepJoystick(robot.platform.state(), 0.8, 0.0, 0.0, robot.t_s); });
  }
  EXPECT_GT(robot.platform.state().x_m, 6.0)
      << "did not pass the doorway; local: " << robot.navigation.local_status();
  EXPECT_EQ(robot.contacts, 0);

  // The same stick on plain teleop (no local planner) hits the frame.
  sim::Unicycle raw(robot.options.platform.limits, robot.options.platform.footprint_radius_m);
  sim::UnicycleState s;
  s.x_m = 2.0;
  s.y_m = 4.3;
  raw.set_state(s);
  int raw_contacts = 0;
  const auto grid = robot.planner->Grid("wheeled");
  for (int i = 0; i < 400; ++i) raw_contacts += raw.Step(0.8, 0.0, kDt, *grid).contact ? 1 : 0;
  EXPECT_GT(raw_contacts, 0);
}

TEST(NavigationTest, SmartJoystickPulledBackOnAWheeledRobotBrakesInsteadOfSwerving) {
  auto world = std::make_shared<const sim::World>(FlatWorld(10, 8));
  SimRobot robot(world, "wheeled", 5.0, 4.0, 0.0);
  for (int i = 0; i < 100; ++i) {
    robot.Tick(
        [&] { return robot.navigation.StepJoystick(robot.platform.state(), -0.5, 0.0, 0.0, robot.t_s); });
  }
  const auto& s = robot.platform.state();
  EXPECT_LT(std::hypot(s.x_m - 5.0, s.y_m - 4.0), 0.02);
  EXPECT_NE(robot.navigation.local_status().find("outside the platform's local planner headings"),
            std::string::npos)
      << robot.navigation.local_status();
}

TEST(NavigationTest, ReplansWhenTheMapChangesUnderThePath) {
  sim::World w = FlatWorld(16, 8, 0.1, 1.5);
  auto world = std::make_shared<const sim::World>(w);
  SimRobot robot(world, "wheeled", 1.0, 4.0, 0.0);
  const nav::GlobalPlan plan = robot.navigation.SetGoal(robot.platform.state(), 15.0, 4.0, 0.0, 0.0);
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  for (int i = 0; i < 100; ++i)
    robot.Tick([&] { return robot.navigation.StepWaypoint(robot.platform.state(), robot.t_s); });
  // A rockfall across the straight route ahead.
  FillBox(&w, {9.0, 2.0, 0.0}, {9.4, 8.0, 1.6});
  robot.planner->UpdateWorld(std::make_shared<const sim::World>(w));
  nav::NavigationStep out;
  while (robot.t_s < 60.0 && !out.arrived && !out.failed) {
    out = robot.Tick([&] { return robot.navigation.StepWaypoint(robot.platform.state(), robot.t_s); });
  }
  EXPECT_TRUE(out.arrived) << out.reason;
  EXPECT_GE(robot.navigation.replans(), 1);
  EXPECT_EQ(robot.contacts, 0);
}

TEST(NavigationTest, FailsWhenTheMapChangeLeavesNoPath) {
  sim::World w = FlatWorld(16, 8, 0.1, 1.5);
  SimRobot robot(std::make_shared<const sim::World>(w), "wheeled", 1.0, 4.0, 0.0);
  ASSERT_TRUE(robot.navigation.SetGoal(robot.platform.state(), 15.0, 4.0, 0.0, 0.0).IsUsable());
  FillBox(&w, {9.0, 0.0, 0.0}, {9.4, 8.0, 1.6});
  robot.planner->UpdateWorld(std::make_shared<const sim::World>(w));
  nav::NavigationStep out;
  while (robot.t_s < 5.0 && !out.failed) {
    out = robot.Tick([&] { return robot.navigation.StepWaypoint(robot.platform.state(), robot.t_s); });
  }
  EXPECT_TRUE(out.failed);
  EXPECT_NE(out.reason.find("the map changed under the path and no new path exists"), std::string::npos)
      << out.reason;
  EXPECT_FALSE(robot.navigation.has_goal());
}

// A late scan (1-3 s) brakes the robot and keeps its goal; only a longer silence loses obstacle sensing.
TEST(NavigationTest, StaleObstacleInputBrakesFirstAndIsLostLater) {
  auto world = std::make_shared<const sim::World>(FlatWorld(10, 6));
  SimRobot robot(world, "legged", 2.0, 3.0, 0.0);
  ASSERT_TRUE(robot.navigation.SetGoal(robot.platform.state(), 8.0, 3.0, 0.0, 0.0).IsUsable());
  robot.navigation.SetObstacles({}, robot.platform.state(), 0.0);
  std::string why;
  EXPECT_TRUE(robot.navigation.LocalPlannerHealthy(0.5, &why));
  EXPECT_FALSE(robot.navigation.LocalPlannerHealthy(2.0, &why));
  EXPECT_EQ(why, "obstacle input is 2.00 s old (limit 1.00 s)");
  EXPECT_TRUE(robot.navigation.ObstacleSensingAlive(2.0, &why));
  const nav::NavigationStep braking = robot.navigation.StepWaypoint(robot.platform.state(), 2.0);
  EXPECT_FALSE(braking.failed) << braking.reason;
  EXPECT_NEAR(braking.linear_x_mps, 0.0, 1e-9);
  EXPECT_FALSE(robot.navigation.ObstacleSensingAlive(3.5, &why));
  EXPECT_EQ(why, "obstacle input is 3.50 s old (limit 3.00 s)");
  EXPECT_TRUE(robot.navigation.has_goal());
}

TEST(NavigationTest, StopsWithoutObstacleInput) {
  auto world = std::make_shared<const sim::World>(FlatWorld(10, 6));
  SimRobot robot(world, "legged", 2.0, 3.0, 0.0);
  ASSERT_TRUE(robot.navigation.SetGoal(robot.platform.state(), 8.0, 3.0, 0.0, 0.0).IsUsable());
  std::string why;
  EXPECT_FALSE(robot.navigation.LocalPlannerHealthy(0.0, &why));
  EXPECT_EQ(why, "no obstacle input yet");
  const nav::NavigationStep out = robot.navigation.StepWaypoint(robot.platform.state(), 0.0);
  EXPECT_NEAR(out.linear_x_mps, 0.0, 1e-9);
  EXPECT_EQ(robot.navigation.local_status(), "stopped: no fresh obstacle input");
}

// Recovery (the WaypointRecovery tree of the shipped mode tree file). A "ghost" in the live obstacles: a
// U of points around the robot's nose (front and both sides, open behind), which no map holds, e.g. people
// standing round the robot. Boxed in with the goal ahead, navigation gives up; the recovery tree clears the
// obstacle memory and retries (the ghost is still there: attempt 1 fails), backs up and retries after the
// ghost has left (attempt 2 arrives).
struct GhostRobot {
  explicit GhostRobot(double blocked_timeout_s,
                      double stall_timeout_s = nav::NavigationOptions{}.stall_timeout_s)
      : world(std::make_shared<const sim::World>(FlatWorld(16.0, 8.0, 0.1, 2.0))),
        robot(world, "wheeled", 3.0, 4.0, 0.0, blocked_timeout_s, stall_timeout_s),
        recovery(cairn::core::ConfigDir() + "/mode_tree.xml", &robot.navigation,
                 WaypointRecovery::Hooks{[this] { ++clears; }}) {
    for (double d = -0.5; d <= 0.5 + 1e-9; d += 0.05) {
      ghost_W.emplace_back(3.45, 4.0 + d);  // front, 0.45 m ahead of the centre
    }
    for (double x = 2.4; x <= 3.45 + 1e-9; x += 0.05) {
      ghost_W.emplace_back(x, 3.5);  // sides, 0.5 m off
      ghost_W.emplace_back(x, 4.5);
    }
  }

  // One 50 Hz step: senses (ghost included while ghost_present) every 0.1 s, then navigation or recovery.
  nav::NavigationStep Tick() {
    const auto& s = robot.platform.state();
    if (std::fmod(robot.t_s + 1e-9, 0.1) < kDt) {
      std::vector<Eigen::Vector3f> points_B;
      nav::LethalCellsNear(*robot.planner->Grid("wheeled"), s.x_m, s.y_m, s.yaw_rad, 3.5, &points_B);
      if (ghost_present) {
        const double c = std::cos(s.yaw_rad), sn = std::sin(s.yaw_rad);
        for (const Eigen::Vector2d& g : ghost_W) {
          const Eigen::Vector2d d = g - Eigen::Vector2d(s.x_m, s.y_m);
          points_B.emplace_back(static_cast<float>(c * d.x() + sn * d.y()),
                                static_cast<float>(-sn * d.x() + c * d.y()), 0.3f);
        }
      }
      robot.navigation.SetObstacles(points_B, s, robot.t_s);
    }
    nav::NavigationStep step;
    if (recovery.active()) {
      step = recovery.Step(s, robot.t_s);
      // The plan of an attempt comes from a worker thread: wait for it in wall time (the robot holds
      // still), or the simulated clock runs the whole test ahead of a busy machine's planner.
      while (recovery.planning()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        step = recovery.Step(s, robot.t_s);
      }
      if (recovery.active()) report = recovery.Report();
    } else {
      step = robot.navigation.StepWaypoint(s, robot.t_s);
      if (step.failed) {
        first_failure = step.reason;
        recovery.Start(goal.x(), goal.y(), 0.0, step.reason);
        step = nav::NavigationStep{};
      }
    }
    const sim::UnicycleStepResult r =
        robot.platform.Step(step.linear_x_mps, step.angular_z_radps, kDt, *robot.planner->Grid("wheeled"));
    robot.contacts += r.contact ? 1 : 0;
    robot.t_s += kDt;
    return step;
  }

  std::shared_ptr<const sim::World> world;
  SimRobot robot;
  WaypointRecovery recovery;
  std::vector<Eigen::Vector2d> ghost_W;
  bool ghost_present = true;
  Eigen::Vector2d goal{9.0, 4.0};
  int clears = 0;
  std::string report;
  std::string first_failure;
};

TEST(WaypointRecoveryTest, ABoxedInRobotRecoversByClearingBackingUpAndRetrying) {
  GhostRobot g(3.0);
  ASSERT_TRUE(g.recovery.enabled());
  ASSERT_TRUE(
      g.robot.navigation.SetGoal(g.robot.platform.state(), g.goal.x(), g.goal.y(), 0.0, 0.0).IsUsable());
  nav::NavigationStep step;
  double backed_up_from_x = 0.0;
  bool saw_attempt_1 = false;
  while (g.robot.t_s < 60.0 && !step.arrived && !step.failed) {
    step = g.Tick();
    if (!saw_attempt_1 && g.report.find("attempt 1 ") != std::string::npos) {
      saw_attempt_1 = true;  // attempt 1 failed while the ghost was there; it leaves now
      g.ghost_present = false;
      backed_up_from_x = g.robot.platform.state().x_m;
    }
  }
  EXPECT_TRUE(step.arrived) << step.reason << " | report: " << g.report;
  std::printf("recovered, arrived after %.1f s; the report on the way: %s\n", g.robot.t_s, g.report.c_str());
  EXPECT_NE(g.first_failure.find("blocked: no progress"), std::string::npos) << g.first_failure;
  EXPECT_TRUE(saw_attempt_1);
  EXPECT_NE(g.report.find("attempt 1 (clear the local obstacle memory): blocked"), std::string::npos)
      << g.report;
  EXPECT_EQ(g.clears, 1);
  EXPECT_EQ(g.robot.contacts, 0);
  EXPECT_LT(backed_up_from_x, 3.05);  // it had not got past the ghost before the recovery
  EXPECT_LT((Eigen::Vector2d(g.robot.platform.state().x_m, g.robot.platform.state().y_m) - g.goal).norm(),
            0.25);
}

TEST(WaypointRecoveryTest, AGhostThatStaysFailsTheGoalWithEveryAttemptAndTheRobotGoesElsewhere) {
  GhostRobot g(2.0);
  ASSERT_TRUE(
      g.robot.navigation.SetGoal(g.robot.platform.state(), g.goal.x(), g.goal.y(), 0.0, 0.0).IsUsable());
  nav::NavigationStep step;
  while (g.robot.t_s < 120.0 && !step.arrived && !step.failed) step = g.Tick();
  ASSERT_TRUE(step.failed) << "arrived through a ghost?";
  std::printf("recovery failed after %.1f s: %s\n", g.robot.t_s, step.reason.c_str());
  EXPECT_FALSE(g.recovery.active());
  for (const char* attempt :
       {"attempt 1 (clear the local obstacle memory): blocked", "attempt 2 (back up 0.40 m): blocked",
        "attempt 3 (rotate 90 deg): ", "attempt 4 (wait 5 s): ", "attempt 5 (replan from here): ",
        "attempt 6 (replan, reduced clearance): "}) {
    EXPECT_NE(step.reason.find(attempt), std::string::npos) << attempt << " in: " << step.reason;
  }
  EXPECT_EQ(step.reason.rfind("blocked: no progress", 0), 0u) << step.reason;
  EXPECT_EQ(g.robot.contacts, 0);
  // Sent elsewhere (back the way it came, where no ghost stands), it goes.
  g.goal = Eigen::Vector2d(1.0, 4.0);
  const nav::NavigationStep back = [&] {
    EXPECT_TRUE(g.robot.navigation.SetGoal(g.robot.platform.state(), 1.0, 4.0, 0.0, g.robot.t_s).IsUsable());
    nav::NavigationStep s;
    const double until = g.robot.t_s + 40.0;
    while (g.robot.t_s < until && !s.arrived && !s.failed) s = g.Tick();
    return s;
  }();
  EXPECT_TRUE(back.arrived) << back.reason;
}

// A retry of the recovery tree held before a peer that never gets out of the way (here from attempt 2 on)
// ends the recovery when navigation abandons the goal after max_hold_s: no further attempt repeats the wait.
TEST(WaypointRecoveryTest, AnAttemptWhoseGoalIsAbandonedEndsTheRecovery) {
  GhostRobot g(2.0);
  ASSERT_TRUE(g.recovery.enabled());
  ASSERT_TRUE(
      g.robot.navigation.SetGoal(g.robot.platform.state(), g.goal.x(), g.goal.y(), 0.0, 0.0).IsUsable());
  nav::NavigationStep step;
  double held_from_s = -1.0;
  while (g.robot.t_s < 300.0 && !step.arrived && !step.failed) {
    if (held_from_s < 0 && g.report.find("attempt 1 ") != std::string::npos) held_from_s = g.robot.t_s;
    if (held_from_s >= 0) g.robot.navigation.SetHold("asked r9 to get out of the way", "r9");
    step = g.Tick();
  }
  ASSERT_TRUE(step.failed) << step.reason;
  std::printf("recovery ended after %.1f s (held from %.1f s): %s\n", g.robot.t_s, held_from_s,
              step.reason.c_str());
  EXPECT_TRUE(step.abandoned);
  EXPECT_FALSE(g.recovery.active());
  EXPECT_NE(step.reason.find("; attempt 2 (back up 0.40 m): blocked by r9: held 90 s without progress "
                             "(navigation.max_hold_s 90 s): asked r9 to get out of the way"),
            std::string::npos)
      << step.reason;
  EXPECT_EQ(step.reason.find("attempt 3"), std::string::npos) << step.reason;
  EXPECT_LT(g.robot.t_s - held_from_s, nav::NavigationOptions{}.max_hold_s + 5.0);
}

// A robot that does not move loses its goal after stall_timeout_s whatever else navigation counts as
// progress (a new plan resets the blocked_timeout_s clock, so a robot whose plans kept changing on the stairs
// kept its goal for 240 s): here the blocked rule alone would wait 600 s.
TEST(NavigationTest, ARobotThatDoesNotMoveStallsWhateverItsPlansDo) {
  GhostRobot g(/*blocked_timeout_s=*/600.0, /*stall_timeout_s=*/20.0);
  ASSERT_TRUE(
      g.robot.navigation.SetGoal(g.robot.platform.state(), g.goal.x(), g.goal.y(), 0.0, 0.0).IsUsable());
  nav::NavigationStep step;
  while (g.robot.t_s < 60.0 && !step.failed && !step.arrived) {
    step = g.robot.Tick([&] { return nav::NavigationStep{}; });  // a body that never moves
    if (!step.failed) step = g.robot.navigation.StepWaypoint(g.robot.platform.state(), g.robot.t_s);
  }
  ASSERT_TRUE(step.failed);
  EXPECT_TRUE(step.stalled);
  EXPECT_EQ(step.reason.rfind("stalled: moved less than 0.5 m in 20 s", 0), 0u) << step.reason;
  EXPECT_NEAR(g.robot.t_s, 20.0, 0.5);
}

// A goal given its own stall timeout (exploration's target through a tight gap) stalls after that, not the
// options' one; the next goal without one has the options' again.
TEST(NavigationTest, AGoalsOwnStallTimeoutReplacesTheOptions) {
  GhostRobot g(/*blocked_timeout_s=*/600.0, /*stall_timeout_s=*/20.0);
  nav::Navigation& navigation = g.robot.navigation;
  const auto run_until_failed = [&g, &navigation] {
    const double start_s = g.robot.t_s;
    nav::NavigationStep step;
    while (g.robot.t_s - start_s < 60.0 && !step.failed && !step.arrived) {
      step = g.robot.Tick([&] { return nav::NavigationStep{}; });  // a body that never moves
      if (!step.failed) step = navigation.StepWaypoint(g.robot.platform.state(), g.robot.t_s);
    }
    return std::make_pair(step, g.robot.t_s - start_s);
  };
  const nav::GlobalPlan plan =
      g.robot.planner->Plan(navigation.GoalRequest(g.robot.platform.state(), g.goal.x(), g.goal.y()));
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  navigation.AcceptGoal(plan, g.goal.x(), g.goal.y(), 0.0, g.robot.t_s,
                        std::numeric_limits<double>::quiet_NaN(),
                        /*stall_timeout_s=*/8.0);
  auto [step, took_s] = run_until_failed();
  ASSERT_TRUE(step.failed);
  EXPECT_TRUE(step.stalled);
  EXPECT_EQ(step.reason.rfind("stalled: moved less than 0.5 m in 8 s", 0), 0u) << step.reason;
  EXPECT_NEAR(took_s, 8.0, 0.5);

  navigation.AcceptGoal(plan, g.goal.x(), g.goal.y(), 0.0, g.robot.t_s);
  std::tie(step, took_s) = run_until_failed();
  ASSERT_TRUE(step.failed);
  EXPECT_TRUE(step.stalled);
  EXPECT_NEAR(took_s, 20.0, 0.5);
}

// Peers: each robot is told where the other is (PeerTracker::Live() as the agent would, here every
// 0.2 s as at peers.rate_hz 5) and keeps clear of it; a simulated robot's lidar never sees another robot.
nav::PeerBody PeerOf(const std::string& id, const SimRobot& robot) {
  nav::PeerBody peer;
  peer.robot_id = id;
  const sim::UnicycleState& s = robot.platform.state();
  peer.pose_M.x_m = s.x_m;
  peer.pose_M.y_m = s.y_m;
  peer.pose_M.z_m = s.z_m;
  peer.pose_M.yaw_rad = s.yaw_rad;
  peer.pose_M.v_mps = s.v_mps;
  peer.footprint_radius_m = robot.options.platform.footprint_radius_m;
  return peer;
}

double CentreDistance(const SimRobot& a, const SimRobot& b) {
  return std::hypot(a.platform.state().x_m - b.platform.state().x_m,
                    a.platform.state().y_m - b.platform.state().y_m);
}

// A robot parked in a 1.4 m corridor (too narrow to pass it): the other, sent past it, stops short of it and
// its goal fails as blocked. Told nothing of the peer, it drives through it (what the test would catch).
TEST(NavigationPeersTest, ARobotParkedInANarrowCorridorIsNeverDrivenInto) {
  sim::World w = FlatWorld(20, 6, 0.1, 1.5);
  FillBox(&w, {0.0, 0.0, 0.0}, {20.0, 2.3, 1.6});
  FillBox(&w, {0.0, 3.7, 0.0}, {20.0, 6.0, 1.6});  // free band y in [2.3, 3.7]
  const auto world = std::make_shared<const sim::World>(std::move(w));
  for (const bool told : {true, false}) {
    SCOPED_TRACE(told ? "told of the peer" : "not told");
    SimRobot mover(world, "wheeled", 2.0, 3.0, 0.0, /*blocked_timeout_s=*/8.0);
    SimRobot parked(world, "wheeled", 10.0, 3.0, 0.0);
    const nav::PeerAvoidanceOptions options;
    const nav::GlobalPlan plan = mover.navigation.SetGoal(mover.platform.state(), 18.0, 3.0, 0.0, mover.t_s);
    ASSERT_TRUE(plan.IsUsable()) << plan.reason;
    double closest_m = 1e9;
    nav::NavigationStep out;
    while (mover.t_s < 40.0 && !out.arrived && !out.failed) {
      if (told) mover.navigation.SetPeers({PeerOf("parked", parked)}, options);
      out = mover.Tick([&] { return mover.navigation.StepWaypoint(mover.platform.state(), mover.t_s); });
      closest_m = std::min(closest_m, CentreDistance(mover, parked));
    }
    const double touching_m = 2 * mover.options.platform.footprint_radius_m;
    if (told) {
      EXPECT_GT(closest_m, touching_m + 0.1) << "it came within " << closest_m << " m";
      EXPECT_TRUE(out.failed) << "arrived: " << out.arrived;
      EXPECT_NE(out.reason.find("blocked"), std::string::npos) << out.reason;
      std::printf("FIGURE peer_parked_in_corridor closest_centre_distance_m %.2f (touching %.2f)\n",
                  closest_m, touching_m);
    } else {
      EXPECT_LT(closest_m, touching_m) << "a ghost peer is driven through";
    }
  }
}

// Two robots sent head-on along a 6 m wide yard, each told of the other: they pass without touching and both
// arrive.
TEST(NavigationPeersTest, TwoRobotsMeetingHeadOnPassWithoutTouching) {
  const auto world = std::make_shared<const sim::World>(FlatWorld(20, 6, 0.1, 1.5));
  SimRobot a(world, "wheeled", 2.0, 3.0, 0.0);
  SimRobot b(world, "wheeled", 18.0, 3.1, M_PI);
  ASSERT_TRUE(a.navigation.SetGoal(a.platform.state(), 18.0, 3.0, 0.0, a.t_s).IsUsable());
  ASSERT_TRUE(b.navigation.SetGoal(b.platform.state(), 2.0, 3.1, 0.0, b.t_s).IsUsable());
  const nav::PeerAvoidanceOptions options;
  double closest_m = 1e9;
  nav::NavigationStep out_a, out_b;
  int cycle = 0;
  while (a.t_s < 60.0 && b.t_s < 60.0 && !(out_a.arrived && out_b.arrived) && !out_a.failed &&
         !out_b.failed) {
    if (cycle++ % 10 == 0) {  // 5 Hz
      a.navigation.SetPeers({PeerOf("b", b)}, options);
      b.navigation.SetPeers({PeerOf("a", a)}, options);
    }
    if (!out_a.arrived) out_a = a.Tick([&] { return a.navigation.StepWaypoint(a.platform.state(), a.t_s); });
    if (!out_b.arrived) out_b = b.Tick([&] { return b.navigation.StepWaypoint(b.platform.state(), b.t_s); });
    closest_m = std::min(closest_m, CentreDistance(a, b));
  }
  EXPECT_TRUE(out_a.arrived) << out_a.reason;
  EXPECT_TRUE(out_b.arrived) << out_b.reason;
  const double touching_m = 2 * a.options.platform.footprint_radius_m;
  EXPECT_GT(closest_m, touching_m) << "they came within " << closest_m << " m";
  EXPECT_EQ(a.contacts + b.contacts, 0);
  std::printf("FIGURE peers_head_on closest_centre_distance_m %.2f (touching %.2f) time_s %.1f\n", closest_m,
              touching_m, std::max(a.t_s, b.t_s));
}

// ---- Goals that cannot be reached: the agent stepped on a simulated clock (RobotAgent::Stepped) in
// builtin:tunnels, its goals sent as the console sends them and planned on its own map. Walls are 0.3 m
// thick: behind them the world is solid rock that no lidar ever sees.

// r2 looks along the main tunnel from its west end, then is sent to a point of the north wall it has seen:
// refused at once, naming the nearest free point, which is free ground beside the wall.
TEST(UnreachableGoalTest, AGoalTheMapKnowsIsInsideAnObstacleIsRefusedNamingTheNearestFreePoint) {
  team_testing::AgentTeam team("builtin:tunnels", {{"r2", {4.0, 20.0, 0.0}}});
  team.StepFor(3.0);  // at rest: the map and the planner's grid take in the first scans
  const std::string refused = team.Goto(0, 8.0, 21.6);
  std::printf("FIGURE goal_in_obstacle: refused: %s\n", refused.c_str());
  EXPECT_NE(refused.find("goal (8.00, 21.60) is inside an obstacle on r2's map"), std::string::npos)
      << refused;
  EXPECT_FALSE(team.modes(0).waypoint().has_goal());
  double x = 0, y = 0;
  const std::size_t at = refused.find("nearest free point (");
  ASSERT_NE(at, std::string::npos) << refused;
  ASSERT_EQ(std::sscanf(refused.c_str() + at, "nearest free point (%lf, %lf)", &x, &y), 2) << refused;
  EXPECT_LT(std::hypot(x - 8.0, y - 21.6), 1.2) << refused;
  // The judge: the simulated world itself, where the robot's body fits at that point.
  const nav::TraversabilityGrid truth(sim::LoadWorld("builtin:tunnels"));
  EXPECT_TRUE(truth.IsFootprintFree(x, y, nav::GetPlatformProfile("wheeled").footprint_radius_m)) << refused;
  EXPECT_EQ(team.Goto(0, x, y), "") << "the point it names is taken";
}

// r2 is sent into the rock between the main tunnel and the south branch, where its map has seen nothing: the
// goal is accepted as one in unmapped space (the reply says so), and abandoned with the reason once its
// replans make no progress, not driven at for minutes.
TEST(UnreachableGoalTest, AGoalInUnmappedSpaceIsAcceptedWithANoticeAndAbandonedWithinItsBound) {
  team_testing::AgentTeam team("builtin:tunnels", {{"r2", {4.0, 20.0, 0.0}}});  // the shipped bounds
  team.StepFor(3.0);
  GoalCommand goal;
  goal.frame_id = "map";
  goal.x_m = 20.0;
  goal.y_m = 12.0;
  const std::uint32_t request = team.base().Send("r2", goal);
  team.StepOnce();
  const std::optional<CommandReply> reply = team.base().Reply("r2", request);
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->result, CommandResult::kAccepted) << reply->reason;
  EXPECT_NE(reply->reason.find("goal in unmapped space: r2 will look"), std::string::npos) << reply->reason;
  EXPECT_TRUE(team.robot(0).navigation().global_plan().goal_unmapped);
  const double start_s = team.now_s();
  int most_replans = 0;
  while (team.now_s() < start_s + 300 && team.modes(0).waypoint().has_goal()) {
    team.StepOnce();
    most_replans = std::max(most_replans, team.robot(0).navigation().replans());
  }
  const WaypointGoal& ended = team.modes(0).waypoint().goal();
  std::printf("FIGURE unmapped_goal: ended after %.1f s (%d replans of its last plan): %s\n",
              team.now_s() - start_s, most_replans, ended.reason.c_str());
  ASSERT_EQ(ended.status, GoalStatus::kFailed) << ended.reason;
  EXPECT_EQ(ended.reason.rfind("goal in unmapped space abandoned: no progress toward (20.00, 12.00)", 0), 0u)
      << ended.reason;
  EXPECT_LT(team.now_s() - start_s, 120.0);
}

}  // namespace
}  // namespace cairn::agent
