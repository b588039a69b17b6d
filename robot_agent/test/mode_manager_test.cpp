#include "cairn/agent/mode_manager.h"

#include <fstream>

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

const std::string kTree = std::string(CAIRN_SOURCE_DIR) + "/config/mode_tree.xml";

ModeConditions Held() {
  ModeConditions c;
  c.holder_id = "opA";
  c.holder_alive = true;
  c.localized = true;
  c.local_planner_healthy = true;
  return c;
}

TEST(ModeManager, ShippedTreeLoadsWithItsModes) {
  ModeManager modes(kTree);
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_EQ(modes.channel(), "none");
  EXPECT_EQ(modes.known_modes(), (std::vector<std::string>{"idle", "manual", "smart_joystick", "waypoint"}));
}

TEST(ModeManager, AcceptsManualWhenConditionsHoldAndSelectsTeleop) {
  ModeManager modes(kTree);
  const ModeDecision d = modes.Request("manual", Held());
  EXPECT_TRUE(d.accepted) << d.reason;
  EXPECT_EQ(modes.mode(), "manual");
  EXPECT_EQ(modes.channel(), "teleop");
}

TEST(ModeManager, RefusalNamesTheFailedConditionAndKeepsTheMode) {
  ModeManager modes(kTree);
  ModeConditions free;  // nobody holds the lock
  free.localized = true;
  ModeDecision d = modes.Request("manual", free);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.mode, "idle");
  EXPECT_NE(d.reason.find("IsControlHeld"), std::string::npos) << d.reason;

  d = modes.Request("waypoint", Held());
  EXPECT_FALSE(d.accepted);
  EXPECT_NE(d.reason.find("HasWaypointGoal"), std::string::npos) << d.reason;
  EXPECT_EQ(modes.last_refusal(), d.reason);

  d = modes.Request("warp", Held());
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, "unknown mode 'warp' (valid: idle, manual, smart_joystick, waypoint)");
}

TEST(ModeManager, RecheckFallsBackToIdleWhenHolderIsLost) {
  ModeManager modes(kTree);
  ASSERT_TRUE(modes.Request("manual", Held()).accepted);
  EXPECT_TRUE(modes.Recheck(Held()).accepted);
  ModeConditions lost = Held();
  lost.holder_alive = false;
  const ModeDecision d = modes.Recheck(lost);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_EQ(modes.channel(), "none");
  EXPECT_NE(d.reason.find("liveliness of control holder opA is lost"), std::string::npos) << d.reason;
}

TEST(ModeManager, ValidModesAreTheOperatorsValidActions) {
  ModeManager modes(kTree);
  EXPECT_EQ(modes.ValidModes(ModeConditions{}), (std::vector<std::string>{"idle"}));
  ModeConditions with_goal = Held();
  with_goal.has_waypoint_goal = true;
  EXPECT_EQ(modes.ValidModes(with_goal), (std::vector<std::string>{"idle", "manual", "waypoint"}));
  with_goal.joystick_alive = true;
  EXPECT_EQ(modes.ValidModes(with_goal),
            (std::vector<std::string>{"idle", "manual", "smart_joystick", "waypoint"}));
  EXPECT_EQ(modes.mode(), "idle") << "ValidModes must not switch";
}

TEST(ModeManager, SmartJoystickNeedsAJoystickAndAHealthyLocalPlanner) {
  ModeManager modes(kTree);
  ModeConditions c = Held();
  ModeDecision d = modes.Request("smart_joystick", c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, "IsJoystickAlive: the control holder has no live joystick");
  c.joystick_alive = true;
  c.local_planner_healthy = false;
  c.local_planner_problem = "obstacle input is 0.80 s old (limit 0.50 s)";
  d = modes.Request("smart_joystick", c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, "IsLocalPlannerHealthy: obstacle input is 0.80 s old (limit 0.50 s)");
  c.local_planner_healthy = true;
  d = modes.Request("smart_joystick", c);
  EXPECT_TRUE(d.accepted) << d.reason;
  EXPECT_EQ(modes.channel(), "smart_joystick");
  // The local planner going stale drops the robot to idle (zero twist).
  c.local_planner_healthy = false;
  d = modes.Recheck(c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(modes.mode(), "idle");
}

TEST(ModeManager, RejectsTreesWithoutIdleOrBroken) {
  const std::string path = ::testing::TempDir() + "/no_idle.xml";
  std::ofstream(path) << R"(<root BTCPP_format="4"><BehaviorTree ID="T"><Sequence>
      <IsModeRequested mode="manual"/><SelectMode mode="manual" channel="teleop"/></Sequence></BehaviorTree></root>)";
  EXPECT_THROW(ModeManager{path}, bt::TreeError);
  EXPECT_THROW(ModeManager{"/nonexistent/tree.xml"}, bt::TreeError);
}

}  // namespace
}  // namespace cairn::agent
