// Copyright Cairn authors.
//
// Test helpers for nav: hand-made worlds.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <memory>
#include <vector>

#include "../../sim/test/test_util.h"
#include "cairn/core/voxel_grid.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/unicycle.h"
#include "cairn/sim/world.h"

namespace cairn::nav::testing {

/// A size_x_m x size_y_m world at `res` with its min corner at (0, 0, -0.2): a 0.2 m floor slab whose top is
/// z = 0, and free space above up to z = height_m (the top of the grid).
inline sim::World FlatWorld(double size_x_m, double size_y_m, double res = 0.1, double height_m = 1.5) {
  const Eigen::Vector3i dims(static_cast<int>(std::lround(size_x_m / res)),
                             static_cast<int>(std::lround(size_y_m / res)),
                             static_cast<int>(std::lround((height_m + 0.2) / res)));
  sim::World world("flat", Eigen::Vector3d(0.0, 0.0, -0.2), res, dims);
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < static_cast<int>(std::lround(0.2 / res)); ++iz) world.SetOccupied({ix, iy, iz});
    }
  }
  return world;
}

/// Sets (or clears) every voxel whose centre lies in the box [lo, hi) (metres, frame W).
inline void FillBox(sim::World* world, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                    bool occupied = true) {
  const Eigen::Vector3i& dims = world->dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3d c = world->CenterOf({ix, iy, iz});
        if ((c.array() >= lo.array()).all() && (c.array() < hi.array()).all())
          world->SetOccupied({ix, iy, iz}, occupied);
      }
    }
  }
}

/// `truth` as a robot's own map would hold it had its lidar observed everything up to `max_z_m` and nothing
/// above: the occupied voxels whose centres lie at or below max_z_m go into `*world`, the free ones into
/// `*seen_free` (both new, with truth's geometry); free voxels up to `free_max_z_m` (NaN: max_z_m) count as
/// seen (a lidar's rays pass over the steps whose treads it does not see).
inline void SeenBelow(const core::VoxelGrid& truth, double max_z_m, std::shared_ptr<core::VoxelGrid>* world,
                      std::shared_ptr<core::VoxelGrid>* seen_free, double free_max_z_m = std::nan("")) {
  if (std::isnan(free_max_z_m)) free_max_z_m = max_z_m;
  *world = std::make_shared<core::VoxelGrid>("own", truth.p_W_min(), truth.resolution_m(), truth.dims());
  *seen_free = std::make_shared<core::VoxelGrid>("seen", truth.p_W_min(), truth.resolution_m(), truth.dims());
  for (int ix = 0; ix < truth.dims().x(); ++ix) {
    for (int iy = 0; iy < truth.dims().y(); ++iy) {
      for (int iz = 0; iz < truth.dims().z(); ++iz) {
        const double z = truth.CenterOf({ix, iy, iz}).z();
        if (truth.IsOccupiedIndex({ix, iy, iz})) {
          if (z <= max_z_m) (*world)->SetOccupied({ix, iy, iz});
        } else if (z <= free_max_z_m) {
          (*seen_free)->SetOccupied({ix, iy, iz});
        }
      }
    }
  }
}

}  // namespace cairn::nav::testing
