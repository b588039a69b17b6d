#include "cairn/agent/services/nav_map.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::agent {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// The grid `*grid` points to, copied first if anyone else holds it (the planner, a search in flight, the
// multi-level grid over the voxels): what a map update may change without touching what others read.
template <class Grid>
Grid& Writable(std::shared_ptr<Grid>* grid) {
  if (grid->use_count() > 1) *grid = std::make_shared<Grid>(**grid);
  return **grid;
}

const NavMapOptions& Checked(const NavMapOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}

}  // namespace

bool NavMapOptions::IsValid(std::string* why) const {
  using core::InRange;
  if (!InRange("navigation.map_half_extent_m", half_extent_m, 5, 200, false, why) ||
      !InRange("navigation.map_max_extent_m", max_extent_m, 10, 2000, false, why) ||
      !InRange("navigation.map_grow_margin_m", grow_margin_m, 0, 100, false, why) ||
      !InRange("navigation.map_grow_step_m", grow_step_m, 1, 500, false, why)) {
    return false;
  }
  if (max_extent_m < 2 * half_extent_m) {
    if (why != nullptr) {
      *why = "navigation.map_max_extent_m = " + core::Fixed(max_extent_m, 1) +
             " is below 2 * navigation.map_half_extent_m = " + core::Fixed(2 * half_extent_m, 1) +
             " (the map starts that large)";
    }
    return false;
  }
  return InRange("navigation.map_below_m", below_m, 0.5, 50, false, why) &&
         InRange("navigation.map_above_m", above_m, 0.5, 50, false, why) &&
         InRange("navigation.map_ground_band_below_m", ground_band_below_m, 0.1, 10, false, why) &&
         InRange("navigation.map_ground_band_above_m", ground_band_above_m, 0.1, 10, false, why) &&
         InRange("navigation.map_update_period_s", update_period_s, 0.1, 10, false, why) &&
         InRange("navigation.map_update_budget_s", update_budget_s, 0.05, 10, false, why);
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
  const Eigen::Vector3d size(2 * options.half_extent_m, 2 * options.half_extent_m,
                             options.below_m + options.above_m);
  const Eigen::Vector3i dims =
      (size / resolution_m).array().ceil().cast<int>().matrix() + Eigen::Vector3i::Ones();
  return std::make_shared<const core::VoxelGrid>("robot map", p_min, resolution_m, dims);
}

NavMap::NavMap(const NavMapOptions& options, double resolution_m, const core::BaseState& start_M,
               std::shared_ptr<nav::GlobalPlanner> planner, const std::string& platform)
    : options_(Checked(options)),
      planner_(std::move(planner)),
      platform_(platform),
      voxels_(std::make_shared<core::VoxelGrid>(*EmptyGrid(options, resolution_m, start_M))),
      seen_free_(std::make_shared<core::VoxelGrid>(*voxels_)) {
  if (!planner_) throw std::invalid_argument("NavMap: planner is null");
  if (planner_->Profile(platform) == nullptr) {
    throw std::invalid_argument("NavMap: platform '" + platform +
                                "' is not served by the planner (valid: " + planner_->PlatformList() + ")");
  }
  extent_M_ = Eigen::AlignedBox2d(voxels_->p_W_min().head<2>(), voxels_->p_W_max().head<2>());
  RebuildGrids();
  Publish({});
}

void NavMap::Wait(const Eigen::Vector2i& tile) {
  if (waiting_set_.insert({tile.x(), tile.y()}).second) waiting_tiles_.push_back(tile);
}

