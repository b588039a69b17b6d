#include "cairn/agent/services/planning_service.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::agent {

std::string GoalPlanReason(const std::string& robot_id, const nav::GlobalPlan& plan,
                           const Eigen::Vector2d& goal_M) {
  // The main level's message, "goal (x, y) is not traversable (cell state ...)", whose parenthesis says why;
  // a reason the planner extended (the step that stops the platform) or a level's message is kept.
  const std::string& message = plan.result.message;
  const std::size_t open = message.find(" (cell ");
  if (plan.result.status != nav::PlanResult::Status::kGoalBlocked || !plan.platform_known ||
      open == std::string::npos || plan.reason != message) {
    return plan.reason.empty() ? message : plan.reason;
  }
  const std::string cell = message.substr(open);
  // Centimetres: the nearest free point is a cell centre, and rounded to decimetres it may leave its cell.
  std::string reason = "goal (" + core::Fixed(goal_M.x(), 2) + ", " + core::Fixed(goal_M.y(), 2) +
                       ") is inside an obstacle on " + robot_id + "'s map" + cell;
  if (plan.nearest_free_W.allFinite()) {
    reason += "; nearest free point (" + core::Fixed(plan.nearest_free_W.x(), 2) + ", " +
              core::Fixed(plan.nearest_free_W.y(), 2) + ")";
  } else {
    reason += "; no free point within " + core::Fixed(nav::kNearestFreeSearchM, 0) + " m";
  }
  return reason;
}

std::string GoalNotice(const std::string& robot_id, const nav::GlobalPlan& plan) {
  return plan.goal_unmapped ? "goal in unmapped space: " + robot_id + " will look" : "";
}

PlanningService::PlanningService(PlanningServiceOptions options, std::shared_ptr<nav::GlobalPlanner> planner,
                                 Hooks hooks)
    : options_(std::move(options)), planner_(std::move(planner)), hooks_(std::move(hooks)) {
  if (!planner_) throw std::invalid_argument("PlanningService: planner is null");
  if (!hooks_.goal_planned || !hooks_.answer) {
    throw std::invalid_argument("PlanningService: both hooks (goal_planned, answer) are required");
  }
  std::string why;
  if (!core::InRange("path_queries_per_s", options_.path_queries_per_s, 0.0, 1000.0, true, &why)) {
    throw std::invalid_argument("PlanningService: " + why);
  }
  if (options_.max_waiting_queries < 1)
    throw std::invalid_argument("PlanningService: max_waiting_queries = 0");
}

void PlanningService::SubmitGoal(const GoalCommand& goal, const nav::GlobalPlanRequest& request) {
  {
    std::lock_guard<std::mutex> guard(mutex_);
    goals_.push_back(GoalJob{goal, request});
  }
  cv_.notify_one();
}

void PlanningService::SubmitPathQuery(const PathQuery& query, core::SteadyTime now) {
  std::string refusal;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    Budget& budget = budgets_[query.participant];
    const double rate = options_.path_queries_per_s;
    budget.tokens = std::min(2 * rate, budget.tokens + rate * core::SecondsBetween(budget.last, now));
    budget.last = now;
    if (budget.tokens < 1.0) {
      ++queries_refused_;
      // One refusal a second per process says why; the rest of a flood is dropped unanswered.
      if (core::SecondsBetween(budget.last_refusal, now) < 1.0) return;
      budget.last_refusal = now;
      refusal = "rate limited: more than " + core::Fixed(rate, 0) + " path requests/s (burst " +
                core::Fixed(2 * rate, 0) + ") from this process";
    } else if (queries_.size() >= options_.max_waiting_queries) {
      ++queries_refused_;
      refusal = "busy: " + std::to_string(options_.max_waiting_queries) + " path requests are waiting";
    } else {
      budget.tokens -= 1.0;
      queries_.push_back(query);
    }
  }
  if (refusal.empty()) {
    cv_.notify_one();
    return;
  }
  PathAnswer a;
  a.request_id = query.request_id;
  a.requester_id = query.requester_id;
  a.requester_participant = query.participant;
  a.status = "kRateLimited";
  a.reason = refusal;
  hooks_.answer(a);
}

