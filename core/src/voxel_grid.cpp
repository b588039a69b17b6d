// Copyright Cairn authors.
#include "cairn/core/voxel_grid.h"

#include <algorithm>
#include <bitset>
#include <cmath>
#include <sstream>

namespace cairn::core {

VoxelGrid::VoxelGrid(std::string name, const Eigen::Vector3d& p_W_min, double resolution_m,
                     const Eigen::Vector3i& dims, std::int64_t max_voxels)
    : name_(std::move(name)), p_W_min_(p_W_min), resolution_m_(resolution_m), dims_(dims), num_voxels_(0) {
  if (!std::isfinite(resolution_m) || resolution_m <= 0.0) {
    throw VoxelGridError("voxel grid '" + name_ + "': resolution_m = " + std::to_string(resolution_m) +
                         " must be finite and > 0");
  }
  if (!p_W_min.allFinite()) {
    throw VoxelGridError("voxel grid '" + name_ + "': p_W_min must be finite");
  }
  if (dims.minCoeff() < 1) {
    std::ostringstream msg;
    msg << "voxel grid '" << name_ << "': dims (" << dims.x() << ", " << dims.y() << ", " << dims.z()
        << ") must all be >= 1";
    throw VoxelGridError(msg.str());
  }
  const double n = static_cast<double>(dims.x()) * dims.y() * dims.z();
  if (n > static_cast<double>(max_voxels)) {
    std::ostringstream msg;
    msg << "voxel grid '" << name_ << "': grid of " << dims.x() << " x " << dims.y() << " x " << dims.z()
        << " = " << n << " voxels is too large (limit " << max_voxels << " voxels, max_voxels)";
    throw VoxelGridError(msg.str());
  }
  num_voxels_ = static_cast<std::int64_t>(dims.x()) * dims.y() * dims.z();
  bits_.assign(static_cast<std::size_t>((num_voxels_ + 63) / 64), 0u);
}

std::optional<Eigen::Vector3i> VoxelGrid::IndexOf(const Eigen::Vector3d& p_W) const {
  if (!p_W.allFinite()) return std::nullopt;
  const Eigen::Vector3d q = (p_W - p_W_min_) / resolution_m_;
  if ((q.array() < 0.0).any() || (q.array() >= dims_.cast<double>().array()).any()) return std::nullopt;
  Eigen::Vector3i index(static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
                        static_cast<int>(std::floor(q.z())));
  if (!Contains(index)) return std::nullopt;  // Guards rounding at the max faces.
  return index;
}

bool VoxelGrid::IsOccupied(const Eigen::Vector3d& p_W) const {
  const auto index = IndexOf(p_W);
  return index.has_value() && IsOccupiedIndex(*index);
}

void VoxelGrid::SetOccupied(const Eigen::Vector3i& index, bool occupied) {
  if (!Contains(index)) {
    std::ostringstream msg;
    msg << "VoxelGrid::SetOccupied: index (" << index.x() << ", " << index.y() << ", " << index.z()
        << ") is outside the grid " << dims_.x() << " x " << dims_.y() << " x " << dims_.z();
    throw std::out_of_range(msg.str());
  }
  const std::int64_t i = LinearIndex(index);
  const std::uint64_t mask = std::uint64_t{1} << (i & 63);
  if (occupied) {
    bits_[static_cast<std::size_t>(i >> 6)] |= mask;
  } else {
    bits_[static_cast<std::size_t>(i >> 6)] &= ~mask;
  }
}

void VoxelGrid::FreeColumns(int ix, int iy_first, int iy_last) {
  if (iy_first > iy_last) return;
  if (!Contains({ix, iy_first, 0}) || !Contains({ix, iy_last, 0})) {
    std::ostringstream msg;
    msg << "VoxelGrid::FreeColumns: columns x = " << ix << ", y = " << iy_first << ".." << iy_last
        << " are not all inside the grid " << dims_.x() << " x " << dims_.y() << " x " << dims_.z();
    throw std::out_of_range(msg.str());
  }
  // Bits [begin, end) of the run: whole words in the middle, masked words at either end.
  const std::int64_t begin = LinearIndex({ix, iy_first, 0});
  const std::int64_t end = LinearIndex({ix, iy_last, 0}) + dims_.z();
  const std::int64_t first_word = begin >> 6;
  const std::int64_t last_word = (end - 1) >> 6;
  for (std::int64_t w = first_word; w <= last_word; ++w) {
    std::uint64_t keep = 0;  // the bits of word w outside [begin, end)
    if (w == first_word) keep |= (std::uint64_t{1} << (begin & 63)) - 1;
    if (w == last_word && (end & 63) != 0) keep |= ~((std::uint64_t{1} << (end & 63)) - 1);
    bits_[static_cast<std::size_t>(w)] &= keep;
  }
}

bool VoxelGrid::SetOccupiedAt(const Eigen::Vector3d& p_W, bool occupied) {
  const auto index = IndexOf(p_W);
  if (!index) return false;
  SetOccupied(*index, occupied);
  return true;
}

std::int64_t VoxelGrid::CountOccupied() const {
  std::int64_t n = 0;
  for (const std::uint64_t word : bits_) n += static_cast<std::int64_t>(std::bitset<64>(word).count());
  return n;
}

int VoxelGrid::HighestOccupiedInColumn(int ix, int iy, int iz) const {
  if (ix < 0 || iy < 0 || ix >= dims_.x() || iy >= dims_.y()) return -1;
  iz = std::min(iz, dims_.z() - 1);
  if (iz < 0) return -1;
  const std::int64_t base = LinearIndex({ix, iy, 0});  // the column is bits [base, base + dims_.z())
  std::int64_t i = base + iz;
  while (i >= base) {
    const std::int64_t word_index = i >> 6;
    const int bit = static_cast<int>(i & 63);
    std::uint64_t word = bits_[static_cast<std::size_t>(word_index)];
    if (bit < 63) word &= (std::uint64_t{1} << (bit + 1)) - 1;                        // bits at or below i
    if ((base >> 6) == word_index) word &= ~((std::uint64_t{1} << (base & 63)) - 1);  // bits of this column
    if (word != 0) return static_cast<int>(word_index * 64 + (63 - __builtin_clzll(word)) - base);
    i = word_index * 64 - 1;
  }
  return -1;
}

}  // namespace cairn::core