void NavMap::RebuildGrids() {
  const nav::PlatformProfile& profile = *planner_->Profile(platform_);
  grid_ = std::make_shared<nav::TraversabilityGrid>(*voxels_, planner_->TerrainOptionsFor(profile),
                                                    seen_free_.get(), sensor_max_z_m_);
  Progress();
  diagnose_grid_.reset();
  if (const auto relaxed = planner_->DiagnoseTerrainOptionsFor(profile)) {
    diagnose_grid_ =
        std::make_shared<nav::TraversabilityGrid>(*voxels_, *relaxed, seen_free_.get(), sensor_max_z_m_);
    Progress();
  }
  nav::TraversabilityOptions level_options = planner_->LevelOptionsFor(profile);
  levels_ = std::make_shared<nav::MultiLevelGrid>(voxels_, level_options, seen_free_, sensor_max_z_m_);
  Progress();
  diagnose_levels_.reset();
  if (const auto relaxed = planner_->DiagnoseTerrainOptionsFor(profile)) {
    level_options.max_step_m = relaxed->max_step_m;
    diagnose_levels_ =
        std::make_shared<nav::MultiLevelGrid>(voxels_, level_options, seen_free_, sensor_max_z_m_);
  }
}

void NavMap::AddStairFrontiers(const Eigen::Vector3d& robot_M, const nav::FrontierOptions& options,
                               nav::FrontierSet* set) const {
  const nav::MultiLevelGrid& levels = *levels_;
  for (const perception::Staircase& stairs : stair_priors_) {
    const Eigen::Vector2d dir(std::cos(stairs.yaw_rad), std::sin(stairs.yaw_rad));
    const Eigen::Vector2d foot = stairs.p_W_first_step.head<2>();
    const double length_m = (stairs.num_steps - 1) * stairs.run_m;
    // Each end, kStairEndM off the flight: the floor at its foot, and the landing or floor past its last
    // riser.
    const std::array<std::pair<Eigen::Vector2d, double>, 2> ends = {
        std::make_pair(Eigen::Vector2d(foot - kStairEndM * dir), stairs.p_W_first_step.z()),
        std::make_pair(Eigen::Vector2d(foot + (length_m + kStairEndM) * dir),
                       stairs.p_W_first_step.z() + stairs.num_steps * stairs.rise_m)};
    for (const auto& [end_M, end_z] : ends) {
      int ix = 0, iy = 0;
      if (!levels.CellOf(end_M.x(), end_M.y(), &ix, &iy)) continue;
      const int node = levels.NodeNear(ix, iy, end_z, levels.options().max_step_m);
      // Known ground there: traversable, it is the frontier search's; not (the ragged treads of a flight
      // detected only part way up, the end then lies on the treads above), a plan to it is refused at once
      // and that failure would bar the flight's own frontiers within blacklist_radius_m. The same for an end
      // whose column holds something in the body space (a riser seen, its tread not: the frontier search
      // counts it as unseen from the tread below). Only an end the map shows nothing at is a stair frontier
      // (a plan to unknown ground is allowed).
      if (node >= 0 || !levels.IsUnknownAt(ix, iy, end_z)) continue;
      if (!options.region_M.isEmpty() && !options.region_M.contains(end_M)) continue;
      if (end_z < options.min_z_m || end_z > options.max_z_m) continue;
      nav::FrontierCluster c;
      c.target_M = end_M;
      c.centroid_M = end_M;
      c.target_ground_z_m = end_z;
      c.cells = 1;
      c.on_main_level = false;
      c.gain_m2 = nav::VisibleUnknownM2(levels, {end_M.x(), end_M.y(), end_z}, options.gain_radius_m);
      if (c.gain_m2 < options.min_gain_m2) continue;
      // The robot to the other end, then along the flight: an estimate (straight lines), the search over the
      // map's surfaces does not cross a flight its 0.1 m cells show narrower than the robot.
      const Eigen::Vector2d other =
          (end_M - foot).norm() < kStairEndM + 1e-6 ? Eigen::Vector2d(foot + length_m * dir) : foot;
      c.travel_cost_m = (robot_M.head<2>() - other).norm() + (end_M - other).norm();
      c.utility = c.gain_m2 / (c.travel_cost_m + options.cost_offset_m);
      set->clusters.push_back(c);
    }
  }
  nav::SortFrontierClusters(&set->clusters);
}

