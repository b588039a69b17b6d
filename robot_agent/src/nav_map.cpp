#include "cairn/agent/nav_map.h"

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "range_check.h"

namespace cairn::agent {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

const NavMapOptions& Checked(const NavMapOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}

}  // namespace

bool NavMapOptions::IsValid(std::string* why) const {
  using internal::InRange;
  return InRange("navigation.map_half_extent_m", half_extent_m, 5, 200, false, why) &&
         InRange("navigation.map_below_m", below_m, 0.5, 50, false, why) &&
         InRange("navigation.map_above_m", above_m, 0.5, 50, false, why) &&
         InRange("navigation.map_ground_band_below_m", ground_band_below_m, 0.1, 10, false, why) &&
         InRange("navigation.map_ground_band_above_m", ground_band_above_m, 0.1, 10, false, why) &&
         InRange("navigation.map_update_period_s", update_period_s, 0.1, 10, false, why);
}

nav::MapReading NavMap::Reading(const NavMapOptions& options, const core::BaseState& start_M) {
  nav::MapReading r;
  r.reference_height_m = start_M.z_m;
  r.ground_search_min_z_m = start_M.z_m - options.ground_band_below_m;
  r.ground_search_max_z_m = start_M.z_m + options.ground_band_above_m;
  r.unknown_is_lethal = false;
  return r;
}

std::shared_ptr<nav::GlobalPlanner> NavMap::MakePlanner(const NavMapOptions& options, double resolution_m,
                                                       const core::BaseState& start_M,
                                                       std::vector<nav::PlatformProfile> profiles) {
  nav::GlobalPlannerOptions planner_options;
  planner_options.reading = Reading(options, start_M);
  return std::make_shared<nav::GlobalPlanner>(EmptyGrid(options, resolution_m, start_M), std::move(profiles),
                                              planner_options);
}

std::shared_ptr<const core::VoxelGrid> NavMap::EmptyGrid(const NavMapOptions& options, double resolution_m,
                                                         const core::BaseState& start_M) {
  Checked(options);
  // Aligned to the OctoMap's voxels: voxel i covers [i * res, (i + 1) * res).
  const Eigen::Vector3d lo(start_M.x_m - options.half_extent_m, start_M.y_m - options.half_extent_m,
                           start_M.z_m - options.below_m);
  const Eigen::Vector3d p_min = (lo / resolution_m).array().floor().matrix() * resolution_m;
  const Eigen::Vector3d size(2 * options.half_extent_m, 2 * options.half_extent_m, options.below_m + options.above_m);
  const Eigen::Vector3i dims = (size / resolution_m).array().ceil().cast<int>().matrix() + Eigen::Vector3i::Ones();
  return std::make_shared<const core::VoxelGrid>("robot map", p_min, resolution_m, dims);
}

NavMap::NavMap(const NavMapOptions& options, double resolution_m, const core::BaseState& start_M,
               std::shared_ptr<nav::GlobalPlanner> planner, const std::string& platform)
    : options_(Checked(options)),
      planner_(std::move(planner)),
      platform_(platform),
      voxels_(*EmptyGrid(options, resolution_m, start_M)),
      seen_free_(voxels_) {
  if (!planner_) throw std::invalid_argument("NavMap: planner is null");
  const nav::PlatformProfile* profile = planner_->Profile(platform);
  if (profile == nullptr) {
    throw std::invalid_argument("NavMap: platform '" + platform + "' is not served by the planner (valid: " +
                                planner_->PlatformList() + ")");
  }
  grid_ = std::make_unique<nav::TraversabilityGrid>(voxels_, planner_->TerrainOptionsFor(*profile), &seen_free_);
  if (const auto relaxed = planner_->DiagnoseTerrainOptionsFor(*profile)) {
    diagnose_grid_ = std::make_unique<nav::TraversabilityGrid>(voxels_, *relaxed, &seen_free_);
  }
  auto world = std::make_shared<const core::VoxelGrid>(voxels_);
  auto seen_free = std::make_shared<const core::VoxelGrid>(seen_free_);
  nav::TraversabilityOptions level_options = planner_->LevelOptionsFor(*profile);
  levels_ = std::make_unique<nav::MultiLevelGrid>(world, level_options, seen_free);
  if (const auto relaxed = planner_->DiagnoseTerrainOptionsFor(*profile)) {
    level_options.max_step_m = relaxed->max_step_m;
    diagnose_levels_ = std::make_unique<nav::MultiLevelGrid>(world, level_options, seen_free);
  }
  Publish({});
}

