// The robot's planning thread (Sriganesh et al. 2024, § Navigation Layer: the global planner as a query-able
// service): plans the control holder's waypoint goals and answers peers' path queries, off the DDS threads
// and the control loop. The holder's goals go first; path queries are rate-limited per asking process (a
// token bucket), so a flood from one process never delays a goal. DDS-free: the agent feeds it and sends the
// answers.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "cairn/agent/command/commands.h"
#include "cairn/core/time.h"
#include "cairn/nav/global_planner.h"
#include "cairn/perception/staircase.h"

namespace cairn::agent {

/// Options of PlanningService.
struct PlanningServiceOptions {
  std::string robot_id;              ///< names the robot in log lines
  std::string platform;              ///< the robot's platform: a query naming none is planned for it
  double path_queries_per_s = 10.0;  ///< answered per second per asking process (burst twice this), (0, 1000]
  std::size_t max_waiting_queries = 32;  ///< queries waiting beyond this are refused "busy", >= 1
  double map_max_extent_m =
      200.0;  ///< the navigation map's largest extent, metres (named by out-of-map reasons)
};

/// Why robot `robot_id` cannot take a goal whose `plan` is not usable, for operators: a goal the map knows is
/// inside an obstacle (kGoalBlocked) names the nearest free point when the planner found one, "goal
/// (12.00, 3.00) is inside an obstacle on r2's map (cell state obstacle); nearest free point (12.05, 4.15)"
/// (centimetres: the point is a cell centre, which decimetres could move out of its cell); other failures
/// give the plan's reason (so does a blocked goal whose reason the planner extended, e.g. with the step that
/// stops the platform, or one on another level).
std::string GoalPlanReason(const std::string& robot_id, const nav::GlobalPlan& plan,
                           const Eigen::Vector2d& goal_M);

/// The notice an accepted goal comes with: "goal in unmapped space: r2 will look" when `plan` says the goal
/// lies where the map has not seen (nav::GlobalPlan::goal_unmapped; the goal is abandoned if no way there
/// appears, NavigationOptions::unmapped_goal_max_replans), else "".
std::string GoalNotice(const std::string& robot_id, const nav::GlobalPlan& plan);

/// Goal planning and the path query service. Thread-safe: Submit*() from any thread, Run() on one thread.
class PlanningService {
 public:
  /// What the service hands on. Both required.
  struct Hooks {
    /// A goal's plan is done (called on the planning thread, without the service's lock).
    std::function<void(const GoalCommand& goal, const nav::GlobalPlan& plan)> goal_planned;
    /// A path query's answer (the planning thread, or the submitting thread for a refusal).
    std::function<void(const PathAnswer& answer)> answer;
    /// Optional: called for a goal (x, y, metres, map frame) before it is planned; returns why the robot's
    /// navigation map cannot cover it (the goal is then refused with that reason), or "" after asking the
    /// map to grow over it when it lies beyond (the plan then ends at the map's edge and is extended as the
    /// map grows).
    std::function<std::string(const Eigen::Vector2d& goal_M)> cover_goal;
    /// Optional: the staircases the robot has detected (map frame). A goal on another level that cannot be
    /// reached, whose reason names no step, is told of the nearest one whose rise is above the platform's
    /// max_step_m (StairNote()): the map may not show enough of the flight for the planner to name its step.
    std::function<std::vector<perception::Staircase>()> staircases;
  };

  /// `planner` (thread-safe) serves the goals and the queries. @throws std::invalid_argument for a null
  /// planner, a missing hook or options out of range.
  PlanningService(PlanningServiceOptions options, std::shared_ptr<nav::GlobalPlanner> planner, Hooks hooks);

  /// "; the staircase seen at (x, y, z) rises R m per step, above platform P's max_step_m M m" for the
  /// staircase of `staircases` nearest `from_M` (metres, map frame) whose rise is above `platform`'s step;
  /// "" when there is none or the platform is unknown to `planner`.
  static std::string StairNote(const nav::GlobalPlanner& planner, const std::string& platform,
                               const std::vector<perception::Staircase>& staircases,
                               const Eigen::Vector2d& from_M);

  /// Queues a goal already checked by the command interface, with the request planned from the robot's pose.
  void SubmitGoal(const GoalCommand& goal, const nav::GlobalPlanRequest& request);
  /// Queues a peer's path query, within its process's rate and the queue's length. A refused query is
  /// answered at once ("kRateLimited": "rate limited: ..." once a second per process, the rest of a flood
  /// dropped unanswered; "busy: ..." when the queue is full).
  void SubmitPathQuery(const PathQuery& query, core::SteadyTime now);
  /// Plans what is queued, the holder's goals first, until `keep_running` returns false (checked at least
  /// every 100 ms). Exceptions from the planner are logged, never thrown.
  void Run(const std::function<bool()>& keep_running);
  /// Plans one queued job, if any within `wait`; false when none came.
  bool RunOnce(std::chrono::milliseconds wait);

  /// A failed plan's reason for operators (an out-of-map point names the navigation map's largest extent and
  /// its key).
  std::string PlanReason(const nav::GlobalPlan& plan) const;
  /// Path queries refused so far (rate or queue).
  std::uint64_t queries_refused() const;
  /// The planner's map memory, bytes (GlobalPlanner::map_memory_bytes()). Any thread, never waits.
  std::size_t map_memory_bytes() const { return planner_->map_memory_bytes(); }

 private:
  struct GoalJob {
    GoalCommand goal;
    nav::GlobalPlanRequest request;
  };
  struct Budget {  // token bucket per asking process
    double tokens = 0;
    core::SteadyTime last{};
    core::SteadyTime last_refusal{};
  };
  PathAnswer Answer(const PathQuery& query) const;

  PlanningServiceOptions options_;
  std::shared_ptr<nav::GlobalPlanner> planner_;
  Hooks hooks_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<GoalJob> goals_;
  std::deque<PathQuery> queries_;
  std::map<std::string, Budget> budgets_;
  std::uint64_t queries_refused_ = 0;
};

}  // namespace cairn::agent