nav::FrontierSet NavMap::Frontiers(const Eigen::Vector3d& robot_M, nav::FrontierOptions options,
                                   bool every_level, const nav::PeerCoverage* peers) const {
  if (!options.progress) options.progress = progress_;
  if (!every_level) return nav::FindFrontiers(*grid_, robot_M.head<2>(), options, peers);
  options.peer_coverage_min_z_m = grid_->options().ground_search_min_z_m;
  options.peer_coverage_max_z_m = grid_->options().ground_search_max_z_m;
  nav::FrontierSet set = nav::FindFrontiersMultiLevel(*levels_, robot_M, options, peers);
  // A plan from a robot on another level (an upper floor) searches the map's levels whatever the target's.
  const bool robot_on_main_level = grid_->OnLevel(robot_M.x(), robot_M.y(), robot_M.z());
  for (nav::FrontierCluster& c : set.clusters) {
    const std::optional<double> ground = grid_->GroundHeight(c.target_M.x(), c.target_M.y());
    c.on_main_level = robot_on_main_level && ground &&
                      std::abs(*ground - c.target_ground_z_m) <= grid_->options().max_step_m &&
                      grid_->IsTraversableAt(c.target_M.x(), c.target_M.y());
  }
  AddStairFrontiers(robot_M, options, &set);
  return set;
}

Eigen::AlignedBox2d NavMap::extent_M() const {
  std::lock_guard<std::mutex> guard(extent_mutex_);
  return extent_M_;
}

bool NavMap::CanCover(const Eigen::Vector2d& p_M, std::string* why) const {
  const Eigen::AlignedBox2d extent = extent_M();
  if (!p_M.allFinite()) {
    if (why != nullptr) *why = "the point is not finite";
    return false;
  }
  Eigen::AlignedBox2d need = extent;
  need.extend(p_M);
  const Eigen::Vector2d size = need.sizes();
  if (size.maxCoeff() <= options_.max_extent_m) return true;
  if (why != nullptr) {
    *why = "(" + core::Fixed(p_M.x(), 2) + ", " + core::Fixed(p_M.y(), 2) +
           ") is too far for the robot's navigation map: it spans x in [" + core::Fixed(extent.min().x(), 1) +
           ", " + core::Fixed(extent.max().x(), 1) + "], y in [" + core::Fixed(extent.min().y(), 1) + ", " +
           core::Fixed(extent.max().y(), 1) + "] and may grow to " + core::Fixed(options_.max_extent_m, 0) +
           " m along x and y (navigation.map_max_extent_m = " + core::Fixed(options_.max_extent_m, 0) + ")";
  }
  return false;
}

void NavMap::RequestCover(const Eigen::Vector2d& p_M) {
  if (!p_M.allFinite()) return;
  std::lock_guard<std::mutex> guard(extent_mutex_);
  if (extent_M_.contains(p_M)) return;
  pending_cover_M_.extend(p_M);
}

std::string NavMap::Cover(const Eigen::Vector2d& p_M) {
  std::string why;
  if (!CanCover(p_M, &why)) return why;
  RequestCover(p_M);
  return "";
}

Eigen::AlignedBox2d NavMap::GrownExtent(const Eigen::AlignedBox2d& current_M,
                                        const Eigen::AlignedBox2d& want_M) const {
  if (want_M.isEmpty()) return current_M;
  // Within the margin of an edge (or beyond): grow that side to cover it plus grow_step_m.
  const Eigen::Vector2d margin = Eigen::Vector2d::Constant(options_.grow_margin_m);
  Eigen::Vector2d lo = current_M.min(), hi = current_M.max();
  const Eigen::Vector2d step = Eigen::Vector2d::Constant(options_.grow_step_m);
  for (int a = 0; a < 2; ++a) {
    if (want_M.min()[a] < current_M.min()[a] + margin[a]) lo[a] = std::min(lo[a], want_M.min()[a] - step[a]);
    if (want_M.max()[a] > current_M.max()[a] - margin[a]) hi[a] = std::max(hi[a], want_M.max()[a] + step[a]);
    // Within max_extent_m: what must be covered first, then as much of the step as fits.
    const double max = options_.max_extent_m;
    if (hi[a] - lo[a] > max) {
      const double need_lo = std::min(current_M.min()[a], want_M.min()[a]);
      const double need_hi = std::max(current_M.max()[a], want_M.max()[a]);
      const double spare = std::max(0.0, max - (need_hi - need_lo));
      const double grow_lo = need_lo - lo[a], grow_hi = hi[a] - need_hi;  // the steps asked for
      const double share_lo = grow_lo + grow_hi > 0 ? spare * grow_lo / (grow_lo + grow_hi) : 0.0;
      lo[a] = need_lo - std::min(grow_lo, share_lo);
      hi[a] = std::min(need_hi + std::min(grow_hi, spare - (need_lo - lo[a])), lo[a] + max);
      lo[a] = std::max(lo[a], hi[a] - max);
    }
  }
  return Eigen::AlignedBox2d(lo, hi);
}

