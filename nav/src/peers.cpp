#include "cairn/nav/peers.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "cairn/core/range_check.h"

namespace cairn::nav {

bool PeerAvoidanceOptions::IsValid(std::string* why) const {
  std::string msg;
  const bool ok = core::InRange("peers.margin_m", margin_m, 0, 2, false, &msg) &&
                  core::InRange("peers.prediction_s", prediction_s, 0, 5, false, &msg) &&
                  core::InRange("peers.same_level_dz_m", same_level_dz_m, 0, 10, true, &msg);
  if (!ok && why != nullptr) *why = msg;
  return ok;
}

namespace {

// Coordinates beyond this are no map of a robot's (and would lose all precision as floats).
constexpr double kMaxCoordinateM = 1e6;

bool Coordinate(double v) { return std::isfinite(v) && std::abs(v) <= kMaxCoordinateM; }

}  // namespace

std::string CheckPeerBody(const PeerBody& peer) {
  std::ostringstream why;
  const core::BaseState& p = peer.pose_M;
  if (peer.robot_id.empty()) {
    why << "robot_id is empty";
  } else if (!Coordinate(p.x_m) || !Coordinate(p.y_m) || !Coordinate(p.z_m)) {
    why << "position (" << p.x_m << ", " << p.y_m << ", " << p.z_m << ") must be finite, within "
        << kMaxCoordinateM << " m";
  } else if (!(std::isfinite(p.yaw_rad) && std::abs(p.yaw_rad) <= 10.0)) {
    why << "yaw_MB_rad = " << p.yaw_rad << " must be finite, within 10 rad";
  } else if (!(std::isfinite(p.v_mps) && std::abs(p.v_mps) <= 20.0)) {
    why << "v_B_mps = " << p.v_mps << " must be finite, within 20 m/s";
  } else if (!(std::isfinite(p.w_radps) && std::abs(p.w_radps) <= 20.0)) {
    why << "w_B_radps = " << p.w_radps << " must be finite, within 20 rad/s";
  } else if (!(peer.footprint_radius_m > 0 && peer.footprint_radius_m <= 5.0)) {
    why << "footprint_radius_m = " << peer.footprint_radius_m << " must be in (0, 5]";
  } else {
    for (std::size_t i = 0; i < peer.path_ahead_M.size(); ++i) {
      const Eigen::Vector3d& q = peer.path_ahead_M[i];
      if (!Coordinate(q.x()) || !Coordinate(q.y()) || !Coordinate(q.z())) {
        why << "path_ahead_M[" << i << "] = (" << q.x() << ", " << q.y() << ", " << q.z()
            << ") must be finite, within " << kMaxCoordinateM << " m";
        break;
      }
    }
  }
  return why.str();
}

std::vector<Eigen::Vector3d> PathAhead(const std::vector<Eigen::Vector3d>& path_M,
                                       const Eigen::Vector2d& from_M, double spacing_m, int max_points) {
  std::vector<Eigen::Vector3d> ahead;
  if (path_M.empty() || max_points <= 0 || !(spacing_m > 0)) return ahead;
  // The nearest point of the path (its segments, in x-y).
  std::size_t segment = 0;
  double t_best = 0.0, d_best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path_M.size(); ++i) {
    const Eigen::Vector2d a = path_M[i].head<2>(), ab = path_M[i + 1].head<2>() - a;
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((from_M - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d = (a + t * ab - from_M).norm();
    if (d < d_best) {
      d_best = d;
      segment = i;
      t_best = t;
    }
  }
  if (path_M.size() == 1) return {path_M.front()};
  Eigen::Vector3d at = path_M[segment] + t_best * (path_M[segment + 1] - path_M[segment]);
  ahead.push_back(at);
  double to_next = spacing_m;  // distance left to the next point to emit
  for (std::size_t i = segment; i + 1 < path_M.size() && static_cast<int>(ahead.size()) < max_points; ++i) {
    const Eigen::Vector3d end = path_M[i + 1];
    double left = (end - at).head<2>().norm();
    while (left >= to_next && static_cast<int>(ahead.size()) < max_points) {
      at += (end - at) * (to_next / left);
      ahead.push_back(at);
      left -= to_next;
      to_next = spacing_m;
    }
    to_next -= left;
    at = end;
  }
  if (static_cast<int>(ahead.size()) < max_points && (ahead.back() - path_M.back()).head<2>().norm() > 1e-6) {
    ahead.push_back(path_M.back());
  }
  return ahead;
}

void AppendPeerObstacles(const std::vector<PeerBody>& peers, const core::BaseState& state, double range_m,
                         double z_B_m, const PeerAvoidanceOptions& options,
                         std::vector<Eigen::Vector3f>* points_B) {
  const double c = std::cos(state.yaw_rad), s = std::sin(state.yaw_rad);
  auto add_circle = [&](double x_M, double y_M, double radius_m) {
    const double dx = x_M - state.x_m, dy = y_M - state.y_m;
    if (std::hypot(dx, dy) - radius_m > range_m) return;
    const int n = std::clamp(static_cast<int>(std::ceil(2 * M_PI * radius_m / 0.1)), 8, 64);
    for (int k = 0; k < n; ++k) {
      const double a = 2 * M_PI * k / n;
      const double px = dx + radius_m * std::cos(a), py = dy + radius_m * std::sin(a);
      // Frame M -> frame B of `state`: rotate by -yaw.
      points_B->emplace_back(static_cast<float>(c * px + s * py), static_cast<float>(-s * px + c * py),
                             static_cast<float>(z_B_m));
    }
  };
  for (const PeerBody& peer : peers) {
    const core::BaseState& p = peer.pose_M;
    if (std::abs(p.z_m - state.z_m) > options.same_level_dz_m) continue;
    const double radius_m = peer.footprint_radius_m + options.margin_m;
    add_circle(p.x_m, p.y_m, radius_m);
    if (std::abs(p.v_mps) <= 0.05 || options.prediction_s <= 0) continue;
    for (const double t : {0.5 * options.prediction_s, options.prediction_s}) {
      // Where it will be on its current arc (a straight line when it does not turn).
      double x = p.x_m, y = p.y_m;
      if (std::abs(p.w_radps) < 1e-3) {
        x += p.v_mps * t * std::cos(p.yaw_rad);
        y += p.v_mps * t * std::sin(p.yaw_rad);
      } else {
        const double r = p.v_mps / p.w_radps, yaw_t = p.yaw_rad + p.w_radps * t;
        x += r * (std::sin(yaw_t) - std::sin(p.yaw_rad));
        y -= r * (std::cos(yaw_t) - std::cos(p.yaw_rad));
      }
      add_circle(x, y, radius_m);
    }
  }
}

}  // namespace cairn::nav
