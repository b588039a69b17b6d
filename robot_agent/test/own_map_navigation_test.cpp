// Navigation on the robot's own knowledge, on the shipping agent (RobotAgent) stepped on a simulated clock in
// process: goals sent as the console sends them, the robot's map built from its own lidar only, the world's
// ground truth used to score (contact, where the body went). A goal beyond the navigation map and a rockfall
// no map holds; a robot boxed in by a rock in the doorway it must take, that recovers once the rock is gone;
// a legged robot sent to a floor its map has never seen, up a switchback stairwell.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include "agent_team.h"
#include "cairn/agent/command/commands.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using team_testing::AgentTeam;
using team_testing::MapGoal;

// (30, 10) is down the south branch of the X junction at (30, 20): out of the lidar's sight from the start
// and beyond the navigation map (x in [-6, 14] at first), so accepted with a notice and a plan to the map's
// edge; the map grows over it. A rock falls 6 s after the start across the south two thirds of the 3 m main
// tunnel 10 m down the robot's way (y in [18.5, 21.5]), into no map: the lidar sees it, the local planner
// avoids it, the path is replanned around it, with no contact.
TEST(OwnMapNavigationTest, AGoalInUnknownSpaceIsReachedAroundARockfall) {
  AgentTeam team(
      "builtin:tunnels", {{"r1", {4.0, 20.0, 0.0}}}, nav::PeerAvoidanceOptions{}.margin_m,
      [](AgentOptions* options) { options->nav_map.half_extent_m = 10.0; },
      [](sim::SimulatedPlatformOptions* sim) {
        sim->rockfalls = sim::ParseRockfalls("6:14,18.3,15.5,20.4,1.2");
      });
  const std::optional<CommandReply> reply = team.Send(0, MapGoal(30.0, 10.0));
  ASSERT_TRUE(reply);
  ASSERT_EQ(reply->result, CommandResult::kAccepted) << reply->reason;
  EXPECT_NE(reply->reason.find("; goal in unmapped space: r1 will look"), std::string::npos) << reply->reason;
  double passed_at_y = 1e9;  // the robot's lowest y beside the rock
  const WaypointGoal goal = team.DriveGoal(0, 120.0, [&] {
    const sim::UnicycleState s = team.truth(0);
    if (s.x_m > 14.0 && s.x_m < 15.5) passed_at_y = std::min(passed_at_y, s.y_m);
  });
  ASSERT_EQ(goal.status, GoalStatus::kArrived) << goal.reason;
  EXPECT_LT(std::hypot(team.truth(0).x_m - 30.0, team.truth(0).y_m - 10.0), 0.3);
  EXPECT_GE(team.robot(0).navigation().replans(), 1) << "the path through the rock was never replanned";
  EXPECT_GT(passed_at_y, 20.4 + 0.25) << "r1 did not keep north of the rock";
  EXPECT_LT(passed_at_y, 1e8) << "r1 never passed the rock";
  EXPECT_TRUE(team.robot(0).nav_map().extent_M().contains(Eigen::Vector2d(30.0, 10.0)))
      << "the navigation map never grew over the goal";
  EXPECT_FALSE(team.ever_in_contact(0));
  std::printf("arrived after %.1f s, passed the rock at y %.2f m, %d replans\n", team.now_s(), passed_at_y,
              team.robot(0).navigation().replans());
}

