// The shipping agent (RobotAgent) stepped on a simulated clock in process over an InProcessTeam: commands
// through the command interface with their replies, a goal driven to arrival, the same run twice giving the
// same result, and bad use of the stepped agent and the in-process team named.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "agent_team.h"
#include "cairn/agent/communication/in_process_link.h"
#include "cairn/agent/robot_agent.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using team_testing::AgentTeam;

// A goal sent as the console sends it is planned on the planning service (in the step after it came), driven
// by the waypoint mode through the mux, and answered with its path; the robot arrives (ground truth).
TEST(SteppedAgentTest, AGoalIsAnsweredDrivenAndReached) {
  AgentTeam team("builtin:tunnels", {{"r1", {5.0, 20.0, 0.0}}});
  GoalCommand goal;
  goal.frame_id = "map";
  goal.x_m = 20.0;
  goal.y_m = 20.0;
  const std::uint32_t request = team.base().Send("r1", goal);
  EXPECT_FALSE(team.base().Reply("r1", request)) << "planned on the planning service, not on the way in";
  team.StepOnce();
  const std::optional<CommandReply> reply = team.base().Reply("r1", request);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->result, CommandResult::kAccepted) << reply->reason;
  EXPECT_NE(reply->reason.find("path 15."), std::string::npos) << reply->reason;
  EXPECT_EQ(reply->goal_id, 1u) << "a stepped agent's goal ids count from 1";
  EXPECT_EQ(team.modes(0).control().mode(), "waypoint");
  team.StepFor(30.0);
  EXPECT_EQ(team.modes(0).waypoint().goal().status, GoalStatus::kArrived)
      << team.modes(0).waypoint().goal().reason;
  const sim::UnicycleState end = team.truth(0);
  EXPECT_LT(std::hypot(end.x_m - 20.0, end.y_m - 20.0), 0.5);
  EXPECT_FALSE(team.ever_in_contact(0));
  EXPECT_GT(team.links().Find("r1")->samples("state"), 100u) << "the robot's telemetry goes out on its link";
}

// Commands from a basestation that does not hold the lock are discarded, as over DDS.
TEST(SteppedAgentTest, ACommandFromAnotherBaseIsDiscarded) {
  AgentTeam team("builtin:tunnels", {{"r1", {5.0, 20.0, 0.0}}});
  InProcessBase other(&team.links(), "op2");
  GoalCommand goal;
  goal.frame_id = "map";
  goal.x_m = 20.0;
  goal.y_m = 20.0;
  const std::uint32_t request = other.Send("r1", goal);
  team.StepOnce();
  const std::optional<CommandReply> reply = other.Reply("r1", request);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->result, CommandResult::kDiscarded) << reply->reason;
  EXPECT_EQ(reply->holder_id, "op");
  team.StepFor(2.0);
  EXPECT_EQ(team.modes(0).control().mode(), "idle");
  EXPECT_LT(std::hypot(team.truth(0).x_m - 5.0, team.truth(0).y_m - 20.0), 0.01) << "the robot never moved";
}

// A wheeled robot sent to the floor above as an operator types it, right after it reached the foot of the
// stairs or a point 3 m short of it: refused naming the step when its map already shows the flight (at the
// foot), or accepted toward the flight it has not seen and then failed at the end of the partial plan naming
// the step (3 m short, and what a real agent whose map lags under load answers at the foot). Either way it
// never climbs, never touches a wall, and the operator learns why.
class WheeledUpstairsTest : public ::testing::TestWithParam<double> {};

TEST_P(WheeledUpstairsTest, TheRobotIsToldTheStepItCannotClimb) {
  const double sent_at_x_m = GetParam();
  AgentTeam team("builtin:building", {{"r2", {10.0, 7.1, 0.0}}});
  ASSERT_EQ(team.Goto(0, sent_at_x_m, 6.9), "");
  const WaypointGoal foot = team.DriveGoal(0, 12.0);
  ASSERT_EQ(foot.status, GoalStatus::kArrived) << foot.reason;
  std::string reason = team.Ask(0, team_testing::MapGoal(15.1, 11.0, 3.2));
  const bool accepted = reason.empty();
  if (accepted) {
    const WaypointGoal upstairs = team.DriveGoal(0, 24.0);
    EXPECT_EQ(upstairs.status, GoalStatus::kFailed);
    reason = upstairs.reason;
  }
  std::printf("sent at x %.1f m: %s, %s\n", sent_at_x_m, accepted ? "accepted, then failed" : "refused",
              reason.c_str());
  EXPECT_NE(reason.find("step"), std::string::npos) << reason;
  EXPECT_NE(reason.find("max_step_m 0.15"), std::string::npos) << reason;
  EXPECT_LT(team.truth(0).z_m, 0.2) << "the wheeled robot climbed";
  EXPECT_FALSE(team.ever_in_contact(0));
}

