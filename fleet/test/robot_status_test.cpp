#include "cairn/fleet/robot_status.h"

#include <gtest/gtest.h>

#include <set>

namespace cairn::fleet {
namespace {

TEST(RobotStatusTest, EachStateFieldsWordsAreDistinctAndTheIdlsOwn) {
  // The IDL's comments (idl/cairn_msgs.idl RobotState) list these words; a word added on one side only would
  // show here as a count or a name that no longer matches.
  const std::vector<std::string_view> explore = {"none",   "exploring", "complete",
                                                 "failed", "stopped",   "paused"};
  EXPECT_EQ(ExploreStates(), explore);
  const std::vector<std::string_view> convoy = {"none", "following", "holding", "lost", "blocked", "paused"};
  EXPECT_EQ(ConvoyStates(), convoy);
  const std::vector<std::string_view> yield = {"",        "moving_aside", "aside",  "returning",
                                               "refused", "asking",       "blocked"};
  EXPECT_EQ(YieldStates(), yield);
  for (const auto* words :
       {&ExploreStates(), &ConvoyStates(), &YieldStates(), &MissionStates(), &MissionKinds()}) {
    EXPECT_EQ(std::set<std::string_view>(words->begin(), words->end()).size(), words->size());
  }
}

TEST(RobotStatusTest, OnlyTheAnswersOfARobotThatMovesGiveWay) {
  std::vector<std::string_view> giving_way;
  for (const std::string_view word : YieldStates()) {
    if (GivesWay(word)) giving_way.push_back(word);
  }
  EXPECT_EQ(giving_way, (std::vector<std::string_view>{"moving_aside", "aside", "returning"}));
  EXPECT_FALSE(GivesWay("Aside"));
}

TEST(RobotStatusTest, NavStatusWordsCoverTheEnumAndAnUnknownValueIsNone) {
  EXPECT_STREQ(NavStatusWord(cairn_msgs::NAV_STATUS_NONE), "none");
  EXPECT_STREQ(NavStatusWord(cairn_msgs::NAV_STATUS_ACTIVE), "active");
  EXPECT_STREQ(NavStatusWord(cairn_msgs::NAV_STATUS_ARRIVED), "arrived");
  EXPECT_STREQ(NavStatusWord(cairn_msgs::NAV_STATUS_FAILED), "failed");
  EXPECT_STREQ(NavStatusWord(cairn_msgs::NAV_STATUS_PAUSED), "paused");
  EXPECT_STREQ(NavStatusWord(static_cast<cairn_msgs::NavStatus>(17)), "none");
}

TEST(RobotStatusTest, AStateOfKnownWordsPassesAndEachUnknownOneIsNamedWithItsValue) {
  cairn_msgs::RobotState state;  // as constructed: every word empty, a robot that set none
  EXPECT_EQ(CheckStateWords(state), "");
  state.explore_state(explore_state::kExploring);
  state.convoy_state(convoy_state::kPaused);
  state.yield_state(yield_state::kAside);
  state.mission_state(mission_state::kPaused);
  state.mission_kind(mission_kind::kConvoy);
  EXPECT_EQ(CheckStateWords(state), "");

  state.explore_state("exploded");
  state.yield_state("none");  // "none" is not a yield word: no yield is ""
  const std::string why = CheckStateWords(state);
  EXPECT_NE(
      why.find("explore_state 'exploded' is none of none, exploring, complete, failed, stopped, paused"),
      std::string::npos)
      << why;
  EXPECT_NE(
      why.find("yield_state 'none' is none of '', moving_aside, aside, returning, refused, asking, blocked"),
      std::string::npos)
      << why;
  EXPECT_EQ(why.find("convoy_state"), std::string::npos) << why;
  EXPECT_EQ(why.find("mission"), std::string::npos) << why;
}

}  // namespace
}  // namespace cairn::fleet
