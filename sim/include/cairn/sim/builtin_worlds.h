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
/// at heights p_W_first_riser.z() + k * rise_m (k = 1..num_steps), risers at (k - 1) * run_m
/// (k = 1..num_steps) along (cos yaw, sin yaw, 0) from the first riser; the top tread may continue into a
/// landing or a floor.
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

/// Names of the built-in worlds, without the "builtin:" prefix: {"tunnels", "narrow", "arena", "building",
/// "plant"}.
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
///  - "plant": a single-storey industrial building of survey-scan size, 90 x 60 m at 0.1 m (x in [0, 90],
///    y in [0, 60], z in [-0.2, 6.2]; the grid is exactly its solid envelope): floor surface at z = 0 (slab
///    0.2 m), roof slab z in [6.0, 6.2], outer walls 0.3 m, inner walls 0.2 m and full height. A voxel is
///    occupied when its centre lies in (or on the face of) a solid box.
///    Hall x in [0.3, 50], y in [0.3, 59.7]: eight rack rows (solid, 1.0 m deep along x, 2.5 m tall) at
///    x in [16 + 4j, 17 + 4j] (j = 0..7, so 3 m aisles), y in [4, 56], cut by a 3 m cross aisle (y in
///    [28.5, 31.5]) and, per half row, one 2 m gap at a seeded y; an east aisle x in [45, 50]; five machines
///    (1-2 m boxes, 1-2 m high, seeded, within 1.55 m of (4, 6), (4, 16), (4, 26), (11, 8), (11, 32)).
///    Mezzanine along the west wall: slab x in [0.3, 6.0], y in [36, 59.7], top at z = 3.0 (0.2 m thick,
///    free space below: 2.8 m headroom, columns 0.4 m square at x in [5.4, 5.8], y = 39, 51, 57), 1.0 m
///    balustrades on its open edges. One straight staircase up to it along -x, y in [44.4, 45.6] (1.2 m
///    wide): 17 risers of 3.0 / 17 m (0.176 m), run 0.28 m, first riser at x = 11.68, last (17th) riser the
///    edge of a landing x in [6.0, 7.2] at z = 3.0 (free below, balustrades on its sides) that joins the
///    mezzanine; the 16 treads are filled down to the floor. The foot is at (12.6, 45), the top at (6.6, 45).
///    Office wing x in [50.2, 89.7], y in [30.2, 59.7]: corridor y in [43.5, 46.5] (3 m) from the hall (a
///    3 m wide, 2.5 m high opening) to the east wall; rooms x in [50.2, 58], [58.2, 66], [66.2, 74],
///    [74.2, 82], [82.2, 89.7] on both sides (south y in [30.2, 43.3], north y in [46.7, 59.7]), each behind
///    a 2.1 m high doorway, 1.0 m wide centred at x = 51.7, 59.7, 67.7, 75.7, 83.7, except the third south
///    room's 0.9 m doorway (x in [67.2, 68.1]). In the second north room, a cabinet (x in [61, 63], y in
///    [59.1, 59.7], 1.8 m tall) behind a single 0.15 m step (x in [61, 63], y in [58.1, 59.1]; its voxels
///    reach z = 0.2): one step, not a staircase.
///    Loading bay x in [50.2, 89.7], y in [0.3, 30.0]: a 6 m wide, 4.5 m high opening to the hall (y in
///    [10, 16]), four closed dock doors recessed 0.1 m into the south wall (3 m wide, 4 m high, centred at
///    x = 60, 68, 76, 84), 1-3 seeded pallet stacks (1.2 x 1.0 m, 0.4-1.6 m high) in y in [2, 6.6] before
///    each, two machines near (57, 23) and (79, 22). The seed varies only the rack gaps, the machines and the
///    pallet stacks.
std::vector<std::string> BuiltinWorldNames();

/// Description, suggested starts and far goal of built-in world `name` (without prefix).
/// Throws WorldError listing the valid names if `name` is unknown.
const BuiltinWorldInfo& GetBuiltinWorldInfo(const std::string& name);

/// Builds built-in world `name` (without prefix) with generator seed `seed` (the seed changes the wall and
/// ceiling roughness, or in "plant" the rack gaps, machines and pallets, only; the layout, starts, goal and
/// staircases stay valid). Deterministic.
/// Throws WorldError listing the valid names if `name` is unknown.
World MakeBuiltinWorld(const std::string& name, std::uint32_t seed = 1);

}  // namespace cairn::sim
