// Paused missions (MissionKeeper): which conditions pause rather than end a mission, and when a paused one is
// tried again or ends. The agent's wiring of it runs in tests/component_fault_test (real processes).
#include "cairn/agent/modes/mission.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

TEST(MissionTest, ConditionsThatClearByThemselvesPauseOthersEnd) {
  EXPECT_TRUE(IsTransientFailure("IsComponentUp: perception is down"));
  EXPECT_TRUE(IsTransientFailure("explore no longer allowed: IsComponentUp: perception is down"));
  EXPECT_TRUE(IsTransientFailure("waypoint no longer allowed: IsLocalized: no valid pose estimate"));
  EXPECT_TRUE(IsTransientFailure("IsMappingHealthy: the map is 9.1 s old"));
  EXPECT_TRUE(IsTransientFailure("IsLocalPlannerHealthy: no trajectory for 3 s"));
  EXPECT_FALSE(IsTransientFailure("explore no longer allowed: IsControlHeld: no basestation holds the lock"));
  EXPECT_FALSE(IsTransientFailure("IsHolderAlive: liveliness of control holder op1 lost"));
  EXPECT_FALSE(IsTransientFailure("HasExploreTask: no exploration task (send explore first)"));
  EXPECT_FALSE(IsTransientFailure(""));
  EXPECT_FALSE(IsTransientFailure("IsComponentUpX: a lookalike"));
}

TEST(MissionTest, APausedMissionIsTriedEverySoOftenHeldThroughAYieldAndExpires) {
  MissionOptions options;
  options.resume_within_s = 10.0;
  options.retry_every_s = 1.0;
  MissionKeeper keeper(options);
  EXPECT_EQ(keeper.Check(0.0), MissionKeeper::Due::kNothing);
  PausedMission m;
  m.kind = PausedMission::Kind::kExplore;
  m.task_id = 7;
  m.reason = "IsComponentUp: perception is down";
  m.since_s = 100.0;
  keeper.Pause(m);
  EXPECT_EQ(keeper.Check(100.5), MissionKeeper::Due::kWait) << "the condition has just failed";
  EXPECT_EQ(keeper.Check(101.0), MissionKeeper::Due::kTry);
  keeper.Tried(101.0);
  EXPECT_EQ(keeper.Check(101.5), MissionKeeper::Due::kWait);
  keeper.SetReason("IsComponentUp: perception is restarting");
  EXPECT_EQ(keeper.paused()->reason, "IsComponentUp: perception is restarting");
  EXPECT_EQ(keeper.Check(110.0), MissionKeeper::Due::kTry);
  EXPECT_EQ(keeper.Check(110.5), MissionKeeper::Due::kExpired);
  const auto taken = keeper.Take();
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->task_id, 7u);
  EXPECT_FALSE(keeper.paused());

  m.held = true;  // a yield: it neither retries nor expires until the yield ends
  keeper.Pause(m);
  EXPECT_EQ(keeper.Check(500.0), MissionKeeper::Due::kWait);
  keeper.Release(500.0);
  EXPECT_EQ(keeper.Check(500.0), MissionKeeper::Due::kTry) << "at once when the yield ends";
  EXPECT_EQ(keeper.Check(510.5), MissionKeeper::Due::kExpired) << "counted from the yield's end";
}

TEST(MissionTest, BadOptionsAreNamed) {
  MissionOptions options;
  options.resume_within_s = 0.0;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "mission.resume_within_s = 0 must be in (0, 3600]");
  options = MissionOptions();
  options.retry_every_s = 61;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "mission.retry_every_s = 61 must be in (0, 60]");
  EXPECT_THROW(MissionKeeper{options}, std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
