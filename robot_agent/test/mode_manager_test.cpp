#include "cairn/agent/modes/mode_manager.h"

#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "cairn/core/build_paths.h"
#include "mode_test_util.h"

namespace cairn::agent {
namespace {

const std::string kTree = cairn::core::SourceDir() + "/config/mode_tree.xml";
// The agent's mux channels.
const std::vector<std::string> kChannels = {"teleop",  "smart_joystick", "waypoint",
                                            "explore", "convoy",         "yield"};

using mode_testing::Held;

TEST(ModeManager, ShippedTreeLoadsWithItsModes) {
  ModeManager modes(kTree, kChannels);
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_EQ(modes.channel(), "none");
  EXPECT_EQ(modes.known_modes(), (std::vector<std::string>{"idle", "manual", "smart_joystick", "waypoint",
                                                           "explore", "convoy", "yield"}));
}

TEST(ModeManager, AcceptsManualWhenConditionsHoldAndSelectsTeleop) {
  ModeManager modes(kTree, kChannels);
  const ModeDecision d = modes.Request("manual", Held());
  EXPECT_TRUE(d.accepted) << d.reason;
  EXPECT_EQ(modes.mode(), "manual");
  EXPECT_EQ(modes.channel(), "teleop");
}

TEST(ModeManager, RefusalNamesTheFailedConditionAndKeepsTheMode) {
  ModeManager modes(kTree, kChannels);
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
  EXPECT_EQ(d.reason,
            "unknown mode 'warp' (valid: idle, manual, smart_joystick, waypoint, explore, convoy, yield)");
}

TEST(ModeManager, RecheckFallsBackToIdleWhenHolderIsLost) {
  ModeManager modes(kTree, kChannels);
  ASSERT_TRUE(modes.Request("manual", Held()).accepted);
  EXPECT_TRUE(modes.Recheck(Held()).accepted);
  ModeConditions lost = Held();
  lost.holder_alive = false;
  const ModeDecision d = modes.Recheck(lost);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_EQ(modes.channel(), "none");
  EXPECT_NE(d.reason.find("IsHolderAlive: liveliness of control holder opA is lost"), std::string::npos)
      << d.reason;
}

// A waypoint goal goes on through a comms drop (the lock stays held); modes driven by a live operator stop.
TEST(ModeManager, WaypointGoesOnWhenTheHoldersLinkDropsManualDoesNot) {
  ModeManager modes(kTree, kChannels);
  ModeConditions c = Held();
  c.has_waypoint_goal = true;
  ASSERT_TRUE(modes.Request("waypoint", c).accepted);
  c.holder_alive = false;
  EXPECT_TRUE(modes.Recheck(c).accepted);
  EXPECT_EQ(modes.mode(), "waypoint");
  EXPECT_EQ(modes.ValidModes(c), (std::vector<std::string>{"idle", "waypoint"}));
  const ModeDecision manual = modes.Request("manual", c);
  EXPECT_FALSE(manual.accepted);
  EXPECT_NE(manual.reason.find("IsHolderAlive"), std::string::npos) << manual.reason;
  c.holder_id.clear();  // the lock freed (lock_keep_s): the goal stops
  EXPECT_FALSE(modes.Recheck(c).accepted);
  EXPECT_EQ(modes.mode(), "idle");
}

TEST(ModeManager, ValidModesAreTheOperatorsValidActions) {
  ModeManager modes(kTree, kChannels);
  EXPECT_EQ(modes.ValidModes(ModeConditions{}), (std::vector<std::string>{"idle"}));
  ModeConditions with_goal = Held();
  with_goal.has_waypoint_goal = true;
  EXPECT_EQ(modes.ValidModes(with_goal), (std::vector<std::string>{"idle", "manual", "waypoint"}));
  with_goal.joystick_alive = true;
  EXPECT_EQ(modes.ValidModes(with_goal),
            (std::vector<std::string>{"idle", "manual", "smart_joystick", "waypoint"}));
  EXPECT_EQ(modes.mode(), "idle") << "ValidModes must not switch";
}

// A mode that needs a component that is down is refused naming it, falls back to idle on its
// re-check, and is valid again once the component is back; the others go on.
TEST(ModeManager, ModesNeedingAComponentThatIsDownAreRefusedUntilItIsBack) {
  ModeManager modes(kTree, kChannels);
  ModeConditions c = Held();
  c.joystick_alive = true;
  c.has_explore_task = true;
  c.mapping_healthy = true;
  ASSERT_TRUE(modes.Request("smart_joystick", c).accepted);
  c.components_down["perception"] = "perception is down (injected fault); restart in 0.8 s";
  const ModeDecision recheck = modes.Recheck(c);
  EXPECT_FALSE(recheck.accepted);
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_NE(recheck.reason.find("IsComponentUp: perception is down (injected fault); restart in 0.8 s"),
            std::string::npos)
      << recheck.reason;
  EXPECT_FALSE(modes.Request("explore", c).accepted);
  EXPECT_EQ(modes.ValidModes(c), (std::vector<std::string>{"idle", "manual"}));
  c.has_waypoint_goal = true;
  EXPECT_EQ(modes.ValidModes(c), (std::vector<std::string>{"idle", "manual", "waypoint"}))
      << "waypoint drives on the platform's live obstacles, not on perception";
  c.components_down.clear();
  c.components_down["platform"] = "platform is down (lidar read threw)";
  EXPECT_EQ(modes.ValidModes(c), (std::vector<std::string>{"idle", "manual", "smart_joystick", "explore"}));
  c.components_down.clear();
  EXPECT_TRUE(modes.Request("smart_joystick", c).accepted);
}

// A robot asked to get out of the way needs no lock (its policy decides, not its operator), only a
// yield it accepted, its pose and a healthy local planner.
TEST(ModeManager, YieldNeedsAnAcceptedRequestButNoLock) {
  ModeManager modes(kTree, kChannels);
  ModeConditions c = Held();
  c.holder_id = "";
  c.holder_alive = false;
  ModeDecision d = modes.Request("yield", c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, "HasYieldTask: no yield request accepted (a peer or yield R asks)");
  c.has_yield_task = true;
  d = modes.Request("yield", c);
  EXPECT_TRUE(d.accepted) << d.reason;
  EXPECT_EQ(d.channel, "yield");
  c.local_planner_healthy = false;
  c.local_planner_problem = "no fresh obstacle input";
  d = modes.Recheck(c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(modes.mode(), "idle");
}

// Explore needs a task, a healthy local planner and a robot that maps; a refusal names which.
TEST(ModeManager, ExploreNeedsATaskAndMappingAndTheRefusalNamesWhich) {
  ModeManager modes(kTree, kChannels);
  ModeConditions c = Held();
  c.has_explore_task = true;
  c.mapping_healthy = false;
  c.mapping_problem = "no lidar scan for 4.0 s";
  ModeDecision d = modes.Request("explore", c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(d.reason, "IsMappingHealthy: no lidar scan for 4.0 s");
  c.mapping_healthy = true;
  c.has_explore_task = false;
  d = modes.Request("explore", c);
  EXPECT_EQ(d.reason, "HasExploreTask: no exploration task (send explore first)");
  c.has_explore_task = true;
  d = modes.Request("explore", c);
  EXPECT_TRUE(d.accepted) << d.reason;
  EXPECT_EQ(d.channel, "explore");
  c.mapping_healthy = false;
  d = modes.Recheck(c);
  EXPECT_FALSE(d.accepted);
  EXPECT_EQ(modes.mode(), "idle") << "mapping lost mid-way: the robot stops";
}

TEST(ModeManager, SmartJoystickNeedsAJoystickAndAHealthyLocalPlanner) {
  ModeManager modes(kTree, kChannels);
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
  EXPECT_THROW((ModeManager{path, kChannels}), bt::TreeError);
  EXPECT_THROW((ModeManager{"/nonexistent/tree.xml", kChannels}), bt::TreeError);
}

// A branch naming a channel the mux lacks loaded, and `stop` then left the twist on.
TEST(ModeManager, RefusesABranchWhoseChannelIsNotAMuxChannelNamingBranchAndChannel) {
  std::ifstream in(kTree);
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string good = R"(<SelectMode mode="manual" channel="teleop"/>)";
  ASSERT_NE(xml.find(good), std::string::npos);
  auto write_variant = [&](const std::string& name, const std::string& select) {
    std::string variant = xml;
    variant.replace(variant.find(good), good.size(), select);
    std::string path = ::testing::TempDir() + "/" + name;
    std::ofstream(path) << variant;
    return path;
  };
  auto message = [](const std::string& path, const std::vector<std::string>& channels) -> std::string {
    try {
      ModeManager modes(path, channels);
    } catch (const bt::TreeError& e) {
      return e.what();
    }
    return "(loaded)";
  };
  const std::string warp =
      message(write_variant("warp.xml", R"(<SelectMode mode="manual" channel="warp"/>)"), kChannels);
  EXPECT_NE(warp.find("branch 'manual'"), std::string::npos) << warp;
  EXPECT_NE(warp.find("mux channel 'warp'"), std::string::npos) << warp;
  EXPECT_NE(warp.find("channels: none, teleop, smart_joystick, waypoint"), std::string::npos) << warp;
  EXPECT_NE(warp.find("warp.xml:"), std::string::npos) << "the file and line are named: " << warp;

  const std::string from_blackboard =
      message(write_variant("bb.xml", R"(<SelectMode mode="manual" channel="{channel}"/>)"), kChannels);
  EXPECT_NE(from_blackboard.find("must be a literal mux channel"), std::string::npos) << from_blackboard;
  // An idle branch that takes its mode from the blackboard cannot hide a channel behind it.
  const std::string mode_from_blackboard = message(
      write_variant("bb_mode.xml", R"(<SelectMode mode="{requested_mode}" channel="teleop"/>)"), kChannels);
  EXPECT_NE(mode_from_blackboard.find("must be a literal mode name"), std::string::npos)
      << mode_from_blackboard;

  // The shipped tree against a mux without the waypoint channel: the waypoint branch is named.
  const std::string no_waypoint = message(kTree, {"teleop", "smart_joystick"});
  EXPECT_NE(no_waypoint.find("branch 'waypoint'"), std::string::npos) << no_waypoint;

  std::string idle_xml = xml;
  const std::string idle = R"(<SelectMode mode="idle" channel="none"/>)";
  ASSERT_NE(idle_xml.find(idle), std::string::npos);
  idle_xml.replace(idle_xml.find(idle), idle.size(), R"(<SelectMode mode="idle" channel="teleop"/>)");
  const std::string idle_path = ::testing::TempDir() + "/idle_teleop.xml";
  std::ofstream(idle_path) << idle_xml;
  const std::string idle_message = message(idle_path, kChannels);
  EXPECT_NE(idle_message.find("fail-safe mode 'idle' must select channel 'none'"), std::string::npos)
      << idle_message;
}

// A condition naming a component the agent does not have failed every tick (its branch could never be taken);
// it is refused at load, naming the node, the value and the components.
TEST(ModeManager, IsComponentUpNamingNoComponentIsRefusedAtLoad) {
  std::ifstream in(kTree);
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string good = R"(<IsComponentUp component="perception"/>)";
  ASSERT_NE(xml.find(good), std::string::npos);
  xml.replace(xml.find(good), good.size(), R"(<IsComponentUp component="nonexistent"/>)");
  const std::string path = ::testing::TempDir() + "/nonexistent_component.xml";
  std::ofstream(path) << xml;
  try {
    ModeManager modes(path, kChannels);
    FAIL() << "a tree naming no component loaded";
  } catch (const bt::TreeError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("nonexistent_component.xml:"), std::string::npos) << what;
    EXPECT_NE(what.find("IsComponentUp"), std::string::npos) << what;
    EXPECT_NE(
        what.find("component \"nonexistent\" is not a component of cairn_agent (its components: platform, "
                  "perception"),
        std::string::npos)
        << what;
  }
}

TEST(ModeManager, ForceIdleStopsWhateverTheTreeSays) {
  ModeManager modes(kTree, kChannels);
  ASSERT_TRUE(modes.Request("manual", Held()).accepted);
  const ModeDecision d = modes.ForceIdle("stopped by opB");
  EXPECT_EQ(d.mode, "idle");
  EXPECT_EQ(d.channel, "none");
  EXPECT_EQ(modes.mode(), "idle");
  EXPECT_EQ(modes.channel(), "none");
  EXPECT_TRUE(modes.Recheck(Held()).accepted) << "idle stays valid after a forced stop";
  EXPECT_EQ(modes.channel(), "none");
}

TEST(ModeManagerTest, TheShippedTreeCarriesTheGeneratedTreeNodesModel) {
  // Groot2 opens the shipped tree only with a model of its custom nodes; it must match the registered ones.
  std::ifstream in(kTree);
  ASSERT_TRUE(in) << kTree;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string model = ModeManager::TreeNodesModel();
  EXPECT_NE(model.find("<Condition ID=\"IsLocalized\""), std::string::npos) << model;
  EXPECT_NE(model.find("<Action ID=\"SelectMode\""), std::string::npos) << model;
  EXPECT_EQ(ModeManager::WithTreeNodesModel(text), text)
      << "config/mode_tree.xml's <TreeNodesModel> is out of date: regenerate it (cairn_agent "
         "--print-tree-nodes-model)";
}

}  // namespace
}  // namespace cairn::agent
