// Getting out of the way as the agent composes it, without DDS: yb parked idle at (14, 5) in builtin:narrow's
// 2 m tunnel with the shipped mode tree and real modes (agent_modes_fixture.h), asked by ya driving through.
// A request that comes before yb listens to its peers waits until they could be heard; a bad or unheard one
// is refused and shown; an accepted one puts yb in the yield mode, holding the mission it ran until the yield
// ends. The policy itself is yield_test.cpp's.
#include "cairn/agent/team/yield_coordination.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "agent_modes_fixture.h"
#include "cairn/sim/builtin_worlds.h"

namespace cairn::agent {
namespace {

using mode_testing::Robot;

std::shared_ptr<const sim::World> Narrow() {
  static const auto world = std::make_shared<const sim::World>(sim::MakeBuiltinWorld("narrow"));
  return world;
}

// ya at (4, 5), asking for itself to drive the south tunnel to (30, 5).
YieldCommand FromYa() {
  YieldCommand c;
  c.sender_id = "ya";
  c.request_id = 1;
  c.passing_id = "ya";
  c.passing_radius_m = 0.3;
  c.keep_clear_M = {{4.0, 5.0}, {30.0, 5.0}};
  return c;
}

YieldOrigin FromAPeer() {
  YieldOrigin o;
  o.peer_robot = true;
  return o;
}

Peer Ya() {
  Peer p;
  p.robot_id = "ya";
  p.pose_M = Robot::At(4.0, 5.0);
  p.footprint_radius_m = 0.3;
  p.mode = "waypoint";
  return p;
}

// yb, with the agent's yield coordination (RobotModes::yielding()).
struct Yb {
  Yb() : robot(Narrow(), "yb", Robot::At(14.0, 5.0)), yielding(robot.modes.yielding()) {}
  // yb as the agent sees it at `now_s`, hearing `peers` (kept here while it is used).
  YieldCoordination::Robot At(double now_s, std::vector<Peer> peers, bool listening = true) {
    heard = std::move(peers);
    return {now_s, robot.control.mode(), robot.pose_M, &heard, listening};
  }
  Robot robot;
  YieldCoordination& yielding;
  std::vector<Peer> heard;
};

TEST(YieldCoordination, ARequestBeforeThePeersAreReadWaitsUntilTheyCouldBeHeardThenYbStandsAside) {
  Yb yb;
  yb.yielding.OnRequest(FromYa(), FromAPeer(), "", yb.At(10.0, {}, /*listening=*/false));
  EXPECT_TRUE(yb.yielding.waiting_to_hear_peers());
  EXPECT_FALSE(yb.robot.yield->active());
  yb.yielding.DecideWaitingRequest(yb.At(11.0, {Ya()}));
  EXPECT_TRUE(yb.yielding.waiting_to_hear_peers()) << "1 s after it came: not decided yet";
  yb.yielding.DecideWaitingRequest(yb.At(11.6, {Ya()}));
  EXPECT_FALSE(yb.yielding.waiting_to_hear_peers());
  EXPECT_EQ(yb.robot.control.mode(), "yield");
  EXPECT_EQ(yb.robot.yield->status().state, YieldStatus::State::kMovingAside)
      << yb.robot.yield->status().reason;
  EXPECT_EQ(yb.robot.yield->passing_id(), "ya");
  EXPECT_FALSE(yb.robot.missions.paused().has_value()) << "an idle robot has no mission to hold";
}

TEST(YieldCoordination, ABadRequestOrOneForARobotNotHeardIsRefusedAndShown) {
  Yb yb;
  yb.yielding.OnRequest(FromYa(), FromAPeer(), "yield request: keep_clear_M[0].x_m nan is not finite",
                        yb.At(10.0, {Ya()}));
  EXPECT_EQ(yb.robot.control.mode(), "idle");
  EXPECT_EQ(yb.robot.yield->status().state, YieldStatus::State::kRefused);
  EXPECT_EQ(yb.robot.yield->status().reason, "yield request: keep_clear_M[0].x_m nan is not finite");

  yb.yielding.OnRequest(FromYa(), FromAPeer(), "", yb.At(11.0, {}));
  EXPECT_EQ(yb.robot.control.mode(), "idle");
  EXPECT_EQ(yb.robot.yield->status().state, YieldStatus::State::kRefused);
  EXPECT_NE(yb.robot.yield->status().reason.find("ya"), std::string::npos) << yb.robot.yield->status().reason;
  EXPECT_NE(yb.robot.yield->status().reason, "yield request: keep_clear_M[0].x_m nan is not finite");
}

TEST(YieldCoordination, AGoalRunningWhenYbYieldsIsHeldWhileItYields) {
  Yb yb;
  Robot& r = yb.robot;
  const nav::GlobalPlan plan = r.planner->Plan(r.navigation.GoalRequest(r.pose_M, 10.0, 5.0));
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  ASSERT_TRUE(r.waypoint
                  ->Start(plan, 10.0, 5.0, 0.0, std::nan(""), 0.0,
                          [&] { return r.control.Request("waypoint", r.Conditions()); })
                  .accepted);
  yb.yielding.OnRequest(FromYa(), FromAPeer(), "", yb.At(1.0, {Ya()}));
  ASSERT_EQ(r.control.mode(), "yield") << r.yield->status().reason;
  ASSERT_TRUE(r.missions.paused().has_value());
  EXPECT_TRUE(r.missions.paused()->held);
  EXPECT_EQ(r.missions.paused()->reason, "yielding to ya");
  EXPECT_EQ(r.missions.paused()->kind, PausedMission::Kind::kWaypoint);
}

}  // namespace
}  // namespace cairn::agent
