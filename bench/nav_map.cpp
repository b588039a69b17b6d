// Bench: the navigation map on the robot's own OctoMap. A simulated wheeled robot drives the
// tunnels' main corridor (4,20) -> (26,20) at 1 m/s scanning at 10 Hz; every second the map's changed tiles
// are applied incrementally (NavMap::Update). Baseline, in the same run on the same voxels: a full rebuild of
// the traversability grid. Then plan time on the robot's own map against the ground-truth planner (the
// planner on the simulator's world) for the same goals. And the frontier update
// after each map update, against that update and the full rebuild.
//
//   build/bench/cairn_bench_nav_map
#include "cairn/agent/services/nav_map.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

#include "bench_util.h"
#include "cairn/nav/frontier.h"
#include "cairn/nav/global_planner.h"
#include "cairn/perception/perception_pipeline.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace {

using cairn::bench::Median;

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

int main() {
  using namespace cairn;
  const nav::PlatformProfile profile = nav::GetPlatformProfile("wheeled");
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  sim_options.start_W = core::PlanarPose{4.0, 20.0, 0.0};
  sim::ApplyPlatformProfile(profile, &sim_options);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();

  perception::PerceptionOptions perception_options;
  perception_options.camera_rate_hz = 0;
  perception::PerceptionPipeline perception(perception_options, "r1");
  agent::NavMapOptions map_options;
  auto planner =
      agent::NavMap::MakePlanner(map_options, perception_options.map.resolution_m, start_M, {profile});
  agent::NavMap nav_map(map_options, perception_options.map.resolution_m, start_M, planner, "wheeled");

  std::vector<double> incremental_ms, full_ms, tiles, frontier_ms, level_frontier_ms;
  nav::FrontierSet last_frontiers, last_level_frontiers;
  for (int k = 1; k <= 220; ++k) {
    const double now_s = 0.1 * k;
    sim::UnicycleState s = platform.TrueState();
    s.x_m = 4.0 + 0.1 * k;
    platform.SetTrueState(s);
    platform.Update(now_s);
    core::LidarScan scan;
    if (platform.ReadLidarScan(now_s, &scan)) perception.Tick(now_s, &scan, nullptr);
    if (k % 10 != 0) continue;
    const agent::NavMapUpdateStats stats =
        nav_map.Update(*perception.map(), perception.TakeChangedTiles(), perception.change_tile_m(),
                       perception.max_sensor_z_m());
    if (!stats.applied) continue;
    incremental_ms.push_back(stats.read_ms + stats.traversability_ms);
    tiles.push_back(stats.tiles);
    auto t = Clock::now();
    const nav::TraversabilityGrid full(nav_map.voxels(), planner->TerrainOptionsFor(profile));
    full_ms.push_back(MsSince(t));
    // Exploration's frontier update on the map just updated, from where the robot is.
    t = Clock::now();
    last_frontiers = nav::FindFrontiers(nav_map.grid(), {s.x_m, s.y_m});
    frontier_ms.push_back(MsSince(t));
    // ...and on every level of the map (a legged robot's search), the same map.
    t = Clock::now();
    last_level_frontiers = nav::FindFrontiersMultiLevel(nav_map.levels(), {s.x_m, s.y_m, s.z_m});
    level_frontier_ms.push_back(MsSince(t));
  }
  std::printf(
      "nav map update (80 x 80 m extent, 0.1 m, %zu updates at 1 Hz, median %.0f changed 2 m tiles):\n",
      incremental_ms.size(), Median(tiles));
  std::printf("  incremental (read tiles + re-analyse)  median %7.1f ms  max %7.1f ms\n",
              Median(incremental_ms), *std::max_element(incremental_ms.begin(), incremental_ms.end()));
  std::printf("  full rebuild (baseline)                median %7.1f ms  max %7.1f ms\n", Median(full_ms),
              *std::max_element(full_ms.begin(), full_ms.end()));
  std::printf("  ratio full / incremental (median)      %7.1fx\n", Median(full_ms) / Median(incremental_ms));
  std::printf(
      "frontier update per map change (FindFrontiers on the updated grid): median %.1f ms, max "
      "%.1f ms; ratio to the incremental update %.2f, to the full rebuild %.2f; last: %zu clusters (%d "
      "reachable), %d frontier cells, %.0f m^2 known free\n",
      Median(frontier_ms), *std::max_element(frontier_ms.begin(), frontier_ms.end()),
      Median(frontier_ms) / Median(incremental_ms), Median(frontier_ms) / Median(full_ms),
      last_frontiers.clusters.size(), last_frontiers.reachable(), last_frontiers.frontier_cells,
      last_frontiers.known_free_m2);
  std::printf(
      "  on every level (FindFrontiersMultiLevel, same maps): median %.1f ms, max %.1f ms; ratio to the main "
      "level's search %.2f; last: %zu clusters (%d reachable), %d frontier surfaces, %.0f m^2 of surfaces\n",
      Median(level_frontier_ms), *std::max_element(level_frontier_ms.begin(), level_frontier_ms.end()),
      Median(level_frontier_ms) / Median(frontier_ms), last_level_frontiers.clusters.size(),
      last_level_frontiers.reachable(), last_level_frontiers.frontier_cells,
      last_level_frontiers.known_free_m2);

  // Column scans (what every grid rebuild does per x-y column): the word-wise scan down each column of the
  // robot's map after the drive, and of an empty map (the agent's start), against a voxel-by-voxel scan.
  for (const bool empty : {false, true}) {
    const core::VoxelGrid empty_grid("empty", nav_map.voxels().p_W_min(), nav_map.voxels().resolution_m(),
                                     nav_map.voxels().dims());
    const core::VoxelGrid& voxels = empty ? empty_grid : nav_map.voxels();
    const Eigen::Vector3i dims = voxels.dims();
    long long word_sum = 0;
    long long voxel_sum = 0;
    auto t = Clock::now();
    for (int ix = 0; ix < dims.x(); ++ix) {
      for (int iy = 0; iy < dims.y(); ++iy) {
        for (int iz = voxels.HighestOccupiedInColumn(ix, iy, dims.z() - 1); iz >= 0;
             iz = voxels.HighestOccupiedInColumn(ix, iy, iz - 1)) {
          word_sum += iz;
        }
      }
    }
    const double word_ms = MsSince(t);
    t = Clock::now();
    for (int ix = 0; ix < dims.x(); ++ix) {
      for (int iy = 0; iy < dims.y(); ++iy) {
        for (int iz = dims.z() - 1; iz >= 0; --iz) {
          if (voxels.IsOccupiedIndex({ix, iy, iz})) voxel_sum += iz;
        }
      }
    }
    const double voxel_ms = MsSince(t);
    std::printf(
        "column scans of the %s (%d x %d columns of %d voxels): word-wise %.1f ms, voxel by voxel "
        "(baseline) %.1f ms, ratio %.1fx%s\n",
        empty ? "empty map (the agent's start)" : "robot's map after the drive", dims.x(), dims.y(), dims.z(),
        word_ms, voxel_ms, voxel_ms / word_ms, word_sum == voxel_sum ? "" : " (DIFFERENT OCCUPANCY: a bug)");
    if (word_sum != voxel_sum) return 1;
  }

  // Plan time: the robot's own map (after the drive) against the ground-truth planner on the world.
  auto truth_planner =
      std::make_shared<nav::GlobalPlanner>(platform.world(), std::vector<nav::PlatformProfile>{profile});
  const core::BaseState here = platform.ReadPose().PlanarState();
  const std::vector<Eigen::Vector2d> goals = {{30, 12}, {30, 30}, {40, 5}, {20, 35}, {14, 20}};
  std::vector<double> own_ms, truth_ms;
  int own_ok = 0, truth_ok = 0;
  truth_planner->Grid("wheeled");  // built once, outside the timing, as the agent's map is
  for (const auto& goal : goals) {
    nav::GlobalPlanRequest request;
    request.start_W = {here.x_m, here.y_m};
    request.goal_W = goal;
    request.start_is_robot = true;
    auto t = Clock::now();
    own_ok += planner->Plan(request).IsUsable();
    own_ms.push_back(MsSince(t));
    t = Clock::now();
    truth_ok += truth_planner->Plan(request).IsUsable();
    truth_ms.push_back(MsSince(t));
  }
  std::printf(
      "plan time from (%.1f, %.1f) to %zu goals: own map median %.1f ms (%d planned), ground truth median "
      "%.1f ms (%d planned), ratio own / truth %.2f\n",
      here.x_m, here.y_m, goals.size(), Median(own_ms), own_ok, Median(truth_ms), truth_ok,
      Median(own_ms) / Median(truth_ms));
  return 0;
}
