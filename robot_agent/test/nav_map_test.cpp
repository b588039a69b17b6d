// The navigation map on the robot's own OctoMap, driven through a built-in world faster than real time without
// DDS: the simulated platform's scans -> perception's map -> changed tiles -> NavMap -> planner. Scored against
// the simulator's ground truth (which the map never reads).
#include "cairn/agent/nav_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

#include "cairn/agent/perception_pipeline.h"
#include "cairn/nav/global_planner.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

TEST(NavMapTest, DrivingTheTunnelsBuildsAnIncrementalMapThatPlansOnlyOverRealFloor) {
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  sim_options.start_W = core::PlanarPose{4.0, 20.0, 0.0};
  const nav::PlatformProfile profile = nav::GetPlatformProfile("wheeled");
  sim_options.SetProfile(profile);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();

  PerceptionOptions perception_options;
  perception_options.camera_rate_hz = 0;
  PerceptionPipeline perception(perception_options, "r1");
  NavMapOptions map_options;
  auto planner = NavMap::MakePlanner(map_options, perception_options.map.resolution_m, start_M, {profile});
  NavMap nav_map(map_options, perception_options.map.resolution_m, start_M, planner, "wheeled");

  // Before anything is seen, a goal down the tunnel is planned optimistically (unknown space is traversable).
  nav::GlobalPlanRequest request;
  request.start_W = {start_M.x_m, start_M.y_m};
  request.goal_W = {26.0, 20.0};
  request.platform = "wheeled";
  ASSERT_TRUE(planner->Plan(request).IsUsable());

  // Drive the true base east along the tunnel's centre line at 1 m/s, scanning at 10 Hz, updating at 1 Hz.
  std::vector<double> update_ms;
  int tiles_total = 0;
  const double dt_s = 0.1;
  for (int k = 1; k <= 220; ++k) {
    const double now_s = k * dt_s;
    sim::UnicycleState s = platform.TrueState();
    s.x_m = 4.0 + 0.1 * k;
    s.v_mps = 1.0;
    platform.SetTrueState(s);
    platform.Update(now_s);
    core::LidarScan scan;
    ASSERT_TRUE(platform.ReadLidarScan(now_s, &scan));
    perception.Tick(now_s, &scan, nullptr);
    if (k % 10 == 0) {
      const NavMapUpdateStats stats =
          nav_map.Update(*perception.map(), perception.TakeChangedTiles(), perception.change_tile_m(),
                         perception.max_sensor_z_m());
      if (!stats.applied) continue;
      update_ms.push_back(stats.read_ms + stats.traversability_ms + stats.publish_ms);
      tiles_total += stats.tiles;
    }
  }
  ASSERT_GE(update_ms.size(), 20u);
  std::sort(update_ms.begin(), update_ms.end());
  std::printf("FIGURE nav map update: %zu updates, %.1f tiles each, median %.1f ms, max %.1f ms (read + "
              "traversability + hand-over; 80 x 80 m extent at 0.1 m)\n",
              update_ms.size(), static_cast<double>(tiles_total) / update_ms.size(), update_ms[update_ms.size() / 2],
              update_ms.back());

  // The incremental grid equals a full rebuild from the same voxels.
  const nav::TraversabilityGrid& incremental = nav_map.grid();
  nav::TraversabilityGrid full(nav_map.voxels(), planner->TerrainOptionsFor(profile), &nav_map.seen_free());
  full.SetObserverHeight(perception.max_sensor_z_m());
  full.Update(nav_map.voxels(), &nav_map.seen_free(),
              {Eigen::AlignedBox2d(full.p_W_min(), full.p_W_max())});  // the whole grid with that height
  int differing = 0;
  for (int ix = 0; ix < full.nx(); ++ix) {
    for (int iy = 0; iy < full.ny(); ++iy) {
      const bool same = full.State(ix, iy) == incremental.State(ix, iy) &&
                        full.IsLethal(ix, iy) == incremental.IsLethal(ix, iy) &&
                        full.IsTraversable(ix, iy) == incremental.IsTraversable(ix, iy) &&
                        (full.ClearanceM(ix, iy) > 2.0 ? incremental.ClearanceM(ix, iy) > 2.0
                                                       : full.ClearanceM(ix, iy) == incremental.ClearanceM(ix, iy));
      differing += !same;
    }
  }
  EXPECT_EQ(differing, 0);

  // Planning on the robot's own map: a goal past the junction is reached over floor the ground truth calls
  // traversable for the same robot, never through a wall the robot saw.
  const core::BaseState here = platform.ReadPose().PlanarState();
  request.start_W = {here.x_m, here.y_m};
  request.goal_W = {30.0, 12.0};
  request.start_is_robot = true;
  const nav::GlobalPlan plan = planner->Plan(request);
  ASSERT_TRUE(plan.IsUsable()) << plan.reason;
  const auto& truth = *platform.terrain();
  int off_floor = 0;
  for (std::size_t i = 0; i + 1 < plan.result.path_W.size(); ++i) {
    const Eigen::Vector2d a = plan.result.path_W[i].head<2>();
    const Eigen::Vector2d b = plan.result.path_W[i + 1].head<2>();
    const int n = std::max(1, static_cast<int>((b - a).norm() / 0.05));
    for (int j = 0; j <= n; ++j) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(j) / n);
      off_floor += !truth.IsFootprintFree(p.x(), p.y(), profile.footprint_radius_m);
    }
  }
  EXPECT_EQ(off_floor, 0) << "path samples whose body would touch the true world";

  // A goal in a wall the robot has seen is refused with the cell's state.
  request.goal_W = {15.0, 21.9};  // the tunnel (3 m wide, centred on y = 20) has its north wall here
  const nav::GlobalPlan blocked = planner->Plan(request);
  EXPECT_FALSE(blocked.IsUsable());
  EXPECT_NE(blocked.reason.find("not traversable"), std::string::npos) << blocked.reason;
}

