// Copyright Cairn authors.
#include "cairn/nav/scan_obstacles.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace cairn::nav {
namespace {

bool Check(const char* field, double value, double lo, bool lo_open, double hi, std::ostringstream* msg) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    *msg << "ScanObstacleOptions::" << field << " = " << value << " must be in " << (lo_open ? "(" : "[")
         << lo << ", " << hi << "]";
  }
  return ok;
}

}  // namespace

bool ScanObstacleOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  const bool ok = Check("cell_size_m", cell_size_m, 0.02, false, 1.0, &msg) &&
                  Check("range_m", range_m, 0.0, true, 30.0, &msg) &&
                  Check("max_step_m", max_step_m, 0.0, false, 2.0, &msg) &&
                  Check("robot_height_m", robot_height_m, 0.0, true, 10.0, &msg) &&
                  Check("depth_below_m", depth_below_m, 0.0, true, 10.0, &msg) &&
                  Check("min_points_per_cell", min_points_per_cell, 1.0, false, 1000.0, &msg);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

ScanObstacleStats ObstaclesFromPoints(const std::vector<Eigen::Vector3f>& points_M,
                                      const core::BaseState& pose_M, const ScanObstacleOptions& options,
                                      std::vector<Eigen::Vector3f>* points_B) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  if (points_B == nullptr) throw std::invalid_argument("ObstaclesFromPoints: points_B is null");
  points_B->clear();
  ScanObstacleStats stats;
  if (!std::isfinite(pose_M.x_m) || !std::isfinite(pose_M.y_m) || !std::isfinite(pose_M.z_m) ||
      !std::isfinite(pose_M.yaw_rad)) {
    return stats;
  }
  // A square grid of n x n cells centred on the robot, in frame M's axes.
  const double c = options.cell_size_m;
  const int half = static_cast<int>(std::ceil(options.range_m / c));
  const int n = 2 * half + 1;
  const double x0 = pose_M.x_m - (half + 0.5) * c;
  const double y0 = pose_M.y_m - (half + 0.5) * c;
  constexpr float kNone = std::numeric_limits<float>::infinity();
  std::vector<float> low(static_cast<std::size_t>(n) * n, kNone);
  std::vector<float> high(low.size(), -kNone);
  std::vector<std::uint16_t> count(low.size(), 0);
  const double z_lo = pose_M.z_m - options.depth_below_m;
  const double z_hi = pose_M.z_m + options.robot_height_m;
  const double r2 = options.range_m * options.range_m;
  // The cell of a point in the analysed band, or -1.
  auto cell_of = [&](const Eigen::Vector3f& p) -> std::ptrdiff_t {
    if (!p.allFinite() || p.z() < z_lo || p.z() > z_hi) return -1;
    const double dx = p.x() - pose_M.x_m;
    const double dy = p.y() - pose_M.y_m;
    if (dx * dx + dy * dy > r2) return -1;
    const int ix = static_cast<int>(std::floor((p.x() - x0) / c));
    const int iy = static_cast<int>(std::floor((p.y() - y0) / c));
    if (ix < 0 || iy < 0 || ix >= n || iy >= n) return -1;
    return static_cast<std::ptrdiff_t>(ix) + static_cast<std::ptrdiff_t>(n) * iy;
  };
  for (const Eigen::Vector3f& p : points_M) {
    const std::ptrdiff_t cell = cell_of(p);
    if (cell < 0) continue;
    const std::size_t i = static_cast<std::size_t>(cell);
    low[i] = std::min(low[i], p.z());
    high[i] = std::max(high[i], p.z());
    if (count[i] < 0xffff) ++count[i];
    ++stats.points_used;
  }
  // Lethal cells, and per lethal cell the height above which its points are the obstacle: above its lowest
  // point + max_step_m when its own points span too much (a wall standing on the floor in the cell), all of
  // them when it stands too high above a neighbour (a step's top).
  const float step = static_cast<float>(options.max_step_m) + 1e-4f;
  std::vector<float> obstacle_above(low.size(), kNone);  // kNone: not lethal
  for (int iy = 0; iy < n; ++iy) {
    for (int ix = 0; ix < n; ++ix) {
      const std::size_t i = static_cast<std::size_t>(ix) + static_cast<std::size_t>(n) * iy;
      if (low[i] == kNone) continue;
      ++stats.cells_observed;
      if (count[i] < options.min_points_per_cell) continue;  // a stray return is no obstacle
      bool above_neighbour = false;
      for (int dy = -1; dy <= 1 && !above_neighbour; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int jx = ix + dx;
          const int jy = iy + dy;
          if ((dx == 0 && dy == 0) || jx < 0 || jy < 0 || jx >= n || jy >= n) continue;
          const std::size_t j = static_cast<std::size_t>(jx) + static_cast<std::size_t>(n) * jy;
          if (low[j] != kNone && count[j] >= options.min_points_per_cell && low[i] - low[j] > step) {
            above_neighbour = true;
            break;
          }
        }
      }
      if (above_neighbour) {
        obstacle_above[i] = -kNone;
      } else if (high[i] - low[i] > step) {
        obstacle_above[i] = low[i] + step;
      } else {
        continue;
      }
      ++stats.cells_lethal;
    }
  }
  // Each lethal cell is reported at its obstacle point nearest the robot in x-y: the surface as measured.
  // Its centre lies up to half a cell (5 cm) off the surface on either side and moves with the robot's
  // position modulo a cell; in a 1.0 m doorway that decides whether a 0.6 m robot fits.
  std::vector<Eigen::Vector2f> nearest(low.size(), Eigen::Vector2f::Zero());
  std::vector<float> nearest_d2(low.size(), kNone);
  for (const Eigen::Vector3f& p : points_M) {
    const std::ptrdiff_t cell = cell_of(p);
    if (cell < 0) continue;
    const std::size_t i = static_cast<std::size_t>(cell);
    if (!(p.z() > obstacle_above[i])) continue;
    const float dx = static_cast<float>(p.x() - pose_M.x_m);
    const float dy = static_cast<float>(p.y() - pose_M.y_m);
    const float d2 = dx * dx + dy * dy;
    if (d2 < nearest_d2[i]) {
      nearest_d2[i] = d2;
      nearest[i] = Eigen::Vector2f(dx, dy);
    }
  }
  const double cos_yaw = std::cos(pose_M.yaw_rad);
  const double sin_yaw = std::sin(pose_M.yaw_rad);
  for (std::size_t i = 0; i < low.size(); ++i) {
    if (nearest_d2[i] == kNone) continue;
    const double dx = nearest[i].x();
    const double dy = nearest[i].y();
    points_B->emplace_back(static_cast<float>(cos_yaw * dx + sin_yaw * dy),
                           static_cast<float>(-sin_yaw * dx + cos_yaw * dy), 0.0f);
  }
  return stats;
}

}  // namespace cairn::nav