bool PlanningService::RunOnce(std::chrono::milliseconds wait) {
  std::optional<GoalJob> goal;
  std::optional<PathQuery> query;
  {
    std::unique_lock<std::mutex> guard(mutex_);
    cv_.wait_for(guard, wait, [this] { return !goals_.empty() || !queries_.empty(); });
    if (!goals_.empty()) {  // the holder's goals before peers' path queries
      goal = std::move(goals_.front());
      goals_.pop_front();
    } else if (!queries_.empty()) {
      query = std::move(queries_.front());
      queries_.pop_front();
    } else {
      return false;
    }
  }
  try {
    if (goal) {
      const std::string refusal = hooks_.cover_goal ? hooks_.cover_goal(goal->request.goal_W) : "";
      if (!refusal.empty()) {
        nav::GlobalPlan refused;
        refused.result.status = nav::PlanResult::Status::kOutOfMap;
        refused.result.message = refusal;
        refused.reason = refusal;
        refused.map_version = planner_->map_version();
        hooks_.goal_planned(goal->goal, refused);
      } else {
        nav::GlobalPlan plan = planner_->Plan(goal->request);
        if (plan.result.status == nav::PlanResult::Status::kGoalBlocked) {
          plan.reason = GoalPlanReason(options_.robot_id, plan, goal->request.goal_W);  // refused at once
        }
        if (!plan.IsUsable() && plan.platform_known && std::isfinite(goal->request.goal_z_m) &&
            plan.reason.find("step") == std::string::npos && hooks_.staircases) {
          plan.reason +=
              StairNote(*planner_, goal->request.platform, hooks_.staircases(), goal->request.start_W);
        }
        hooks_.goal_planned(goal->goal, plan);
      }
    } else {
      hooks_.answer(Answer(*query));
    }
  } catch (const std::exception& e) {
    spdlog::error("robot {}: planning failed: {}", options_.robot_id, e.what());
  }
  return true;
}

void PlanningService::Run(const std::function<bool()>& keep_running) {
  while (keep_running()) RunOnce(std::chrono::milliseconds(100));
}

PathAnswer PlanningService::Answer(const PathQuery& query) const {
  PathAnswer a;
  a.request_id = query.request_id;
  a.requester_id = query.requester_id;
  a.requester_participant = query.participant;
  if (query.frame_id != "map") {
    a.status = "kInvalidFrame";
    a.reason = "frame_id '" + query.frame_id + "' is not supported (use 'map')";
    return a;
  }
  nav::GlobalPlanRequest request;
  request.start_W = query.start_M;
  request.goal_W = query.goal_M;
  request.platform = query.platform.empty() ? options_.platform : query.platform;
  const nav::GlobalPlan plan = planner_->Plan(request);  // thread-safe: no agent lock here
  a.success = plan.IsUsable();
  a.status = plan.platform_known ? nav::ToString(plan.result.status) : "kUnknownPlatform";
  a.reason = plan.IsUsable() ? "" : PlanReason(plan);
  a.path_M = plan.result.path_W;
  a.length_m = plan.result.length_m;
  a.map_version = plan.map_version;
  a.planning_time_s = plan.total_time_s;
  spdlog::info("robot {}: path request {} from {} ({}): {}", options_.robot_id, query.request_id,
               query.requester_id, request.platform, plan.IsUsable() ? "path" : plan.reason);
  return a;
}

std::string PlanningService::StairNote(const nav::GlobalPlanner& planner, const std::string& platform,
                                       const std::vector<perception::Staircase>& staircases,
                                       const Eigen::Vector2d& from_M) {
  const nav::PlatformProfile* profile = planner.Profile(platform);
  if (profile == nullptr) return "";
  const double max_step_m = profile->traversability.max_step_m;
  const perception::Staircase* nearest = nullptr;
  double nearest_m = std::numeric_limits<double>::infinity();
  for (const perception::Staircase& stairs : staircases) {
    const double d = (stairs.p_W_first_step.head<2>() - from_M).norm();
    if (stairs.rise_m > max_step_m + 1e-9 && d < nearest_m) {
      nearest = &stairs;
      nearest_m = d;
    }
  }
  if (nearest == nullptr) return "";
  const Eigen::Vector3d& p = nearest->p_W_first_step;
  return "; the staircase seen at (" + core::Fixed(p.x(), 2) + ", " + core::Fixed(p.y(), 2) + ", " +
         core::Fixed(p.z(), 2) + ") rises " + core::Fixed(nearest->rise_m, 2) +
         " m per step, above platform " + platform + "'s max_step_m " + core::Fixed(max_step_m, 2) + " m";
}

std::string PlanningService::PlanReason(const nav::GlobalPlan& plan) const {
  if (plan.result.status != nav::PlanResult::Status::kOutOfMap ||
      plan.reason.find("navigation.map_max_extent_m") != std::string::npos) {
    return plan.reason;
  }
  const std::string extent = core::Fixed(options_.map_max_extent_m, 0);
  return plan.reason + " (the robot's navigation map grows as the robot maps or is sent beyond it, up to " +
         extent + " m along x and y: navigation.map_max_extent_m = " + extent + ")";
}

std::uint64_t PlanningService::queries_refused() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return queries_refused_;
}

}  // namespace cairn::agent
