#include "cairn/agent/modes/explore_mode.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::agent {

namespace {

// A frontier set with less known-free ground than this is no map yet (the first scans are not in), m².
constexpr double kMinKnownFreeM2 = 2.0;

std::string Point(const Eigen::Vector2d& p) {
  return "(" + core::Fixed(p.x(), 2) + ", " + core::Fixed(p.y(), 2) + ")";
}

}  // namespace

std::string CheckExploreTask(const ExploreTask& task) {
  std::ostringstream why;
  if (task.region_M) {
    const Eigen::Vector2d lo = task.region_M->min(), hi = task.region_M->max();
    const std::string region = "region (" + std::to_string(lo.x()) + ", " + std::to_string(lo.y()) + ", " +
                               std::to_string(hi.x()) + ", " + std::to_string(hi.y()) + ")";
    if (!lo.allFinite() || !hi.allFinite()) return region + " must be finite, metres";
    if (!(lo.x() < hi.x()) || !(lo.y() < hi.y())) return region + ": x0 must be below x1 and y0 below y1";
  }
  if (std::isnan(task.min_z_m) || std::isnan(task.max_z_m) || !(task.min_z_m < task.max_z_m)) {
    why << "z range (" << task.min_z_m << ", " << task.max_z_m
        << ") must be two numbers, the first below the "
        << "second, metres";
  } else if (!(task.home_after_silence_s >= 0 && task.home_after_silence_s <= 86400)) {
    why << "home_after_silence_s = " << task.home_after_silence_s << " must be in [0, 86400] (0 = never)";
  }
  return why.str();
}

const char* ToString(ExplorationState state) {
  switch (state) {
    case ExplorationState::kNone:
      return fleet::explore_state::kNone;
    case ExplorationState::kExploring:
      return fleet::explore_state::kExploring;
    case ExplorationState::kComplete:
      return fleet::explore_state::kComplete;
    case ExplorationState::kFailed:
      return fleet::explore_state::kFailed;
    case ExplorationState::kStopped:
      return fleet::explore_state::kStopped;
  }
  return fleet::explore_state::kNone;
}

bool ExploreModeOptions::IsValid(std::string* why) const {
  std::string msg;
  bool ok = core::InRange("explore.channel_timeout_s", channel_timeout_s, 0, 60, true, &msg) &&
            core::InRange("explore.contact_timeout_s", contact_timeout_s, 0, 3600, true, &msg) &&
            core::InRange("explore.target_tolerance_m", target_tolerance_m, 0, 3, true, &msg) &&
            core::InRange("explore.settle_s", settle_s, 0, 10, false, &msg) &&
            core::InRange("explore.complete_settle_s", complete_settle_s, 0, 30, false, &msg) &&
            core::InRange("explore.map_wait_s", map_wait_s, 0, 600, true, &msg) &&
            core::InRange("explore.tight_gap_stall_s", tight_gap_stall_s, 0, 600, true, &msg) &&
            core::InRange("explore.platform_max_step_m", platform_max_step_m, 0, 10, false, &msg);
  std::string nested;
  if (ok && !(frontiers.IsValid(&nested) && explorer.IsValid(&nested))) {
    msg = "explore: " + nested;  // the config section; the option struct names the field
    ok = false;
  }
  if (ok && !team.IsValid(&msg)) ok = false;  // names the config field itself
  if (ok && first_task_id == 0) {
    msg = "explore.first_task_id = 0 must be >= 1";
    ok = false;
  }
  if (!ok && why != nullptr) *why = msg;
  return ok;
}

namespace {

const ExploreModeOptions& Checked(const ExploreModeOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("ExploreMode: " + why);
  return options;
}

}  // namespace

ExploreMode::ExploreMode(ExploreModeOptions options, nav::Navigation* navigation,
                         std::unique_ptr<WaypointRecovery> recovery)
    : ModeModule(kName, MuxChannelOptions{kChannel, Checked(options).channel_timeout_s}),
      options_(std::move(options)),
      navigation_(navigation),
      recovery_(std::move(recovery)),
      explorer_(options_.explorer),
      next_task_id_(options_.first_task_id) {
  if (navigation_ == nullptr) throw std::invalid_argument("ExploreMode: navigation is null");
}

ExploreMode::~ExploreMode() {
  if (plan_.valid()) navigation_->Abandon(std::move(plan_));
}

