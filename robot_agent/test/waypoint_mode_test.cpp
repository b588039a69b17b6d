// The waypoint mode's one record of the goal, without DDS: a goal the tree accepts or refuses, a goal
// cancelled by a mode switch, and a goal failed by contact.
#include "cairn/agent/modes/waypoint_mode.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <string>

#include "agent_modes_fixture.h"
#include "cairn/core/build_paths.h"

namespace cairn::agent {
namespace {

const core::SteadyTime kT0 = core::SteadyTime{} + std::chrono::seconds(100);

core::SteadyTime At(double s) {
  return kT0 + std::chrono::duration_cast<core::SteadyClock::duration>(std::chrono::duration<double>(s));
}

ModeDecision Accept() { return ModeDecision{true, "waypoint", "waypoint", ""}; }
ModeDecision Refuse() {
  return ModeDecision{false, "idle", "none", "IsLocalPlannerHealthy: no obstacle input"};
}

struct Fixture {
  Fixture()
      : planner(std::make_shared<nav::GlobalPlanner>(
            std::make_shared<const sim::World>(nav::testing::FlatWorld(10, 8)),
            std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")})),
        navigation(nav::NavigationOptions{}, planner, mode_testing::Library()),
        waypoint(Options(), &navigation, nullptr) {
    start.x_m = 1.0;
    start.y_m = 2.0;
  }
  static WaypointModeOptions Options() {
    WaypointModeOptions o;
    o.robot_id = "r1";
    o.first_goal_id = 7;
    return o;
  }
  nav::GlobalPlan Plan(double x, double y) { return planner->Plan(navigation.GoalRequest(start, x, y)); }
  GoalStart Start(double x, double y, ModeDecision (*decision)()) {
    const nav::GlobalPlan plan = Plan(x, y);
    EXPECT_TRUE(plan.IsUsable()) << plan.reason;
    return waypoint.Start(plan, x, y, 0.0, std::nan(""), 0.0, [&] {
      EXPECT_TRUE(waypoint.has_goal()) << "the tree decides with the new goal in place";
      return decision();
    });
  }

  std::shared_ptr<nav::GlobalPlanner> planner;
  nav::Navigation navigation;
  WaypointMode waypoint;
  core::BaseState start;
};

TEST(WaypointMode, AnAcceptedGoalIsTheOneRecordAndNavigationDrivesIt) {
  Fixture f;
  EXPECT_EQ(f.waypoint.goal().status, GoalStatus::kNone);
  EXPECT_EQ(f.waypoint.goal().goal_id, 0u);
  const GoalStart start = f.Start(8.0, 5.0, Accept);
  ASSERT_TRUE(start.accepted) << start.reason;
  EXPECT_EQ(start.goal_id, 7u);
  const WaypointGoal& goal = f.waypoint.goal();
  EXPECT_TRUE(goal.active());
  EXPECT_EQ(goal.goal_id, 7u);
  EXPECT_DOUBLE_EQ(goal.x_m, 8.0);
  EXPECT_DOUBLE_EQ(goal.y_m, 5.0);
  EXPECT_GT(goal.distance_left_m, 7.0);
  EXPECT_TRUE(f.navigation.has_goal());
  const ModeOutput out = f.waypoint.Step(ModeInputs{At(0), 0.0, f.start});
  EXPECT_TRUE(out.twist_B) << "a driven goal feeds the waypoint channel";
  EXPECT_FALSE(out.done);
}

TEST(WaypointMode, ARefusedFirstGoalLeavesNoGoalButUsesItsId) {
  Fixture f;
  const GoalStart refused = f.Start(8.0, 5.0, Refuse);
  EXPECT_FALSE(refused.accepted);
  EXPECT_EQ(refused.reason, "IsLocalPlannerHealthy: no obstacle input");
  EXPECT_EQ(f.waypoint.goal().status, GoalStatus::kNone);
  EXPECT_EQ(f.waypoint.goal().goal_id, 0u);
  EXPECT_FALSE(f.navigation.has_goal());
  EXPECT_FALSE(f.waypoint.Step(ModeInputs{At(0), 0.0, f.start}).twist_B) << "nothing to drive";
  EXPECT_EQ(f.Start(8.0, 5.0, Accept).goal_id, 8u) << "goal ids are never reused";
}

TEST(WaypointMode, ARefusedNewGoalEndsThePreviousOneWhichNavigationDropped) {
  Fixture f;
  ASSERT_TRUE(f.Start(8.0, 5.0, Accept).accepted);
  EXPECT_FALSE(f.Start(3.0, 6.0, Refuse).accepted);
  const WaypointGoal& goal = f.waypoint.goal();
  EXPECT_EQ(goal.goal_id, 7u) << "the record is the previous goal";
  EXPECT_DOUBLE_EQ(goal.x_m, 8.0);
  EXPECT_EQ(goal.status, GoalStatus::kFailed);
  EXPECT_EQ(goal.reason, "cancelled: a new goal was refused: IsLocalPlannerHealthy: no obstacle input");
  EXPECT_FALSE(f.navigation.has_goal());
}

TEST(WaypointMode, ANewGoalReplacesTheDrivenOne) {
  Fixture f;
  ASSERT_TRUE(f.Start(8.0, 5.0, Accept).accepted);
  ASSERT_TRUE(f.Start(3.0, 6.0, Accept).accepted);
  EXPECT_EQ(f.waypoint.goal().goal_id, 8u);
  EXPECT_TRUE(f.waypoint.goal().active());
  EXPECT_DOUBLE_EQ(f.waypoint.goal().x_m, 3.0);
}

TEST(WaypointMode, LeavingTheModeCancelsTheGoalOnce) {
  Fixture f;
  ASSERT_TRUE(f.Start(8.0, 5.0, Accept).accepted);
  f.waypoint.Deactivate("mode switched to manual");
  EXPECT_EQ(f.waypoint.goal().status, GoalStatus::kFailed);
  EXPECT_EQ(f.waypoint.goal().reason, "cancelled: mode switched to manual");
  EXPECT_FALSE(f.navigation.has_goal());
  f.waypoint.Deactivate("stopped by opB");
  EXPECT_EQ(f.waypoint.goal().reason, "cancelled: mode switched to manual")
      << "an ended goal stays as it ended";
}

TEST(WaypointMode, ContactLongerThanTheTimeoutFailsTheGoal) {
  Fixture f;
  ASSERT_TRUE(f.Start(8.0, 5.0, Accept).accepted);
  core::PlatformStatus contact;
  contact.in_contact = true;
  const ModeInputs in{At(0), 0.0, f.start};
  EXPECT_FALSE(f.waypoint.OnPlatformStatus(contact, in).done);
  EXPECT_FALSE(f.waypoint.OnPlatformStatus(contact, ModeInputs{At(0.9), 0.9, f.start}).done);
  EXPECT_FALSE(f.waypoint.OnPlatformStatus(core::PlatformStatus{}, ModeInputs{At(1.0), 1.0, f.start}).done)
      << "contact broken: the clock restarts";
  EXPECT_FALSE(f.waypoint.OnPlatformStatus(contact, ModeInputs{At(1.1), 1.1, f.start}).done);
  EXPECT_TRUE(f.waypoint.OnPlatformStatus(contact, ModeInputs{At(2.2), 2.2, f.start}).done);
  EXPECT_EQ(f.waypoint.goal().status, GoalStatus::kFailed);
  EXPECT_EQ(f.waypoint.goal().reason, "blocked: in contact with occupied space at (1.00, 2.00)");
}

// A goal navigation abandons (a peer held the robot for max_hold_s) fails at once: the recovery tree, though
// loaded, does not retry it.
TEST(WaypointMode, AnAbandonedGoalIsNotRecovered) {
  nav::NavigationOptions options;
  options.max_hold_s = 5.0;
  const auto planner = std::make_shared<nav::GlobalPlanner>(
      std::make_shared<const sim::World>(nav::testing::FlatWorld(10, 8)),
      std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")});
  nav::Navigation navigation(options, planner, mode_testing::Library());
  WaypointMode waypoint(Fixture::Options(), &navigation,
                        std::make_unique<WaypointRecovery>(cairn::core::ConfigDir() + "/mode_tree.xml",
                                                           &navigation, WaypointRecovery::Hooks{}));
  ASSERT_TRUE(waypoint.recovery_enabled());
  core::BaseState start;
  start.x_m = 1.0;
  start.y_m = 2.0;
  const nav::GlobalPlan plan = planner->Plan(navigation.GoalRequest(start, 8.0, 5.0));
  ASSERT_TRUE(waypoint.Start(plan, 8.0, 5.0, 0.0, std::nan(""), 0.0, Accept).accepted);
  navigation.SetHold("asked r9, 1.7 m ahead in a passage too narrow to pass, to get out of the way", "r9");
  ModeOutput out;
  double t = 0.0;
  for (; t < 10.0 && !out.done; t += 0.02) {
    navigation.SetObstacles({}, start, t);
    out = waypoint.Step(ModeInputs{At(t), t, start});
  }
  ASSERT_TRUE(out.done) << waypoint.goal().reason;
  EXPECT_NEAR(t, 5.0, 0.1);
  EXPECT_EQ(waypoint.goal().status, GoalStatus::kFailed);
  EXPECT_EQ(
      waypoint.goal().reason,
      "blocked by r9: held 5 s without progress (navigation.max_hold_s 5 s): asked r9, 1.7 m ahead in a "
      "passage too narrow to pass, to get out of the way");
  EXPECT_FALSE(navigation.has_goal());
}

TEST(WaypointMode, AnUnusablePlanIsAProgrammingError) {
  Fixture f;
  nav::GlobalPlan unusable;
  EXPECT_THROW(f.waypoint.Start(unusable, 1.0, 1.0, 0.0, std::nan(""), 0.0, Accept), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
