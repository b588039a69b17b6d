// Bench: goal success rate and time to goal over a fixed set of goals per built-in world (issue 11), for the
// navigation stack on the robot's own knowledge (simulated platform: lidar scans -> OctoMap -> navigation map
// -> global planner; live lidar obstacles -> local planner; SLAM pose -> controller), against the ground-truth
// stack of before issue 11 (planner on the simulator's world, lethal cells of the world as obstacles, true
// pose), in the same run. Each goal starts a fresh robot (no prior map) at the world's first suggested start.
// In process, on a simulated clock (50 Hz control, 10 Hz lidar, 1 Hz map updates), no DDS.
//
//   build/bench/cairn_bench_nav_goals [--goals N] [--half-extent M (navigation map, default 40)]
//                                     [--world builtin:NAME]...
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/live_obstacles.h"
#include "cairn/agent/nav_map.h"
#include "cairn/agent/navigation.h"
#include "cairn/agent/perception_pipeline.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/sampling.h"
#include "cairn/nav/scan_obstacles.h"
#include "cairn/perception/staircase.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/simulated_platform.h"

namespace {

using namespace cairn;
constexpr double kDt = 0.02;

struct Outcome {
  bool arrived = false;
  bool contact = false;
  double time_s = 0.0;
  std::string reason;
};

double g_half_extent_m = agent::NavMapOptions().half_extent_m;
bool g_verbose = false;

agent::AgentOptions Options() {
  agent::AgentOptions o;
  o.robot_id = "bench";
  o.SetPlatform("wheeled");
  o.nav_map.half_extent_m = g_half_extent_m;
  return o;
}

// The stack of issue 11: everything from the simulated platform's sensors and pose estimate.
Outcome RunOwnMap(const std::string& world, const core::PlanarPose& start, const Eigen::Vector2d& goal,
                  double timeout_s) {
  const agent::AgentOptions options = Options();
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = world;
  sim_options.start_W = start;
  sim_options.SetProfile(options.navigation.platform);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();
  agent::PerceptionOptions perception_options = options.perception;
  perception_options.camera_rate_hz = 0;
  agent::PerceptionPipeline perception(perception_options, "bench");
  auto planner = agent::NavMap::MakePlanner(options.nav_map, perception_options.map.resolution_m, start_M,
                                            {options.navigation.platform});
  agent::NavMap nav_map(options.nav_map, perception_options.map.resolution_m, start_M, planner, "wheeled");
  agent::Navigation navigation(options.navigation, planner,
                               std::make_shared<const nav::TrajectoryLibrary>(options.LibraryForPlatform()));
  agent::LiveObstacles live_obstacles(options);
  std::vector<Eigen::Vector3f> points_B;
  Outcome out;
  core::LidarScan scan;
  bool goal_set = false;
  for (double t = kDt; t < timeout_s; t += kDt) {
    platform.Update(t);
    const core::BaseState pose = platform.ReadPose().PlanarState();
    if (platform.ReadLidarScan(t, &scan)) {
      core::BaseState at_scan;
      live_obstacles.AddScan(scan, &points_B, &at_scan);
      navigation.SetObstacles(points_B, at_scan, t);
      perception.Tick(t, &scan, nullptr);
    }
    if (std::fmod(t + 1e-9, 1.0) < kDt) nav_map.Update(*perception.map(), perception.TakeChangedTiles(),
                                                       perception.change_tile_m());
    if (!goal_set) {
      const nav::GlobalPlan plan = navigation.SetGoal(pose, goal.x(), goal.y(), 0.0, t);
      if (!plan.IsUsable()) {
        out.reason = "refused: " + plan.reason;
        return out;
      }
      goal_set = true;
    }
    const agent::NavigationStep step = navigation.StepWaypoint(pose, t);
    platform.CommandTwist(step.linear_x_mps, step.angular_z_radps, t);
    out.contact = out.contact || platform.ReadStatus().in_contact;
    if (g_verbose && std::fmod(t + 1e-9, 0.5) < kDt) {
      std::printf("    t %5.1f pose (%.2f, %.2f, %.2f) v %.2f w %.2f cmd (%.2f, %.2f) left %.1f local '%s'\n", t, pose.x_m,
                  pose.y_m, pose.yaw_rad, pose.v_mps, pose.w_radps, step.linear_x_mps, step.angular_z_radps,
                  navigation.distance_left_m(), navigation.local_status().c_str());
      // Obstacles within 1 m, frame M, and what the ground truth and the navigation map say there.
      const auto truth = platform.terrain();
      for (const auto& p : points_B) {
        if (p.head<2>().norm() > 1.0) continue;
        const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
        const double x = pose.x_m + c * p.x() - s * p.y(), y = pose.y_m + s * p.x() + c * p.y();
        int ix = 0, iy = 0;
        const bool in_map = nav_map.grid().CellOf(x, y, &ix, &iy);
        std::printf("      obstacle (%.2f, %.2f): truth %s, nav map %s\n", x, y,
                    truth->IsTraversableAt(x, y) ? "traversable" : "blocked",
                    in_map ? nav::ToString(nav_map.grid().State(ix, iy)) : "outside");
      }
    }
    out.time_s = t;
    if (step.arrived) {
      const auto truth = platform.TrueState();
      out.arrived = std::hypot(truth.x_m - goal.x(), truth.y_m - goal.y()) < 0.5;  // SLAM drift counted
      if (!out.arrived) out.reason = "arrived by its estimate but 0.5 m or more from the goal";
      return out;
    }
    if (step.failed) {
      out.reason = step.reason;
      return out;
    }
  }
  out.reason = "timeout";
  return out;
}

// The stack before issue 11: the simulator's world is the map, its lethal cells the obstacles, the true pose.
Outcome RunGroundTruth(const std::string& world_spec, const core::PlanarPose& start, const Eigen::Vector2d& goal,
                       double timeout_s) {
  const agent::AgentOptions options = Options();
  auto world = std::make_shared<const sim::World>(sim::LoadWorld(world_spec));
  auto planner = std::make_shared<nav::GlobalPlanner>(world, std::vector<nav::PlatformProfile>{
                                                                 options.navigation.platform});
  const auto grid = planner->Grid("wheeled");
  agent::Navigation navigation(options.navigation, planner,
                               std::make_shared<const nav::TrajectoryLibrary>(options.LibraryForPlatform()));
  sim::Unicycle base(options.navigation.platform.limits, options.navigation.platform.footprint_radius_m);
  sim::UnicycleState s;
  s.x_m = start.x_m;
  s.y_m = start.y_m;
  s.yaw_rad = start.yaw_rad;
  base.set_state(s);
  Outcome out;
  const nav::GlobalPlan plan = navigation.SetGoal(base.state(), goal.x(), goal.y(), 0.0, 0.0);
  if (!plan.IsUsable()) {
    out.reason = "refused: " + plan.reason;
    return out;
  }
  std::vector<Eigen::Vector3f> points_B;
  for (double t = kDt; t < timeout_s; t += kDt) {
    if (std::fmod(t + 1e-9, 0.1) < kDt) {
      nav::LethalCellsNear(*grid, base.state().x_m, base.state().y_m, base.state().yaw_rad,
                           options.navigation.sensor_range_m, &points_B);
      navigation.SetObstacles(points_B, base.state(), t);
    }
    const agent::NavigationStep step = navigation.StepWaypoint(base.state(), t);
    out.contact = base.Step(step.linear_x_mps, step.angular_z_radps, kDt, *grid).contact || out.contact;
    out.time_s = t;
    if (step.arrived || step.failed) {
      out.arrived = step.arrived;
      out.reason = step.reason;
      return out;
    }
  }
  out.reason = "timeout";
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  int goals_per_world = 20;
  std::vector<std::string> worlds;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--goals") && i + 1 < argc) {
      goals_per_world = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--half-extent") && i + 1 < argc) {
      g_half_extent_m = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--verbose")) {
      g_verbose = true;
    } else if (!std::strcmp(argv[i], "--one") && i + 6 < argc) {  // --one WORLD SX SY SYAW GX GY
      const std::string world = argv[i + 1];
      const core::PlanarPose start{std::atof(argv[i + 2]), std::atof(argv[i + 3]), std::atof(argv[i + 4])};
      const Eigen::Vector2d goal(std::atof(argv[i + 5]), std::atof(argv[i + 6]));
      const Outcome own = RunOwnMap(world, start, goal, 120.0);
      std::printf("own map: %s after %.1f s %s\n", own.arrived ? "arrived" : "FAILED", own.time_s, own.reason.c_str());
      const Outcome gt = RunGroundTruth(world, start, goal, 120.0);
      std::printf("ground truth: %s after %.1f s %s\n", gt.arrived ? "arrived" : "FAILED", gt.time_s, gt.reason.c_str());
      return own.arrived ? 0 : 1;
    } else if (!std::strcmp(argv[i], "--world") && i + 1 < argc) {
      worlds.push_back(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--goals N] [--half-extent M] [--world builtin:NAME]...\n", argv[0]);
      return 2;
    }
  }
  if (worlds.empty()) worlds = {"builtin:tunnels", "builtin:arena"};
  for (const std::string& world : worlds) {
    const auto& info = sim::GetBuiltinWorldInfo(world.substr(8));
    const core::PlanarPose start = info.suggested_starts.front();
    // Fixed goals: free cells of the ground truth at least 4 m from the start, seeded.
    const nav::TraversabilityGrid truth(sim::LoadWorld(world), nav::GetPlatformProfile("wheeled").traversability);
    std::vector<Eigen::Vector2d> goals;
    for (const Eigen::Vector3d& p : nav::SampleFreeStarts(truth, 4 * goals_per_world, 1.5, /*seed=*/11)) {
      if (std::hypot(p.x() - start.x_m, p.y() - start.y_m) >= 4.0 && static_cast<int>(goals.size()) < goals_per_world) {
        goals.emplace_back(p.x(), p.y());
      }
    }
    int own_ok = 0, truth_ok = 0, own_contacts = 0, truth_contacts = 0;
    double own_time = 0, truth_time = 0;  // over goals both reached
    int both = 0;
    for (std::size_t g = 0; g < goals.size(); ++g) {
      const Outcome own = RunOwnMap(world, start, goals[g], 240.0);
      const Outcome gt = RunGroundTruth(world, start, goals[g], 240.0);
      own_ok += own.arrived;
      truth_ok += gt.arrived;
      own_contacts += own.contact;
      truth_contacts += gt.contact;
      if (own.arrived && gt.arrived) {
        own_time += own.time_s;
        truth_time += gt.time_s;
        ++both;
      }
      std::printf("  %s goal %2zu (%5.1f, %5.1f): own map %s %5.1f s%s | ground truth %s %5.1f s%s\n", world.c_str(),
                  g, goals[g].x(), goals[g].y(), own.arrived ? "arrived" : "FAILED ", own.time_s,
                  own.arrived ? "" : (" (" + own.reason + ")").c_str(), gt.arrived ? "arrived" : "FAILED ",
                  gt.time_s, gt.arrived ? "" : (" (" + gt.reason + ")").c_str());
    }
    std::printf("%s, %zu goals from (%.1f, %.1f): success own map %d/%zu, ground truth %d/%zu (ratio %.2f); "
                "contacts %d vs %d; mean time to goal on the %d both reached: own %.1f s, ground truth %.1f s "
                "(ratio %.2f)\n",
                world.c_str(), goals.size(), start.x_m, start.y_m, own_ok, goals.size(), truth_ok, goals.size(),
                truth_ok ? static_cast<double>(own_ok) / truth_ok : 0.0, own_contacts, truth_contacts, both,
                both ? own_time / both : 0.0, both ? truth_time / both : 0.0,
                truth_time > 0 ? own_time / truth_time : 0.0);
  }
  return 0;
}
