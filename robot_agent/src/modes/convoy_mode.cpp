#include "cairn/agent/modes/convoy_mode.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <stdexcept>

#include "cairn/core/peer_input.h"
#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::agent {

const char* ToString(ConvoyStatus::State state) {
  switch (state) {
    case ConvoyStatus::State::kNone:
      return fleet::convoy_state::kNone;
    case ConvoyStatus::State::kFollowing:
      return fleet::convoy_state::kFollowing;
    case ConvoyStatus::State::kHolding:
      return fleet::convoy_state::kHolding;
    case ConvoyStatus::State::kLost:
      return fleet::convoy_state::kLost;
    case ConvoyStatus::State::kBlocked:
      return fleet::convoy_state::kBlocked;
    case ConvoyStatus::State::kPaused:
      return fleet::convoy_state::kPaused;
  }
  return fleet::convoy_state::kNone;
}

namespace {

nav::Navigation* Required(nav::Navigation* navigation) {
  if (navigation == nullptr) throw std::invalid_argument("ConvoyMode: navigation is null");
  return navigation;
}

// A follower re-tries a blocked way once its target moved this far from where navigation gave up, metres.
constexpr double kBlockedRetryM = 1.0;

}  // namespace

ConvoyMode::ConvoyMode(const ConvoyOptions& options, double channel_timeout_s, nav::Navigation* navigation)
    : ModeModule(kName, MuxChannelOptions{kChannel, channel_timeout_s}),
      options_(options),
      navigation_(Required(navigation)),
      trail_(options) {}

std::string ConvoyMode::Start(const std::string& own_id, const std::vector<std::string>& ahead_ids,
                              double now_s) {
  if (ahead_ids.empty()) return "a convoy follower needs the robot ahead of it";
  std::set<std::string> seen;
  for (const std::string& id : ahead_ids) {
    if (std::string why = core::CheckId("robot id", id); !why.empty()) return why;
    if (id == own_id) return "robot " + own_id + " cannot follow itself";
    if (!seen.insert(id).second) return "robot " + id + " is named twice ahead of " + own_id;
  }
  // A re-link to a robot already ahead (the one followed peeled off): it drove the same trail, which is kept.
  const bool same_trail = active() && std::find(status_.ahead_ids.begin(), status_.ahead_ids.end(),
                                                ahead_ids.front()) != status_.ahead_ids.end();
  DropGoal();
  if (!same_trail) trail_ = ConvoyTrail(options_);
  skipped_ = 0;  // the operator's order: every robot ahead is named
  trail_.Relinked(now_s);
  const std::string before = status_.ahead_id;
  status_ = ConvoyStatus{};
  status_.state = ConvoyStatus::State::kHolding;
  status_.ahead_ids = ahead_ids;
  status_.ahead_id = ahead_ids.front();
  status_.gap_m = std::numeric_limits<double>::quiet_NaN();
  status_.reason = same_trail && before != status_.ahead_id
                       ? "re-linked to " + status_.ahead_id + " (was " + before + ")"
                       : "waiting to hear " + status_.ahead_id;
  return "";
}

void ConvoyMode::SetPeers(const std::vector<Peer>& peers, double now_s) {
  if (!active()) return;
  auto heard = [&](const std::string& id) -> const Peer* {
    auto it = std::find_if(peers.begin(), peers.end(), [&](const Peer& p) { return p.robot_id == id; });
    return it == peers.end() ? nullptr : &*it;
  };
  const Peer* ahead = heard(status_.ahead_id);
  if (ahead == nullptr && status_.state == ConvoyStatus::State::kLost) {
    // The robot followed is lost: the nearest one further ahead that is heard, if any, drove the same trail.
    std::vector<std::string>& ids = status_.ahead_ids;  // ids.front() is the one followed
    for (std::size_t k = 1; k < ids.size(); ++k) {
      if (const Peer* further = heard(ids[k])) {
        skipped_ += static_cast<int>(k);
        status_.reason = "re-linked to " + ids[k] + ": " + status_.ahead_id + " was not heard (keeping " +
                         core::Fixed(options_.spacing_m * (skipped_ + 1), 1) + " m: it may still be in line)";
        ids.erase(ids.begin(), ids.begin() + static_cast<std::ptrdiff_t>(k));
        status_.ahead_id = ids.front();
        status_.state = ConvoyStatus::State::kHolding;
        trail_.Relinked(now_s, skipped_ + 1);
        ahead = further;
        break;
      }
    }
  }
  if (ahead != nullptr) {
    trail_.OnAhead({ahead->pose_M.x_m, ahead->pose_M.y_m, ahead->pose_M.z_m}, now_s, ahead->pose_M.v_mps);
  }
}

