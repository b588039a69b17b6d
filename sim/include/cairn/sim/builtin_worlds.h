// Copyright Cairn authors.
//
// Procedurally generated built-in worlds (seeded, deterministic) and their suggested start poses and goals.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/sim/world.h"

namespace cairn::sim {

/// A planar pose on the floor of a world (position metres, frame W; heading radians about +z).
using PlanarPose = core::PlanarPose;

/// One straight flight of stairs of a world, as its definition builds it: the ground truth that scores a
/// staircase detector (bench/staircase_accuracy.cpp). Described ascending, like perception::Staircase: treads
/// at heights p_W_first_riser.z() + k * rise_m (k = 1..num_steps), risers at (k - 1) * run_m (k = 1..num_steps)
/// along (cos yaw, sin yaw, 0) from the first riser; the top tread may continue into a landing or a floor.
struct StaircaseFlight {
  /// Foot of the first riser (at the level of the floor before it), centred across the width, metres,
  /// frame W.
  Eigen::Vector3d p_W_first_riser = Eigen::Vector3d::Zero();
  /// Ascending direction, radians about +z of W.
  double yaw_rad = 0.0;
  /// Height of one riser, metres.
  double rise_m = 0.0;
  /// Depth of one tread (horizontal distance between consecutive risers), metres.
  double run_m = 0.0;
  /// Width across the ascending direction, metres.
  double width_m = 0.0;
  /// Number of risers.
  int num_steps = 0;
};

/// Description of one built-in world.
struct BuiltinWorldInfo {
  /// Name without the "builtin:" prefix, e.g. "tunnels".
  std::string name;
  /// One-line description of the layout.
  std::string description;
  /// Voxel edge, metres.
  double resolution_m = 0.1;
  /// Height of the floor surface (top of the floor voxels), metres, frame W.
  double floor_z_m = 0.0;
  /// Free start poses on the floor, at least 3, pairwise >= 2 m apart, all in one connected region, valid for
  /// any seed and for a wheeled robot of radius <= 0.35 m.
  std::vector<PlanarPose> suggested_starts;
  /// A far goal on the floor reachable from every suggested start (yaw unused).
  PlanarPose far_goal;
  /// Every flight of stairs the world has (a world with stairs must list them all: the staircase accuracy
  /// bench counts a detection of an unlisted flight as a false positive). Valid for any seed.
  std::vector<StaircaseFlight> staircases = {};
};

/// Names of the built-in worlds, without the "builtin:" prefix: {"tunnels", "narrow", "arena", "building"}.
///  - "tunnels": about 60 x 40 m (x in [0, 60], y in [0, 40], z in [-0.3, 3.8]) at 0.1 m: tunnels ~3 m wide
///    and ~3 m high with rough walls and ceilings, an X junction at (30, 20), two L bends at (30, 5) and
///    (30, 35), a 10 x 10 m room (x in [46, 56], y in [15, 25], 3.5 m high) with a staircase (5 steps of
///    0.2 m rise, 0.5 m run, x in [50, 52.5], y in [22.5, 25]) up to a 1.0 m platform (x in [52.5, 56]);
///    floor surface at z = 0; floor, walls and ceiling are occupied shells (0.2-0.3 m thick).
///  - "narrow": 34 x 20 m (x in [0, 34], y in [0, 20], z in [-0.3, 3.0]) at 0.1 m: two tunnels 2 m wide and
///    ~2.5 m high along x in [1, 33] (centre lines y = 5 and y = 15), joined by a third at x = 2, each with a
///    2 m wide bay on its north wall (x in [19, 21], 2.5 m deep): two robots cannot pass in the tunnels, one
///    can stand aside in a bay (get-out-of-the-way). Smooth walls; the seed varies the ceilings.
///  - "arena": 20 x 14 m walled yard at 0.1 m (x in [0, 20], y in [0, 14], z in [-0.2, 1.5]), no ceiling,
///    walls 1.5 m high, three 1 x 1 m pillars and a 0.1 m high plate (x in [3, 6], y in [2, 5]); floor
///    surface at z = 0.
///  - "building": 24 x 14 m, two floors at 0.1 m (x in [0, 24], y in [0, 14], z in [-0.3, 6.5]): floor
///    surfaces at z = 0 and z = 3.2 (slabs 0.2 m, roof at 6.2), on each floor a corridor (x in [0.2, 18],
///    y in [6.0, 8.2]) and six rooms (x partitions at 6 and 12, y in [0.2, 5.8] and [8.4, 13.8]) behind
///    1.0 m doorways centred at x = 3.1, 9.1, 15.1; a stairwell (x in [18.2, 23.8], y in [6.0, 8.2]) behind a
///    1.2 m entrance per floor: the lower flight (y in [6, 7], 7 steps of 0.2 m rise and 0.3 m run, x in
///    [19.4, 21.5]) up to a mid landing at 1.6 m (x in [21.5, 23.8]), the upper flight (y in [7.2, 8.2]) back
///    along -x to floor 2 at x = 19.4; free space under the upper flight and the landing (a floor-1 pocket
///    under them), a railing on floor 2 over the lower flight. Deterministic (the seed is unused).
std::vector<std::string> BuiltinWorldNames();

/// Description, suggested starts and far goal of built-in world `name` (without prefix).
/// Throws WorldError listing the valid names if `name` is unknown.
const BuiltinWorldInfo& GetBuiltinWorldInfo(const std::string& name);

/// Builds built-in world `name` (without prefix) with generator seed `seed` (the seed changes the wall and
/// ceiling roughness only; the layout, starts and goal stay valid). Deterministic.
/// Throws WorldError listing the valid names if `name` is unknown.
World MakeBuiltinWorld(const std::string& name, std::uint32_t seed = 1);

}  // namespace cairn::sim
