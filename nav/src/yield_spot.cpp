// Copyright Cairn authors.
#include "cairn/nav/yield_spot.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <queue>

namespace cairn::nav {

double DistanceToPolyline(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& p) {
  if (path.empty()) return std::numeric_limits<double>::infinity();
  double best = (path.front() - p).norm();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d ab = path[i + 1] - path[i];
    const double len2 = ab.squaredNorm();
    const double t = len2 > 0 ? std::clamp((p - path[i]).dot(ab) / len2, 0.0, 1.0) : 0.0;
    best = std::min(best, (path[i] + t * ab - p).norm());
  }
  return best;
}

namespace {

std::string Num(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", v);
  return text;
}

std::string CheckRequest(const YieldSpotRequest& r) {
  if (!r.from_W.allFinite()) return "YieldSpotRequest::from_W is not finite";
  if (r.keep_clear_W.empty()) return "YieldSpotRequest::keep_clear_W is empty";
  for (const Eigen::Vector2d& p : r.keep_clear_W) {
    if (!p.allFinite()) return "YieldSpotRequest::keep_clear_W holds a point that is not finite";
  }
  if (!(r.clearance_m > 0) || !std::isfinite(r.clearance_m))
    return "YieldSpotRequest::clearance_m = " + Num(r.clearance_m) + " must be finite and > 0";
  if (!(r.robot_radius_m > 0) || !std::isfinite(r.robot_radius_m))
    return "YieldSpotRequest::robot_radius_m = " + Num(r.robot_radius_m) + " must be finite and > 0";
  if (!(r.keep_off_m >= 0) || !std::isfinite(r.keep_off_m))
    return "YieldSpotRequest::keep_off_m = " + Num(r.keep_off_m) + " must be finite and >= 0";
  if (!(r.max_drive_m > 0) || !std::isfinite(r.max_drive_m))
    return "YieldSpotRequest::max_drive_m = " + Num(r.max_drive_m) + " must be finite and > 0";
  return "";
}

}  // namespace

YieldSpot FindYieldSpot(const TraversabilityGrid& grid, const YieldSpotRequest& request) {
  YieldSpot spot;
  if (const std::string why = CheckRequest(request); !why.empty()) {
    spot.reason = why;
    return spot;
  }
  int sx = 0, sy = 0;
  if (!grid.CellOf(request.from_W.x(), request.from_W.y(), &sx, &sy)) {
    spot.reason =
        "the robot at (" + Num(request.from_W.x()) + ", " + Num(request.from_W.y()) + ") is off its map";
    return spot;
  }
  const double cell = grid.cell_size_m();
  const int nx = grid.nx();
  std::vector<double> dist(static_cast<std::size_t>(nx) * static_cast<std::size_t>(grid.ny()),
                           std::numeric_limits<double>::infinity());
  using Entry = std::pair<double, int>;  // (drive metres, cell index)
  std::vector<int> parent(dist.size(), -1);
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  dist[static_cast<std::size_t>(sy) * nx + sx] = 0.0;
  open.push({0.0, sy * nx + sx});
  int searched = 0;
  constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  while (!open.empty()) {
    const auto [d, index] = open.top();
    open.pop();
    if (d > dist[static_cast<std::size_t>(index)]) continue;
    ++searched;
    const int ix = index % nx, iy = index / nx;
    const Eigen::Vector2d c = grid.CellCenter(ix, iy);
    // The start cell counts only if the robot can stand there (it may be in a tight spot).
    if (grid.IsTraversableFor(ix, iy, request.robot_radius_m)) {
      const double clear = DistanceToPolyline(request.keep_clear_W, c);
      if (clear >= request.clearance_m) {
        spot.found = true;
        spot.p_W = c;
        spot.drive_m = d;
        spot.clearance_m = clear;
        for (int k = index; k >= 0; k = parent[static_cast<std::size_t>(k)])
          spot.path_W.push_back(grid.CellCenter(k % nx, k / nx));
        std::reverse(spot.path_W.begin(), spot.path_W.end());
        if (spot.path_W.size() > 1) spot.path_W.front() = request.from_W;  // from the robot itself
        return spot;
      }
    }
    for (int k = 0; k < 8; ++k) {
      const int jx = ix + kDx[k], jy = iy + kDy[k];
      if (!grid.InGrid(jx, jy) || !grid.IsTraversableFor(jx, jy, request.robot_radius_m)) continue;
      // Never toward the passing robot within touching distance (in a tunnel a spot behind it cannot be
      // reached); away from it is fine, even from a start already that close.
      const Eigen::Vector2d& passing = request.keep_clear_W.front();
      const double to_passing = (grid.CellCenter(jx, jy) - passing).norm();
      if (to_passing < request.keep_off_m && to_passing <= (c - passing).norm()) continue;
      const double step = k < 4 ? cell : cell * std::sqrt(2.0);
      const double nd = d + step;
      if (nd > request.max_drive_m) continue;
      const std::size_t j = static_cast<std::size_t>(jy) * nx + jx;
      if (nd < dist[j]) {
        dist[j] = nd;
        parent[j] = index;
        open.push({nd, jy * nx + jx});
      }
    }
  }
  spot.reason = "no spot " + Num(request.clearance_m) + " m clear of the path within " +
                Num(request.max_drive_m) + " m of driving (" + std::to_string(searched) + " cells of " +
                Num(cell) + " m searched)";
  return spot;
}

bool CanPassBeside(const TraversabilityGrid& grid, const Eigen::Vector2d& peer_W,
                   const Eigen::Vector2d& direction_W, double offset_m, double robot_radius_m,
                   double along_m) {
  if (!(direction_W.norm() > 1e-9) || !peer_W.allFinite()) return false;
  const Eigen::Vector2d along = direction_W.normalized();
  const Eigen::Vector2d across(-along.y(), along.x());
  const double step = grid.cell_size_m();
  for (double t = -along_m; t <= along_m + 1e-9; t += step) {
    for (const double side : {-1.0, 1.0}) {
      const Eigen::Vector2d q = peer_W + t * along + side * offset_m * across;
      int ix = 0, iy = 0;
      if (grid.CellOf(q.x(), q.y(), &ix, &iy) && grid.IsTraversableFor(ix, iy, robot_radius_m)) return true;
    }
    if (along_m <= 0) break;
  }
  return false;
}

}  // namespace cairn::nav