void NavMap::Reallocate(const Eigen::AlignedBox2d& extent_M) {
  const double res = voxels_->resolution_m();
  // Whole voxels beyond the current grid on each side, so that voxel boundaries stay where they were.
  const Eigen::Vector2d old_lo = voxels_->p_W_min().head<2>(), old_hi = voxels_->p_W_max().head<2>();
  const Eigen::Vector2i grow_lo =
      ((old_lo - extent_M.min()) / res).array().ceil().cast<int>().max(0).matrix();
  const Eigen::Vector2i grow_hi =
      ((extent_M.max() - old_hi) / res).array().ceil().cast<int>().max(0).matrix();
  const Eigen::Vector3i offset(grow_lo.x(), grow_lo.y(), 0);
  const Eigen::Vector3d p_min = voxels_->p_W_min() - offset.cast<double>() * res;
  const Eigen::Vector3i dims = voxels_->dims() + offset + Eigen::Vector3i(grow_hi.x(), grow_hi.y(), 0);
  auto copy = [&](const core::VoxelGrid& from) {
    core::VoxelGrid to(from.name(), p_min, res, dims);
    from.ForEachOccupied([&](const Eigen::Vector3i& index) { to.SetOccupied(index + offset); });
    return to;
  };
  voxels_ = std::make_shared<core::VoxelGrid>(copy(*voxels_));
  Progress();
  seen_free_ = std::make_shared<core::VoxelGrid>(copy(*seen_free_));
  Progress();
}

std::size_t NavMap::MemoryBytes() const {
  std::size_t bytes =
      voxels_->MemoryBytes() + seen_free_->MemoryBytes() + grid_->MemoryBytes() + levels_->MemoryBytes();
  if (diagnose_grid_) bytes += diagnose_grid_->MemoryBytes();
  if (diagnose_levels_) bytes += diagnose_levels_->MemoryBytes();
  return bytes;
}

std::size_t NavMap::UnpublishedMemoryBytes() const {
  std::size_t bytes = 0;
  auto add = [&](const auto& grid) {
    if (grid && std::find(published_.begin(), published_.end(), grid.get()) == published_.end())
      bytes += grid->MemoryBytes();
  };
  add(voxels_);
  add(seen_free_);
  add(grid_);
  add(diagnose_grid_);
  add(levels_);
  add(diagnose_levels_);
  return bytes;
}

void NavMap::Publish(const std::vector<Eigen::AlignedBox2d>& columns) {
  if (!columns.empty()) {
    Writable(&levels_).Update(voxels_, seen_free_, columns, sensor_max_z_m_);
    Progress();
    if (diagnose_levels_) Writable(&diagnose_levels_).Update(voxels_, seen_free_, columns, sensor_max_z_m_);
    Progress();
  }
  // Handed over, not copied: the planner plans on these very grids, and the next update copies any it
  // changes.
  planner_->UpdateMap(voxels_, platform_, grid_, seen_free_, diagnose_grid_, levels_, sensor_max_z_m_,
                      diagnose_levels_);
  published_ = {voxels_.get(),        seen_free_.get(), grid_.get(),
                diagnose_grid_.get(), levels_.get(),    diagnose_levels_.get()};
}

