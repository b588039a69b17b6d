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

namespace {

constexpr float kNone = std::numeric_limits<float>::infinity();

// The scan's points in a square grid of n x n cells centred on the robot, in frame M's axes: per cell the
// lowest and highest point and the count, of the points within range_m in x-y and in the band from
// depth_below_m under the robot to robot_height_m over it.
class ScanCells {
 public:
  ScanCells(const core::BaseState& pose_M, const ScanObstacleOptions& options)
      : pose_M_(pose_M),
        options_(options),
        cell_m_(options.cell_size_m),
        half_(static_cast<int>(std::ceil(options.range_m / cell_m_))),
        n_(2 * half_ + 1),
        x0_(pose_M.x_m - (half_ + 0.5) * cell_m_),
        y0_(pose_M.y_m - (half_ + 0.5) * cell_m_),
        z_lo_(pose_M.z_m - options.depth_below_m),
        z_hi_(pose_M.z_m + options.robot_height_m),
        low_(static_cast<std::size_t>(n_) * n_, kNone),
        high_(low_.size(), -kNone),
        count_(low_.size(), 0) {}

  std::size_t size() const { return low_.size(); }

  // The cell of a point in the analysed band, or -1.
  std::ptrdiff_t CellOf(const Eigen::Vector3f& p) const {
    if (!p.allFinite() || p.z() < z_lo_ || p.z() > z_hi_) return -1;
    const double dx = p.x() - pose_M_.x_m;
    const double dy = p.y() - pose_M_.y_m;
    if (dx * dx + dy * dy > options_.range_m * options_.range_m) return -1;
    const int ix = static_cast<int>(std::floor((p.x() - x0_) / cell_m_));
    const int iy = static_cast<int>(std::floor((p.y() - y0_) / cell_m_));
    if (ix < 0 || iy < 0 || ix >= n_ || iy >= n_) return -1;
    return static_cast<std::ptrdiff_t>(ix) + static_cast<std::ptrdiff_t>(n_) * iy;
  }

  void Add(const std::vector<Eigen::Vector3f>& points_M, ScanObstacleStats* stats) {
    for (const Eigen::Vector3f& p : points_M) {
      const std::ptrdiff_t cell = CellOf(p);
      if (cell < 0) continue;
      const std::size_t i = static_cast<std::size_t>(cell);
      low_[i] = std::min(low_[i], p.z());
      high_[i] = std::max(high_[i], p.z());
      if (count_[i] < 0xffff) ++count_[i];
      ++stats->points_used;
    }
  }

  // Lethal cells, and per lethal cell the height above which its points are the obstacle (kNone: not
  // lethal): above its lowest point + max_step_m when its own points span too much (a wall standing on the
  // floor in the cell), all of them when it stands too high above a neighbour (a step's top).
  std::vector<float> ObstacleHeights(ScanObstacleStats* stats) const {
    const float step = Step();
    std::vector<float> obstacle_above(low_.size(), kNone);
    for (int iy = 0; iy < n_; ++iy) {
      for (int ix = 0; ix < n_; ++ix) {
        const std::size_t i = Index(ix, iy);
        if (low_[i] == kNone) continue;
        ++stats->cells_observed;
        if (count_[i] < options_.min_points_per_cell) continue;  // a stray return is no obstacle
        if (AboveNeighbour(ix, iy)) {
          obstacle_above[i] = -kNone;
        } else if (high_[i] - low_[i] > step) {
          obstacle_above[i] = low_[i] + step;
        } else {
          continue;
        }
        ++stats->cells_lethal;
      }
    }
    return obstacle_above;
  }

 private:
  std::size_t Index(int ix, int iy) const {
    return static_cast<std::size_t>(ix) + static_cast<std::size_t>(n_) * iy;
  }
  float Step() const { return static_cast<float>(options_.max_step_m) + 1e-4f; }
  // The cell's lowest point stands more than a step above a neighbour's, where the neighbour is ground
  // (enough points, spanning no more than a step). A wall's lowest point is not ground: the face of the wall
  // beside a stair flight reaches down to the floor under the flight, and its lowest points (seen from that
  // floor earlier, kept in the blind zone) made every tread along the wall read as a 1.6 m step.
  bool AboveNeighbour(int ix, int iy) const {
    const std::size_t i = Index(ix, iy);
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int jx = ix + dx;
        const int jy = iy + dy;
        if ((dx == 0 && dy == 0) || jx < 0 || jy < 0 || jx >= n_ || jy >= n_) continue;
        const std::size_t j = Index(jx, jy);
        if (low_[j] != kNone && count_[j] >= options_.min_points_per_cell && high_[j] - low_[j] <= Step() &&
            low_[i] - low_[j] > Step()) {
          return true;
        }
      }
    }
    return false;
  }

  const core::BaseState& pose_M_;
  const ScanObstacleOptions& options_;
  const double cell_m_;
  const int half_, n_;
  const double x0_, y0_;      // the grid's corner, frame M, metres
  const double z_lo_, z_hi_;  // the analysed band, frame M, metres
  std::vector<float> low_, high_;
  std::vector<std::uint16_t> count_;
};

}  // namespace

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
  ScanCells cells(pose_M, options);
  cells.Add(points_M, &stats);
  const std::vector<float> obstacle_above = cells.ObstacleHeights(&stats);
  // Each lethal cell is reported at its obstacle point nearest the robot in x-y: the surface as measured.
  // Its centre lies up to half a cell (5 cm) off the surface on either side and moves with the robot's
  // position modulo a cell; in a 1.0 m doorway that decides whether a 0.6 m robot fits.
  std::vector<Eigen::Vector2f> nearest(cells.size(), Eigen::Vector2f::Zero());
  std::vector<float> nearest_d2(cells.size(), kNone);
  for (const Eigen::Vector3f& p : points_M) {
    const std::ptrdiff_t cell = cells.CellOf(p);
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
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (nearest_d2[i] == kNone) continue;
    const double dx = nearest[i].x();
    const double dy = nearest[i].y();
    points_B->emplace_back(static_cast<float>(cos_yaw * dx + sin_yaw * dy),
                           static_cast<float>(-sin_yaw * dx + cos_yaw * dy), 0.0f);
  }
  return stats;
}

}  // namespace cairn::nav
