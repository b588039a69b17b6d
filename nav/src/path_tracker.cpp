// Copyright Cairn authors.
#include "cairn/nav/path_tracker.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace cairn::nav {
namespace {

constexpr double kPi = 3.14159265358979323846;

double Wrap(double a) {
  a = std::fmod(a + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

}  // namespace

bool PathTrackerOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, bool lo_open, double hi) {
    if (std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi) return true;
    msg << "PathTrackerOptions::" << field << " = " << value << " must be finite and in "
        << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    return false;
  };
  const bool ok = range("lookahead_m", lookahead_m, 0.05, false, 5.0) &&
                  range("cruise_speed_mps", cruise_speed_mps, 0.0, true, 5.0) &&
                  range("goal_tolerance_m", goal_tolerance_m, 0.01, false, 2.0) &&
                  range("max_yaw_rate_radps", max_yaw_rate_radps, 0.0, true, 10.0) &&
                  range("slow_down_radius_m", slow_down_radius_m, 0.0, false, 10.0) &&
                  range("rotate_in_place_angle_rad", rotate_in_place_angle_rad, 0.1, false, kPi) &&
                  range("min_speed_mps", min_speed_mps, 0.0, true, cruise_speed_mps) &&
                  range("turn_gain_per_s", turn_gain_per_s, 0.0, true, 20.0);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

PathTracker::PathTracker(const PathTrackerOptions& options) : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
}

void PathTracker::SetPath(const std::vector<Eigen::Vector3d>& path_W) {
  if (path_W.empty()) throw std::invalid_argument("PathTracker::SetPath: the path is empty");
  for (std::size_t i = 0; i < path_W.size(); ++i) {
    if (!path_W[i].head<2>().allFinite()) {
      throw std::invalid_argument("PathTracker::SetPath: waypoint " + std::to_string(i) + " is not finite");
    }
  }
  path_.clear();
  cumulative_m_.clear();
  for (const Eigen::Vector3d& p : path_W) {
    const Eigen::Vector2d q = p.head<2>();
    if (!path_.empty() && (q - path_.back()).norm() < 1e-9) continue;  // Drop repeated points.
    cumulative_m_.push_back(path_.empty() ? 0.0 : cumulative_m_.back() + (q - path_.back()).norm());
    path_.push_back(q);
  }
  segment_ = 0;
  progress_m_ = 0.0;
  arrived_ = false;
  turning_ = false;
}

TrackerCommand PathTracker::Compute(double x_m, double y_m, double yaw_rad) {
  TrackerCommand cmd;
  if (path_.empty() || arrived_) {
    cmd.arrived = true;
    return cmd;
  }
  if (!std::isfinite(x_m) || !std::isfinite(y_m) || !std::isfinite(yaw_rad)) return cmd;
  const Eigen::Vector2d p(x_m, y_m);
  const double total = cumulative_m_.back();

  // 1. Project onto the path, searching forward from the last projection within a window, so that a path
  //    passing near itself does not make progress jump.
  const double window_m = options_.lookahead_m + 1.0;
  double best_d2 = std::numeric_limits<double>::infinity();
  double best_s = progress_m_;
  std::size_t best_seg = segment_;
  for (std::size_t i = segment_; i + 1 < path_.size() && cumulative_m_[i] <= progress_m_ + window_m; ++i) {
    const Eigen::Vector2d a = path_[i];
    const Eigen::Vector2d ab = path_[i + 1] - a;
    const double len = ab.norm();
    // Arc length of the closest point of this segment, never behind the last projection.
    const double s =
        std::max(progress_m_, cumulative_m_[i] + std::clamp((p - a).dot(ab) / (len * len), 0.0, 1.0) * len);
    const double t = std::clamp((s - cumulative_m_[i]) / len, 0.0, 1.0);
    const double d2 = (p - (a + t * ab)).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      best_s = std::min(s, cumulative_m_[i + 1]);
      best_seg = i;
    }
  }
  segment_ = best_seg;
  progress_m_ = std::min(best_s, total);
  cmd.distance_left_m = total - progress_m_;

  // 2. Arrival.
  const double to_end = (path_.back() - p).norm();
  if (to_end <= options_.goal_tolerance_m &&
      cmd.distance_left_m <= options_.lookahead_m + options_.goal_tolerance_m) {
    arrived_ = true;
    cmd.arrived = true;
    cmd.distance_left_m = 0.0;
    return cmd;
  }

  // 3. Look-ahead point: lookahead_m further along the path (or the end).
  const double s_target = std::min(progress_m_ + options_.lookahead_m, total);
  std::size_t i = segment_;
  while (i + 1 < path_.size() - 1 && cumulative_m_[i + 1] < s_target) ++i;
  Eigen::Vector2d target = path_.back();
  if (path_.size() > 1) {
    const double seg_len = cumulative_m_[i + 1] - cumulative_m_[i];
    const double t = seg_len > 0 ? std::clamp((s_target - cumulative_m_[i]) / seg_len, 0.0, 1.0) : 1.0;
    target = path_[i] + t * (path_[i + 1] - path_[i]);
  }
  if (to_end < options_.lookahead_m) target = path_.back();
  const Eigen::Vector2d to_target = target - p;
  const double ld = to_target.norm();
  const double alpha = ld > 1e-9 ? Wrap(std::atan2(to_target.y(), to_target.x()) - yaw_rad) : 0.0;

  // 4. Turn in place for large heading errors (with hysteresis), else pure pursuit.
  if (std::abs(alpha) > options_.rotate_in_place_angle_rad) turning_ = true;
  if (turning_ && std::abs(alpha) < 0.5 * options_.rotate_in_place_angle_rad) turning_ = false;
  if (turning_) {
    cmd.turning_in_place = true;
    cmd.wz_radps = std::clamp(options_.turn_gain_per_s * alpha, -options_.max_yaw_rate_radps,
                              options_.max_yaw_rate_radps);
    return cmd;
  }
  double v = options_.cruise_speed_mps;
  if (options_.slow_down_radius_m > 0.0) {
    const double remaining = std::max(to_end, cmd.distance_left_m);
    v = std::max(options_.min_speed_mps, v * std::min(1.0, remaining / options_.slow_down_radius_m));
  }
  const double curvature = ld > 1e-9 ? 2.0 * std::sin(alpha) / ld : 0.0;  // Coulter (1992), eq. for gamma.
  double w = v * curvature;
  if (std::abs(w) > options_.max_yaw_rate_radps) {
    v *= options_.max_yaw_rate_radps / std::abs(w);
    w = std::copysign(options_.max_yaw_rate_radps, w);
  }
  cmd.vx_mps = v;
  cmd.wz_radps = w;
  return cmd;
}

}  // namespace cairn::nav