void ConvoyMode::Pause(const std::vector<std::string>& ahead_ids, const std::string& why) {
  if (ahead_ids.empty()) return;
  DropGoal();
  status_.state = ConvoyStatus::State::kPaused;
  status_.ahead_ids = ahead_ids;
  status_.ahead_id = ahead_ids.front();
  status_.reason = "paused: " + why;
}

void ConvoyMode::Deactivate(const std::string& why) {
  if (!active()) return;
  DropGoal();
  status_.state = ConvoyStatus::State::kNone;
  status_.reason = why;
}

void ConvoyMode::DropGoal() {
  if (has_goal_) navigation_->ClearGoal(goal_serial_);
  has_goal_ = false;
}

ModeOutput ConvoyMode::Stop(ConvoyStatus::State state, const std::string& reason, const ModeInputs& in) {
  DropGoal();
  status_.state = state;
  status_.reason = reason;
  ModeOutput out;
  out.twist_B = Twist2{0.0, 0.0};  // the channel stays fresh: the robot is held at rest, not left stale
  out.stamp = in.now;
  return out;
}

ModeOutput ConvoyMode::Step(const ModeInputs& in) {
  if (!active()) return {};
  const core::BaseState& s = in.pose_M;
  const ConvoyDecision decision = trail_.Next({s.x_m, s.y_m, s.z_m}, in.now_s);
  status_.gap_m = decision.gap_m;
  switch (decision.kind) {
    case ConvoyDecision::Kind::kHold:
      return Stop(ConvoyStatus::State::kHolding,
                  trail_.heard() ? decision.reason : "waiting to hear " + status_.ahead_id, in);
    case ConvoyDecision::Kind::kLost:
      return Stop(ConvoyStatus::State::kLost, status_.ahead_id + " lost: " + decision.reason, in);
    case ConvoyDecision::Kind::kFollow:
      break;
  }
  const Eigen::Vector2d target = decision.path_M.back().head<2>();
  if (status_.state == ConvoyStatus::State::kBlocked && (target - blocked_at_M_).norm() < kBlockedRetryM) {
    return Stop(ConvoyStatus::State::kBlocked, status_.reason, in);
  }
  if (!has_goal_ || !navigation_->has_goal() || (target - goal_M_).norm() >= kRefreshM) {
    navigation_->AcceptGoal(nav::PlanAlong(decision.path_M, navigation_->global_plan().map_version,
                                           "the trail of the robot ahead"),
                            target.x(), target.y(), 0.0, in.now_s);
    goal_serial_ = navigation_->goal_serial();
    goal_M_ = target;
    has_goal_ = true;
  }
  const nav::NavigationStep step =
      navigation_->StepWaypoint(s, in.now_s, decision.speed_mps, /*follow_path=*/true);
  if (step.failed) {
    blocked_at_M_ = target;
    has_goal_ = false;  // navigation dropped it
    return Stop(ConvoyStatus::State::kBlocked,
                "blocked on the way after " + status_.ahead_id + ": " + step.reason, in);
  }
  if (step.arrived) {
    has_goal_ = false;
    return Stop(ConvoyStatus::State::kHolding,
                core::Fixed(decision.gap_m, 1) + " m behind " + status_.ahead_id + " (at its target)", in);
  }
  status_.state = ConvoyStatus::State::kFollowing;
  status_.reason = "";
  ModeOutput out;
  out.twist_B = Twist2{step.linear_x_mps, step.angular_z_radps};
  out.stamp = in.now;
  return out;
}

}  // namespace cairn::agent
