// Copyright Cairn authors.
//
// Seeded sampling of robot start positions on a TraversabilityGrid.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "cairn/nav/traversability.h"

namespace cairn::nav {

/// Cells of the largest connected traversable region of `grid` (4-connected, which is the connectivity of
/// PlanPath(): its diagonal moves need both side cells traversable), as linear indices grid.Index(ix, iy),
/// ascending. Empty if no cell is traversable.
std::vector<std::size_t> LargestTraversableComponent(const TraversabilityGrid& grid);

/// Up to `n` (>= 0) start positions (cell centres; x, y metres, z = ground height, frame W) drawn with
/// std::mt19937(seed) from the largest connected traversable region, pairwise at least min_spacing_m
/// (metres, >= 0) apart. Cells with clearance >= robot_radius_m + 0.2 m are preferred; other traversable
/// cells are used only if those do not give n positions. Deterministic for a given grid and seed; returns
/// fewer than n positions if the region is too small. Throws std::invalid_argument if n < 0 or
/// min_spacing_m is negative or not finite. Any two results are joined by a PlanPath() path.
std::vector<Eigen::Vector3d> SampleFreeStarts(const TraversabilityGrid& grid, int n, double min_spacing_m,
                                              std::uint32_t seed);

}  // namespace cairn::nav
