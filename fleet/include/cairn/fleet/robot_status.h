// The words a robot uses in its RobotState (idl/cairn_msgs.idl) to say what it is doing: its exploration,
// convoy, get-out-of-the-way and paused-mission states. One vocabulary, written by the agent (telemetry, its
// modes, its peer messages) and read by every basestation (console, events, GUI), so that both sides can
// never drift apart, and a basestation can tell a word it does not know (a newer or a broken robot) from one
// it does. Pure logic, no DDS.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "cairn_msgs.h"

namespace cairn::fleet {

/// RobotState::explore_state: the exploration a robot runs by itself (Sriganesh et al. 2024, § Exploration).
namespace explore_state {
inline constexpr char kNone[] = "none";            ///< no exploration since the robot started
inline constexpr char kExploring[] = "exploring";  ///< under way
inline constexpr char kComplete[] = "complete";    ///< no reachable frontier left in its region
inline constexpr char kFailed[] = "failed";        ///< could not go on (no path to any frontier, stuck)
inline constexpr char kStopped[] = "stopped";      ///< ended by an operator or by another mode taking over
inline constexpr char kPaused[] = "paused";        ///< interrupted; the robot resumes it by itself
}  // namespace explore_state

/// RobotState::convoy_state: a convoy follower's state.
namespace convoy_state {
inline constexpr char kNone[] = "none";            ///< not in a convoy
inline constexpr char kFollowing[] = "following";  ///< on the trail of the robot ahead
inline constexpr char kHolding[] = "holding";      ///< stopped at its spacing behind the robot ahead
inline constexpr char kLost[] = "lost";            ///< the robot ahead is not heard
inline constexpr char kBlocked[] = "blocked";      ///< no way along the trail
inline constexpr char kPaused[] = "paused";        ///< interrupted; the robot resumes it by itself
}  // namespace convoy_state

/// RobotState::yield_state and PeerState::yield_state: get out of the way (Sriganesh et al. 2024, § Advanced
/// Multi-agent Coordination). The first four are the answer of the robot asked to yield; the last two the
/// state of the robot that asked.
namespace yield_state {
inline constexpr char kNone[] = "";                     ///< no yield under way
inline constexpr char kMovingAside[] = "moving_aside";  ///< driving to its spot aside
inline constexpr char kAside[] = "aside";               ///< standing aside, waiting for the other to pass
inline constexpr char kReturning[] = "returning";       ///< the other passed; driving back
inline constexpr char kRefused[] = "refused";           ///< will not yield (manual control, no spot, policy)
inline constexpr char kAsking[] = "asking";             ///< asked another robot to get out of its way
inline constexpr char kBlocked[] = "blocked";           ///< the robot it asked refused or found no spot
}  // namespace yield_state

/// true for the answers of a robot that gives way (moving aside, aside, returning).
bool GivesWay(std::string_view yield_state);

/// RobotState::mission_state and mission_kind: an operator's mission a transient condition interrupted.
namespace mission_state {
inline constexpr char kNone[] = "";
inline constexpr char kPaused[] = "paused";
}  // namespace mission_state
namespace mission_kind {
inline constexpr char kNone[] = "";
inline constexpr char kWaypoint[] = "waypoint";
inline constexpr char kExplore[] = "explore";
inline constexpr char kConvoy[] = "convoy";
}  // namespace mission_kind

/// The words of each state field, in the order above (explore_state's first, ...).
const std::vector<std::string_view>& ExploreStates();
const std::vector<std::string_view>& ConvoyStates();
const std::vector<std::string_view>& YieldStates();
const std::vector<std::string_view>& MissionStates();
const std::vector<std::string_view>& MissionKinds();

/// The operator's word for a NavStatus: "none" | "active" | "arrived" | "failed" | "paused" (the console's
/// `robots`, the GUI's nav_status); "none" for a value outside the enum (a newer robot's).
const char* NavStatusWord(cairn_msgs::NavStatus status);

/// "" when every state word of `state` is one of this vocabulary's (an empty explore or convoy state counts
/// as none: a robot that never set it); else which are not, naming each field and its value, e.g.
/// "explore_state 'exploded' is none of none, exploring, complete, failed, stopped, paused". A basestation
/// still shows such a state (what the robot said), and says so.
std::string CheckStateWords(const cairn_msgs::RobotState& state);

}  // namespace cairn::fleet
