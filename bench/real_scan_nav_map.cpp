// Bench: the navigation map thread's work on a large sparse survey scan (a 90 x 60 m industrial building
// surveyed at about 270 k points: sim::MakeSurveyScan of builtin:plant, as cairn_survey_pcd writes it; or any
// FILE.pcd given). A legged robot stands at the foot of the plant's staircase and turns in place, then walks
// 20 m east along the hall, scanning at 10 Hz; once a second the map thread's iteration runs as the agent
// runs it: NavMap::Update (read the changed tiles within the budget, re-analyse, hand over), then the
// frontier search on every level (a legged robot's exploration). Each step is timed, and the longest stretch
// without a progress call (what the health monitor sees as the loop's heartbeat).
//
// Baseline in the same run: the same drive with the budget lifted (every changed tile read in the update it
// arrives with, as before the budget); the ratio of the longest update and of the longest stretch without
// progress, budgeted against not.
//
//   build/bench/cairn_bench_real_scan_nav_map [FILE.pcd]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/nav/frontier.h"
#include "cairn/nav/global_planner.h"
#include "cairn/perception/perception_pipeline.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"
#include "cairn/sim/survey_scan.h"

namespace {

using cairn::bench::Median;

using Clock = std::chrono::steady_clock;
double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

struct Run {
  std::vector<double> update_ms, frontier_ms, tiles, waiting;
  double longest_silence_ms = 0.0;  // between progress calls (and iteration ends)
  int growths = 0;
  double extent_x_m = 0.0, extent_y_m = 0.0;
};

double Max(const std::vector<double>& v) { return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end()); }
Run Drive(const std::string& world, double budget_s) {
  using namespace cairn;
  const nav::PlatformProfile profile = nav::GetPlatformProfile("legged");
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = world;
  sim_options.start_W = core::PlanarPose{13.8, 45.0, M_PI};
  sim::ApplyPlatformProfile(profile, &sim_options);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();
  perception::PerceptionOptions perception_options;
  perception_options.camera_rate_hz = 0;
  perception::PerceptionPipeline perception(perception_options, "r1");
  agent::NavMapOptions map_options;
  map_options.update_budget_s = budget_s;
  auto planner =
      agent::NavMap::MakePlanner(map_options, perception_options.map.resolution_m, start_M, {profile});
  agent::NavMap nav_map(map_options, perception_options.map.resolution_m, start_M, planner, "legged");
  Run run;
  Clock::time_point last_progress = Clock::now();
  nav_map.SetProgressHook([&] {
    run.longest_silence_ms = std::max(run.longest_silence_ms, MsSince(last_progress));
    last_progress = Clock::now();
  });
  for (int k = 1; k <= 300; ++k) {
    const double now_s = 0.1 * k;
    sim::UnicycleState s = platform.TrueState();
    if (k <= 100) {
      s.yaw_rad = M_PI + 2 * M_PI * k / 100.0;  // a turn in place: the whole hall around it at once
    } else {
      s.yaw_rad = 0.0;
      s.x_m = 13.8 + 0.1 * (k - 100);
    }
    platform.SetTrueState(s);
    platform.Update(now_s);
    core::LidarScan scan;
    if (platform.ReadLidarScan(now_s, &scan)) perception.Tick(now_s, &scan, nullptr);
    if (k % 10 != 0) continue;
    last_progress = Clock::now();
    auto t = Clock::now();
    const agent::NavMapUpdateStats stats =
        nav_map.Update(*perception.map(), perception.TakeChangedTiles(), perception.change_tile_m(),
                       perception.max_sensor_z_m(), perception.Staircases());
    run.update_ms.push_back(MsSince(t));
    run.tiles.push_back(stats.tiles);
    run.waiting.push_back(stats.tiles_waiting);
    const core::BaseState here = platform.ReadPose().PlanarState();
    t = Clock::now();
    nav_map.Frontiers({here.x_m, here.y_m, here.z_m}, nav::FrontierOptions(), /*every_level=*/true, nullptr);
    run.frontier_ms.push_back(MsSince(t));
    run.longest_silence_ms = std::max(run.longest_silence_ms, MsSince(last_progress));
  }
  run.growths = nav_map.growths();
  run.extent_x_m = nav_map.extent_M().sizes().x();
  run.extent_y_m = nav_map.extent_M().sizes().y();
  return run;
}

void Print(const char* name, const Run& r) {
  std::printf(
      "%s: %zu iterations; update median %.0f ms, max %.0f ms; tiles read median %.0f, max %.0f; tiles "
      "left waiting max %.0f; frontiers (every level) median %.0f ms, max %.0f ms; longest stretch "
      "without progress %.0f ms; %d growths, extent %.0f x %.0f m\n",
      name, r.update_ms.size(), Median(r.update_ms), Max(r.update_ms), Median(r.tiles), Max(r.tiles),
      Max(r.waiting), Median(r.frontier_ms), Max(r.frontier_ms), r.longest_silence_ms, r.growths,
      r.extent_x_m, r.extent_y_m);
}

}  // namespace

int main(int argc, char** argv) {
  std::string world = argc > 1 ? argv[1] : "";
  if (world.empty()) {
    world = "/tmp/cairn_bench_plant.pcd";
    const cairn::sim::World plant = cairn::sim::MakeBuiltinWorld("plant", 1);
    cairn::sim::SurveyScanOptions options;
    options.floor_points_per_m2 = 20.0;
    options.wall_keep_fraction = 0.13;
    options.outside_is_solid = true;
    const cairn::sim::SurveyScan scan = cairn::sim::MakeSurveyScan(plant, options, 1);
    cairn::sim::WritePcd(world, scan.points_W);
    std::printf("survey scan of builtin:plant: %zu points -> %s\n", scan.points_W.size(), world.c_str());
  }
  const Run budgeted = Drive(world, cairn::agent::NavMapOptions().update_budget_s);
  const Run unbounded = Drive(world, 10.0);
  Print("budgeted (map_update_budget_s 0.5)", budgeted);
  Print("baseline (no budget: every tile in the update it arrives with)", unbounded);
  std::printf("ratio budgeted / baseline: longest update %.2f, longest stretch without progress %.2f\n",
              Max(budgeted.update_ms) / Max(unbounded.update_ms),
              budgeted.longest_silence_ms / unbounded.longest_silence_ms);
  return 0;
}
