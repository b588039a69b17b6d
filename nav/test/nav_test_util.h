// Copyright Cairn authors.
//
// Test helpers for nav: hand-made worlds.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "../../sim/test/test_util.h"
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

}  // namespace cairn::nav::testing