namespace {

// A flight's x-y frame: origin at the foot of its first riser, `along` its ascent, `across` it (map frame).
struct FlightAxes {
  explicit FlightAxes(const perception::Staircase& stairs)
      : origin(stairs.p_W_first_step.head<2>()),
        along(std::cos(stairs.yaw_rad), std::sin(stairs.yaw_rad)),
        across(-along.y(), along.x()),
        depth_m(stairs.num_steps * stairs.run_m) {}
  Eigen::Vector2d origin, along, across;
  double depth_m;  // from the first riser to the last tread's end
};

}  // namespace

Eigen::AlignedBox2d NavMap::StairArea(const perception::Staircase& stairs) const {
  const FlightAxes axes(stairs);
  Eigen::AlignedBox2d box;
  for (const double a : {-stairs.run_m, axes.depth_m}) {
    for (const double b : {-0.5 * stairs.width_m, 0.5 * stairs.width_m}) {
      box.extend(axes.origin + a * axes.along + b * axes.across);
    }
  }
  const Eigen::Vector2d cell = Eigen::Vector2d::Constant(voxels_->resolution_m());
  return Eigen::AlignedBox2d(box.min() - cell, box.max() + cell);
}

void NavMap::ApplyStairPrior(const perception::Staircase& stairs) {
  Writable(&voxels_);
  Writable(&seen_free_);
  const double res = voxels_->resolution_m();
  const double half_width = 0.5 * stairs.width_m - kStairSideMargin_m;
  const FlightAxes axes(stairs);
  if (!(half_width > 0) || !(axes.depth_m > 0) || !(stairs.rise_m > 0) ||
      !stairs.p_W_first_step.allFinite()) {
    return;
  }
  // Voxels of one rise below a tread's top: a ray through any of them went through the step's body.
  const int body_voxels = std::max(1, static_cast<int>(std::lround(stairs.rise_m / res)));
  const Eigen::AlignedBox2d box = StairArea(stairs);
  const Eigen::Vector3i last = voxels_->dims() - Eigen::Vector3i::Ones();
  const Eigen::Vector2d min_W = voxels_->p_W_min().head<2>();
  const int x_lo = std::max(0, static_cast<int>(std::floor((box.min().x() - min_W.x()) / res)));
  const int x_hi = std::min(last.x(), static_cast<int>(std::floor((box.max().x() - min_W.x()) / res)));
  const int y_lo = std::max(0, static_cast<int>(std::floor((box.min().y() - min_W.y()) / res)));
  const int y_hi = std::min(last.y(), static_cast<int>(std::floor((box.max().y() - min_W.y()) / res)));
  for (int ix = x_lo; ix <= x_hi; ++ix) {
    for (int iy = y_lo; iy <= y_hi; ++iy) {
      const Eigen::Vector2d c = voxels_->CenterOf({ix, iy, 0}).head<2>() - axes.origin;
      const double a = c.dot(axes.along);  // along the ascent from the first riser
      if (std::abs(c.dot(axes.across)) > half_width + 1e-6 || a < -stairs.run_m || a >= axes.depth_m)
        continue;
      // A column across a riser holds the higher tread's top; step 0 is the floor at the flight's foot (one
      // run deep), the lidar's blind spot when the robot stands there.
      const int step = std::clamp(static_cast<int>(std::floor((a + 0.5 * res + 1e-6) / stairs.run_m)) + 1, 0,
                                  stairs.num_steps);
      const double top_z = stairs.p_W_first_step.z() + step * stairs.rise_m;
      const int iz_top = static_cast<int>(std::lround((top_z - voxels_->p_W_min().z()) / res)) - 1;
      if (iz_top < 0 || iz_top > last.z()) continue;
      // A ray through the step's body below its top voxel: no tread there (the floor before the flight, where
      // the model's first riser lies a little off). The top voxel itself does not count: a ray grazing a
      // tread on its way to the next riser clears it (an OctoMap miss), which left holes in the treads of the
      // flight a robot stood at the foot of, and no plan onto it.
      const int body_top = body_voxels >= 2 ? iz_top - 1 : iz_top;
      bool seen_through = false;
      for (int iz = std::max(0, iz_top - body_voxels + 1); iz <= body_top && !seen_through; ++iz) {
        seen_through = seen_free_->IsOccupiedIndex({ix, iy, iz});
      }
      if (seen_through) continue;
      voxels_->SetOccupied({ix, iy, iz_top}, true);
      seen_free_->SetOccupied({ix, iy, iz_top}, false);
      // One occupied voxel right above the tread with free space above it is the tread itself read a voxel
      // high (a tread top on a voxel boundary; the lidar's hits on a riser's edge): a bump of 0.1 m next to a
      // grazed neighbour read 0.1 m low cut the landing from its upper flight (1.9 m beside 1.5 m). Two or
      // more are an obstacle on the tread, and stay.
      if (iz_top + 2 <= last.z() && voxels_->IsOccupiedIndex({ix, iy, iz_top + 1}) &&
          !voxels_->IsOccupiedIndex({ix, iy, iz_top + 2})) {
        voxels_->SetOccupied({ix, iy, iz_top + 1}, false);
      }
      for (int iz = iz_top + 1; iz <= std::min(last.z(), iz_top + kStairClearVoxels); ++iz) {
        if (voxels_->IsOccupiedIndex({ix, iy, iz})) break;
        seen_free_->SetOccupied({ix, iy, iz}, true);
      }
    }
  }
}

