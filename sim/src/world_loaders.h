// Copyright Cairn authors.
//
// Private: file loaders used by LoadWorld(). Each lives in its own .cpp so that heavy third-party headers
// (OctoMap, PCL) are seen by one translation unit only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <unordered_map>

#include "cairn/sim/world.h"

namespace cairn::sim::internal {

/// Loads an OctoMap .bt (binary) or .ot (full) file; see LoadWorld().
World LoadOctomapFile(const std::string& path, bool binary, const WorldLoadOptions& options,
                      WorldLoadReport* report);

/// Loads a PCD point cloud file; see LoadWorld().
World LoadPcdFile(const std::string& path, const WorldLoadOptions& options, WorldLoadReport* report);

/// Points per voxel of a PCD, keyed by World::LinearIndex().
using PointCounts = std::unordered_map<std::int64_t, int>;

/// Support filter then floor hole filling of a loaded scan (see WorldLoadOptions); fills the clean-up fields
/// of `report`. `counts` (PCD only, may be null) gives the points per voxel. Throws WorldError if no voxel
/// survives. Lives in world_cleanup.cpp.
void CleanUpScannedWorld(World* world, const WorldLoadOptions& options, const PointCounts* counts,
                         WorldLoadReport* report);

/// Throws WorldError unless `path` names a readable regular file.
void CheckReadableFile(const std::string& path);

/// Grid covering the axis-aligned box [lo, hi] (metres) with voxels of edge `resolution_m` aligned to
/// multiples of resolution_m. Throws WorldError (naming `source` and the dims) if it exceeds max_voxels.
World MakeGridCovering(const std::string& name, const std::string& source, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi, double resolution_m, std::int64_t max_voxels);

}  // namespace cairn::sim::internal
