// The operator's mission across interruptions, without DDS: the shipped mode tree with the real mode modules
// on a flat yard; a mission paused by a condition that clears by itself is retried while it lasts and resumed
// under its old id once it clears, dropped when an operator's command comes, and ended with its reason when
// it stays paused too long.
#include "cairn/agent/modes/mission_resumption.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>

#include "../../nav/test/nav_test_util.h"
#include "cairn/agent/modes/modes.h"

namespace cairn::agent {
namespace {

const std::string kTree = std::string(CAIRN_SOURCE_DIR) + "/config/mode_tree.xml";

std::shared_ptr<const nav::TrajectoryLibrary> Library() {
  static auto library = [] {
    nav::TrajectoryLibraryOptions o;
    o.heading_range_rad = nav::GetPlatformProfile("wheeled").local_heading_range_rad;
    return std::make_shared<const nav::TrajectoryLibrary>(o);
  }();
  return library;
}

// One robot's modes on a 10 x 8 m yard, held by opA; `localized` is the condition that comes and goes.
struct Robot {
  Robot()
      : planner(std::make_shared<nav::GlobalPlanner>(
            std::make_shared<const sim::World>(nav::testing::FlatWorld(10, 8)),
            std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")})),
        navigation(NavigationOptions{}, planner, Library()),
        control(kTree, Registry(), "r1"),
        missions("r1", Options(), {&control, waypoint, explore, convoy, yield, &navigation},
                 [this](const std::string& mode) { return control.Request(mode, Conditions()); }) {
    pose_M.x_m = 1.0;
    pose_M.y_m = 4.0;
  }

  static MissionOptions Options() {
    MissionOptions o;
    o.resume_within_s = 10.0;
    o.retry_every_s = 1.0;
    return o;
  }
  ModeRegistry Registry() {
    ModeRegistry r;
    r.Emplace<IdleMode>();
    r.Emplace<ManualMode>(0.5);
    r.Emplace<SmartJoystickMode>(&navigation, 0.5, 0.5);
    WaypointModeOptions w;
    w.robot_id = "r1";
    w.first_goal_id = 40;
    waypoint = &r.Emplace<WaypointMode>(w, &navigation, nullptr);
    ExploreModeOptions e;
    e.robot_id = "r1";
    e.first_task_id = 70;
    explore = &r.Emplace<ExploreMode>(e, &navigation, nullptr);
    convoy = &r.Emplace<ConvoyMode>(ConvoyOptions{}, 0.5, &navigation);
    yield = &r.Emplace<YieldMode>(YieldOptions{}, 0.5, &navigation);
    return r;
  }
  ModeConditions Conditions() const {
    ModeConditions c;
    c.holder_id = "opA";
    c.holder_alive = true;
    c.localized = localized;
    c.local_planner_healthy = true;
    c.mapping_healthy = true;
    c.has_waypoint_goal = waypoint->has_goal();
    c.has_explore_task = explore->exploring();
    c.has_convoy_task = convoy->active();
    c.has_yield_task = yield->active();
    return c;
  }
  // The agent's handling of a lost condition: the tree re-checks, the mode goes idle, the mission pauses.
  void LoseLocalization(double now_s) {
    std::optional<PausedMission> running = missions.Running(now_s);
    ASSERT_TRUE(running.has_value()) << "a mission runs in " << control.mode();
    localized = false;
    const ModeDecision d = control.Recheck(Conditions());
    ASSERT_FALSE(d.accepted);
    ASSERT_EQ(control.mode(), "idle");
    missions.Pause(std::move(*running), "IsLocalized: no pose estimate", mission_commands);
  }
  void Step(double now_s) {
    missions.Step(now_s, pose_M, {}, mission_commands, [this] { return localized; });
  }

  std::shared_ptr<nav::GlobalPlanner> planner;
  Navigation navigation;
  WaypointMode* waypoint = nullptr;
  ExploreMode* explore = nullptr;
  ConvoyMode* convoy = nullptr;
  YieldMode* yield = nullptr;
  ModeControl control;
  MissionResumption missions;
  core::BaseState pose_M;
  bool localized = true;
  std::uint64_t mission_commands = 0;
};

TEST(MissionResumption, AnExplorationPausedWhileLocalizationIsLostResumesUnderItsIdOnceItComesBack) {
  Robot r;
  ASSERT_EQ(
      r.explore->Start(ExploreTask{}, 0.0, [&] { return r.control.Request("explore", r.Conditions()); }), "");
  const uint32_t task_id = r.explore->status().task_id;
  EXPECT_EQ(MissionResumption::Name(*r.missions.Running(1.0)), "explore " + std::to_string(task_id));
  r.LoseLocalization(1.0);
  ASSERT_TRUE(r.missions.paused().has_value());

  r.Step(1.5);  // the condition has just failed: not tried yet
  r.Step(2.0);  // tried: the tree still refuses, naming the condition
  ASSERT_TRUE(r.missions.paused().has_value());
  EXPECT_EQ(r.control.mode(), "idle");
  EXPECT_NE(r.missions.paused()->reason.find("IsLocalized"), std::string::npos)
      << r.missions.paused()->reason;

  r.localized = true;
  r.Step(2.5);  // tried less than retry_every_s ago
  EXPECT_TRUE(r.missions.paused().has_value());
  r.Step(3.0);
  EXPECT_FALSE(r.missions.paused().has_value());
  EXPECT_EQ(r.control.mode(), "explore");
  EXPECT_EQ(r.explore->status().task_id, task_id) << "the same exploration goes on";
  EXPECT_EQ(r.missions.note().rfind("resumed after 2.0 s paused: ", 0), 0u) << r.missions.note();
}

TEST(MissionResumption, APausedGoalIsPlannedAgainFromWhereTheRobotIsAndGoesOnUnderItsId) {
  Robot r;
  const nav::GlobalPlan plan = r.planner->Plan(r.navigation.GoalRequest(r.pose_M, 8.0, 4.0));
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  const GoalStart start = r.waypoint->Start(plan, 8.0, 4.0, 0.0, std::nan(""), 0.0,
                                            [&] { return r.control.Request("waypoint", r.Conditions()); });
  ASSERT_TRUE(start.accepted) << start.reason;
  const uint32_t goal_id = r.waypoint->goal().goal_id;
  r.LoseLocalization(1.0);
  r.localized = true;
  r.pose_M.x_m = 3.0;  // it coasted on
  r.Step(2.0);         // due: the goal is planned again, off this thread
  for (int i = 0; i < 500 && r.missions.paused(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
    r.Step(2.0 + 0.01 * i);
  }
  ASSERT_FALSE(r.missions.paused().has_value()) << "not resumed within 5 s";
  EXPECT_EQ(r.control.mode(), "waypoint");
  EXPECT_EQ(r.waypoint->goal().goal_id, goal_id);
  EXPECT_DOUBLE_EQ(r.waypoint->goal().x_m, 8.0);
}

TEST(MissionResumption, AnOperatorsCommandDropsThePausedMissionAndALongPauseEndsIt) {
  Robot r;
  auto explore = [&] {
    return r.explore->Start(ExploreTask{}, 0.0, [&] { return r.control.Request("explore", r.Conditions()); });
  };
  ASSERT_EQ(explore(), "");
  r.LoseLocalization(1.0);
  r.mission_commands = 1;  // e.g. a stop, or another mode
  r.Step(1.2);
  EXPECT_FALSE(r.missions.paused().has_value());
  EXPECT_EQ(r.missions.note(), "dropped: an operator's command came");

  r.localized = true;
  ASSERT_EQ(explore(), "");
  r.LoseLocalization(20.0);
  for (double t = 20.0; t <= 30.0 && r.missions.paused(); t += 0.5) r.Step(t);
  ASSERT_TRUE(r.missions.paused().has_value()) << "10 s (resume_within_s) not over yet";
  r.Step(30.2);
  EXPECT_FALSE(r.missions.paused().has_value());
  EXPECT_EQ(
      r.missions.note().rfind("paused for 10 s (mission.resume_within_s 10) and not resumed: IsLocalized", 0),
      0u)
      << r.missions.note();
  EXPECT_EQ(r.explore->status().state, ExplorationState::kStopped);
  EXPECT_EQ(r.control.mode(), "idle");
}

}  // namespace
}  // namespace cairn::agent