namespace {

// True when the flights of `a` and `b` are the same to within what moves a tread by about a voxel: the
// registry refines its estimates with every detection, and re-writing the map each time would change it
// under the robot's path every second.
bool SameStairs(const std::vector<perception::Staircase>& a, const std::vector<perception::Staircase>& b) {
  return std::equal(a.begin(), a.end(), b.begin(), b.end(),
                    [](const perception::Staircase& x, const perception::Staircase& y) {
                      const double dyaw = std::remainder(x.yaw_rad - y.yaw_rad, 2.0 * M_PI);
                      return (x.p_W_first_step - y.p_W_first_step).norm() <= 0.03 && std::abs(dyaw) <= 0.02 &&
                             std::abs(x.rise_m - y.rise_m) <= 0.01 && std::abs(x.run_m - y.run_m) <= 0.01 &&
                             std::abs(x.width_m - y.width_m) <= 0.05 && x.num_steps == y.num_steps;
                    });
}

}  // namespace

NavMapUpdateStats NavMap::Update(const perception::OccupancyMap& map,
                                 const std::vector<Eigen::Vector2i>& changed, double tile_m,
                                 double sensor_max_z_m,
                                 const std::vector<perception::Staircase>& staircases) {
  NavMapUpdateStats stats;
  Eigen::AlignedBox2d want;  // what must be covered: changed tiles and requests
  Eigen::AlignedBox2d current;
  {
    std::lock_guard<std::mutex> guard(extent_mutex_);
    want = pending_cover_M_;
    pending_cover_M_.setEmpty();
    current = extent_M_;
  }
  // Only flights the platform climbs: one that cannot gains nothing from their treads (its map shows the
  // steps the lidar saw, and a refusal names the one it saw).
  const double max_step_m = planner_->Profile(platform_)->traversability.max_step_m;
  std::vector<perception::Staircase> climbable;
  std::copy_if(staircases.begin(), staircases.end(), std::back_inserter(climbable),
               [max_step_m](const perception::Staircase& stairs) { return stairs.rise_m <= max_step_m; });
  const bool stairs_changed = !SameStairs(climbable, stair_priors_);
  if (!(tile_m > 0) || (changed.empty() && waiting_tiles_.empty() && want.isEmpty() && !stairs_changed)) {
    stats.extent_M = current;
    return stats;
  }
  auto start = Clock::now();
  for (const Eigen::Vector2i& tile : changed) {
    want.extend(Eigen::Vector2d(tile.cast<double>() * tile_m));
    want.extend(Eigen::Vector2d((tile + Eigen::Vector2i::Ones()).cast<double>() * tile_m));
    Wait(tile);
  }
  stats.grown = GrowOver(current, want, tile_m);
  if (stairs_changed) {
    // The footprints of flights that went or changed are read again from the map (their old treads go), as
    // are those of new ones (then written over).
    for (const auto* flights : {&stair_priors_, &climbable}) {
      for (const perception::Staircase& stairs : *flights) WaitOver(StairArea(stairs), tile_m);
    }
    stair_priors_ = std::move(climbable);
  }
  std::vector<Eigen::AlignedBox2d> columns = ReadWaitingTiles(map, tile_m, start, &stats);
  ApplyStairPriorsOver(&columns, &stats);
  stats.extent_M = extent_M();
  stats.tiles_waiting = tiles_waiting();
  if (columns.empty() && !stats.grown) return stats;
  stats.read_ms = MsSince(start);
  Progress();
  start = Clock::now();
  sensor_max_z_m_ = sensor_max_z_m;
  if (stats.grown) {
    RebuildGrids();  // every grid over the new extent (their geometry changed)
    columns.clear();
  } else {
    for (auto* grid : {&grid_, &diagnose_grid_}) {
      if (!*grid) continue;
      Progress();
      nav::TraversabilityGrid& writable = Writable(grid);
      writable.SetObserverHeight(sensor_max_z_m);
      writable.Update(*voxels_, seen_free_.get(), columns);
    }
  }
  stats.traversability_ms = MsSince(start);
  Progress();
  start = Clock::now();
  Publish(columns);
  stats.publish_ms = MsSince(start);
  stats.map_version = planner_->map_version();
  stats.applied = true;
  return stats;
}

