// Copyright Cairn authors.
//
// Private: file loaders used by LoadWorld(). Each lives in its own .cpp so that heavy third-party headers
// (OctoMap, PCL) are seen by one translation unit only.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>

#include "cairn/sim/world.h"

namespace cairn::sim::internal {

/// Loads an OctoMap .bt (binary) or .ot (full) file; see LoadWorld().
World LoadOctomapFile(const std::string& path, bool binary, const WorldLoadOptions& options,
                      WorldLoadReport* report);

/// Loads a PCD point cloud file; see LoadWorld().
World LoadPcdFile(const std::string& path, const WorldLoadOptions& options, WorldLoadReport* report);

/// Throws WorldError unless `path` names a readable regular file.
void CheckReadableFile(const std::string& path);

/// Grid covering the axis-aligned box [lo, hi] (metres) with voxels of edge `resolution_m` aligned to
/// multiples of resolution_m. Throws WorldError (naming `source` and the dims) if it exceeds max_voxels.
World MakeGridCovering(const std::string& name, const std::string& source, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi, double resolution_m, std::int64_t max_voxels);

}  // namespace cairn::sim::internal
