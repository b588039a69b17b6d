#include "cairn/agent/modes/come_home.h"

#include <spdlog/spdlog.h>

#include <utility>

#include "cairn/core/range_check.h"

namespace cairn::agent {

ComeHome::ComeHome(std::string robot_id, const core::BaseState& start_M)
    : robot_id_(std::move(robot_id)), start_M_(start_M) {}

void ComeHome::Step(
    double silence_s, const core::BaseState& pose_M, ExploreMode& explore, nav::Navigation& navigation,
    const std::function<GoalStart(const nav::GlobalPlan& plan, const core::BaseState& goal_M)>& start_goal) {
  if (plan_.valid()) {
    if (nav::PlanRunning(plan_)) return;
    const nav::GlobalPlan plan = plan_.get();
    if (!plan.IsUsable()) {
      spdlog::error("robot {}: no way back to its start ({:.2f}, {:.2f}): {}; it stays here", robot_id_,
                    start_M_.x_m, start_M_.y_m, plan.reason);
      return;
    }
    const GoalStart start = start_goal(plan, start_M_);
    if (start.accepted) {
      spdlog::warn("robot {}: driving back to its start ({:.2f}, {:.2f}), {:.1f} m (waypoint {})", robot_id_,
                   start_M_.x_m, start_M_.y_m, plan.result.length_m, start.goal_id);
    } else {
      spdlog::error("robot {}: cannot drive back to its start: {}; it stays here", robot_id_, start.reason);
    }
    return;
  }
  if (!explore.exploring()) return;
  const double limit_s = explore.status().task.home_after_silence_s;
  if (limit_s <= 0 || silence_s <= limit_s) return;
  explore.Deactivate("no basestation heard for " + core::Fixed(silence_s, 1) +
                     " s: driving back to the start");
  plan_ = navigation.PlanGoalAsync(pose_M, start_M_.x_m, start_M_.y_m, start_M_.z_m);
}

void ComeHome::Abandon(nav::Navigation& navigation) {
  if (plan_.valid()) navigation.Abandon(std::move(plan_));
}

}  // namespace cairn::agent
