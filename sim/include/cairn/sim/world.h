// Copyright Cairn authors.
//
// Dense 3D voxel occupancy worlds for simulation: built-in procedural worlds, OctoMap (.bt/.ot) files and
// PCD point clouds. See DESIGN.md "Simulation".
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::sim {

/// Error raised when a world cannot be built or loaded. The message names the path or field and the value
/// at fault (e.g. "world file '/x/y.bt' does not exist").
class WorldError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Options for LoadWorld().
struct WorldLoadOptions {
  /// Voxel edge used to voxelize PCD point clouds, metres, range [0.02, 2].
  double pcd_resolution_m = 0.1;
  /// Seed of the procedural generator for `builtin:` worlds, any value; same seed -> same world.
  std::uint32_t builtin_seed = 1;
  /// Largest grid (number of voxels, occupied or not) a load may allocate, range [1, 2e9]. The default
  /// (500 M voxels) takes 62.5 MB as a bit grid.
  std::int64_t max_voxels = 500'000'000;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// A dense, axis-aligned 3D occupancy grid in the world frame W (z up), one bit per voxel.
///
/// Voxel (ix, iy, iz), with 0 <= ix < dims().x() etc., covers the box
/// [p_W_min + (ix, iy, iz) * resolution_m, p_W_min + (ix+1, iy+1, iz+1) * resolution_m). Points outside the
/// grid are free. A voxel is either occupied or not: the grid does not tell free from unknown space.
class World {
 public:
  /// Default largest grid, in voxels.
  static constexpr std::int64_t kDefaultMaxVoxels = 500'000'000;

  /// Builds an all-free grid named `name` with min corner `p_W_min` (metres, frame W), voxel edge
  /// `resolution_m` (> 0, finite) and `dims` voxels per axis (each >= 1).
  /// Throws WorldError if a value is invalid or dims.prod() > max_voxels.
  World(std::string name, const Eigen::Vector3d& p_W_min, double resolution_m, const Eigen::Vector3i& dims,
        std::int64_t max_voxels = kDefaultMaxVoxels);

  /// Name given at construction (for loaded worlds: the spec, e.g. "builtin:tunnels" or the file path).
  const std::string& name() const { return name_; }
  /// Voxel edge, metres.
  double resolution_m() const { return resolution_m_; }
  /// Number of voxels along x, y, z.
  const Eigen::Vector3i& dims() const { return dims_; }
  /// Min corner of the grid, metres, frame W.
  const Eigen::Vector3d& p_W_min() const { return p_W_min_; }
  /// Max corner of the grid, metres, frame W.
  Eigen::Vector3d p_W_max() const { return p_W_min_ + dims_.cast<double>() * resolution_m_; }
  /// Axis-aligned box [p_W_min, p_W_max], metres, frame W.
  Eigen::AlignedBox3d bounds() const { return Eigen::AlignedBox3d(p_W_min_, p_W_max()); }
  /// Total number of voxels, dims().prod().
  std::int64_t num_voxels() const { return num_voxels_; }

  /// True if `index` lies in the grid.
  bool Contains(const Eigen::Vector3i& index) const {
    return index.x() >= 0 && index.y() >= 0 && index.z() >= 0 && index.x() < dims_.x() &&
           index.y() < dims_.y() && index.z() < dims_.z();
  }
  /// Index of the voxel containing `p_W` (metres, frame W), or nullopt if outside the grid or not finite.
  std::optional<Eigen::Vector3i> IndexOf(const Eigen::Vector3d& p_W) const;
  /// Centre of voxel `index` (metres, frame W); defined for any index, also outside the grid.
  Eigen::Vector3d CenterOf(const Eigen::Vector3i& index) const {
    return p_W_min_ + (index.cast<double>().array() + 0.5).matrix() * resolution_m_;
  }

  /// True if the voxel containing `p_W` (metres, frame W) is occupied; false outside the grid.
  bool IsOccupied(const Eigen::Vector3d& p_W) const;
  /// True if voxel `index` is occupied; false outside the grid.
  bool IsOccupiedIndex(const Eigen::Vector3i& index) const {
    if (!Contains(index)) return false;
    const std::int64_t i = LinearIndex(index);
    return (bits_[static_cast<std::size_t>(i >> 6)] >> (i & 63)) & 1u;
  }
  /// Marks voxel `index` occupied (or free). Throws std::out_of_range outside the grid.
  void SetOccupied(const Eigen::Vector3i& index, bool occupied = true);
  /// Marks the voxel containing `p_W` occupied; returns false (and does nothing) outside the grid.
  bool SetOccupiedAt(const Eigen::Vector3d& p_W, bool occupied = true);
  /// Number of occupied voxels.
  std::int64_t CountOccupied() const;

  /// Linear storage index of an in-grid voxel; z varies fastest, so a column (ix, iy) is contiguous.
  std::int64_t LinearIndex(const Eigen::Vector3i& index) const {
    return (static_cast<std::int64_t>(index.x()) * dims_.y() + index.y()) * dims_.z() + index.z();
  }

 private:
  std::string name_;
  Eigen::Vector3d p_W_min_;
  double resolution_m_;
  Eigen::Vector3i dims_;
  std::int64_t num_voxels_;
  std::vector<std::uint64_t> bits_;
};

/// What LoadWorld() read, for logs and tests.
struct WorldLoadReport {
  /// "builtin", "bt", "ot" or "pcd".
  std::string kind;
  /// Occupied OctoMap leaves read (.bt/.ot), 0 otherwise.
  std::int64_t leaves_occupied = 0;
  /// Points in the PCD file (.pcd), 0 otherwise.
  std::int64_t points_total = 0;
  /// PCD points dropped because a coordinate was NaN or infinite.
  std::int64_t points_dropped_non_finite = 0;
};

/// Loads or builds the world named by `spec`:
///  - `builtin:NAME`: a procedural world (see BuiltinWorldNames(), builtin_worlds.h), seeded by
///    options.builtin_seed;
///  - a path ending `.bt` (OctoMap binary) or `.ot` (OctoMap full, OcTree only): every occupied leaf, coarse
///    leaves expanded into voxels at the tree resolution; the grid spans the occupied leaves;
///  - a path ending `.pcd` (PCL, fields x y z): every finite point voxelized at options.pcd_resolution_m;
///    NaN/inf points are dropped and counted in `report`.
/// Frames: the file's frame is taken as W, z up. Units: metres.
/// Throws WorldError naming the path/field and value when: options are invalid, the builtin name is
/// unknown (the message lists valid names), the extension is unknown, the file is missing or unreadable,
/// the file is not a valid .bt/.ot/.pcd (corrupt or truncated), the map has no occupied voxel, a PCD has no
/// finite point, or the grid would exceed options.max_voxels.
/// If `report` is not null it is filled with what was read.
World LoadWorld(const std::string& spec, const WorldLoadOptions& options = {},
                WorldLoadReport* report = nullptr);

/// Writes the occupied voxels of `world` as an OctoMap binary file (.bt) at the world's resolution, e.g. to
/// view a builtin world in octovis. Exact round trip with LoadWorld when p_W_min is a multiple of
/// resolution_m (true for builtin worlds and loaded .bt files). Throws WorldError if the file cannot be
/// written.
void SaveWorldAsBt(const World& world, const std::string& path);

}  // namespace cairn::sim
