// Copyright Cairn authors.
//
// The robot's 3D occupancy map: an OctoMap built from lidar scans and SLAM poses, queried by planners and
// exploration, and diffed into coarse voxels for map telemetry. See perception/README.md. OctoMap stays
// behind a pimpl: only occupancy_map.cpp includes its headers.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <iosfwd>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/perception/coarse_voxel.h"

namespace cairn::perception {

/// Error raised by OccupancyMap for invalid options or arguments and for map files that cannot be written or
/// read. The message names the field or path and the value at fault (e.g. "map file '/x/m.bt' is truncated:
/// ...").
class MapError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Options of an OccupancyMap. Probabilities follow OctoMap's sensor model (Hornung et al., "OctoMap: an
/// efficient probabilistic 3D mapping framework based on octrees", Autonomous Robots 2013, eq. 2-3): each
/// observation adds log(p / (1 - p)) to a voxel's log-odds, clamped to [clamping_min, clamping_max]; a voxel
/// is occupied when its probability is >= 0.5.
struct OccupancyMapOptions {
  /// Edge of the finest voxel, metres, range [0.01, 10]. The map spans +-32768 voxels around the origin of W
  /// on each axis (+-3276.8 m at 0.1 m).
  double resolution_m = 0.1;
  /// Longest ray used, metres, range (0, 30000 * resolution_m]. Points farther than this from the sensor
  /// carve free space up to max_range_m and mark no hit.
  double max_range_m = 30.0;
  /// Probability that a voxel holding a scan end point is occupied, range (0.5, 1).
  double probability_hit = 0.7;
  /// Probability that a voxel crossed by a ray is occupied, range (0, 0.5).
  double probability_miss = 0.4;
  /// Lower clamp of a voxel's occupancy probability, range (0, 0.5).
  double clamping_min = 0.12;
  /// Upper clamp of a voxel's occupancy probability, range (0.5, 1).
  double clamping_max = 0.97;
  /// Cast one ray per end-point voxel (to the first point of the scan in it) instead of one per point: ~1.5x
  /// faster insertion of VLP-16 scans in tunnels, 3-5x of dense close-range scans (bench/map_insert.cpp), at
  /// the cost of a few missed free-space updates (see OccupancyMap::InsertScan). False (and
  /// floor_guard_layers 0) gives exactly OctoMap's insertPointCloud map.
  bool one_ray_per_endpoint_voxel = true;
  /// Floor-erosion guard: a ray whose end point lies more than this many voxel layers below the sensor's
  /// carves no free space in the end point's layer nor the layers above it up to this many in all, [0, 8];
  /// 0 gives OctoMap's update. A VLP-16's low beams meet a floor 2-6 m away at 5-15 degrees, so each ray
  /// crosses the floor's own layer over 0.4-1.1 m before its end: misses outnumber the hits there and the
  /// floor is erased (worst when the floor lies on a voxel boundary and its hits fall in either layer). In
  /// geb079.bt, whose corridor floor is at z = 0.00, the corridor a robot had driven was unknown in its map,
  /// both layers free or never hit (cairn_bench_explore). Free space at those heights is still carved by the
  /// rays that end lower (a drop, a stairwell) or meet a wall there.
  int floor_guard_layers = 2;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// State of a voxel.
enum class Occupancy {
  kUnknown,   ///< Never observed (or outside the map).
  kFree,      ///< Observed, occupancy probability < 0.5.
  kOccupied,  ///< Observed, occupancy probability >= 0.5.
};

/// What one OccupancyMap::InsertScan() call did, for logs, tests and benchmarks.
struct InsertStats {
  /// Points given, points_S.size().
  std::int64_t points_in = 0;
  /// Points dropped because a coordinate was NaN or infinite.
  std::int64_t dropped_non_finite = 0;
  /// Points farther than max_range_m from the sensor: their ray carved free space up to max_range_m, no hit.
  std::int64_t clipped_max_range = 0;
  /// Points (or clipped ray ends) outside the map's extent (see OccupancyMapOptions::resolution_m): dropped
  /// with their whole ray, as OctoMap does.
  std::int64_t dropped_out_of_map = 0;
  /// Distinct voxels holding an end point within max_range_m.
  std::int64_t unique_endpoints = 0;
  /// Distinct voxels given a miss (crossed by a ray, holding no end point of this scan).
  std::int64_t free_updates = 0;
  /// Distinct voxels given a hit (equals unique_endpoints).
  std::int64_t occupied_updates = 0;
};

/// A probabilistic 3D occupancy map (an OctoMap OcTree) in frame W, z up, metres, built from lidar scans.
///
/// Thread safety: one writer thread may call InsertScan() and TakeCoarseChanges() while any number of
/// threads call the const queries; writers take an exclusive lock (a std::shared_mutex), queries a shared
/// one, and a waiting writer goes before new queries, so back-to-back queries cannot starve the mapping
/// thread. Moving a map is not thread-safe, and a moved-from map may only be destroyed or assigned to.
///
/// Insertion (InsertScan) builds the map OctoMap's `OcTree::insertPointCloud(cloud, origin, max_range_m)`
/// builds, faster; see InsertScan() for the two deviations.
class OccupancyMap {
 public:
  /// Largest `coarse_levels` accepted by TakeCoarseChanges() and CoarseSnapshot().
  static constexpr int kMaxCoarseLevels = 6;