INSTANTIATE_TEST_SUITE_P(SteppedAgentTest, WheeledUpstairsTest, ::testing::Values(18.9, 16.0),
                         [](const auto& info) {
                           return info.param > 18.0 ? "AtTheFoot" : "ThreeMetresShort";
                         });

// Two runs of the same scenario end in the same place to the bit: nothing depends on the machine's speed.
TEST(SteppedAgentTest, TheSameRunTwiceEndsInTheSameState) {
  auto run = [] {
    AgentTeam team("builtin:tunnels", {{"r1", {5.0, 20.0, 0.0}}});
    EXPECT_EQ(team.Goto(0, 30.0, 26.0), "");
    team.StepFor(12.0);
    return team.truth(0);
  };
  const sim::UnicycleState a = run(), b = run();
  EXPECT_EQ(a.x_m, b.x_m);
  EXPECT_EQ(a.y_m, b.y_m);
  EXPECT_EQ(a.yaw_rad, b.yaw_rad);
  EXPECT_GT(std::hypot(a.x_m - 5.0, a.y_m - 20.0), 5.0) << "it drove";
}

// An agent made on a shared clock that already reads 100 s counts its own time from there: the platform, the
// loops and the modes all run on the agent's time, and a goal is driven and reached as at time 0.
TEST(SteppedAgentTest, AnAgentMadeLateOnASharedClockCountsFromItsStart) {
  InProcessTeam links;
  auto clock = std::make_shared<core::SimulatedClock>();
  clock->SetSeconds(100.0);
  AgentOptions options;
  options.robot_id = "r1";
  options.SetPlatform("wheeled");
  options.perception.camera_rate_hz = 0;
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  sim_options.start_W = {5.0, 20.0, 0.0};
  sim::ApplyPlatformProfile(options.navigation.platform, &sim_options);
  auto platform = std::make_shared<sim::SimulatedPlatform>(sim_options);
  std::unique_ptr<RobotAgent> agent = RobotAgent::Stepped(options, platform, links.Join("r1"), clock);
  InProcessBase base(&links, "op");
  base.Send("r1", ControlCommand{});
  GoalCommand goal;
  goal.frame_id = "map";
  goal.x_m = 20.0;
  goal.y_m = 20.0;
  const std::uint32_t request = base.Send("r1", goal);
  double t = 100.0;
  while (t < 130.0 && !(agent->modes().waypoint().goal().status == GoalStatus::kArrived))
    agent->Step(t += 0.02);
  const std::optional<CommandReply> reply = base.Reply("r1", request);
  ASSERT_TRUE(reply);
  EXPECT_EQ(reply->result, CommandResult::kAccepted) << reply->reason;
  EXPECT_EQ(agent->modes().waypoint().goal().status, GoalStatus::kArrived)
      << agent->modes().waypoint().goal().reason;
  EXPECT_LT(std::hypot(platform->TrueState().x_m - 20.0, platform->TrueState().y_m - 20.0), 0.5);
}

TEST(SteppedAgentTest, BadUseIsNamed) {
  InProcessTeam links;
  auto clock = std::make_shared<core::SimulatedClock>();
  AgentOptions options;
  options.robot_id = "r1";
  options.perception.camera_rate_hz = 0;
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  sim_options.start_W = {5.0, 20.0, 0.0};
  auto platform = std::make_shared<sim::SimulatedPlatform>(sim_options);
  EXPECT_THROW(RobotAgent::Stepped(options, platform, nullptr, clock), std::invalid_argument);
  EXPECT_THROW(RobotAgent::Stepped(options, platform, links.Join("r0"), nullptr), std::invalid_argument);
  std::unique_ptr<RobotAgent> agent = RobotAgent::Stepped(options, platform, links.Join("r1"), clock);
  EXPECT_THROW(agent->Run(), std::logic_error);
  agent->Step(1.0);
  EXPECT_THROW(agent->Step(0.5), std::invalid_argument) << "time runs forward";
  try {
    links.Join("r1");
    ADD_FAILURE() << "a second r1 joined";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("'r1' is already on the team"), std::string::npos) << e.what();
  }
  InProcessBase base(&links, "op");
  try {
    base.Send("r9", StopCommand{});
    ADD_FAILURE() << "sent to a robot not on the team";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no robot 'r9'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cairn::agent