std::string ExploreMode::Start(const ExploreTask& task, double now_s,
                               const std::function<ModeDecision()>& enter_mode, uint32_t resume_task_id) {
  if (std::string why = CheckExploreTask(task); !why.empty()) return why;
  const ExplorationStatus previous = status_;
  const bool was_exploring = exploring();
  DropTarget();
  ExplorationStatus s;
  s.task_id = resume_task_id != 0 ? resume_task_id : next_task_id_++;
  s.state = ExplorationState::kExploring;
  s.reason = "waiting for the first frontiers of the map";
  s.task = task;
  s.started_s = now_s;
  status_ = s;
  explorer_ = nav::Explorer(options_.explorer);  // a new task starts with no barred target
  frontiers_.reset();
  settle_until_s_ = now_s;  // only frontiers computed from now on
  complete_pending_ = false;
  last_tight_stall_M_.setConstant(std::numeric_limits<double>::quiet_NaN());
  contact_.Reset();
  const ModeDecision d = enter_mode();
  if (d.accepted) {
    spdlog::info(
        "robot {}: exploration {} started{}", options_.robot_id, s.task_id,
        task.region_M ? " in region " + Point(task.region_M->min()) + "-" + Point(task.region_M->max()) : "");
    return "";
  }
  if (status_.task_id == s.task_id && status_.active()) {
    status_ = previous;  // the refused task never ran; a running one was dropped with its target
    if (was_exploring) Finish(ExplorationState::kStopped, "a new exploration was refused: " + d.reason);
  }
  return d.reason.empty() ? "refused" : d.reason;
}

std::optional<nav::FrontierOptions> ExploreMode::frontier_search() const {
  if (!exploring()) return std::nullopt;
  nav::FrontierOptions o = options_.frontiers;
  o.region_M = status_.task.region_M.value_or(Eigen::AlignedBox2d());
  o.min_z_m = status_.task.min_z_m;
  o.max_z_m = status_.task.max_z_m;
  o.tight_radius_m =
      navigation_->reduced_radius_m();  // a gap the map closes that navigation squeezes through
  return o;
}

void ExploreMode::OnFrontiers(nav::FrontierSet set, double computed_at_s) {
  if (!exploring()) return;
  frontiers_ = std::move(set);
  frontiers_at_s_ = computed_at_s;
}

std::optional<nav::PeerClaim> ExploreMode::OwnClaim(double now_s) const {
  if (!exploring() || !status_.has_target) return std::nullopt;
  return nav::PeerClaim{options_.robot_id, status_.target_M, explorer_.HeldS(now_s)};
}

std::optional<ExploreClaim> DueClaim(const ExploreMode& mode, ExploreTeam& team, double now_s,
                                     const std::function<std::optional<nav::CoverageBitmap>()>& coverage) {
  const std::optional<nav::PeerClaim> own = mode.OwnClaim(now_s);
  const bool active = mode.exploring();
  if (!team.ClaimDue(now_s, active, own.has_value(), own ? own->target_M : Eigen::Vector2d::Zero())) {
    return std::nullopt;
  }
  ExploreClaim claim = team.MakeClaim(mode.status().task_id, active, own, mode.status().target_z_m);
  if (team.CoverageDue(now_s) && coverage) claim.coverage = coverage();
  team.Sent(claim, now_s);
  return claim;
}

bool ExploreMode::planning() const {
  return nav::PlanRunning(plan_) || (recovery_ && recovery_->planning()) || navigation_->replanning();
}

void ExploreMode::DropTarget() {
  if (plan_.valid()) navigation_->Abandon(std::move(plan_));
  plan_ = {};
  if (recovery_) recovery_->Halt();
  if (driving_) navigation_->ClearGoal(goal_serial_);
  navigation_->SetReducedClearance(false);
  driving_ = false;
  target_through_tight_gap_ = false;
  status_.has_target = false;
}

void ExploreMode::Finish(ExplorationState state, const std::string& reason) {
  DropTarget();
  explorer_.ClearTarget();
  status_.state = state;
  status_.reason = reason;
  frontiers_.reset();
  if (state == ExplorationState::kComplete) {
    spdlog::info("robot {}: exploration {} {} ({:.0f} m² explored, {} targets reached, {} given up)",
                 options_.robot_id, status_.task_id, reason, status_.explored_m2, status_.targets_reached,
                 status_.targets_failed);
  } else {
    spdlog::warn("robot {}: exploration {} {}: {}", options_.robot_id, status_.task_id, ToString(state),
                 reason);
  }
}

void ExploreMode::EndPaused(uint32_t task_id, const std::string& reason) {
  if (status_.task_id != task_id || exploring()) return;
  status_.state = ExplorationState::kStopped;
  status_.reason = reason;
  spdlog::warn("robot {}: exploration {} stopped: {}", options_.robot_id, task_id, reason);
}