// A 0.6 m wheeled robot in a room whose only way out is a 1.0 m doorway, sent to the corridor outside. As it
// comes within 4.3 m of the doorway a rock falls into it and boxes the robot in: its map (every wall of the
// room seen) holds no way out. The rock is cleared 4 s later, like a person or dust that moves on; the robot
// sees the doorway's floor again and its map lets it through. The goal does not fail: the recovery tree runs
// (reported in the goal's reason while it does), and the robot passes the doorway's middle and arrives, with
// no contact.
TEST(OwnMapNavigationTest, ABoxedInRobotRecoversAndPassesAOneMetreDoorway) {
  // The doorway at x = 9.1 in the corridor's south wall (y 5.8-6.0), the rock 0.15 m beyond it each side;
  // the robot in the room south of the corridor (x 6.2-12.0, y 0.2-5.8), facing the doorway.
  AgentTeam team("builtin:building", {{"r1", {9.1, 0.8, 1.5708}}}, nav::PeerAvoidanceOptions{}.margin_m, {},
                 [](sim::SimulatedPlatformOptions* sim) {
                   sim->rockfalls = sim::ParseRockfalls("near4.3:8.5,5.65,9.7,6.15,1.0:+4");
                 });
  ASSERT_EQ(team.Ask(0, MapGoal(9.1, 7.1)), "");
  std::string recovery_report;  // the longest report seen while the goal was active
  double door_x_m = 1e9;        // x where the robot crossed the wall's line y = 5.9
  double previous_y = team.truth(0).y_m;
  const WaypointGoal goal = team.DriveGoal(0, 120.0, [&] {
    const std::string& reason = team.modes(0).waypoint().goal().reason;
    if (reason.rfind("recovering after:", 0) == 0 && reason.size() > recovery_report.size()) {
      recovery_report = reason;
    }
    const sim::UnicycleState s = team.truth(0);
    if (previous_y < 5.9 && s.y_m >= 5.9) door_x_m = s.x_m;
    previous_y = s.y_m;
  });
  ASSERT_EQ(goal.status, GoalStatus::kArrived) << goal.reason;
  EXPECT_LT(std::hypot(team.truth(0).x_m - 9.1, team.truth(0).y_m - 7.1), 0.3);
  EXPECT_FALSE(recovery_report.empty()) << "no recovery was reported: was the robot boxed in?";
  EXPECT_NEAR(door_x_m, 9.1, 0.2) << "r1 did not pass through the doorway's middle";
  EXPECT_FALSE(team.ever_in_contact(0));
  std::printf("arrived after %.1f s; recovery report: %s\n", team.now_s(), recovery_report.c_str());
}

// A legged robot sent to a room on floor 2 of builtin:building (z = 3.2), which its map has never seen: from
// the foot of the switchback stairwell it climbs with partial plans that grow with its map and arrives on
// floor 2 without touching a wall. (The wheeled robot's refusal: stepped_agent_test.cpp.)
TEST(OwnMapNavigationTest, ALeggedRobotReachesTheFloorAboveUpTheStairwell) {
  AgentTeam team("builtin:building", {{"r1", {14.0, 7.1, 0.0}}}, nav::PeerAvoidanceOptions{}.margin_m,
                 [](AgentOptions* options) { options->SetPlatform("legged"); });
  // To the foot of the stairwell, through its 1.2 m entrance.
  ASSERT_EQ(team.Ask(0, MapGoal(19.0, 6.5)), "");
  WaypointGoal goal = team.DriveGoal(0, 60.0);
  ASSERT_EQ(goal.status, GoalStatus::kArrived) << goal.reason;
  const double climb_start_s = team.now_s();
  double highest_z_m = 0.0;
  ASSERT_EQ(team.Ask(0, MapGoal(15.1, 11.0, 3.2)), "");
  goal = team.DriveGoal(0, 120.0, [&] { highest_z_m = std::max(highest_z_m, team.truth(0).z_m); });
  std::printf("floor 2 goal: %s after %.1f s (%s); highest z %.2f m\n",
              goal.status == GoalStatus::kArrived ? "arrived" : "not arrived", team.now_s() - climb_start_s,
              goal.reason.c_str(), highest_z_m);
  EXPECT_EQ(goal.status, GoalStatus::kArrived) << goal.reason;
  EXPECT_LT(std::hypot(team.truth(0).x_m - 15.1, team.truth(0).y_m - 11.0), 0.3);
  EXPECT_NEAR(team.truth(0).z_m, 3.2, 0.15) << "not on floor 2";
  EXPECT_FALSE(team.ever_in_contact(0));
}

}  // namespace
}  // namespace cairn::agent
