#include "cairn/agent/modes/waypoint_mode.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::agent {

WaypointMode::WaypointMode(WaypointModeOptions options, nav::Navigation* navigation,
                           std::unique_ptr<WaypointRecovery> recovery)
    : ModeModule(kName, MuxChannelOptions{kChannel, options.channel_timeout_s}),
      options_(std::move(options)),
      navigation_(navigation),
      recovery_(std::move(recovery)),
      next_goal_id_(options_.first_goal_id) {
  if (navigation_ == nullptr) throw std::invalid_argument("WaypointMode: navigation is null");
}

GoalStart WaypointMode::Start(const nav::GlobalPlan& plan, double x_m, double y_m, double tolerance_m,
                              double z_m, double now_s, const std::function<ModeDecision()>& enter_mode,
                              uint32_t resume_goal_id) {
  if (!plan.IsUsable())
    throw std::invalid_argument("WaypointMode::Start: the plan is not usable: " + plan.reason);
  const WaypointGoal previous = goal_;
  if (recovery_) recovery_->Halt();  // a recovering previous goal is superseded
  navigation_->AcceptGoal(plan, x_m, y_m, tolerance_m, now_s, z_m);
  own_serial_ = navigation_->goal_serial();
  WaypointGoal goal;
  goal.goal_id = resume_goal_id != 0 ? resume_goal_id : next_goal_id_++;
  goal.x_m = x_m;
  goal.y_m = y_m;
  goal.tolerance_m = tolerance_m;
  goal.z_m = z_m;
  goal.status = GoalStatus::kActive;
  goal.distance_left_m = plan.result.length_m;
  goal_ = goal;
  contact_.Reset();
  const ModeDecision d = enter_mode();  // the tree sees the new goal (HasWaypointGoal)
  if (d.accepted) return GoalStart{true, "", goal.goal_id};
  // Refused by the tree (the new goal still stands here), or stopped by a failed switch (it was cancelled).
  if (goal_.goal_id == goal.goal_id && goal_.active()) {
    goal_ = previous;
    if (previous.active()) {
      // Navigation already holds the new goal, so the previous one ends here, with a status.
      Finish(GoalStatus::kFailed, "cancelled: a new goal was refused: " + d.reason);
    } else {
      navigation_->ClearGoal();
    }
  }
  return GoalStart{false, d.reason, 0};
}

void WaypointMode::Finish(GoalStatus status, const std::string& reason, bool only_own) {
  goal_.status = status;
  goal_.reason = reason;
  if (recovery_) recovery_->Halt();
  if (only_own) {
    navigation_->ClearGoal(own_serial_);
  } else {
    navigation_->ClearGoal();
  }
  if (status == GoalStatus::kFailed) {
    spdlog::warn("robot {}: waypoint {} failed: {}", options_.robot_id, goal_.goal_id, reason);
  }
}

void WaypointMode::EndPaused(uint32_t goal_id, const std::string& reason) {
  if (goal_.goal_id != goal_id || goal_.active()) return;
  goal_.status = GoalStatus::kFailed;
  goal_.reason = reason;
  spdlog::warn("robot {}: waypoint {} failed: {}", options_.robot_id, goal_id, reason);
}

void WaypointMode::Deactivate(const std::string& why) {
  if (has_goal()) Finish(GoalStatus::kFailed, "cancelled: " + why, /*only_own=*/true);
}

ModeOutput WaypointMode::Step(const ModeInputs& in) {
  ModeOutput out;
  if (!has_goal()) return out;
  const core::BaseState& s = in.pose_M;
  nav::NavigationStep step;
  if (recovery_ && recovery_->active()) {
    step = recovery_->Step(s, in.now_s);
    if (recovery_->active()) {
      const std::string report = recovery_->Report();
      if (report != goal_.reason)
        spdlog::warn("robot {}: waypoint {} {}", options_.robot_id, goal_.goal_id, report);
      goal_.reason = report;
    }
  } else {
    step = navigation_->StepWaypoint(s, in.now_s);
    if (step.failed && !step.abandoned && recovery_enabled()) {  // an abandoned goal is not retried
      recovery_->Start(goal_.x_m, goal_.y_m, goal_.tolerance_m, step.reason, goal_.z_m);
      goal_.reason = recovery_->Report();
      spdlog::warn("robot {}: waypoint {} {}", options_.robot_id, goal_.goal_id, goal_.reason);
      step = nav::NavigationStep{};  // brake this cycle; the recovery tree runs from the next
    }
  }
  own_serial_ = navigation_->goal_serial();  // the recovery may have planned the goal again
  goal_.distance_left_m = navigation_->distance_left_m();
  if (step.arrived) {
    spdlog::info("robot {}: waypoint {} arrived ({:.2f} m from the goal)", options_.robot_id, goal_.goal_id,
                 std::hypot(s.x_m - goal_.x_m, s.y_m - goal_.y_m));
    goal_.distance_left_m = 0.0;
    Finish(GoalStatus::kArrived, "");
    out.done = true;
  } else if (step.failed) {
    Finish(GoalStatus::kFailed, step.reason);
    out.done = true;
  } else {
    out.twist_B = Twist2{step.linear_x_mps, step.angular_z_radps};
    out.stamp = in.now;
  }
  return out;
}

ModeOutput WaypointMode::OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) {
  ModeOutput out;
  if (!has_goal()) return out;
  if (const std::string blocked = contact_.Update(status, in, options_.contact_timeout_s); !blocked.empty()) {
    Finish(GoalStatus::kFailed, blocked);
    out.done = true;
  }
  return out;
}

}  // namespace cairn::agent
