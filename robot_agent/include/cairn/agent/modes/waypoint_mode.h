// Waypoint mode (Sriganesh et al. 2024, lesson L1): drives to an operator's goal along the global path
// (global plan -> local planner -> iLQR, Navigation::StepWaypoint), runs the recovery tree when navigation
// gives up (WaypointRecovery), and fails the goal when the robot stays in contact with occupied space. The
// module owns the robot's one record of its waypoint goal (the one that is driven, or how the last one
// ended); RobotState, the global path and the mode tree's HasWaypointGoal read it.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/modes/mode_module.h"
#include "cairn/agent/modes/waypoint_recovery.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

/// How a waypoint goal stands (RobotState.nav_status).
enum class GoalStatus { kNone, kActive, kArrived, kFailed };

/// The waypoint goal: the one being driven, or the last one and how it ended.
struct WaypointGoal {
  uint32_t goal_id = 0;  ///< robot-assigned (CommandResponse.goal_id, RobotState.nav_goal_id); 0 = none yet
  double x_m = 0.0;      ///< goal point, frame M, metres
  double y_m = 0.0;
  double tolerance_m = 0.0;  ///< arrival radius as asked, metres; 0 = navigation's default
  double z_m =
      std::numeric_limits<double>::quiet_NaN();  ///< level asked for, metres, frame M; NaN = the robot's
  GoalStatus status = GoalStatus::kNone;
  std::string reason;            ///< why it failed; while recovering, the recovery's report
  double distance_left_m = 0.0;  ///< along the global path, metres
  bool active() const { return status == GoalStatus::kActive; }
};

/// Options of WaypointMode (from AgentOptions).
struct WaypointModeOptions {
  std::string robot_id;            ///< names the robot in log lines
  double channel_timeout_s = 0.5;  ///< the waypoint channel's staleness, seconds, (0, 60]
  double contact_timeout_s =
      1.0;                     ///< in contact with occupied space longer than this -> the goal fails, s, > 0
  uint32_t first_goal_id = 1;  ///< id of the first goal; the agent draws it at random (ids never repeat a
                               ///< restarted robot's), >= 1
};

/// Outcome of WaypointMode::Start.
struct GoalStart {
  bool accepted = false;
  std::string reason;    ///< why it was refused (the tree's failed condition)
  uint32_t goal_id = 0;  ///< the new goal's id when accepted
};

/// The waypoint mode module. Not thread-safe (the agent calls it under its lock, on its control thread).
class WaypointMode : public ModeModule {
 public:
  static constexpr const char* kName = "waypoint";
  static constexpr const char* kChannel = "waypoint";

  /// `navigation` (not owned) outlives this. `recovery` runs when navigation gives up on a goal; null or not
  /// enabled() = the goal fails at once. @throws std::invalid_argument for a null navigation.
  WaypointMode(WaypointModeOptions options, nav::Navigation* navigation,
               std::unique_ptr<WaypointRecovery> recovery);

  /// Makes the goal (x_m, y_m) (metres, frame M; arrival radius tolerance_m, 0 = navigation's default), whose
  /// usable `plan` was made from the robot's pose, the one driven: navigation takes it (a running recovery is
  /// halted), then `enter_mode` asks the mode tree for this mode with the new goal in place. Accepted: the
  /// goal is active and replaces any previous one. Refused: the record is the previous goal again, which ends
  /// ("cancelled: a new goal was refused: ...") since navigation already dropped it. Either way the goal id
  /// is used up. `resume_goal_id` != 0: a paused goal goes on under its id (MissionKeeper), else a new id is
  /// drawn. @throws std::invalid_argument for an unusable plan.
  GoalStart Start(const nav::GlobalPlan& plan, double x_m, double y_m, double tolerance_m, double z_m,
                  double now_s, const std::function<ModeDecision()>& enter_mode, uint32_t resume_goal_id = 0);
  /// A paused goal `goal_id` (not active) that will not be resumed ends as failed with `reason`.
  void EndPaused(uint32_t goal_id, const std::string& reason);

  /// The goal record (see WaypointGoal).
  const WaypointGoal& goal() const { return goal_; }
  /// True while a goal is driven (the tree's HasWaypointGoal).
  bool has_goal() const { return goal_.active(); }
  /// True when a blocked goal is recovered before it fails.
  bool recovery_enabled() const { return recovery_ && recovery_->enabled(); }

  /// Cancels the goal, if one is driven: it fails with "cancelled: <why>".
  void Deactivate(const std::string& why) override;
  /// One step toward the goal (or of the recovery); `done` when it arrived or failed this step.
  ModeOutput Step(const ModeInputs& in) override;
  /// In contact with occupied space for longer than contact_timeout_s: the goal fails ("blocked: ..."), done.
  ModeOutput OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) override;
  bool uses_local_planner() const override { return true; }

 private:
  // Ends the goal with `status`; navigation's goal is dropped, or with `only_own`, only while it is still
  // the one this mode drove last (a mode taking over has set its own before this one is deactivated).
  void Finish(GoalStatus status, const std::string& reason, bool only_own = false);

  WaypointModeOptions options_;
  nav::Navigation* navigation_;
  std::unique_ptr<WaypointRecovery> recovery_;
  WaypointGoal goal_;
  uint32_t next_goal_id_;
  std::uint64_t own_serial_ = 0;  // Navigation::goal_serial() of the goal this mode drove last
  ContactTimer contact_;          // the task's contact with occupied space
};

}  // namespace cairn::agent
