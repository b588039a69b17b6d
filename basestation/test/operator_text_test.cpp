#include "cairn/base/operator_text.h"

#include <gtest/gtest.h>

namespace cairn::base {
namespace {

RobotView HeldBy(const std::string& holder, const std::vector<std::string>& valid_modes,
                 bool goal_acceptable) {
  RobotView v;
  v.robot_id = "r1";
  cairn_msgs::RobotState s;
  s.robot_id("r1");
  s.mode("idle");
  s.holder_id(holder);
  s.holder_alive(true);
  v.state = s;
  cairn_msgs::BehaviorTreeState t;
  t.valid_modes(valid_modes);
  t.goal_acceptable(goal_acceptable);
  v.tree = t;
  return v;
}

TEST(ExplainReason, RewritesTreeConditionsInOperatorWordsKeepingTheId) {
  OperatorReason r = ExplainReason("r1", "HasWaypointGoal: no accepted waypoint goal (send goto first)");
  EXPECT_EQ(r.text, "waypoint mode needs a goal: use goto r1 X Y");
  EXPECT_EQ(r.condition, "HasWaypointGoal");
  r = ExplainReason("r1", "IsControlHeld: no basestation holds the control lock");
  EXPECT_EQ(r.text, "nobody holds r1's control lock: request-control r1 first");
  r = ExplainReason("r2",
                    "manual no longer allowed: IsHolderAlive: liveliness of control holder opA is lost");
  EXPECT_EQ(r.condition, "IsHolderAlive");
  EXPECT_EQ(r.text.rfind("manual no longer allowed: the basestation holding r2 is not connected", 0), 0u)
      << r.text;
  r = ExplainReason("r1", "IsLocalPlannerHealthy: obstacle input is 0.80 s old (limit 0.50 s)");
  EXPECT_EQ(r.text, "r1's obstacle sensing is not ready: obstacle input is 0.80 s old (limit 0.50 s)");
  // A component that is starting is not one that went down.
  EXPECT_EQ(ExplainReason("r1", "IsComponentUp: platform is starting").text,
            "r1 is still starting its software: platform is starting; try again in a moment");
  EXPECT_EQ(
      ExplainReason("r1", "IsComponentUp: perception is down (stalled); restart in 0.6 s").text,
      "a part of r1's software is down and restarting by itself: perception is down (stalled); restart in "
      "0.6 s (health r1)");
  r = ExplainReason("r1", "IsMappingHealthy: no lidar scan for 3.5 s");
  EXPECT_EQ(r.text, "r1 is not mapping: no lidar scan for 3.5 s");
  EXPECT_EQ(r.condition, "IsMappingHealthy");
  // Why the robot is not localized: its platform's words (the driver's topic), kept.
  EXPECT_EQ(
      ExplainReason("r1", "IsLocalized: no valid pose estimate: no odometry on /odom for 1.5 s").text,
      "r1 does not know where it is (not localized: no valid pose estimate: no odometry on /odom for 1.5 s)");
  EXPECT_EQ(ExplainReason("r1", "IsLocalized:").text, "r1 does not know where it is (not localized)");
  EXPECT_EQ(ExplainReason("r1", "HasExploreTask: no exploration task (send explore first)").text,
            "explore mode needs a task: use explore r1");
  // A reason with no condition id is already in operator words.
  r = ExplainReason("r1", "robot r1 is locked by basestation opA");
  EXPECT_EQ(r.text, "robot r1 is locked by basestation opA");
  EXPECT_EQ(r.condition, "");
}

TEST(ValidActions, OfferOnlyWhatTheRobotWouldAcceptFromThisBasestation) {
  RobotView free = HeldBy("", {"idle"}, false);
  EXPECT_EQ(ValidActions(free, "op1"), (std::vector<std::string>{"request-control", "yield", "stop"}));
  RobotView other = HeldBy("opB", {"idle", "manual"}, true);
  EXPECT_EQ(ValidActions(other, "op1"), (std::vector<std::string>{"request-control", "yield", "stop"}))
      << "a request asks the holder to hand it over";
  RobotView mine = HeldBy("op1", {"idle", "manual", "waypoint"}, true);
  EXPECT_EQ(ValidActions(mine, "op1"),
            (std::vector<std::string>{"mode idle|manual", "goto", "home", "convoy", "teleop", "yield",
                                      "handover", "release", "stop"}));
  EXPECT_EQ(ValidActionsText(mine, "op1"),
            "valid now: mode idle|manual, goto, home, convoy, teleop, yield, handover, release, stop");
  // Another basestation asks for it: the holder may grant or deny.
  RobotView asked = mine;
  asked.state->control_requester_id("op2");
  EXPECT_EQ(ValidActions(asked, "op1").front(), "grant op2");
  EXPECT_EQ(ValidActions(asked, "op1")[1], "deny op2");
  // Explore when the tree would take a task (a mapping robot); the explore mode itself is not a
  // `mode` action (explore sets the task).
  RobotView explorer = HeldBy("op1", {"idle", "manual", "waypoint", "explore"}, true);
  explorer.tree->explore_acceptable(true);
  EXPECT_EQ(ValidActions(explorer, "op1"),
            (std::vector<std::string>{"mode idle|manual", "goto", "home", "explore", "convoy", "teleop",
                                      "yield", "handover", "release", "stop"}));
  // A convoy follower may peel off or end the convoy; convoy mode itself is set by convoy.
  RobotView follower = HeldBy("op1", {"idle", "manual", "waypoint", "convoy"}, true);
  follower.state->convoy_ahead_ids({"r0"});
  EXPECT_EQ(ValidActions(follower, "op1"),
            (std::vector<std::string>{"mode idle|manual", "goto", "home", "convoy", "peel", "convoy-stop",
                                      "teleop", "yield", "handover", "release", "stop"}));
  RobotView no_goal = HeldBy("op1", {"idle"}, false);  // e.g. the local planner is not ready
  EXPECT_EQ(ValidActions(no_goal, "op1"),
            (std::vector<std::string>{"mode idle", "yield", "handover", "release", "stop"}));
  // Get out of the way is never offered for a robot an operator drives (its policy would refuse).
  RobotView driven = HeldBy("opB", {"idle", "manual"}, true);
  driven.state->mode("manual");
  EXPECT_EQ(ValidActions(driven, "op1"), (std::vector<std::string>{"request-control", "stop"}));
  mine.lost = true;
  EXPECT_EQ(ValidActions(mine, "op1"), (std::vector<std::string>{"stop"})) << "a stop is always allowed";
}

// What a robot is doing, in the words the robots table prints: never a stale "arrived" while it does
// something else; a follower's place in its convoy counted from the fleet.
TEST(TaskText, SaysWhatTheRobotDoesNow) {
  RobotView r = HeldBy("op1", {"idle"}, true);
  EXPECT_EQ(TaskText(r, {r}), "idle");
  r.state->nav_status(cairn_msgs::NAV_STATUS_ARRIVED);
  r.state->nav_goal_M().x_m(12.0);
  r.state->nav_goal_M().y_m(4.5);
  EXPECT_EQ(TaskText(r, {r}), "arrived at (12.0, 4.5)");
  r.state->mode("manual");
  EXPECT_EQ(TaskText(r, {r}), "driven (manual)") << "no stale arrival";
  r.state->mode("waypoint");
  r.state->nav_status(cairn_msgs::NAV_STATUS_ACTIVE);
  EXPECT_EQ(TaskText(r, {r}), "to (12.0, 4.5)");
  r.state->mode("explore");
  r.state->explore_state("exploring");
  r.state->explored_m2(64.4);
  r.state->reachable_frontiers(12);
  EXPECT_EQ(TaskText(r, {r}), "exploring: 64 m² mapped, 12 frontiers");
  r.state->yield_state("moving_aside");
  r.state->yield_peer_id("r3");
  EXPECT_EQ(TaskText(r, {r}), "yielding to r3");
  r.state->yield_state("asking");
  EXPECT_EQ(TaskText(r, {r}), "waiting for r3 to yield");
  r.state->mission_state("paused");
  r.state->mission_kind("explore");
  r.state->mission_reason("perception restarting");
  EXPECT_EQ(TaskText(r, {r}), "explore paused: perception restarting");

  // A convoy of three: r1 leads, r2 behind it, r3 behind r2.
  RobotView leader = HeldBy("op1", {"idle"}, true);
  RobotView second = HeldBy("op1", {"idle"}, true);
  RobotView third = HeldBy("op1", {"idle"}, true);
  second.robot_id = "r2";
  third.robot_id = "r3";
  second.state->mode("convoy");
  second.state->convoy_ahead_ids({"r1"});
  second.state->convoy_state("following");
  third.state->mode("convoy");
  third.state->convoy_ahead_ids({"r2", "r1"});
  third.state->convoy_state("holding");
  const std::vector<RobotView> fleet = {leader, second, third};
  EXPECT_EQ(TaskText(second, fleet), "convoy 2 of 3 behind r1");
  EXPECT_EQ(TaskText(third, fleet), "convoy 3 of 3 behind r2, holding");
  EXPECT_EQ(TaskText(leader, fleet), "leads a convoy of 3; idle");
  RobotView unheard;
  unheard.robot_id = "r9";
  EXPECT_EQ(TaskText(unheard, fleet), "?");
}

TEST(DidYouMean, FindsTyposAndPrefixes) {
  const std::vector<std::string> commands = {"goto", "status", "stop", "stairs", "snapshot"};
  EXPECT_EQ(DidYouMean("gotoo", commands), (std::vector<std::string>{"goto"}));
  EXPECT_EQ(DidYouMeanText("gotoo", commands), " (did you mean goto?)");
  EXPECT_EQ(DidYouMean("snap", commands).front(), "snapshot") << "a prefix ranks first";
  EXPECT_EQ(DidYouMean("stp", commands).front(), "stop");
  EXPECT_TRUE(DidYouMean("teleportation", commands).empty());
  EXPECT_EQ(DidYouMeanText("r9", {"r1", "r2"}), " (did you mean r1 or r2?)");
}

TEST(ShortIdTest, LastThreeDigitsOfARandomStartSmallIdsWhole) {
  EXPECT_EQ(ShortId(482913845), "#845");
  EXPECT_EQ(ShortId(482913846), "#846");
  EXPECT_EQ(ShortId(482913005), "#005");
  EXPECT_EQ(ShortId(12), "#12");
  EXPECT_EQ(ShortId(0), "#0");
  EXPECT_EQ(ShortId(4294967295U), "#295");
}

}  // namespace
}  // namespace cairn::base
