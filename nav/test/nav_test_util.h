// Copyright Cairn authors.
//
// Test helpers for nav: hand-made worlds and a closed-loop drive (unicycle + pure pursuit).
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "../../sim/test/test_util.h"
#include "cairn/nav/path_tracker.h"
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

/// Outcome of DriveClosedLoop().
struct DriveResult {
  bool arrived = false;           ///< The tracker reported arrival.
  int contacts = 0;               ///< Steps that ended in contact.
  double final_distance_m = 0.0;  ///< Planar distance from the final pose to the path end.
  double time_s = 0.0;            ///< Simulated time.
  sim::UnicycleState final_state;
};

/// Drives a wheeled unicycle (footprint 0.25 m) from `start` along `path_W` with a PathTracker at dt_s until
/// arrival or max_time_s.
inline DriveResult DriveClosedLoop(const TraversabilityGrid& grid, const std::vector<Eigen::Vector3d>& path_W,
                                   const sim::UnicycleState& start, double max_time_s = 300.0,
                                   double dt_s = 0.05, const PathTrackerOptions& tracker_options = {}) {
  PathTracker tracker(tracker_options);
  tracker.SetPath(path_W);
  sim::Unicycle robot(sim::UnicycleLimits::Wheeled(), 0.25, start);
  DriveResult result;
  for (; result.time_s < max_time_s; result.time_s += dt_s) {
    const TrackerCommand cmd = tracker.Compute(robot.state().x_m, robot.state().y_m, robot.state().yaw_rad);
    if (cmd.arrived) {
      result.arrived = true;
      break;
    }
    result.contacts += robot.Step(cmd.vx_mps, cmd.wz_radps, dt_s, grid).contact ? 1 : 0;
  }
  result.final_state = robot.state();
  result.final_distance_m =
      (Eigen::Vector2d(robot.state().x_m, robot.state().y_m) - path_W.back().head<2>()).norm();
  return result;
}

}  // namespace cairn::nav::testing
