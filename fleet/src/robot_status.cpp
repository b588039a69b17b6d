#include "cairn/fleet/robot_status.h"

#include <algorithm>

namespace cairn::fleet {

bool GivesWay(std::string_view yield_state) {
  return yield_state == yield_state::kMovingAside || yield_state == yield_state::kAside ||
         yield_state == yield_state::kReturning;
}

const std::vector<std::string_view>& ExploreStates() {
  static const std::vector<std::string_view> words = {explore_state::kNone,     explore_state::kExploring,
                                                      explore_state::kComplete, explore_state::kFailed,
                                                      explore_state::kStopped,  explore_state::kPaused};
  return words;
}

const std::vector<std::string_view>& ConvoyStates() {
  static const std::vector<std::string_view> words = {convoy_state::kNone,    convoy_state::kFollowing,
                                                      convoy_state::kHolding, convoy_state::kLost,
                                                      convoy_state::kBlocked, convoy_state::kPaused};
  return words;
}

const std::vector<std::string_view>& YieldStates() {
  static const std::vector<std::string_view> words = {
      yield_state::kNone,    yield_state::kMovingAside, yield_state::kAside,  yield_state::kReturning,
      yield_state::kRefused, yield_state::kAsking,      yield_state::kBlocked};
  return words;
}

const std::vector<std::string_view>& MissionStates() {
  static const std::vector<std::string_view> words = {mission_state::kNone, mission_state::kPaused};
  return words;
}

const std::vector<std::string_view>& MissionKinds() {
  static const std::vector<std::string_view> words = {mission_kind::kNone, mission_kind::kWaypoint,
                                                      mission_kind::kExplore, mission_kind::kConvoy};
  return words;
}

const char* NavStatusWord(cairn_msgs::NavStatus status) {
  switch (status) {
    case cairn_msgs::NAV_STATUS_NONE:
      return "none";
    case cairn_msgs::NAV_STATUS_ACTIVE:
      return "active";
    case cairn_msgs::NAV_STATUS_ARRIVED:
      return "arrived";
    case cairn_msgs::NAV_STATUS_FAILED:
      return "failed";
    case cairn_msgs::NAV_STATUS_PAUSED:
      return "paused";
  }
  return "none";
}

namespace {

// Appends to `why` when `value` is none of `words` ("" written as '').
void CheckWord(const char* field, const std::string& value, const std::vector<std::string_view>& words,
               std::string* why) {
  if (std::find(words.begin(), words.end(), value) != words.end()) return;
  std::string list;
  for (const std::string_view word : words) {
    if (!list.empty()) list += ", ";
    list += word.empty() ? std::string("''") : std::string(word);
  }
  if (!why->empty()) *why += "; ";
  *why += std::string(field) + " '" + value + "' is none of " + list;
}

}  // namespace

std::string CheckStateWords(const cairn_msgs::RobotState& state) {
  std::string why;
  if (!state.explore_state().empty())
    CheckWord("explore_state", state.explore_state(), ExploreStates(), &why);
  if (!state.convoy_state().empty()) CheckWord("convoy_state", state.convoy_state(), ConvoyStates(), &why);
  CheckWord("yield_state", state.yield_state(), YieldStates(), &why);
  CheckWord("mission_state", state.mission_state(), MissionStates(), &why);
  CheckWord("mission_kind", state.mission_kind(), MissionKinds(), &why);
  return why;
}

}  // namespace cairn::fleet