void ExploreMode::Deactivate(const std::string& why) {
  if (exploring()) Finish(ExplorationState::kStopped, "stopped: " + why);
}

void ExploreMode::EndTarget(bool reached, const std::string& reason, double now_s) {
  const Eigen::Vector2d target = status_.target_M;
  DropTarget();
  if (reached) {
    explorer_.Reached();
    ++status_.targets_reached;
    spdlog::info("robot {}: exploration {} reached the frontier at {}", options_.robot_id, status_.task_id,
                 Point(target));
  } else {
    explorer_.Fail(reason, now_s);
    ++status_.targets_failed;
    spdlog::warn("robot {}: exploration {} gave up the frontier at {}: {}", options_.robot_id,
                 status_.task_id, Point(target), reason);
  }
  settle_until_s_ = now_s + options_.settle_s;
}

void ExploreMode::Choose(const core::BaseState& pose_M, double now_s, ModeOutput* out) {
  const nav::FrontierSet set = std::move(*frontiers_);
  frontiers_.reset();
  status_.frontier_clusters = static_cast<int>(set.clusters.size());
  status_.reachable_frontiers = set.reachable();
  status_.explored_m2 = set.known_free_m2;
  if (!set.robot_on_grid || set.known_free_m2 < kMinKnownFreeM2) {
    if (now_s - status_.started_s > options_.map_wait_s) {
      Finish(ExplorationState::kFailed,
             std::string("no map around the robot after ") + core::Fixed(options_.map_wait_s, 0) + " s (" +
                 (set.robot_on_grid ? core::Fixed(set.known_free_m2, 1) + " m² known free"
                                    : "the robot is on no traversable cell of its map") +
                 ")");
      out->done = true;
    }
    return;
  }
  const nav::ExplorerDecision d =
      explorer_.Decide(set, nav::TeamView{options_.robot_id, now_s, peer_claims_});
  if (d.kind == nav::ExplorerDecision::Kind::kWait) {
    if (status_.has_target || status_.reason != d.reason) {
      spdlog::info("robot {}: exploration {}: {}", options_.robot_id, status_.task_id, d.reason);
    }
    DropTarget();
    complete_pending_ = false;
    status_.reason = d.reason;
    return;
  }
  if (d.kind == nav::ExplorerDecision::Kind::kComplete) {
    if (!complete_pending_) {
      // Confirm it with a set computed once the robot has held still for complete_settle_s: a frontier may be
      // just out of sight, and perception may not have confirmed what the robot sees from here yet.
      DropTarget();
      complete_pending_ = true;
      settle_until_s_ = now_s + options_.complete_settle_s;
      return;
    }
    Finish(ExplorationState::kComplete, d.reason);
    out->done = true;
    return;
  }
  complete_pending_ = false;
  status_.reason = d.reason;
  const bool same = (driving_ || plan_.valid()) && d.kind == nav::ExplorerDecision::Kind::kKeep;
  status_.target_gain_m2 = d.target.gain_m2;
  if (same) return;  // the frontier moved a little as the map grew: the goal stands
  DropTarget();
  status_.has_target = true;
  status_.target_M = d.target.target_M;
  status_.target_z_m = d.target.target_ground_z_m;
  // A target the main level holds, with the robot on it too, is planned there (NaN: the start's level, robust
  // to the holes a robot-built map shows around the robot). Any other names its surface: one only the map's
  // levels hold (a flight of stairs, an upper floor, the pocket under a landing), and any while the robot
  // stands on another floor (NaN would plan to the same x-y on the robot's floor).
  goal_z_m_ = d.target.on_main_level ? std::numeric_limits<double>::quiet_NaN() : d.target.target_ground_z_m;
  // Reached only through a gap the map shows narrower than the footprint's inflation: planned (and driven)
  // with reduced clearance, as the waypoint recovery's last attempt would.
  navigation_->SetReducedClearance(d.target.through_tight_gap);
  target_through_tight_gap_ = d.target.through_tight_gap;
  plan_ = navigation_->PlanGoalAsync(pose_M, d.target.target_M.x(), d.target.target_M.y(), goal_z_m_);
  const std::string where = d.target.viewpoint
                                ? "to " + Point(d.target.target_M) + " to look at the frontier at " +
                                      Point(d.target.centroid_M) + ", not reachable yet,"
                                : "to the frontier at " + Point(d.target.target_M);
  spdlog::info("robot {}: exploration {} {} ({:.0f} m² unknown behind it, {:.1f} m away{}): {}",
               options_.robot_id, status_.task_id, where, d.target.gain_m2, d.target.travel_cost_m,
               d.target.through_tight_gap ? ", through a tight gap" : "", d.reason);
}

