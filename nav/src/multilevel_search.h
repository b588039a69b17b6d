// Copyright Cairn authors.
//
// Internal: the moves of a search over a MultiLevelGrid's surfaces and its unknown space, shared by
// PlanPathMultiLevel (multilevel.cpp) and FindFrontiersMultiLevel (frontier_multilevel.cpp).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <unordered_map>

#include "cairn/nav/astar.h"
#include "cairn/nav/multilevel.h"

namespace cairn::nav {
namespace internal {

// A search state: a known surface (id < node_count) or a height in an unknown cell (key node_count + column *
// nz + iz), see PlanPathMultiLevel.
struct LevelState {
  int ix = 0;
  int iy = 0;
  double z = 0.0;
  int node = -1;               // -1: unknown cell entered at height z
  float unknown_run_m = 0.0f;  // unknown space crossed since the last known surface (metres)
};

}  // namespace internal

/// A body's moves over a MultiLevelGrid: which state it reaches entering a neighbouring cell at a height.
class MultiLevelSearch {
 public:
  MultiLevelSearch(const MultiLevelGrid& grid, const AStarOptions& options) : grid_(grid) {
    radius_m_ = grid.options().robot_radius_m;
    if (std::isfinite(options.robot_radius_m) && options.robot_radius_m < radius_m_)
      radius_m_ = options.robot_radius_m;
  }

  std::int64_t Key(const internal::LevelState& s) const {
    if (s.node >= 0) return s.node;
    const int iz = static_cast<int>(std::lround((s.z - grid_.world_p_min_.z()) / grid_.res_m_));
    return static_cast<std::int64_t>(grid_.node_count()) +
           (static_cast<std::int64_t>(grid_.Column(s.ix, s.iy)) * (grid_.world_dims_.z() + 2) + iz + 1);
  }

  bool Traversable(int node) const { return grid_.IsTraversableFor(node, radius_m_); }

  // An unknown cell entered at height z: every cell within the radius is a connected surface or unknown too.
  // Remembered per cell and height for the search's life (the grid does not change under a search): a
  // search enters the same unknown cell from up to 8 neighbours and tests it again for diagonal moves, and
  // each test reads some 30 cells (most of a large frontier search's time on a sparse map before).
  bool VirtualClear(int ix, int iy, double z) const {
    // The cell and the height to the millimetre (heights are those of surfaces left: voxel tops).
    const std::int64_t key = static_cast<std::int64_t>(grid_.Column(ix, iy)) * (std::int64_t{1} << 24) +
                             (std::llround(z * 1000.0) & ((std::int64_t{1} << 24) - 1));
    if (const auto it = virtual_clear_.find(key); it != virtual_clear_.end()) return it->second;
    const bool clear = VirtualClearUncached(ix, iy, z);
    virtual_clear_.emplace(key, clear);
    return clear;
  }

  bool VirtualClearUncached(int ix, int iy, double z) const {
    if (grid_.IsUnobservedAround(ix, iy)) return true;  // nothing known within the radius
    const int span = static_cast<int>(std::ceil(radius_m_ / grid_.cell_size_m()));
    const Eigen::Vector2d c = grid_.CellCenter(ix, iy);
    for (int jx = ix - span; jx <= ix + span; ++jx) {
      for (int jy = iy - span; jy <= iy + span; ++jy) {
        if ((grid_.CellCenter(jx, jy) - c).norm() > radius_m_ + 1e-9) continue;
        if (!grid_.InGrid(jx, jy)) return false;
        bool unknown = false;
        if (grid_.Connected(jx, jy, z, &unknown) < 0 && !unknown) return false;
      }
    }
    return true;
  }

  // The state a body at `from` height reaches in cell (jx, jy), if it may stand there.
  std::optional<internal::LevelState> Enter(int jx, int jy, double z) const {
    if (!grid_.InGrid(jx, jy)) return std::nullopt;
    bool unknown = false;
    const int m = grid_.Connected(jx, jy, z, &unknown);
    if (m >= 0) {
      if (!Traversable(m)) return std::nullopt;
      return internal::LevelState{jx, jy, grid_.NodeZ(m), m};
    }
    if (unknown && VirtualClear(jx, jy, z)) return internal::LevelState{jx, jy, z, -1};
    return std::nullopt;
  }

  double Clearance(const internal::LevelState& s) const {
    return s.node >= 0 ? grid_.ClearanceM(s.node) : std::numeric_limits<double>::infinity();
  }

  double radius_m() const { return radius_m_; }

 private:
  const MultiLevelGrid& grid_;
  double radius_m_ = 0.0;
  mutable std::unordered_map<std::int64_t, bool> virtual_clear_;  // VirtualClear() by cell and height
};

}  // namespace cairn::nav
