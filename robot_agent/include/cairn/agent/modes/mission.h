// Missions that outlast interruptions (Sriganesh et al. 2024, § Lessons learned: component failures are
// normal, the operator decides). An operator's mission — a waypoint goal, an exploration or a place in a
// convoy — ends only by an operator's command (stop, another mode, release, a new goal) or a permanent
// failure. A transient condition (a component down or restarting, localization lost, the mapping or the local
// planner unhealthy, a yield to another robot) pauses it: the robot keeps the mission, retries it while the
// condition lasts, resumes it by itself once the mode tree allows it again, and ends it with the reason if
// that takes longer than MissionOptions::resume_within_s.
//
// The paused mission rides on RobotState (mission_state "paused", mission_kind, mission_reason,
// mission_paused_s; explore_state "paused", nav_status NAV_STATUS_PAUSED with the same task or goal id, or
// convoy_state "paused" with the same robots ahead), so
// `explore --wait` and `goto --wait` wait through it and basestations tell their operators (events
// mission_paused / mission_resumed).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/waypoint_mode.h"

namespace cairn::agent {

/// Options of paused missions (config section `mission`).
struct MissionOptions {
  /// A paused mission not resumed within this long ends, with the reason it was paused, seconds, (0, 3600].
  double resume_within_s = 60.0;
  /// A paused mission is tried again this often while its condition lasts, seconds, (0, 60].
  double retry_every_s = 1.0;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// True when `failure` — a mode-tree refusal or re-check failure, "Condition: text" (ModeDecision::reason,
/// possibly after "<mode> no longer allowed: ") — names a condition that clears by itself: IsComponentUp,
/// IsLocalized, IsMappingHealthy, IsLocalPlannerHealthy. The control lock (IsControlHeld, IsHolderAlive)
/// and the task conditions (HasWaypointGoal, HasExploreTask) are an operator's business: not transient.
bool IsTransientFailure(const std::string& failure);

/// The condition's part of a mode-tree failure: "Condition: text", without the "<mode> no longer allowed: "
/// a re-check puts before it (ModeManager::Recheck); `failure` itself when it has none.
std::string FailedCondition(const std::string& failure);

/// A mission interrupted by a transient condition, kept to be resumed.
struct PausedMission {
  enum class Kind { kWaypoint, kExplore, kConvoy };
  Kind kind = Kind::kWaypoint;
  WaypointGoal goal;     ///< kWaypoint: the goal (its id is kept when it resumes)
  ExploreTask task;      ///< kExplore: the task...
  uint32_t task_id = 0;  ///< ...and its id (kept when it resumes)
  /// kConvoy: the robots ahead, nearest first, as they were when it paused (ConvoyStatus::ahead_ids).
  std::vector<std::string> convoy_ahead_ids;
  std::string reason;    ///< why it is paused (the condition's words)
  double since_s = 0.0;  ///< when it was paused, seconds (the agent's clock)
  /// While true the pause does not expire and is not retried on its own (a yield in progress: the yield's
  /// end resumes it).
  bool held = false;
};

/// "waypoint" | "explore" | "convoy".
const char* ToString(PausedMission::Kind kind);

/// The robot's paused mission, if any, and when to try it again. Not thread-safe (the agent calls it under
/// its lock, on its control thread).
class MissionKeeper {
 public:
  /// @throws std::invalid_argument for invalid options.
  explicit MissionKeeper(const MissionOptions& options);

  /// Keeps `mission` (replacing any other paused one).
  void Pause(PausedMission mission);
  /// Drops the paused mission (an operator's command, a resume, an end); returns it.
  std::optional<PausedMission> Take();
  /// The paused mission's hold ends (the yield ended): it is tried at once and may expire from now on.
  void Release(double now_s);
  /// Updates why it is still paused (a retry refused, naming the condition).
  void SetReason(const std::string& reason);

  enum class Due { kNothing, kWait, kTry, kExpired };
  /// At `now_s`: nothing paused, wait (held, or tried less than retry_every_s ago), try now (then call
  /// Tried()), or expired (paused longer than resume_within_s: end it with the reason).
  Due Check(double now_s) const;
  void Tried(double now_s) { last_try_s_ = now_s; }

  const std::optional<PausedMission>& paused() const { return paused_; }
  const MissionOptions& options() const { return options_; }

 private:
  MissionOptions options_;
  std::optional<PausedMission> paused_;
  double last_try_s_ = -1e300;
};

}  // namespace cairn::agent
