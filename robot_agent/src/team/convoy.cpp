#include "cairn/agent/team/convoy.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::agent {

bool ConvoyOptions::IsValid(std::string* why) const {
  std::string msg;
  const bool ok = core::InRange("convoy.spacing_m", spacing_m, 1, 50, false, &msg) &&
                  core::InRange("convoy.hold_band_m", hold_band_m, 0, 5, false, &msg) &&
                  core::InRange("convoy.breadcrumb_step_m", breadcrumb_step_m, 0.05, 2, false, &msg) &&
                  core::InRange("convoy.gap_gain_per_s", gap_gain_per_s, 0.1, 5, false, &msg) &&
                  core::InRange("convoy.lost_after_s", lost_after_s, 0, 60, true, &msg) &&
                  core::InRange("convoy.max_trail_m", max_trail_m, 10, 1000, false, &msg);
  if (!ok && why != nullptr) *why = msg;
  return ok;
}

namespace {

const ConvoyOptions& Checked(const ConvoyOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}

// The point of segment a-b nearest p in x-y (z interpolated).
Eigen::Vector3d NearestOnSegment2D(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                   const Eigen::Vector3d& p) {
  const Eigen::Vector2d ab = (b - a).head<2>();
  const double len2 = ab.squaredNorm();
  const double t = len2 > 0 ? std::clamp((p - a).head<2>().dot(ab) / len2, 0.0, 1.0) : 0.0;
  return a + t * (b - a);
}

double Distance2D(const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).head<2>().norm(); }

// Window of trail searched for the follower's place, metres along it: far enough for a follower that fell
// behind its place by a few steps, short enough that a trail looping back near the follower is not taken.
constexpr double kPlaceSearchM = 6.0;

}  // namespace

ConvoyTrail::ConvoyTrail(const ConvoyOptions& options) : options_(Checked(options)) {}

void ConvoyTrail::OnAhead(const Eigen::Vector3d& p_M, double now_s, double speed_mps) {
  if (!p_M.allFinite() || !std::isfinite(now_s)) return;
  ahead_M_ = p_M;
  ahead_speed_mps_ = std::isfinite(speed_mps) ? std::abs(speed_mps) : 0.0;
  last_heard_s_ = now_s;
  heard_ = true;
  if (trail_M_.empty() || Distance2D(trail_M_.back(), p_M) >= options_.breadcrumb_step_m)
    trail_M_.push_back(p_M);
  // Bound the trail: the oldest breadcrumbs go beyond max_trail_m.
  double length = 0;
  for (std::size_t i = trail_M_.size(); i-- > 1;) {
    length += Distance2D(trail_M_[i], trail_M_[i - 1]);
    if (length > options_.max_trail_m) {
      trail_M_.erase(trail_M_.begin(), trail_M_.begin() + static_cast<std::ptrdiff_t>(i - 1));
      break;
    }
  }
}

ConvoyDecision ConvoyTrail::Next(const Eigen::Vector3d& follower_M, double now_s) {
  ConvoyDecision command;
  if (!heard_ && now_s - last_heard_s_ <= options_.lost_after_s) {
    command.gap_m = std::numeric_limits<double>::quiet_NaN();
    command.reason = "nothing heard from the robot ahead yet";
    return command;
  }
  if (now_s - last_heard_s_ > options_.lost_after_s) {
    command.kind = ConvoyDecision::Kind::kLost;
    command.gap_m = std::numeric_limits<double>::quiet_NaN();
    command.reason = "the robot ahead was not heard for " + core::Fixed(now_s - last_heard_s_, 1) +
                     " s (convoy.lost_after_s = " + core::Fixed(options_.lost_after_s, 1) + ")";
    return command;
  }
  // The follower's place: the nearest point of the first kPlaceSearchM of trail (a single breadcrumb: it).
  std::size_t segment = 0;
  Eigen::Vector3d place = trail_M_.front();
  double best = Distance2D(follower_M, place);
  double along = 0;
  for (std::size_t i = 0; i + 1 < trail_M_.size() && along <= kPlaceSearchM; ++i) {
    const Eigen::Vector3d q = NearestOnSegment2D(trail_M_[i], trail_M_[i + 1], follower_M);
    const double d = Distance2D(follower_M, q);
    if (d < best) {
      best = d;
      segment = i;
      place = q;
    }
    along += Distance2D(trail_M_[i], trail_M_[i + 1]);
  }
  // Passed breadcrumbs go: the trail starts at the follower's segment.
  trail_M_.erase(trail_M_.begin(), trail_M_.begin() + static_cast<std::ptrdiff_t>(segment));

  // The way to the robot ahead: to the place, along the trail, then to where the robot ahead is now.
  std::vector<Eigen::Vector3d> way = {follower_M, place};
  way.insert(way.end(), trail_M_.begin() + 1, trail_M_.end());
  way.push_back(ahead_M_);
  double gap = 0;
  for (std::size_t i = 0; i + 1 < way.size(); ++i) gap += Distance2D(way[i], way[i + 1]);
  command.gap_m = gap;
  const double spacing_m = options_.spacing_m * static_cast<double>(slots_);
  const double error_m = gap - spacing_m;
  const double speed = ahead_speed_mps_ + options_.gap_gain_per_s * error_m;
  if ((ahead_speed_mps_ < kAtRestMps && error_m <= options_.hold_band_m) || speed < kMinSpeedMps) {
    command.reason =
        core::Fixed(gap, 1) + " m behind the robot ahead (spacing " + core::Fixed(spacing_m, 1) + " m)";
    return command;
  }
  // The way ends past the spacing point (speed matching keeps the spacing), never within half of it of the
  // robot ahead.
  command.kind = ConvoyDecision::Kind::kFollow;
  command.speed_mps = speed;
  double left = gap - std::max(spacing_m - kTargetBeyondM, 0.5 * spacing_m);
  command.path_M.push_back(way.front());
  for (std::size_t i = 0; i + 1 < way.size() && left > 0; ++i) {
    const double d = Distance2D(way[i], way[i + 1]);
    if (d < 1e-9) continue;
    if (d >= left) {
      command.path_M.emplace_back(way[i] + (left / d) * (way[i + 1] - way[i]));
      break;
    }
    command.path_M.push_back(way[i + 1]);
    left -= d;
  }
  return command;
}

PathProjection ProjectOntoPath2D(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p) {
  PathProjection best{std::numeric_limits<double>::infinity(), 0.0};
  if (path.empty()) return best;
  best.distance_m = Distance2D(path.front(), p);
  double along = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector3d q = NearestOnSegment2D(path[i], path[i + 1], p);
    if (const double d = Distance2D(q, p); d < best.distance_m) best = {d, along + Distance2D(path[i], q)};
    along += Distance2D(path[i], path[i + 1]);
  }
  return best;
}

double DistanceToPath2D(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p) {
  return ProjectOntoPath2D(path, p).distance_m;
}

}  // namespace cairn::agent
