// The operator's mission across interruptions, without DDS: the shipped mode tree with the real mode modules
// on a flat yard (agent_modes_fixture.h); a mission paused by a condition that clears by itself is retried
// while it lasts and resumed under its old id once it clears, dropped when an operator's command comes, and
// ended with its reason when it stays paused too long.
#include "cairn/agent/modes/mission_resumption.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>

#include "agent_modes_fixture.h"

namespace cairn::agent {
namespace {

using mode_testing::Robot;

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