bool NavMap::GrowOver(const Eigen::AlignedBox2d& current, const Eigen::AlignedBox2d& want, double tile_m) {
  const Eigen::AlignedBox2d grown = GrownExtent(current, want);
  if (grown.isApprox(current)) return false;
  Reallocate(grown);
  // The new area is read from the map like changed tiles (tiles already read are read again: harmless).
  const Eigen::Vector2d lo = voxels_->p_W_min().head<2>(), hi = voxels_->p_W_max().head<2>();
  const Eigen::Vector2i t_lo = (lo / tile_m).array().floor().cast<int>().matrix();
  const Eigen::Vector2i t_hi = (hi / tile_m).array().ceil().cast<int>().matrix() - Eigen::Vector2i::Ones();
  for (int tx = t_lo.x(); tx <= t_hi.x(); ++tx) {
    for (int ty = t_lo.y(); ty <= t_hi.y(); ++ty) {
      const Eigen::AlignedBox2d box(Eigen::Vector2d(tx, ty) * tile_m,
                                    Eigen::Vector2d(tx + 1, ty + 1) * tile_m);
      if (!current.contains(box)) Wait(Eigen::Vector2i(tx, ty));
    }
  }
  ++growths_;
  std::lock_guard<std::mutex> guard(extent_mutex_);
  extent_M_ = Eigen::AlignedBox2d(lo, hi);
  return true;
}

void NavMap::WaitOver(const Eigen::AlignedBox2d& box_M, double tile_m) {
  const Eigen::Vector2i t_lo = (box_M.min() / tile_m).array().floor().cast<int>().matrix();
  const Eigen::Vector2i t_hi = (box_M.max() / tile_m).array().floor().cast<int>().matrix();
  for (int tx = t_lo.x(); tx <= t_hi.x(); ++tx) {
    for (int ty = t_lo.y(); ty <= t_hi.y(); ++ty) Wait(Eigen::Vector2i(tx, ty));
  }
}