// A wheeled robot driven along the building's corridor to the foot of the stairwell, which it then sees: a
// goal on floor 2 is refused naming the step it cannot climb (the multi-process floors test asks the same of
// the agent; here without DDS or timing).
TEST(NavMapTest, AWheeledRobotAtTheFootOfTheStairsIsRefusedTheFloorAboveNamingTheStep) {
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:building";
  sim_options.start_W = core::PlanarPose{10.0, 7.1, 0.0};
  const nav::PlatformProfile profile = nav::GetPlatformProfile("wheeled");
  sim_options.SetProfile(profile);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();
  PerceptionOptions perception_options;
  perception_options.camera_rate_hz = 0;
  PerceptionPipeline perception(perception_options, "r2");
  NavMapOptions map_options;
  auto planner = NavMap::MakePlanner(map_options, perception_options.map.resolution_m, start_M,
                                     {profile, nav::GetPlatformProfile("legged")});
  NavMap nav_map(map_options, perception_options.map.resolution_m, start_M, planner, "wheeled");
  const double dt_s = 0.1;
  for (int k = 1; k <= 120; ++k) {  // 8.9 m east at 1 m/s, then 3 s facing the stairs
    const double now_s = k * dt_s;
    sim::UnicycleState s = platform.TrueState();
    s.x_m = std::min(18.9, 10.0 + 0.1 * k);
    s.y_m = 7.1 - 0.2 * (s.x_m - 10.0) / 8.9;
    platform.SetTrueState(s);
    platform.Update(now_s);
    core::LidarScan scan;
    ASSERT_TRUE(platform.ReadLidarScan(now_s, &scan));
    perception.Tick(now_s, &scan, nullptr);
    if (k % 10 == 0) {
      nav_map.Update(*perception.map(), perception.TakeChangedTiles(), perception.change_tile_m(),
                     perception.max_sensor_z_m());
    }
  }
  const core::BaseState here = platform.ReadPose().PlanarState();
  nav::GlobalPlanRequest request;
  request.start_W = {here.x_m, here.y_m};
  request.start_z_m = here.z_m;
  request.goal_W = {15.1, 11.0};
  request.goal_z_m = 3.2;
  request.allow_partial = true;
  request.platform = "wheeled";
  request.start_is_robot = true;
  const nav::GlobalPlan refused = planner->Plan(request);
  EXPECT_FALSE(refused.IsUsable());
  EXPECT_NE(refused.reason.find("step"), std::string::npos) << refused.reason;
  EXPECT_NE(refused.reason.find("max_step_m 0.15"), std::string::npos) << refused.reason;
  // The legged robot's plan on the same map climbs (partial: the upper flight is not seen yet).
  request.platform = "legged";
  const nav::GlobalPlan legged = planner->Plan(request);
  EXPECT_TRUE(legged.IsUsable()) << legged.reason;
}

TEST(NavMapTest, InvalidOptionsNameTheField) {
  NavMapOptions o;
  std::string why;
  ASSERT_TRUE(o.IsValid(&why)) << why;
  o.half_extent_m = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.map_half_extent_m"), std::string::npos) << why;
  o = NavMapOptions();
  o.update_period_s = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("navigation.map_update_period_s"), std::string::npos) << why;
}

}  // namespace
}  // namespace cairn::agent
