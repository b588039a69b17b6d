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
  std::snprintf(buf, sizeof(buf), "x in [%.2f, %.2f], y in [%.2f, %.2f]", grid.p_W_min().x(),
                grid.p_W_max().x(), grid.p_W_min().y(), grid.p_W_max().y());
  return buf;
}

/// The seen-free rule for a robot-built map: a floor candidate whose voxel top is `top_z_m` (voxel (ix, iy,
/// iz)) counts only if a ray went through the space right above it (one of the 3 x 3 columns around it, one
/// or two voxels up), or it lies 0.1 m below the highest sensor origin so far and was not hit from below (the
/// voxel right under it not seen free): far floor seen at a grazing angle has no free voxel observed right
/// above it, while the underside of a flight or a landing seen from the floor below, whose space above is
/// unseen, is no floor (it read as a ragged tread beside the real ones once a legged robot stood on the
/// landing above it). No `seen_free`: always true.
inline bool SeenFreeAbove(const core::VoxelGrid* seen_free, double sensor_max_z_m, double top_z_m, int ix,
                          int iy, int iz) {
  if (seen_free == nullptr) return true;
  const bool hit_from_below = iz > 0 && seen_free->IsOccupiedIndex({ix, iy, iz - 1});
  if (!hit_from_below && top_z_m <= sensor_max_z_m - 0.1) return true;
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

/// The floor candidates of a map column, as the single-level and multi-level terrain analyses read them: a
/// voxel is one if its top lies in [band_lo_m, band_hi_m], the need_voxels voxels right above it are free
/// (space above the map counts as free when free_above_map) and it passes SeenFreeAbove.
struct FloorColumnScan {
  const core::VoxelGrid& world;
  const core::VoxelGrid* seen_free;  ///< null: every candidate counts as seen
  double sensor_max_z_m;
  double band_lo_m;
  double band_hi_m;
  int need_voxels;
  bool free_above_map;

  /// Top of voxel layer iz, metres, frame W.
  double TopOf(int iz) const { return world.p_W_min().z() + (iz + 1) * world.resolution_m(); }

  /// Calls visit(iz) for each candidate of column (ix, iy), from the top down; returns whether the band holds
  /// an occupied voxel (candidate or not). Skips free runs 64 voxels at a time (HighestOccupiedInColumn).
  template <class Visit>
  bool operator()(int ix, int iy, Visit&& visit) const {
    bool band_occupied = false;
    int free_run = free_above_map ? need_voxels : 0;  // free voxels directly above the current one
    for (int above = world.dims().z() - 1; above >= 0;) {
      const int iz = world.HighestOccupiedInColumn(ix, iy, above);  // voxels iz + 1 .. above are free
      free_run += above - iz;
      if (iz < 0) break;
      const double top = TopOf(iz);
      if (top >= band_lo_m && top <= band_hi_m) {
        band_occupied = true;
        if (free_run >= need_voxels && SeenFreeAbove(seen_free, sensor_max_z_m, top, ix, iy, iz)) visit(iz);
      }
      free_run = 0;
      above = iz - 1;
    }
    return band_occupied;
  }
};

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