  /// An empty map (every voxel unknown). Throws MapError naming the field if `options` is not valid.
  explicit OccupancyMap(const OccupancyMapOptions& options = {});
  ~OccupancyMap();
  OccupancyMap(OccupancyMap&& other) noexcept;
  OccupancyMap& operator=(OccupancyMap&& other) noexcept;
  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Options in force (for a loaded map, resolution_m is the file's).
  const OccupancyMapOptions& options() const;
  /// Edge of the finest voxel, metres.
  double resolution_m() const { return options().resolution_m; }

  /// Inserts one scan: `points_S` (N points, metres, sensor frame S; any order) seen from the sensor pose
  /// `T_W_S` (pose of S in W). For each point p_W = T_W_S * p_S within max_range_m of the sensor origin
  /// p_W_S, the voxels crossed by the segment p_W_S -> p_W get a miss and the voxel holding p_W a hit; a
  /// voxel holding an end point of this scan is never also given a miss. Points beyond max_range_m carve free
  /// space up to max_range_m only. NaN/inf points are dropped and counted; an empty scan is a no-op.
  ///
  /// Result: with options().one_ray_per_endpoint_voxel false and floor_guard_layers 0, exactly the map of
  /// `OcTree::insertPointCloud(cloud_W, p_W_S, max_range_m)` (same voxels, log-odds and pruning; ray
  /// traversal, end-point voxels and max-range clipping use OctoMap's own float arithmetic and
  /// computeRayKeys). With it true (the default), one ray is cast per end-point voxel, to the first point of
  /// the scan in it, so voxels crossed only by the other points' rays into that voxel get no miss. The map is
  /// then conservative against OctoMap's: every voxel OctoMap's map holds occupied is occupied here, a few
  /// (about 0.2 % of the occupied voxels in lidar scans of tunnels, see bench/map_insert.cpp) are occupied
  /// here and free there, and a few voxels (about 0.3 % of the known ones) stay unknown. With
  /// floor_guard_layers > 0 (the default 2), rays that end well below the sensor carve nothing in the layers
  /// at their end point's height, so a floor seen at grazing incidence is kept (OccupancyMapOptions).
  ///
  /// Throws MapError if T_W_S is not finite or the sensor origin lies outside the map's extent.
  InsertStats InsertScan(const std::vector<Eigen::Vector3f>& points_S, const Eigen::Isometry3d& T_W_S);

  /// State of the voxel holding `p_W` (metres, frame W); kUnknown if p_W is not finite or outside the map.
  Occupancy Query(const Eigen::Vector3d& p_W) const;

  /// Walks the voxels crossed by the ray from `origin_W` along `direction_W` (frame W; any non-zero length),
  /// starting with the voxel holding origin_W, up to `max_range_m` metres, and returns the centre (metres,
  /// frame W) of the first occupied voxel, or of the first unknown one when `unknown_is_occupied`; nullopt if
  /// none is met within max_range_m or before the ray leaves the map (also if origin_W is outside the map).
  /// Throws MapError if origin_W or direction_W is not finite, direction_W is zero, or max_range_m is
  /// negative or not finite.
  std::optional<Eigen::Vector3d> CastRay(const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
                                         double max_range_m, bool unknown_is_occupied) const;

  /// Centres (metres, frame W) of the occupied voxels of edge resolution_m (half-open, as in coarse_voxel.h)
  /// holding at least one point of `box_W` (frame W, closed); coarse (pruned) leaves are expanded to their
  /// resolution_m voxels. In no particular order; empty if the box is empty. Throws MapError if a corner of
  /// the box is NaN.
  std::vector<Eigen::Vector3d> OccupiedInBox(const Eigen::AlignedBox3d& box_W) const;
  /// The same for the known-free voxels (observed empty: a lidar ray passed through them); unknown space is
  /// in neither list.
  std::vector<Eigen::Vector3d> FreeInBox(const Eigen::AlignedBox3d& box_W) const;

  /// Number of occupied voxels of edge resolution_m (a pruned leaf of edge 2^k * resolution_m counts as its
  /// 8^k voxels, so the figure does not depend on pruning).
  std::int64_t NumOccupiedLeaves() const;
  /// Number of known (free or occupied) voxels of edge resolution_m, counted as NumOccupiedLeaves().
  std::int64_t NumKnownLeaves() const;
  /// Number of nodes of the underlying OctoMap tree (inner nodes and leaves, after pruning); equals
  /// `OcTree::size()` of the tree insertPointCloud builds from the same scans (with
  /// one_ray_per_endpoint_voxel false).
  std::int64_t NumTreeNodes() const;
  /// Heap memory held by the map, bytes: OctoMap's estimate of the tree plus the change-tracking set and the
  /// insertion scratch buffers.
  std::size_t MemoryBytes() const;

  /// Writes the map as an OctoMap binary file (.bt): maximum-likelihood occupancy, pruned, exactly the bytes
  /// `OcTree::writeBinary()` writes for this map (except that a resolution needing more than 6 significant
  /// digits is written in full rather than rounded), without modifying the map. Writes to `path` + ".tmp" and
  /// renames, so readers never see a partial file. Throws MapError naming the path if it cannot be written.
  void SaveBt(const std::string& path) const;

  /// Reads a map written by SaveBt() or any OctoMap OcTree binary file (.bt) at `path`. The resolution comes
  /// from the file; every other option from `options`. Voxels read are clamped to clamping_min/clamping_max
  /// (a .bt file holds only free/occupied). The header (first line, id OcTree, size, res) and the whole node
  /// stream are validated before OctoMap parses them. Throws MapError naming the path and the fault when the
  /// file is missing, unreadable, empty, not an OctoMap binary file (e.g. text or .ot), of another tree type,
  /// has an invalid resolution, or is corrupt or truncated; or when `options` is not valid.
  static OccupancyMap LoadBt(const std::string& path, const OccupancyMapOptions& options = {});

  /// Writes the bytes of SaveBt()'s file to `out` (e.g. a telemetry baseline). Throws MapError if `out`
  /// fails.
  void WriteBinary(std::ostream& out) const;

  /// Coarse voxels (edge resolution_m * 2^coarse_levels, frame W, see coarse_voxel.h) whose state may have
  /// changed since the previous call (since construction or load for the first call), each with its current
  /// state; known voxels only, in octree (Morton) order, no duplicates. A coarse voxel is kOccupied if any of
  /// its fine voxels is occupied, kFree if some are known and none occupied. Never misses a change; may
  /// report a voxel whose state changed and changed back, and, when coarse_levels is finer than the previous
  /// call's, every known voxel inside the previous level's changed voxels. Tracking memory is bounded by the
  /// number of changed voxels at the level of the previous call (kMaxCoarseLevels before the first call).
  /// Throws MapError if coarse_levels is outside [0, kMaxCoarseLevels].
  std::vector<CoarseVoxel> TakeCoarseChanges(int coarse_levels);

  /// Every known coarse voxel at `coarse_levels` with its state, as TakeCoarseChanges() reports them, in
  /// octree (Morton) order (e.g. for a basestation joining late). Does not affect change tracking.
  /// Throws MapError if coarse_levels is outside [0, kMaxCoarseLevels].
  std::vector<CoarseVoxel> CoarseSnapshot(int coarse_levels) const;

 private:
  std::vector<Eigen::Vector3d> VoxelsInBox(const Eigen::AlignedBox3d& box_W, bool occupied) const;

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::perception
