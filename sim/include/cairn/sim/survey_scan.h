// Copyright Cairn authors.
//
// Sparse, noisy survey scans made from a World: the point cloud a low-resolution lidar survey of a site gives
// (floors thinned to ~50 points/m², walls and ceilings with holes, floor holes, single stray returns in open
// space), to be written as a PCD and loaded back with LoadWorld(), e.g. to test the loader's clean-up and the
// staircase detector on the kind of scan users have. Seeded, deterministic.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cairn/sim/world.h"

namespace cairn::sim {

/// A rectangular opening cut into the floor of a survey scan (a well, a shaft, a stairwell seen from above).
struct SurveyWell {
  /// Horizontal extent of the opening, metres, frame W (x, y).
  Eigen::AlignedBox2d box_W;
  /// If set, the well's bottom is seen at this height (points every 0.05 m over the opening), metres, frame
  /// W.
  std::optional<double> bottom_z_m;
};

/// A thin strip of floor with no return (a lidar artefact: a sweep that skipped a band of the floor).
struct SurveyStrip {
  /// Start of the strip's centre line (x, y), metres, frame W.
  Eigen::Vector2d p_W_start = Eigen::Vector2d::Zero();
  /// End of the strip's centre line (x, y), metres, frame W.
  Eigen::Vector2d p_W_end = Eigen::Vector2d::Zero();
  /// Full width across the centre line (no floor point within width_m / 2 of the segment), metres, range
  /// (0, 10].
  double width_m = 0.2;
};

/// Options of MakeSurveyScan(). The defaults are the degraded geb079 copy (DegradedGeb079Options()), except
/// the floor rule, the holes, the wells and the regions, which depend on the world.
struct SurveyScanOptions {
  /// Points per m² kept on floors (only the top voxel of a floor is scanned), range (0, 1 / resolution²].
  double floor_points_per_m2 = 50.0;
  /// Fraction of the other surface voxels (walls, ceilings, steps' faces) that give a point, range [0, 1].
  double wall_keep_fraction = 0.7;
  /// Floor rule. If set, floors are the voxels whose centre lies below this height (a single-level scan whose
  /// floor slab is below z = 0, like geb079) and every other occupied voxel is a wall voxel. If not set,
  /// floors are the occupied voxels with a free voxel above (every upward-facing surface: floors, treads,
  /// platforms, table tops) and voxels with all six neighbours occupied (inside a solid) give no point.
  std::optional<double> floor_below_z_m;
  /// Centres of round floor holes (no floor point within hole_radius_m), metres, frame W.
  std::vector<Eigen::Vector2d> hole_centres_W;
  /// Radius of the floor holes, metres, range [0, 10].
  double hole_radius_m = 0.2;
  /// Openings cut into the floor.
  std::vector<SurveyWell> wells;
  /// Strips of floor with no point (walls, ceilings and steps' faces in them keep their points).
  std::vector<SurveyStrip> missing_strips;
  /// true: space outside the grid counts as occupied when a voxel's neighbours are tested (top surface,
  /// inside a solid), so a survey of a world whose grid ends at its outer walls, floor slab and roof (e.g.
  /// "builtin:plant") sees only the inside of the building, as a survey made inside does. false: outside
  /// the grid is free (the outer faces of the grid's outermost voxels give points).
  bool outside_is_solid = false;
  /// Number of single stray returns added in open space, range [0, 100000].
  int num_strays = 300;
  /// Where strays are drawn (uniformly), metres, frame W; empty: the world's bounds.
  Eigen::AlignedBox3d stray_region_W;
  /// A stray is at least this far (in x, y and z) from every occupied voxel of the world, metres.
  double stray_clearance_m = 0.5;
  /// Strays are pairwise farther apart than this (single returns, not clusters), metres.
  double stray_spacing_m = 0.6;
  /// Region (x, y, open box) of floor over which SurveyScan::floor_points_per_m2 is measured; empty:
  /// everywhere.
  Eigen::AlignedBox2d density_region_W;

  /// True when every field is in range (floor_points_per_m2 finite and > 0, wall_keep_fraction in [0, 1],
  /// hole_radius_m in [0, 10], num_strays in [0, 100000], stray_clearance_m and stray_spacing_m finite and
  /// >= 0, every strip's ends finite and width in (0, 10]); otherwise false and, if `why` is not null, a
  /// message naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// A survey scan and what was done to make it.
struct SurveyScan {
  /// The scan, N x 3, metres, frame W (the world's frame).
  std::vector<Eigen::Vector3f> points_W;
  /// The stray returns added (also in points_W), metres, frame W.
  std::vector<Eigen::Vector3d> strays_W;
  /// Floor points per m² measured over SurveyScanOptions::density_region_W.
  double floor_points_per_m2 = 0.0;
};

/// Makes a survey scan of `truth`: every kept voxel gives one point jittered uniformly within the voxel
/// (floor points at a height uniform in [-0.06, -0.01] m below the floor top when floor_below_z_m is set,
/// else within the voxel); floors are thinned to floor_points_per_m2, other surfaces keep wall_keep_fraction
/// of their voxels; no floor point inside a hole, a well or a missing strip; stray points added as the
/// options say (at most 1000 draws per stray overall; fewer strays if open space is that rare). Deterministic
/// for a given `seed`. Cost: one pass over the grid. Throws WorldError (the message from IsValid()) if
/// `options` is invalid.
SurveyScan MakeSurveyScan(const World& truth, const SurveyScanOptions& options, std::uint32_t seed);

/// The degraded copy of the real scan data/geb079.bt used by the sparse-scan tests and benches
/// (with seed 79): floor below z = 0 thinned to 50 points/m², walls and ceiling keep 70 %, ten 0.4 m floor
/// holes along the corridor (x = 0, 2, ..., 18), well A (x in [8, 8.5], y in [-1.2, -0.7], bottom seen at
/// -2.03 m: a shaft) and well B (x in [20, 21.2], y in [-1.4, -0.4], nothing seen below), 300 strays in x in
/// [-6, 28], y in [-6, 6], z in [0.3, 2.3]; density measured on the corridor (x in [-4, 26], |y| < 1).
SurveyScanOptions DegradedGeb079Options();

/// Writes `points` (metres) as a binary PCD file (fields x y z, float32) that LoadWorld() reads.
/// Throws WorldError naming the path if the file cannot be written.
void WritePcd(const std::string& path, const std::vector<Eigen::Vector3f>& points);

}  // namespace cairn::sim