void NavMap::Publish(const std::vector<Eigen::AlignedBox2d>& columns) {
  auto world = std::make_shared<const core::VoxelGrid>(voxels_);
  auto seen_free = std::make_shared<const core::VoxelGrid>(seen_free_);
  if (!columns.empty()) {
    levels_->Update(world, seen_free, columns, sensor_max_z_m_);
    if (diagnose_levels_) diagnose_levels_->Update(world, seen_free, columns, sensor_max_z_m_);
  }
  planner_->UpdateMap(world, platform_, std::make_shared<const nav::TraversabilityGrid>(*grid_), seen_free,
                      diagnose_grid_ ? std::make_shared<const nav::TraversabilityGrid>(*diagnose_grid_) : nullptr,
                      std::make_shared<const nav::MultiLevelGrid>(*levels_), sensor_max_z_m_,
                      diagnose_levels_ ? std::make_shared<const nav::MultiLevelGrid>(*diagnose_levels_) : nullptr);
}

NavMapUpdateStats NavMap::Update(const perception::OccupancyMap& map, const std::vector<Eigen::Vector2i>& tiles,
                                 double tile_m, double sensor_max_z_m) {
  NavMapUpdateStats stats;
  if (!(tile_m > 0) || tiles.empty()) return stats;
  auto start = Clock::now();
  const double res = voxels_.resolution_m();
  const Eigen::Vector3i last = voxels_.dims() - Eigen::Vector3i::Ones();
  std::vector<Eigen::AlignedBox2d> columns;
  for (const Eigen::Vector2i& tile : tiles) {
    const Eigen::Vector2d lo_W = tile.cast<double>() * tile_m;
    const Eigen::Vector2d hi_W = lo_W + Eigen::Vector2d::Constant(tile_m);
    // Voxel index range of the tile (inclusive), over the extent's full height.
    const Eigen::Vector2i lo = ((lo_W - voxels_.p_W_min().head<2>()) / res).array().round().cast<int>().matrix()
                                   .cwiseMax(Eigen::Vector2i::Zero());
    const Eigen::Vector2i hi = (((hi_W - voxels_.p_W_min().head<2>()) / res).array().round().cast<int>() - 1).matrix()
                                   .cwiseMin(last.head<2>());
    if (lo.x() > hi.x() || lo.y() > hi.y()) continue;
    for (int ix = lo.x(); ix <= hi.x(); ++ix) {
      for (int iy = lo.y(); iy <= hi.y(); ++iy) {
        for (int iz = 0; iz <= last.z(); ++iz) {
          voxels_.SetOccupied({ix, iy, iz}, false);
          seen_free_.SetOccupied({ix, iy, iz}, false);
        }
      }
    }
    // Voxel centres strictly inside the tile, so that a neighbouring voxel touching its face is not read.
    const Eigen::Vector3d shrink = Eigen::Vector3d::Constant(0.25 * res);
    const Eigen::AlignedBox3d query(voxels_.CenterOf({lo.x(), lo.y(), 0}) - shrink,
                                    voxels_.CenterOf({hi.x(), hi.y(), last.z()}) + shrink);
    for (const Eigen::Vector3d& p : map.OccupiedInBox(query)) stats.occupied_voxels += voxels_.SetOccupiedAt(p);
    for (const Eigen::Vector3d& p : map.FreeInBox(query)) seen_free_.SetOccupiedAt(p);
    const Eigen::AlignedBox2d box(voxels_.CenterOf({lo.x(), lo.y(), 0}).head<2>(),
                                  voxels_.CenterOf({hi.x(), hi.y(), 0}).head<2>());
    columns.push_back(box);
    stats.region_M.extend(box);
    ++stats.tiles;
  }
  if (columns.empty()) return stats;
  stats.read_ms = MsSince(start);
  start = Clock::now();
  sensor_max_z_m_ = sensor_max_z_m;
  grid_->SetObserverHeight(sensor_max_z_m);
  grid_->Update(voxels_, &seen_free_, columns);
  if (diagnose_grid_) {
    diagnose_grid_->SetObserverHeight(sensor_max_z_m);
    diagnose_grid_->Update(voxels_, &seen_free_, columns);
  }
  stats.traversability_ms = MsSince(start);
  start = Clock::now();
  Publish(columns);
  stats.publish_ms = MsSince(start);
  stats.map_version = planner_->map_version();
  stats.applied = true;
  return stats;
}

}  // namespace cairn::agent