std::vector<Eigen::AlignedBox2d> NavMap::ReadWaitingTiles(const perception::OccupancyMap& map, double tile_m,
                                                          Clock::time_point start, NavMapUpdateStats* stats) {
  std::vector<Eigen::AlignedBox2d> columns;
  if (!waiting_tiles_.empty()) {
    Writable(&voxels_);
    Writable(&seen_free_);
  }
  Progress();
  // Oldest first, until the budget is spent (at least one tile: the map always moves on).
  const auto read_until = start + std::chrono::duration_cast<Clock::duration>(
                                      std::chrono::duration<double>(options_.update_budget_s));
  for (int read = 0; !waiting_tiles_.empty() && (read == 0 || Clock::now() < read_until); ++read) {
    const Eigen::Vector2i tile = waiting_tiles_.front();
    waiting_tiles_.pop_front();
    waiting_set_.erase({tile.x(), tile.y()});
    if (read % 16 == 15) Progress();
    if (const auto box = ReadTile(map, tile, tile_m, stats)) {
      columns.push_back(*box);
      stats->region_M.extend(*box);
      ++stats->tiles;
    }
  }
  return columns;
}

std::optional<Eigen::AlignedBox2d> NavMap::ReadTile(const perception::OccupancyMap& map,
                                                    const Eigen::Vector2i& tile, double tile_m,
                                                    NavMapUpdateStats* stats) {
  const double res = voxels_->resolution_m();
  const Eigen::Vector3i last = voxels_->dims() - Eigen::Vector3i::Ones();
  const Eigen::Vector2d lo_W = tile.cast<double>() * tile_m;
  const Eigen::Vector2d hi_W = lo_W + Eigen::Vector2d::Constant(tile_m);
  // Voxel index range of the tile (inclusive), over the extent's full height.
  const Eigen::Vector2i lo = ((lo_W - voxels_->p_W_min().head<2>()) / res)
                                 .array()
                                 .round()
                                 .cast<int>()
                                 .matrix()
                                 .cwiseMax(Eigen::Vector2i::Zero());
  const Eigen::Vector2i hi = (((hi_W - voxels_->p_W_min().head<2>()) / res).array().round().cast<int>() - 1)
                                 .matrix()
                                 .cwiseMin(last.head<2>());
  if (lo.x() > hi.x() || lo.y() > hi.y()) return std::nullopt;
  for (int ix = lo.x(); ix <= hi.x(); ++ix) {
    voxels_->FreeColumns(ix, lo.y(), hi.y());
    seen_free_->FreeColumns(ix, lo.y(), hi.y());
  }
  // Voxel centres strictly inside the tile, so that a neighbouring voxel touching its face is not read.
  const Eigen::Vector3d shrink = Eigen::Vector3d::Constant(0.25 * res);
  const Eigen::AlignedBox3d query(voxels_->CenterOf({lo.x(), lo.y(), 0}) - shrink,
                                  voxels_->CenterOf({hi.x(), hi.y(), last.z()}) + shrink);
  for (const Eigen::Vector3d& p : map.OccupiedInBox(query))
    stats->occupied_voxels += voxels_->SetOccupiedAt(p);
  for (const Eigen::Vector3d& p : map.FreeInBox(query)) seen_free_->SetOccupiedAt(p);
  return Eigen::AlignedBox2d(voxels_->CenterOf({lo.x(), lo.y(), 0}).head<2>(),
                             voxels_->CenterOf({hi.x(), hi.y(), 0}).head<2>());
}

void NavMap::ApplyStairPriorsOver(std::vector<Eigen::AlignedBox2d>* columns, NavMapUpdateStats* stats) {
  const double res = voxels_->resolution_m();
  for (const perception::Staircase& stairs : stair_priors_) {
    const Eigen::AlignedBox2d box = StairArea(stairs);
    const bool read = std::any_of(columns->begin(), columns->end(),
                                  [&box](const Eigen::AlignedBox2d& c) { return c.intersects(box); });
    if (!read) continue;
    ApplyStairPrior(stairs);
    // One cell more: the neighbours' analysis changes too.
    columns->emplace_back(box.min() - Eigen::Vector2d::Constant(res),
                          box.max() + Eigen::Vector2d::Constant(res));
    ++stats->stair_priors;
  }
}

}  // namespace cairn::agent
