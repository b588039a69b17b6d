// Words an operator reads (Sriganesh et al. 2024, lesson L4: the operator is offered only valid actions and
// told plainly why not). One vocabulary of outcomes for every command, robot refusals rewritten from
// behavior-tree condition ids into operator language, the actions valid now, and "did you mean".
// Pure functions, no DDS: the CLI and (later) the GUI share them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "cairn/base/fleet.h"

namespace cairn::base {

/// The outcome of every command, in text and in --json "result". Exit codes: accepted 0; refused, failed and
/// timed out 1; invalid 2.
namespace outcome {
inline constexpr const char* kAccepted = "accepted";  ///< the robot (or this basestation) did it
inline constexpr const char* kRefused = "refused";    ///< not done: the lock, a condition or a limit says no
inline constexpr const char* kFailed =
    "failed";  ///< tried and did not succeed (goal failed, file unwritable)
inline constexpr const char* kTimedOut = "timed out";  ///< no answer or no result in time
inline constexpr const char* kInvalid = "invalid";     ///< the command line is malformed (names the argument)
}  // namespace outcome

/// A reason for an operator, and the machine-readable cause behind it.
struct OperatorReason {
  std::string text;       ///< e.g. "waypoint mode needs a goal: use goto r1 X Y"
  std::string condition;  ///< the mode-tree condition id that refused ("HasWaypointGoal"), or "" when none
};

/// Rewrites a robot's reason (e.g. "HasWaypointGoal: no accepted waypoint goal (send goto first)") in words
/// an operator acts on, keeping the condition id apart. Reasons with no known condition id pass unchanged.
/// `robot_id` names the robot in the advice ("use goto r1 X Y").
OperatorReason ExplainReason(const std::string& robot_id, const std::string& reason);

/// The commands `base_id` may send `view`'s robot now, e.g. {"mode idle|manual|waypoint", "goto", "teleop",
/// "release", "stop"} for its holder; {"stop"} when another basestation holds it; {"request-control",
/// "stop"} when free; {"stop"} when the robot is lost or its state has not arrived. Modes come from the
/// robot's behavior-tree state (valid_modes); "waypoint" is offered as `goto`, which sets the goal and enters
/// it. The robot of `fleet` (not `robot` itself, not lost) whose global path comes nearest `robot`'s
/// position, within `within_m` (metres, frame map): the one `yield` lets pass by default. "" when none.
std::string RobotWhoseRoutePasses(const std::vector<RobotView>& fleet, const RobotView& robot,
                                  double within_m);

std::vector<std::string> ValidActions(const RobotView& view, const std::string& base_id);

/// What `view`'s robot is doing, in a few words, from its latest state and (for convoys) `fleet`'s: "to
/// (12.0, 4.5)", "exploring: 64 m² mapped, 12 frontiers", "convoy 2 of 3 behind r1", "leads a convoy of 3",
/// "yielding to r3", "waiting for r3 to yield", "explore paused: ...", "driven (manual)", "arrived" (only
/// while idle after arriving), "idle". "?" before the first state.
std::string TaskText(const RobotView& view, const std::vector<RobotView>& fleet);

/// A goal or exploration id as an operator reads it: "#845" (its last three digits; a robot numbers its goals
/// and explorations up from a random start, so consecutive ones differ there and ids are unique for 1000 of
/// them), "#7" for an id under 1000. The full id stays in --json output.
std::string ShortId(std::uint32_t id);

/// ValidActions as one line: "valid now: mode idle|manual, goto, teleop, release, stop".
std::string ValidActionsText(const RobotView& view, const std::string& base_id);

/// What a robot offers, from its agent info, in one line: "wheeled, cairn 0.1.0, modes idle manual waypoint,
/// sensors lidar camera, map 0.10 m, link radio 1000 kbit/s". Parts it did not announce are left out.
std::string DescribeAgent(const RobotView& view);

/// Candidates closest to `word` by edit distance (Levenshtein, at most 2 edits, or a prefix of at least 3
/// letters), best first, at most 3. Empty when nothing is close.
std::vector<std::string> DidYouMean(const std::string& word, const std::vector<std::string>& candidates);

/// " (did you mean X?)" / " (did you mean X or Y?)" / "".
std::string DidYouMeanText(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace cairn::base
