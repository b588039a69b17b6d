// Copyright Cairn authors.
//
// A voxel of the coarse map that robots send to basestations (map telemetry). Shared by the mapping library
// (which extracts coarse changes from its OctoMap) and the telemetry codec (which encodes, budgets and merges
// them). See docs/DESIGN.md "Messages and topics" and perception/README.md.
#pragma once

#include <cstdint>

namespace cairn::perception {

/// Known state of a coarse voxel. Unknown voxels are never sent.
enum class CoarseState : std::uint8_t {
  kFree = 1,      ///< Observed, and no fine voxel inside it is occupied.
  kOccupied = 2,  ///< At least one fine voxel inside it is occupied (OctoMap's max-of-children rule).
};

/// One coarse voxel, frame W. Index i covers [i * resolution_m, (i + 1) * resolution_m) on its axis, i.e.
/// i = floor(coordinate_m / resolution_m); this is exactly the OctoMap node at that depth, whose key is
/// (i + 2^15 / 2^levels) << levels for a coarse map `levels` levels above the fine one.
struct CoarseVoxel {
  std::int32_t ix = 0;
  std::int32_t iy = 0;
  std::int32_t iz = 0;
  CoarseState state = CoarseState::kFree;

  friend bool operator==(const CoarseVoxel& a, const CoarseVoxel& b) {
    return a.ix == b.ix && a.iy == b.iy && a.iz == b.iz && a.state == b.state;
  }
};

}  // namespace cairn::perception
