// Copyright Cairn authors.
//
// A dense 3D occupancy grid, one bit per voxel: the simulator's ground-truth world (cairn::sim::World) and
// the robot's own map as navigation reads it (built from its OctoMap). DDS-free.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::core {

/// Error raised when a grid cannot be built; the message names the grid, the field and the value.
class VoxelGridError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A dense, axis-aligned 3D occupancy grid in the world frame W (the frame its producer names: the simulated
/// world, or the robot's map frame M) (z up), one bit per voxel.
///
/// Voxel (ix, iy, iz), with 0 <= ix < dims().x() etc., covers the box
/// [p_W_min + (ix, iy, iz) * resolution_m, p_W_min + (ix+1, iy+1, iz+1) * resolution_m). Points outside the
/// grid are free. A voxel is either occupied or not: the grid does not tell free from unknown space.
class VoxelGrid {
 public:
  /// Default largest grid, in voxels.
  static constexpr std::int64_t kDefaultMaxVoxels = 500'000'000;

  /// Builds an all-free grid named `name` with min corner `p_W_min` (metres, frame W), voxel edge
  /// `resolution_m` (> 0, finite) and `dims` voxels per axis (each >= 1).
  /// Throws VoxelGridError if a value is invalid or dims.prod() > max_voxels.
  VoxelGrid(std::string name, const Eigen::Vector3d& p_W_min, double resolution_m,
            const Eigen::Vector3i& dims, std::int64_t max_voxels = kDefaultMaxVoxels);

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
  /// Heap memory the grid holds, bytes (its bit words, one bit per voxel, and its name); not sizeof(*this).
  std::size_t MemoryBytes() const { return bits_.capacity() * sizeof(std::uint64_t) + name_.capacity(); }

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
  /// True if the voxel at linear storage index `linear` (LinearIndex() of an in-grid voxel) is occupied.
  /// Unchecked: for walks that keep their own bounds (a ray's traversal steps the index by +-1, +-dims.z()
  /// or +-dims.y() * dims.z() instead of recomputing it).
  bool IsOccupiedLinear(std::int64_t linear) const {
    return (bits_[static_cast<std::size_t>(linear >> 6)] >> (linear & 63)) & 1u;
  }
  /// Marks voxel `index` occupied (or free). Throws std::out_of_range outside the grid.
  void SetOccupied(const Eigen::Vector3i& index, bool occupied = true);
  /// Frees every voxel of the columns (ix, iy) for iy in [iy_first, iy_last], at every height. They are one
  /// run of bits in storage order (z fastest, then y), cleared 64 at a time: clearing a 4 m x 4 m tile's
  /// columns costs a few hundred stores instead of one checked call per voxel. Nothing happens when
  /// iy_first > iy_last; throws std::out_of_range when a column in the range is outside the grid.
  void FreeColumns(int ix, int iy_first, int iy_last);
  /// Marks the voxel containing `p_W` occupied; returns false (and does nothing) outside the grid.
  bool SetOccupiedAt(const Eigen::Vector3d& p_W, bool occupied = true);
  /// Number of occupied voxels.
  std::int64_t CountOccupied() const;
  /// Calls `visit(index)` (an Eigen::Vector3i) for every occupied voxel, in storage order. Skips free space
  /// 64 voxels at a time: costs about one load per 64 voxels plus one call per occupied voxel.
  template <class Visit>
  void ForEachOccupied(Visit&& visit) const {
    const std::int64_t column = dims_.z(), plane = static_cast<std::int64_t>(dims_.y()) * column;
    for (std::size_t w = 0; w < bits_.size(); ++w) {
      for (std::uint64_t word = bits_[w]; word != 0; word &= word - 1) {
        const std::int64_t i = static_cast<std::int64_t>(w) * 64 + __builtin_ctzll(word);
        visit(Eigen::Vector3i(static_cast<int>(i / plane), static_cast<int>((i % plane) / column),
                              static_cast<int>(i % column)));
      }
    }
  }
  /// The highest occupied voxel z index of column (ix, iy) at or below `iz` (clamped to the grid's top), or
  /// -1 when there is none or the column is outside the grid. Reads the column 64 voxels at a time, so a scan
  /// down a mostly free column costs a few loads instead of one test per voxel.
  int HighestOccupiedInColumn(int ix, int iy, int iz) const;

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

}  // namespace cairn::core