ModeOutput ExploreMode::Step(const ModeInputs& in) {
  ModeOutput out;
  if (!exploring()) return out;
  out.twist_B = Twist2{0.0, 0.0};  // holds still unless a target is driven
  out.stamp = in.now;
  // While this mode steps, navigation's goal is its own (its recovery may have planned it again).
  if (driving_) goal_serial_ = navigation_->goal_serial();
  // A peer claimed the same frontier first (both chose it before either heard of the other): leave it now.
  if (std::string by;
      status_.has_target &&
      explorer_.CurrentClaimedByPeer(nav::TeamView{options_.robot_id, in.now_s, peer_claims_}, &by)) {
    const Eigen::Vector2d target = status_.target_M;
    DropTarget();
    explorer_.ClearTarget();
    status_.reason = "the frontier at " + Point(target) + " is " + by + "'s (claimed first)";
    spdlog::info("robot {}: exploration {}: {}", options_.robot_id, status_.task_id, status_.reason);
  }
  if (nav::PlanReady(plan_)) {
    const nav::GlobalPlan plan = plan_.get();
    plan_ = {};
    if (plan.IsUsable()) {
      navigation_->AcceptGoal(plan, status_.target_M.x(), status_.target_M.y(), options_.target_tolerance_m,
                              in.now_s, goal_z_m_,
                              target_through_tight_gap_ ? options_.tight_gap_stall_s : 0.0);
      driving_ = true;
      goal_serial_ = navigation_->goal_serial();
    } else {
      EndTarget(false, "no path: " + plan.reason, in.now_s);
    }
  }
  if (driving_) {
    nav::NavigationStep step;
    if (recovery_ && recovery_->active()) {
      step = recovery_->Step(in.pose_M, in.now_s);
      if (recovery_->active()) status_.reason = "recovering: " + recovery_->Report();
    } else {
      step = navigation_->StepWaypoint(in.pose_M, in.now_s);
      // A stall at a tight gap ends the target at once: the gap may be narrower than the robot. A second one
      // where the last one happened is the robot wedged, not the gap (geb079: one robot gave up 12 targets in
      // a row standing in one place): that one goes to the recovery (back up, turn) like any other failure.
      bool tight_gap_stall = step.failed && step.stalled && target_through_tight_gap_;
      const Eigen::Vector2d p_M(in.pose_M.x_m, in.pose_M.y_m);
      if (tight_gap_stall) {
        const bool wedged = (p_M - last_tight_stall_M_).norm() < kWedgedRadiusM;
        last_tight_stall_M_ = p_M;
        if (wedged) {
          tight_gap_stall = false;
          step.reason = "wedged (a second tight-gap stall here), " + step.reason;
        } else {
          step.reason = "at a tight gap, " + step.reason;
        }
      }
      if (step.failed && !tight_gap_stall && recovery_ && recovery_->enabled()) {
        recovery_->Start(status_.target_M.x(), status_.target_M.y(), options_.target_tolerance_m, step.reason,
                         goal_z_m_);
        status_.reason = "recovering: " + recovery_->Report();
        step = nav::NavigationStep{};  // brake this cycle; the recovery tree runs from the next
      }
    }
    if (step.arrived) {
      EndTarget(true, "", in.now_s);
    } else if (step.failed) {
      EndTarget(false, step.reason, in.now_s);
    } else {
      out.twist_B = Twist2{step.linear_x_mps, step.angular_z_radps};
    }
  }
  if (frontiers_ && frontiers_at_s_ >= settle_until_s_) {
    Choose(in.pose_M, in.now_s, &out);
  } else if (!status_.has_target && !complete_pending_ && !frontiers_ &&
             in.now_s - status_.started_s > options_.map_wait_s && status_.explored_m2 < kMinKnownFreeM2) {
    Finish(ExplorationState::kFailed, "no frontier search result " + core::Fixed(options_.map_wait_s, 0) +
                                          " s after the start (is the navigation map updated?)");
    out.done = true;
  }
  if (out.done) out.twist_B.reset();
  return out;
}

ModeOutput ExploreMode::OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) {
  ModeOutput out;
  if (!exploring()) return out;
  if (const std::string blocked = contact_.Update(status, in, options_.contact_timeout_s); !blocked.empty()) {
    Finish(ExplorationState::kFailed, blocked);
    out.done = true;
  }
  return out;
}

}  // namespace cairn::agent
