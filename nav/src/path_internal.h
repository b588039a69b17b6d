// Pieces shared by the single-level (traversability.cpp, astar.cpp) and multi-level (multilevel.cpp) terrain
// analyses and searches.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "cairn/core/voxel_grid.h"
#include "cairn/nav/traversability.h"

namespace cairn::nav::internal {

/// "(x, y)" with two decimals, metres, for messages.
inline std::string FormatPoint(const Eigen::Vector2d& p) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%.2f, %.2f)", p.x(), p.y());
  return buf;
}

/// "x in [.., ..], y in [.., ..]": the grid's extent, metres, for messages.
inline std::string MapExtent(const TraversabilityGrid& grid) {
  char buf[160];
  std::snprintf(buf, sizeof(buf), "x in [%.2f, %.2f], y in [%.2f, %.2f]", grid.p_W_min().x(), grid.p_W_max().x(),
                grid.p_W_min().y(), grid.p_W_max().y());
  return buf;
}

/// The seen-free rule for a robot-built map: a floor candidate whose voxel top is `top_z_m` (voxel (ix, iy,
/// iz)) counts only if a ray went through the space right above it (one of the 3 x 3 columns around it, one or
/// two voxels up) or it lies below every sensor origin so far (seen from above). No `seen_free`: always true.
inline bool SeenFreeAbove(const core::VoxelGrid* seen_free, double sensor_max_z_m, double top_z_m, int ix, int iy,
                          int iz) {
  if (seen_free == nullptr) return true;
  if (top_z_m <= sensor_max_z_m - 0.1) return true;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      if (seen_free->IsOccupiedIndex({ix + dx, iy + dy, iz + 1}) ||
          seen_free->IsOccupiedIndex({ix + dx, iy + dy, iz + 2})) {
        return true;
      }
    }
  }
  return false;
}

/// Puts the exact start on a searched path of cell centres: it replaces the first centre, or is prepended
/// (clearance 0) when the search started from an escape cell; a one-point path gets a second point, so that
/// the caller can replace the last one with the exact goal.
inline void AttachStart(const Eigen::Vector3d& start_point, bool used_start_escape,
                        std::vector<Eigen::Vector3d>* points, std::vector<double>* clearance) {
  if (used_start_escape) {
    points->insert(points->begin(), start_point);
    clearance->insert(clearance->begin(), 0.0);
  } else {
    points->front() = start_point;
  }
  if (points->size() == 1) {
    points->push_back(points->front());
    clearance->push_back(clearance->front());
  }
}

/// Greedy line-of-sight shortcutting: from each kept point, jump to the farthest following point that
/// `joins(anchor, j, need_clearance_m)` reaches in a straight line before the first failure; the clearance
/// needed is the least of `preferred_clearance_m` and the clearances along the skipped points.
template <class Joins>
void ShortcutPath(double preferred_clearance_m, const std::vector<double>& clearance, Joins&& joins,
                  std::vector<Eigen::Vector3d>* points) {
  if (points->size() <= 2) return;
  std::vector<Eigen::Vector3d> simplified = {points->front()};
  std::size_t anchor = 0;
  while (anchor + 1 < points->size()) {
    std::size_t best = anchor + 1;
    double least = clearance[anchor + 1];
    for (std::size_t j = anchor + 2; j < points->size(); ++j) {
      least = std::min(least, clearance[j]);
      if (!joins(anchor, j, std::min(preferred_clearance_m, least) - 1e-9)) break;
      best = j;
    }
    simplified.push_back((*points)[best]);
    anchor = best;
  }
  *points = std::move(simplified);
}

}  // namespace cairn::nav::internal
