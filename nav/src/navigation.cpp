#include "cairn/nav/navigation.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "cairn/core/range_check.h"

namespace cairn::nav {
namespace {

using core::InRange;

constexpr double kPi = 3.14159265358979323846;
constexpr double kArrivalSpeedMps = 0.1;  // arrival needs the robot at most this fast
constexpr double kArrivalLevelM = 0.5;    // ...and this close to the height of a goal's level
// Replans on the worker start at most this often (a search over the map's levels costs up to ~0.5 s of CPU on
// a mostly unknown map; back to back they would take a core from the robot's sensing and mapping).
constexpr double kMinReplanIntervalS = 1.0;
constexpr double kPartialWaitS = 8.0;  // a partial plan's end is a dead end after this long without a way on
constexpr double kGoalSnapM = 0.25;    // largest hop from a free local path sample to the goal
// A goal in unmapped space progresses when the distance left falls this far below its least so far.
constexpr double kUnmappedProgressM = 0.5;

using core::Fixed;

// p_W = R(yaw) p_B + p_WB.
Eigen::Vector2d ToWorld(const core::BaseState& s, const Eigen::Vector2d& p_B) {
  const double c = std::cos(s.yaw_rad), n = std::sin(s.yaw_rad);
  return {s.x_m + c * p_B.x() - n * p_B.y(), s.y_m + n * p_B.x() + c * p_B.y()};
}

// p_B = R(yaw)^T (p_W - p_WB).
Eigen::Vector2d ToBody(const core::BaseState& s, const Eigen::Vector2d& p_W) {
  const double c = std::cos(s.yaw_rad), n = std::sin(s.yaw_rad);
  const double dx = p_W.x() - s.x_m, dy = p_W.y() - s.y_m;
  return {c * dx + n * dy, -n * dx + c * dy};
}

}  // namespace

bool NavigationOptions::IsValid(std::string* why) const {
  if (!platform.IsValid(why)) return false;
  std::string inner;
  if (!local_planner.IsValid(&inner)) {
    *why = "local_planner: " + inner;
    return false;
  }
  if (!controller.IsValid(&inner)) {
    *why = "controller: " + inner;
    return false;
  }
  return InRange("navigation.goal_tolerance_m", goal_tolerance_m, 0, 5, true, why) &&
         InRange("navigation.blocked_timeout_s", blocked_timeout_s, 0, 600, true, why) &&
         InRange("navigation.stall_timeout_s", stall_timeout_s, 0, 3600, true, why) &&
         InRange("navigation.carrot_distance_m", carrot_distance_m, 0, 10, true, why) &&
         InRange("navigation.required_free_length_m", required_free_length_m, 0, 10, true, why) &&
         InRange("navigation.tight_free_length_m", tight_free_length_m, 0, required_free_length_m, true,
                 why) &&
         InRange("navigation.tight_spot_deviation_rad", tight_spot_deviation_rad, 0, kPi, true, why) &&
         InRange("navigation.sensor_range_m", sensor_range_m, 0, 20, true, why) &&
         InRange("navigation.local_planner_period_s", local_planner_period_s, 0, 1, true, why) &&
         InRange("navigation.obstacle_timeout_s", obstacle_timeout_s, 0, 10, true, why) &&
         InRange("navigation.obstacle_lost_s", obstacle_lost_s, obstacle_timeout_s, 60, false, why) &&
         InRange("navigation.replan_check_period_s", replan_check_period_s, 0, 60, true, why) &&
         InRange("navigation.max_path_deviation_m", max_path_deviation_m, 0, 20, true, why) &&
         InRange("navigation.joystick_turn_lookahead_s", joystick_turn_lookahead_s, 0, 5, false, why) &&
         InRange("navigation.unmapped_goal_max_replans", unmapped_goal_max_replans, 1, 1000, false, why) &&
         InRange("navigation.unmapped_goal_timeout_s", unmapped_goal_timeout_s, 0, 3600, true, why) &&
         InRange("navigation.max_hold_s", max_hold_s, 0, 3600, true, why);
}

namespace {

const NavigationOptions& Validated(const NavigationOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}

}  // namespace

Navigation::Navigation(const NavigationOptions& options, std::shared_ptr<GlobalPlanner> planner,
                       std::shared_ptr<const TrajectoryLibrary> library)
    : options_(Validated(options)),
      planner_(std::move(planner)),
      local_planner_(std::move(library), options.local_planner),
      controller_(options.controller, options.platform.limits) {
  if (!planner_) throw std::invalid_argument("Navigation: global planner is null");
  if (planner_->Profile(options_.platform.name) == nullptr) {
    throw std::invalid_argument("Navigation: the global planner does not serve platform '" +
                                options_.platform.name + "'");
  }
  plan_.result.status = PlanResult::Status::kUnreachable;
}

double Navigation::PartialRemaining(const GlobalPlan& plan) const {
  if (!goal_ || plan.result.path_W.empty()) return 0.0;
  return PartialRemainingM(plan.result.path_W.back(), goal_->p_W, goal_->z_m);
}

GlobalPlanRequest Navigation::GoalRequest(const core::BaseState& state, double x_m, double y_m,
                                          double z_m) const {
  GlobalPlanRequest request;
  request.start_W = {state.x_m, state.y_m};
  request.start_z_m = state.z_m;  // the planner uses the map's levels when the robot is off its main level
  request.goal_W = {x_m, y_m};
  request.goal_z_m = z_m;
  request.allow_partial = true;  // an upper floor not yet connected on the map: go as far as it is known
  request.platform = options_.platform.name;
  request.start_is_robot = true;  // where the robot stands: a start the map shows blocked is map noise
  if (reduced_clearance_) {
    // No clearance preference, and cells count as traversable 30 % closer to obstacles than the footprint:
    // the 0.1 m map cells can close a gap the robot fits through (a 0.8 m gap for a 0.6 m robot); the
    // local planner's tight-spot check holds the real footprint against the live lidar points.
    request.preferred_clearance_m = options_.platform.footprint_radius_m;
    request.robot_radius_m = reduced_radius_m();
  }
  return request;
}

GlobalPlan Navigation::SetGoal(const core::BaseState& state, double x_m, double y_m, double tolerance_m,
                               double now_s, double z_m) {
  GlobalPlan plan = planner_->Plan(GoalRequest(state, x_m, y_m, z_m));
  if (plan.IsUsable()) AcceptGoal(plan, x_m, y_m, tolerance_m, now_s, z_m);
  return plan;
}

void Navigation::AcceptGoal(const GlobalPlan& plan, double x_m, double y_m, double tolerance_m, double now_s,
                            double z_m, double stall_timeout_s) {
  DropExtension();
  replan_.partial_stuck_since_s = -1.0;
  Goal goal;
  goal.p_W = {x_m, y_m};
  goal.z_m = z_m;
  goal.tolerance_m = tolerance_m > 0 ? tolerance_m : options_.goal_tolerance_m;
  goal.stall_timeout_s = stall_timeout_s > 0 ? stall_timeout_s : options_.stall_timeout_s;
  goal.best_distance_m = plan.result.length_m;
  goal.best_time_s = now_s;
  goal_ = goal;
  ++goal_serial_;
  plan_ = plan;
  const bool same_unmapped_goal = unmapped_.active && (unmapped_.p_W - goal.p_W).norm() < 1e-6 &&
                                  now_s - unmapped_.last_s <= options_.unmapped_goal_timeout_s;
  if (!plan.goal_unmapped) {
    unmapped_.active = false;
  } else if (same_unmapped_goal) {
    ++unmapped_.replans;  // accepted again: as a replan, without a fresh bound
  } else {
    unmapped_.active = true;
    unmapped_.p_W = goal.p_W;
    unmapped_.best_left_m = plan.result.length_m + (plan.result.partial ? PartialRemaining(plan) : 0.0);
    unmapped_.best_time_s = now_s;
    unmapped_.replans = 0;
  }
  unmapped_.last_s = now_s;
  progress_.segment = 0;
  progress_.segment_start_along_m = 0.0;
  progress_.projection_along_m = 0.0;
  progress_.distance_left_m = plan.result.length_m;
  progress_.mean_speed_mps = options_.platform.cruise_speed_mps;
  progress_.eta_s = progress_.distance_left_m / progress_.mean_speed_mps;
  replan_.count = 0;
  ++replan_.path_revision;
  replan_.last_check_s = now_s;
  local_.track_W.clear();
  local_.last_time_s = -1e9;  // plan locally at once
  controller_.Reset();
  control_.turning_in_place = false;
}

std::future<GlobalPlan> Navigation::PlanOnWorker(GlobalPlanRequest request) const {
  return std::async(std::launch::async,
                    [planner = planner_, request = std::move(request)] { return planner->Plan(request); });
}

std::future<GlobalPlan> Navigation::PlanGoalAsync(const core::BaseState& state, double x_m, double y_m,
                                                  double z_m) const {
  return PlanOnWorker(GoalRequest(state, x_m, y_m, z_m));
}

void Navigation::Abandon(std::future<GlobalPlan> plan) {
  // A running search finishes on its own; its future waits in replan_.abandoned so that nothing here blocks.
  replan_.abandoned.erase(std::remove_if(replan_.abandoned.begin(), replan_.abandoned.end(),
                                         [](const std::future<GlobalPlan>& f) { return PlanReady(f); }),
                          replan_.abandoned.end());
  if (plan.valid()) replan_.abandoned.push_back(std::move(plan));
}

bool Navigation::replanning() const { return PlanRunning(replan_.extension); }

void Navigation::DropExtension() { Abandon(std::move(replan_.extension)); }

void Navigation::ClearGoal() {
  DropExtension();
  if (!goal_) return;
  goal_.reset();
  plan_.result.path_W.clear();
  plan_.result.length_m = 0.0;
  ++replan_.path_revision;
  local_.track_W.clear();
}

void Navigation::ClearGoal(std::uint64_t serial) {
  if (goal_ && serial == goal_serial_) ClearGoal();
}

void Navigation::ClearObstacles() {
  obstacles_.points_B.clear();
  obstacles_.awaiting = true;
  local_.track_W.clear();
}

bool Navigation::IsObstacle(const Eigen::Vector3f& p_B) const {
  const auto& library = local_planner_.library().options();
  return p_B.allFinite() && p_B.z() >= library.obstacle_min_z_m && p_B.z() <= library.obstacle_max_z_m;
}

bool Navigation::ClearBehind(const core::BaseState& state, double distance_m, double margin_m,
                             std::string* why) const {
  const double radius = options_.platform.footprint_radius_m + std::max(0.0, margin_m);
  double nearest = 1e18;
  Eigen::Vector2d nearest_W = Eigen::Vector2d::Zero();
  for (const Eigen::Vector3f& o : obstacles_.points_B) {
    if (!IsObstacle(o)) continue;
    // Obstacles are kept in frame B of obstacles_.pose; the segment runs from `state` backwards.
    const Eigen::Vector2d p_B = ToBody(state, ToWorld(obstacles_.pose, o.head<2>().cast<double>()));
    const double along = std::clamp(p_B.x(), -std::max(0.0, distance_m), 0.0);
    const double d = (p_B - Eigen::Vector2d(along, 0.0)).norm();
    // Points ahead of the robot's centre that it already touches do not block moving away from them.
    if (p_B.x() > 0.0) continue;
    if (d < nearest) {
      nearest = d;
      nearest_W = ToWorld(state, p_B);
    }
  }
  if (nearest > radius) return true;
  if (why != nullptr) {
    *why = "obstacle behind at (" + Fixed(nearest_W.x(), 2) + ", " + Fixed(nearest_W.y(), 2) + "), " +
           Fixed(nearest, 2) + " m from the way back";
  }
  return false;
}

void Navigation::SetObstacles(const std::vector<Eigen::Vector3f>& points_B, const core::BaseState& state,
                              double now_s) {
  obstacles_.points_B = points_B;
  if (obstacles_.peer_options.avoid && !obstacles_.peers.empty()) {
    const auto& band = local_planner_.library().options();
    AppendPeerObstacles(obstacles_.peers, state, options_.sensor_range_m,
                        0.5 * (band.obstacle_min_z_m + band.obstacle_max_z_m), obstacles_.peer_options,
                        &obstacles_.points_B);
  }
  obstacles_.awaiting = false;
  // Kept in frame B of `state`; RunLocalPlanner re-expresses them if the robot moved since.
  obstacles_.pose = state;
  obstacles_.time_s = now_s;
}

void Navigation::SetPeers(std::vector<PeerBody> peers, const PeerAvoidanceOptions& options) {
  obstacles_.peers = std::move(peers);
  obstacles_.peer_options = options;
}

PeerBody Navigation::AsPeer(const std::string& robot_id, const core::BaseState& pose_M) const {
  PeerBody self;
  self.robot_id = robot_id;
  self.pose_M = pose_M;
  self.footprint_radius_m = options_.platform.footprint_radius_m;
  if (has_goal()) {
    self.path_ahead_M =
        PathAhead(plan_.result.path_W, {pose_M.x_m, pose_M.y_m}, kPeerPathSpacingM, kPeerPathPoints);
  }
  return self;
}

namespace {

bool ObstacleInputFresh(double age_s, bool never, double limit_s, std::string* why) {
  if (!never && age_s <= limit_s) return true;
  if (why != nullptr) {
    *why = never ? "no obstacle input yet"
                 : "obstacle input is " + Fixed(age_s, 2) + " s old (limit " + Fixed(limit_s, 2) + " s)";
  }
  return false;
}

}  // namespace

bool Navigation::LocalPlannerHealthy(double now_s, std::string* why) const {
  return ObstacleInputFresh(now_s - obstacles_.time_s, obstacles_.time_s < -1e8, options_.obstacle_timeout_s,
                            why);
}

bool Navigation::ObstacleSensingAlive(double now_s, std::string* why) const {
  return ObstacleInputFresh(now_s - obstacles_.time_s, obstacles_.time_s < -1e8, options_.obstacle_lost_s,
                            why);
}

NavigationStep Navigation::Fail(const std::string& reason) {
  NavigationStep step;
  step.failed = true;
  step.reason = reason;
  ClearGoal();
  return step;
}

double Navigation::UpdateProgress(const Eigen::Vector2d& p_W) {
  const auto& path = plan_.result.path_W;
  if (path.size() < 2) {
    progress_.distance_left_m = goal_ ? (goal_->p_W - p_W).norm() : 0.0;
    return progress_.distance_left_m;
  }
  // Project on the segments from the current one on (a short window ahead), keep the nearest.
  double best_d = 1e18, best_along = progress_.projection_along_m,
         best_seg_start = progress_.segment_start_along_m;
  std::size_t best_seg = progress_.segment;
  double along = progress_.segment_start_along_m;
  // Window: the current and next segment, and on up to 10 m beyond the current projection.
  for (std::size_t i = progress_.segment;
       i + 1 < path.size() && (i <= progress_.segment + 1 || along - progress_.projection_along_m < 10.0);
       ++i) {
    const Eigen::Vector2d a = path[i].head<2>(), b = path[i + 1].head<2>();
    const double len = (b - a).norm();
    const double t = len > 1e-9 ? std::clamp((p_W - a).dot(b - a) / (len * len), 0.0, 1.0) : 0.0;
    const double d = (a + t * (b - a) - p_W).norm();
    if (d < best_d - 1e-9) {
      best_d = d;
      best_seg = i;
      best_seg_start = along;
      best_along = along + t * len;
    }
    along += len;
  }
  progress_.segment = best_seg;
  progress_.segment_start_along_m = best_seg_start;
  progress_.projection_along_m = best_along;
  progress_.distance_left_m = std::max(0.0, plan_.result.length_m - best_along) + best_d;
  return best_d;
}

Eigen::Vector2d Navigation::PointAhead(double ahead_m) const {
  const auto& path = plan_.result.path_W;
  if (path.size() < 2) return goal_ ? goal_->p_W : Eigen::Vector2d::Zero();
  const double target = progress_.projection_along_m + ahead_m;
  double along = progress_.segment_start_along_m;
  for (std::size_t i = progress_.segment; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d a = path[i].head<2>(), b = path[i + 1].head<2>();
    const double len = (b - a).norm();
    if (along + len >= target && len > 1e-9) return a + (b - a) * ((target - along) / len);
    along += len;
  }
  return path.back().head<2>();
}

Eigen::Vector2d Navigation::Carrot(const core::BaseState& state) const {
  constexpr double kMinCarrotM = 0.5;   // never nearer: the local planner needs a direction
  constexpr double kCarrotStepM = 0.1;  // along the path
  Eigen::Vector2d full = PointAhead(options_.carrot_distance_m);
  if (obstacles_.points_B.empty()) return full;
  // Segment from the robot to a path point, in the frame the obstacles are kept in.
  const Eigen::Vector2d robot_O = ToBody(obstacles_.pose, Eigen::Vector2d(state.x_m, state.y_m));
  const double radius = options_.platform.footprint_radius_m;
  auto in_sight = [&](const Eigen::Vector2d& p_W) {
    const Eigen::Vector2d end_O = ToBody(obstacles_.pose, p_W);
    const Eigen::Vector2d d = end_O - robot_O;
    const double len2 = d.squaredNorm();
    for (const Eigen::Vector3f& o : obstacles_.points_B) {
      if (!IsObstacle(o)) continue;
      const Eigen::Vector2d q = o.head<2>().cast<double>();
      const double t = len2 > 1e-12 ? std::clamp((q - robot_O).dot(d) / len2, 0.0, 1.0) : 0.0;
      const double to_segment = (robot_O + t * d - q).norm();
      // Not nearer than the footprint, nor than the robot is now to a point it already stands that near.
      if (to_segment < std::min(radius, (q - robot_O).norm() - 1e-3)) return false;
    }
    return true;
  };
  Eigen::Vector2d carrot = PointAhead(std::min(kMinCarrotM, options_.carrot_distance_m));
  for (double ahead = kMinCarrotM + kCarrotStepM; ahead <= options_.carrot_distance_m + 1e-9;
       ahead += kCarrotStepM) {
    const Eigen::Vector2d p = PointAhead(ahead);
    if (!in_sight(p)) break;
    carrot = p;
  }
  return carrot;
}

void Navigation::AdoptPlan(const GlobalPlan& plan, double now_s) {
  plan_ = plan;
  progress_.segment = 0;
  progress_.segment_start_along_m = 0.0;
  progress_.projection_along_m = 0.0;
  goal_->best_distance_m = plan.result.length_m;  // a detour is not a lack of progress
  goal_->best_time_s = now_s;
  ++replan_.count;
  ++unmapped_.replans;
  ++replan_.path_revision;
}

void Navigation::RunLocalPlanner(const core::BaseState& state, const LocalPlanRequest& request, double now_s,
                                 const std::optional<Eigen::Vector2d>& goal_W) {
  if (now_s - local_.last_time_s < options_.local_planner_period_s - 1e-9) return;
  local_.last_time_s = now_s;
  ReexpressObstacles(state);
  local_.pose = state;
  LocalPlanRequest r = request;
  r.previous_path_id = local_.result.IsUsable() ? local_.result.path_id : -1;
  local_planner_.Plan(obstacles_.points_B, r, &local_.result);
  const bool aligned = r.mode != LocalPlanMode::kGoal || PlanTowardCarrot(r);
  local_.track_W.clear();
  creeping_ = false;
  if (r.mode == LocalPlanMode::kGoal && follow_path_ &&
      TrackGlobalPathIfClear(state, kFollowTrackM, kFollowMarginM, /*tight=*/false)) {
    return;
  }
  // Beyond the bare footprint radius (the platform radius is the body); none with reduced clearance.
  if (r.mode == LocalPlanMode::kGoal && !aligned &&
      TrackGlobalPathIfClear(state, 1.0, reduced_clearance_ ? 0.0 : 0.01, /*tight=*/true)) {
    return;
  }
  if (!local_.result.IsUsable()) {
    local_.status = local_.result.status == LocalPlanResult::Status::kBoxedIn
                        ? local_.result.message
                        : "invalid input: " + local_.result.message;
    return;
  }
  local_.status = "path";
  for (const auto& p : local_.result.path_B)
    local_.track_W.push_back(ToWorld(state, p.head<2>().cast<double>()));
  const double full = local_planner_.library().options().path_length_m;
  local_.track_stop_at_end = local_.result.free_length_m < full - 1e-6;
  if (goal_W) SnapTrackToGoal(*goal_W);
  if (local_.track_W.size() < 2) local_.track_W.clear();
}

// Re-expresses the latest obstacles in the current body frame (in place).
void Navigation::ReexpressObstacles(const core::BaseState& state) {
  const bool moved = std::abs(obstacles_.pose.x_m - state.x_m) > 1e-9 ||
                     std::abs(obstacles_.pose.y_m - state.y_m) > 1e-9 ||
                     std::abs(obstacles_.pose.yaw_rad - state.yaw_rad) > 1e-9;
  if (!moved) return;
  for (auto& p : obstacles_.points_B) {
    const Eigen::Vector2d q = ToBody(state, ToWorld(obstacles_.pose, p.head<2>().cast<double>()));
    p.x() = static_cast<float>(q.x());
    p.y() = static_cast<float>(q.y());
  }
  obstacles_.pose = state;
}

bool Navigation::PlanTowardCarrot(const LocalPlanRequest& r) {
  // Tight spot: the paths free for the full length all turn away from the carrot. Shorter required lengths
  // let the robot creep through a gap whose far side the library's arcs cannot all clear.
  const double target = std::atan2(r.goal_B.y(), r.goal_B.x());
  auto deviation = [&](const LocalPlanResult& result) {
    if (!result.IsUsable() || result.path_B.size() < 2) return kPi + 1.0;
    const Eigen::Vector3f& end = result.path_B.back();
    return std::abs(std::remainder(std::atan2(end.y(), end.x()) - target, 2 * kPi));
  };
  double best = deviation(local_.result);
  double length = std::min(r.max_required_free_length_m, options_.required_free_length_m);
  while (best > options_.tight_spot_deviation_rad && length > options_.tight_free_length_m + 1e-9) {
    length = std::max(options_.tight_free_length_m, 0.5 * length);
    LocalPlanRequest shorter = r;
    shorter.max_required_free_length_m = length;
    LocalPlanResult result;
    local_planner_.Plan(obstacles_.points_B, shorter, &result);
    const double d = deviation(result);
    if (d < best) {
      best = d;
      local_.result = std::move(result);
    }
  }
  return best <= options_.tight_spot_deviation_rad;
}

void Navigation::SnapTrackToGoal(const Eigen::Vector2d& goal_W) {
  // The goal lies within reach of this path: follow it to its sample nearest the goal, then to the goal.
  std::size_t nearest = 0;
  double nearest_d = 1e18;
  for (std::size_t i = 0; i < local_.track_W.size(); ++i) {
    const double d = (local_.track_W[i] - goal_W).norm();
    if (d < nearest_d) {
      nearest_d = d;
      nearest = i;
    }
  }
  // Only when the goal is next to the free part of this path and no farther along the global path than that
  // free part: a short hop from a checked sample to a goal the global planner found traversable.
  if (nearest_d <= kGoalSnapM && progress_.distance_left_m <= local_.result.free_length_m + kGoalSnapM) {
    local_.track_W.resize(nearest + 1);
    if (nearest_d > 1e-3) local_.track_W.push_back(goal_W);
    local_.track_stop_at_end = true;
  }
}

bool Navigation::TrackGlobalPathIfClear(const core::BaseState& state, double track_m, double margin_m,
                                        bool tight) {
  constexpr double kTightSpacingM = 0.05;  // sample spacing of the check
  if (!goal_ || plan_.result.path_W.size() < 2) return false;
  const double radius = options_.platform.footprint_radius_m + margin_m;
  std::vector<Eigen::Vector2d> track{Eigen::Vector2d(state.x_m, state.y_m)};
  for (double ahead = kTightSpacingM; ahead <= track_m + 1e-9; ahead += kTightSpacingM) {
    const Eigen::Vector2d p = PointAhead(ahead);
    if ((p - track.back()).norm() > 1e-6) track.push_back(p);
  }
  if (track.size() < 2) return false;
  double clearance = 1e18;
  for (const Eigen::Vector2d& p_W : track) {
    const Eigen::Vector2d p_B = ToBody(state, p_W);
    for (const Eigen::Vector3f& o : obstacles_.points_B) {
      if (!IsObstacle(o)) continue;
      clearance = std::min(clearance, (o.head<2>().cast<double>() - p_B).norm());
    }
    if (clearance <= radius) return false;
  }
  local_.track_W = std::move(track);
  if (!tight) {
    // Stops at its end only where the path ends there.
    local_.track_stop_at_end = progress_.distance_left_m <= track_m + 1e-6;
    local_.status = "path";
    return true;
  }
  local_.track_stop_at_end = true;
  creeping_ = true;
  local_.status =
      "tight spot: following the global path, " + Fixed(clearance, 2) + " m from the nearest obstacle";
  return true;
}

NavigationStep Navigation::Control(const core::BaseState& state, double cruise_mps, double now_s) {
  IlqrState x0;
  x0 << state.x_m, state.y_m, state.yaw_rad, state.v_mps, state.w_radps;
  const double elapsed =
      control_.last_solve_time_s < 0 ? 0.0 : std::max(0.0, now_s - control_.last_solve_time_s);
  control_.last_solve_time_s = now_s;
  control_.solution = controller_.Solve(x0, local_.track_W, cruise_mps, local_.track_stop_at_end, elapsed);
  NavigationStep step;
  if (control_.solution.IsUsable()) {
    step.linear_x_mps = control_.solution.command_v_mps;
    step.angular_z_radps = control_.solution.command_w_radps;
  }
  return step;
}

NavigationStep Navigation::StepWaypoint(const core::BaseState& state, double now_s, double speed_mps,
                                        bool follow_path) {
  follow_path_ = follow_path;
  const double cruise_mps = std::isfinite(speed_mps) && speed_mps > 0
                                ? std::min(speed_mps, options_.platform.limits.max_speed_mps)
                                : options_.platform.cruise_speed_mps;
  if (!goal_) return {};
  if (!hold_.reason.empty()) return StepHeld(now_s);
  if (goal_->held_since_s >= 0.0) {  // a hold ended: its time counts until the robot makes progress
    goal_->held_s += now_s - goal_->held_since_s;
    goal_->held_since_s = -1.0;
  }
  const Eigen::Vector2d p_W(state.x_m, state.y_m);
  const double to_goal = (goal_->p_W - p_W).norm();
  // Arrived: within the tolerance and (nearly) at rest, so the robot stops where it reports arriving; on the
  // level of the plan's end when the goal names one (an upper floor lies over the same x-y).
  // A partial plan's end is not the goal.
  const bool on_goal_level =
      !plan_.result.partial && (!std::isfinite(goal_->z_m) || plan_.result.path_W.empty() ||
                                std::abs(state.z_m - plan_.result.path_W.back().z()) <= kArrivalLevelM);
  if (to_goal <= goal_->tolerance_m && on_goal_level && std::abs(state.v_mps) <= kArrivalSpeedMps) {
    NavigationStep step;
    step.arrived = true;
    unmapped_.active = false;
    ClearGoal();
    return step;
  }
  if (auto failed = TakeReplan(now_s)) return *failed;
  RequestReplans(state, now_s);
  if (auto failed = CheckProgress(state, now_s)) return *failed;
  return DriveToCarrot(state, to_goal, cruise_mps, now_s);
}

// Replans run on a worker while the robot follows the current path (the local planner keeps it off what the
// lidar sees): the control loop never waits for a search, which takes up to ~1 s over the map's levels on a
// mostly unknown map. A partial plan (the map connects no route to the goal's level yet) is also extended as
// the map grows and at its end, and fails when the map shows no way on from there.
std::optional<NavigationStep> Navigation::TakeReplan(double now_s) {
  if (!PlanReady(replan_.extension)) return std::nullopt;
  const GlobalPlan extended = replan_.extension.get();
  const Eigen::Vector3d end =
      plan_.result.path_W.empty() ? Eigen::Vector3d::Zero() : plan_.result.path_W.back();
  const bool was_partial = plan_.result.partial;
  const double before = PartialRemaining(plan_);
  // On a partial plan, "no route" (nothing nearer the goal than where the robot stands) is the same as no
  // progress, and a goal that looks blocked lies on a part of the map seen from afar (grazing rays, a few
  // voxels): the robot goes on along its plan, sees more, and fails only after a few map updates of that.
  const auto status = extended.result.status;
  const bool map_may_tell =
      was_partial && extended.platform_known &&
      (status == PlanResult::Status::kUnreachable || status == PlanResult::Status::kGoalBlocked);
  if (!extended.IsUsable() && !map_may_tell) {
    return Fail(replan_.extension_cause + " and no new path exists: " + extended.reason);
  }
  if (extended.IsUsable()) AdoptPlan(extended, now_s);
  const bool no_way_on =
      was_partial && (!extended.IsUsable() || (replan_.extension_at_end && extended.result.partial &&
                                               PartialRemaining(extended) > before - 0.3));
  if (!no_way_on) replan_.partial_stuck_since_s = -1.0;
  if (no_way_on && replan_.partial_stuck_since_s < 0.0) replan_.partial_stuck_since_s = now_s;
  // At the end of what the map shows, the robot waits a few map updates (it sees further from there).
  if (no_way_on && now_s - replan_.partial_stuck_since_s >= kPartialWaitS) {
    return Fail("no known route to the goal's level: the map shows no way on from (" + Fixed(end.x(), 2) +
                ", " + Fixed(end.y(), 2) + ") at z " + Fixed(end.z(), 2) + " (" +
                (extended.IsUsable() ? extended.result.message : extended.reason) + ")");
  }
  return std::nullopt;
}

// A partial plan is extended at its end and as the map grows; a whole one is planned again when the map
// changed under the path or the robot is far off it. Also updates the progress along the path.
void Navigation::RequestReplans(const core::BaseState& state, double now_s) {
  const Eigen::Vector2d p_W(state.x_m, state.y_m);
  if (plan_.result.partial && !plan_.result.path_W.empty()) {
    const bool at_end =
        (plan_.result.path_W.back().head<2>() - p_W).norm() <= std::max(goal_->tolerance_m, 0.3);
    if ((at_end && now_s - replan_.last_partial_s >= 1.0) ||
        (planner_->map_version() != plan_.map_version && now_s - replan_.last_partial_s >= 4.0)) {
      ReplanOnWorker(state, now_s, at_end, "the partial plan was extended");
    }
  }
  const double off_path = UpdateProgress(p_W);
  if (now_s - replan_.last_check_s < options_.replan_check_period_s) return;
  replan_.last_check_s = now_s;
  const bool map_changed = planner_->map_version() != plan_.map_version;
  if (map_changed &&
      !planner_->CheckPath(plan_.result.path_W, options_.platform.name, static_cast<int>(progress_.segment))
           .valid) {
    ReplanOnWorker(state, now_s, false, "the map changed under the path");
  } else if (map_changed) {
    plan_.map_version = planner_->map_version();  // still valid on the new map
  } else if (off_path > options_.max_path_deviation_m) {
    ReplanOnWorker(state, now_s, false, "the robot was " + Fixed(off_path, 1) + " m off the path");
  }
}

void Navigation::ReplanOnWorker(const core::BaseState& state, double now_s, bool at_end, std::string cause) {
  if (replan_.extension.valid()) return;  // one at a time; the next check asks again if still needed
  if (now_s - replan_.last_worker_s < kMinReplanIntervalS) return;
  replan_.last_worker_s = now_s;
  if (plan_.result.partial) replan_.last_partial_s = now_s;
  replan_.extension_at_end = at_end;
  replan_.extension_cause = std::move(cause);
  GlobalPlanRequest request = GoalRequest(state, goal_->p_W.x(), goal_->p_W.y(), goal_->z_m);
  request.diagnose = at_end;  // naming a step matters when the robot can go no further
  replan_.extension = PlanOnWorker(std::move(request));
}

// Progress bookkeeping: ETA from a slow mean of the speed; the goal fails when the robot stalls (moves less
// than 0.5 m for stall_timeout_s, whatever the plans did: Nav2's progress checker), makes no progress in
// unmapped space within its bounds, or gets no nearer the goal for blocked_timeout_s.
std::optional<NavigationStep> Navigation::CheckProgress(const core::BaseState& state, double now_s) {
  const Eigen::Vector2d p_W(state.x_m, state.y_m);
  progress_.mean_speed_mps += 0.02 * (std::abs(state.v_mps) - progress_.mean_speed_mps);
  progress_.eta_s = progress_.distance_left_m /
                    std::max(progress_.mean_speed_mps, 0.2 * options_.platform.cruise_speed_mps);
  const std::string local_planner_note =
      local_.status != "path" && !local_.status.empty() ? "; local planner " + local_.status : "";
  constexpr double kStallRadiusM = 0.5;
  if (!goal_->anchor_W.allFinite() || (p_W - goal_->anchor_W).norm() >= kStallRadiusM) {
    goal_->anchor_W = p_W;
    goal_->anchor_time_s = now_s;
  } else if (now_s - goal_->anchor_time_s > goal_->stall_timeout_s) {
    NavigationStep stalled =
        Fail("stalled: moved less than " + Fixed(kStallRadiusM, 1) + " m in " +
             Fixed(goal_->stall_timeout_s, 0) + " s (" + Fixed(progress_.distance_left_m, 1) + " m left, " +
             std::to_string(replan_.count) + " plans" + local_planner_note + ")");
    stalled.stalled = true;
    return stalled;
  }
  if (auto abandoned = CheckUnmappedProgress(now_s)) return abandoned;
  if (progress_.distance_left_m < goal_->best_distance_m - 0.05) {
    goal_->best_distance_m = progress_.distance_left_m;
    goal_->best_time_s = now_s;
    goal_->held_s = 0.0;
  } else if (now_s - goal_->best_time_s > options_.blocked_timeout_s) {
    return Fail("blocked: no progress for " + Fixed(options_.blocked_timeout_s, 1) + " s (" +
                Fixed(progress_.distance_left_m, 1) + " m left" + local_planner_note + ")");
  }
  return std::nullopt;
}

// The local planner toward the carrot (the goal itself when near), then iLQR on its track; or a turn in place
// toward the path when no library path can start that way.
NavigationStep Navigation::DriveToCarrot(const core::BaseState& state, double to_goal, double cruise_mps,
                                         double now_s) {
  const Eigen::Vector2d carrot = Carrot(state);
  progress_.carrot_W = carrot;
  LocalPlanRequest request;
  request.mode = LocalPlanMode::kGoal;
  request.goal_B = ToBody(state, carrot);
  request.max_required_free_length_m = options_.required_free_length_m;
  if (request.goal_B.norm() < 1e-3) request.goal_B = ToBody(state, goal_->p_W);
  const bool goal_near = to_goal <= local_planner_.library().options().path_length_m;
  if (!LocalPlannerHealthy(now_s, nullptr) || obstacles_.awaiting) {
    local_.track_W.clear();
    local_.status = obstacles_.awaiting ? "stopped: obstacle memory cleared, waiting for a fresh scan"
                                        : "stopped: no fresh obstacle input";
    return Control(state, cruise_mps, now_s);
  }
  RunLocalPlanner(state, request, now_s,
                  goal_near ? std::optional<Eigen::Vector2d>(goal_->p_W) : std::nullopt);
  if (auto turn = TurnInPlace(state, request.goal_B)) return *turn;
  return Control(state, (creeping_ ? 0.5 : 1.0) * cruise_mps, now_s);
}

// Turn in place toward the path when no library path can start that way (a forward-looking platform with the
// path behind it, e.g. at a dead end), or when boxed in with the path well to the side. A disk footprint
// cannot collide by turning. Rotation shim (as Nav2's RotationShimController): once turning in place, keep
// turning until the carrot is within kAlignedRad of the heading, so that a robot turning round in a corridor
// does not hand over to the local planner half-way and swing back (a limit cycle seen on geb079).
std::optional<NavigationStep> Navigation::TurnInPlace(const core::BaseState& state,
                                                      const Eigen::Vector2d& carrot_B) {
  const double bearing = std::atan2(carrot_B.y(), carrot_B.x());
  const bool behind = std::abs(bearing) > options_.platform.local_heading_range_rad * 0.9;
  const bool boxed_in = local_.result.status == LocalPlanResult::Status::kBoxedIn;
  constexpr double kAlignedRad = 20.0 * kPi / 180.0;
  if (control_.turning_in_place && std::abs(bearing) < kAlignedRad) control_.turning_in_place = false;
  if (behind || (boxed_in && std::abs(bearing) > kPi / 4)) control_.turning_in_place = true;
  if (!control_.turning_in_place) return std::nullopt;
  local_.track_W.clear();
  controller_.Reset();
  local_.status = std::string("turning in place toward the path") + (boxed_in ? " (boxed in ahead)" : "");
  NavigationStep turn;
  if (std::abs(state.v_mps) <= 0.05) {  // brake first, then turn
    const double max_w = options_.platform.limits.max_yaw_rate_radps;
    turn.angular_z_radps = std::clamp(1.5 * bearing, -max_w, max_w);
  }
  return turn;
}

NavigationStep Navigation::StepHeld(double now_s) {
  // Held (a peer getting out of the way): at rest, and the time counts neither as a lack of progress nor as a
  // stall, up to max_hold_s since the last progress.
  if (goal_->held_since_s < 0.0) goal_->held_since_s = now_s;
  const double held_s = goal_->held_s + now_s - goal_->held_since_s;
  if (held_s > options_.max_hold_s) {
    const std::string by = hold_.by.empty() ? "blocked" : "blocked by " + hold_.by;
    NavigationStep step =
        Fail(by + ": held " + Fixed(held_s, 0) + " s without progress (navigation.max_hold_s " +
             Fixed(options_.max_hold_s, 0) + " s): " + hold_.reason);
    step.abandoned = true;
    return step;
  }
  goal_->anchor_time_s = now_s;
  goal_->best_time_s = now_s;
  unmapped_.best_time_s = now_s;  // waiting for a peer is no lack of progress toward an unmapped goal either
  unmapped_.last_s = now_s;
  local_.track_W.clear();
  local_.status = "held: " + hold_.reason;
  return {};
}

std::optional<NavigationStep> Navigation::CheckUnmappedProgress(double now_s) {
  if (!unmapped_.active) return std::nullopt;
  unmapped_.last_s = now_s;
  const double left_m = progress_.distance_left_m + (plan_.result.partial ? PartialRemaining(plan_) : 0.0);
  if (left_m < unmapped_.best_left_m - kUnmappedProgressM) {
    unmapped_.best_left_m = left_m;
    unmapped_.best_time_s = now_s;
    unmapped_.replans = 0;
    return std::nullopt;
  }
  const int replans = unmapped_.replans;
  const double waited_s = now_s - unmapped_.best_time_s;
  if (replans < options_.unmapped_goal_max_replans && waited_s <= options_.unmapped_goal_timeout_s) {
    return std::nullopt;
  }
  const std::string bound = replans >= options_.unmapped_goal_max_replans
                                ? std::to_string(replans) +
                                      " replans (navigation.unmapped_goal_max_replans " +
                                      std::to_string(options_.unmapped_goal_max_replans) + ")"
                                : Fixed(waited_s, 0) + " s (navigation.unmapped_goal_timeout_s " +
                                      Fixed(options_.unmapped_goal_timeout_s, 0) + " s)";
  NavigationStep step =
      Fail("goal in unmapped space abandoned: no progress toward (" + Fixed(goal_->p_W.x(), 2) + ", " +
           Fixed(goal_->p_W.y(), 2) + ") in " + bound + "; at least " + Fixed(left_m, 1) + " m left, " +
           Fixed(unmapped_.best_left_m, 1) + " m at best: the map shows no way there yet");
  step.abandoned = true;
  unmapped_.active = false;
  return step;
}

NavigationStep Navigation::StepJoystick(const core::BaseState& state, double vx_mps, double vy_mps,
                                        double wz_radps, double now_s) {
  NavigationStep stop;
  if (!std::isfinite(vx_mps) || !std::isfinite(vy_mps) || !std::isfinite(wz_radps)) {
    local_.track_W.clear();
    local_.status = "stopped: joystick twist not finite";
    return Control(state, 0.0, now_s);
  }
  const double speed = std::min(std::hypot(vx_mps, vy_mps), options_.platform.limits.max_speed_mps);
  if (speed < 0.05) {
    // Turn in place (or stop): a disk footprint cannot collide by turning.
    local_.track_W.clear();
    controller_.Reset();
    local_.status = "";
    stop.angular_z_radps = std::clamp(wz_radps, -options_.platform.limits.max_yaw_rate_radps,
                                      options_.platform.limits.max_yaw_rate_radps);
    if (std::abs(state.v_mps) > 0.05) stop.angular_z_radps = 0.0;  // brake first
    return stop;
  }
  if (!LocalPlannerHealthy(now_s, nullptr)) {
    local_.track_W.clear();
    local_.status = "stopped: no fresh obstacle input";
    return Control(state, 0.0, now_s);
  }
  const double bend = std::clamp(wz_radps * options_.joystick_turn_lookahead_s, -kPi / 2, kPi / 2);
  const double direction = std::remainder(std::atan2(vy_mps, vx_mps) + bend, 2 * kPi);
  if (std::abs(direction) > options_.platform.local_heading_range_rad) {
    // E.g. stick pulled back on a forward-looking platform: brake rather than swerve sideways.
    local_.track_W.clear();
    local_.status = "stopped: joystick direction " + Fixed(direction * 180 / kPi, 0) +
                    " deg is outside the platform's local planner headings";
    return Control(state, 0.0, now_s);
  }
  LocalPlanRequest request;
  request.mode = LocalPlanMode::kJoystick;
  request.goal_B = Eigen::Vector2d(std::cos(direction), std::sin(direction));
  request.max_required_free_length_m = options_.required_free_length_m;
  RunLocalPlanner(state, request, now_s, std::nullopt);
  return Control(state, speed, now_s);
}

GlobalPlan PlanAlong(const std::vector<Eigen::Vector3d>& path_M, std::uint64_t map_version,
                     const std::string& what) {
  GlobalPlan plan;
  plan.result.status = PlanResult::Status::kSuccess;
  plan.result.path_W = path_M;
  for (std::size_t i = 0; i + 1 < path_M.size(); ++i)
    plan.result.length_m += (path_M[i + 1] - path_M[i]).head<2>().norm();
  plan.result.message = what;
  plan.map_version = map_version;
  return plan;
}

}  // namespace cairn::nav
