// Bench: goal success rate and time to goal over a fixed set of goals per built-in world, for the
// navigation stack on the robot's own knowledge (simulated platform: lidar scans -> OctoMap -> navigation map
// -> global planner; live lidar obstacles -> local planner; SLAM pose -> controller), against the
// ground-truth stack (planner on the simulator's world, lethal cells of the world as
// obstacles, true pose), in the same run. Each goal starts a fresh robot (no prior map) at the world's first
// suggested start. In process, on a simulated clock (50 Hz control, 10 Hz lidar, 1 Hz map updates), no DDS.
//
//   build/bench/cairn_bench_nav_goals [--goals N] [--half-extent M (navigation map, default 40)]
//                                     [--world builtin:NAME]...
//   build/bench/cairn_bench_nav_goals --floors N
//     a legged robot from N corridor starts in builtin:building to floor 2, with and without the staircase
//     prior (RunFloors).
//   build/bench/cairn_bench_nav_goals [--verbose] [--platform wheeled|legged] [--z GZ] [--pause S] [--then GX
//   GY]...
//                                     --one WORLD SX SY SYAW GX GY
//     one robot from (SX, SY, SYAW) to (GX, GY), then on to each --then goal (given before --one; the last
//     goal on the level nearest GZ, metres: an upper floor), own map against ground truth for the first goal
//     (planar goals only), standing still --pause S seconds before each --then goal (a goal that fails goes
//     on to the next); --verbose traces the robot, its obstacles and maps.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/modes/waypoint_recovery.h"
#include "cairn/agent/services/live_obstacles.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/core/build_paths.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/navigation.h"
#include "cairn/nav/sampling.h"
#include "cairn/nav/scan_obstacles.h"
#include "cairn/perception/perception_pipeline.h"
#include "cairn/perception/staircase.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace {

using namespace cairn;
constexpr double kDt = 0.02;

struct Outcome {
  bool arrived = false;
  bool contact = false;
  double time_s = 0.0;
  std::string reason;
  int recoveries = 0;        // times the recovery tree ran (own map)
  double highest_z_m = 0.0;  // highest true height of the body (own map)
};

double g_half_extent_m = agent::NavMapOptions().half_extent_m;
bool g_verbose = false;
bool g_recovery = true;  // run the recovery tree when navigation gives up (--no-recovery: fail at once)
std::vector<Eigen::Vector2d> g_then_goals;  // --then GX GY: further goals for the same robot (--one)
std::string g_platform = "wheeled";         // --platform (--one)
double g_goal_z_m = std::numeric_limits<double>::quiet_NaN();  // --z: the first goal's level (--one)
bool g_verbose_columns_along_y = std::getenv("CAIRN_BENCH_COLUMNS_ALONG_Y") !=
                                 nullptr;  // PrintLevels' column list along y (true) or x (false)
bool g_stair_prior = true;  // --no-stair-prior: detected flights are not written into the navigation map
double g_pause_s = 0.0;     // --pause: the robot stands still this long before each --then goal (--one)

agent::AgentOptions Options() {
  agent::AgentOptions o;
  o.robot_id = "bench";
  o.SetPlatform(g_platform);
  o.nav_map.half_extent_m = g_half_extent_m;
  return o;
}

// A 4 m x 3 m picture around `center_W`: ground truth | navigation map. '#' lethal, '+' free but not
// traversable, '.' traversable, '?' unknown (nav map, traversable), 'R' the robot; then the nav map's column
// at the centre (occupied and seen-free voxel heights).
void PrintPicture(const nav::TraversabilityGrid& truth, const agent::NavMap& nav_map,
                  const core::BaseState& pose, const Eigen::Vector2d& center_W) {
  const nav::TraversabilityGrid& grid = nav_map.grid();
  auto glyph = [&](const nav::TraversabilityGrid& g, double x, double y) {
    int ix = 0, iy = 0;
    if (!g.CellOf(x, y, &ix, &iy)) return ' ';
    if (std::hypot(x - pose.x_m, y - pose.y_m) < 0.1) return 'R';
    if (g.IsLethal(ix, iy)) return '#';
    if (g.State(ix, iy) == nav::CellState::kUnknown) return '?';
    return g.IsTraversable(ix, iy) ? '.' : '+';
  };
  for (double y = center_W.y() + 1.5; y > center_W.y() - 1.5; y -= 0.1) {
    std::string row;
    for (double x = center_W.x() - 2.0; x < center_W.x() + 2.0; x += 0.1) row += glyph(truth, x, y);
    row += "   ";
    for (double x = center_W.x() - 2.0; x < center_W.x() + 2.0; x += 0.1) row += glyph(grid, x, y);
    std::printf("      %s  y %.2f\n", row.c_str(), y);
  }
  const core::VoxelGrid& voxels = nav_map.voxels();
  const auto index = voxels.IndexOf({center_W.x(), center_W.y(), pose.z_m});
  if (!index) return;
  std::printf("      column at (%.2f, %.2f), occupied z:", center_W.x(), center_W.y());
  for (int iz = 0; iz < voxels.dims().z(); ++iz) {
    if (voxels.IsOccupiedIndex({index->x(), index->y(), iz}))
      std::printf(" %.2f", voxels.CenterOf({0, 0, iz}).z());
  }
  std::printf("; seen free z:");
  for (int iz = 0; iz < voxels.dims().z(); ++iz) {
    if (nav_map.seen_free().IsOccupiedIndex({index->x(), index->y(), iz})) {
      std::printf(" %.2f", voxels.CenterOf({0, 0, iz}).z());
    }
  }
  std::printf("\n");
}

// The navigation map's surfaces near height `z_m` over a 3 m x 2 m window around `center_W` (rows: y):
// per cell the surface nearest z_m within 0.35 m as its height above z_m in decimetres (a letter when not
// traversable: 'a' = -3 .. 'g' = +3), '-' none, '?' unknown at z_m.
void PrintLevels(const agent::NavMap& nav_map, const Eigen::Vector2d& center_W, double z_m) {
  const nav::MultiLevelGrid& levels = nav_map.levels();
  for (double y = center_W.y() + 1.0; y > center_W.y() - 1.0; y -= 0.1) {
    std::string row;
    for (double x = center_W.x() - 1.5; x < center_W.x() + 1.5; x += 0.1) {
      int ix = 0, iy = 0;
      if (!levels.CellOf(x, y, &ix, &iy)) {
        row += ' ';
        continue;
      }
      const int node = levels.NodeNear(ix, iy, z_m, 0.35);
      if (node < 0) {
        row += levels.IsUnknownAt(ix, iy, z_m) ? '?' : '-';
        continue;
      }
      const int dz = static_cast<int>(std::lround((levels.NodeZ(node) - z_m) / 0.1));
      row += levels.IsTraversable(node) ? static_cast<char>('0' + std::clamp(dz + 3, 0, 9))
                                        : static_cast<char>('a' + std::clamp(dz + 3, 0, 9));
    }
    std::printf("      %s  y %.2f\n", row.c_str(), y);
  }
  std::printf(
      "      (x from %.2f; digit = 3 + surface height above z %.2f in dm, letter = not traversable)\n",
      center_W.x() - 1.5, z_m);
  // The columns along y = center's y: voxels (o occupied, f seen free, . unknown) from z_m - 0.5 up, and
  // the surfaces (height, clearance).
  const core::VoxelGrid& voxels = nav_map.voxels();
  for (double t = -1.0; t < 0.6; t += 0.1) {
    const double x = center_W.x() + (g_verbose_columns_along_y ? 0.0 : t);
    const double y = center_W.y() + (g_verbose_columns_along_y ? t : 0.0);
    const auto index = voxels.IndexOf({x, y, z_m});
    int ix = 0, iy = 0;
    if (!index || !levels.CellOf(x, y, &ix, &iy)) continue;
    std::string column;
    for (int dz = -5; dz <= 12; ++dz) {
      const Eigen::Vector3i v(index->x(), index->y(), index->z() + dz);
      column += voxels.IsOccupiedIndex(v) ? 'o' : nav_map.seen_free().IsOccupiedIndex(v) ? 'f' : '.';
    }
    std::printf("      x %.2f y %.2f z %.2f..: %s surfaces:", x, y, voxels.CenterOf(*index).z() - 0.5,
                column.c_str());
    const int c = levels.Column(ix, iy);
    for (int n = levels.FirstNode(c); n < levels.FirstNode(c + 1); ++n) {
      std::printf(" %.2f(%.2f)", levels.NodeZ(n), levels.ClearanceM(n));
    }
    std::printf("\n");
  }
}

// The robot's own stack: everything from the simulated platform's sensors and pose estimate.
Outcome RunOwnMap(const std::string& world, const core::PlanarPose& start, const Eigen::Vector2d& first_goal,
                  double timeout_s) {
  Eigen::Vector2d goal = first_goal;
  std::size_t next_goal = 0;
  const agent::AgentOptions options = Options();
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = world;
  sim_options.start_W = start;
  sim::ApplyPlatformProfile(options.navigation.platform, &sim_options);
  sim::SimulatedPlatform platform(sim_options);
  platform.Update(0.0);
  const core::BaseState start_M = platform.ReadPose().PlanarState();
  // What navigation's classifier makes of the true world (verbose pictures only; contact is the simulator's),
  // built again only when the world changed (a rockfall swaps it).
  std::shared_ptr<const sim::World> truth_world;
  std::shared_ptr<const nav::TraversabilityGrid> truth_classified;
  auto truth_grid = [&] {
    if (platform.world() != truth_world) {
      truth_world = platform.world();
      nav::TraversabilityOptions t = options.navigation.platform.traversability;
      t.robot_radius_m = options.navigation.platform.footprint_radius_m;
      truth_classified = std::make_shared<const nav::TraversabilityGrid>(*truth_world, t);
    }
    return truth_classified;
  };
  perception::PerceptionOptions perception_options = options.perception;
  perception_options.camera_rate_hz = 0;
  perception::PerceptionPipeline perception(perception_options, "bench");
  auto planner = agent::NavMap::MakePlanner(options.nav_map, perception_options.map.resolution_m, start_M,
                                            {options.navigation.platform});
  agent::NavMap nav_map(options.nav_map, perception_options.map.resolution_m, start_M, planner, g_platform);
  nav::Navigation navigation(options.navigation, planner,
                             std::make_shared<const nav::TrajectoryLibrary>(options.LibraryForPlatform()));
  agent::LiveObstacles live_obstacles(options.navigation, options.obstacle_window_s,
                                      platform.Capabilities().lidar_min_elevation_rad);
  agent::WaypointRecovery recovery(cairn::core::SourceDir() + "/config/mode_tree.xml", &navigation,
                                   agent::WaypointRecovery::Hooks{[&] { live_obstacles.Clear(); }});
  std::vector<Eigen::Vector3f> points_B;
  Outcome out;
  core::LidarScan scan;
  bool goal_set = false;
  double active_goal_z_m = std::numeric_limits<double>::quiet_NaN();
  double pause_until_s = 0.0;  // no goal before then (--pause)
  for (double t = kDt; t < timeout_s; t += kDt) {
    platform.Update(t);
    const core::BaseState pose = platform.ReadPose().PlanarState();
    if (platform.ReadLidarScan(t, &scan)) {
      core::BaseState at_scan;
      live_obstacles.AddScan(scan, &points_B, &at_scan);
      navigation.SetObstacles(points_B, at_scan, t);
      perception.Tick(t, &scan, nullptr);
    }
    if (std::fmod(t + 1e-9, 1.0) < kDt) {
      nav_map.Update(*perception.map(), perception.TakeChangedTiles(), perception.change_tile_m(),
                     perception.max_sensor_z_m(),
                     g_stair_prior ? perception.Staircases() : std::vector<perception::Staircase>{});
    }
    // A goal on another level waits for the first map updates (the agent is sent one when it has a map).
    if (!goal_set && t >= pause_until_s && (next_goal > 0 || !std::isfinite(g_goal_z_m) || t >= 2.0)) {
      // As the agent's planning service does (PerceptionService::CoverGoal): a goal beyond the navigation map
      // makes it grow at its next update, the plan ends at its edge meanwhile.
      if (const std::string why = nav_map.Cover(goal); !why.empty()) {
        out.reason = "refused: " + why;
        return out;
      }
      active_goal_z_m =
          next_goal == g_then_goals.size() ? g_goal_z_m : std::numeric_limits<double>::quiet_NaN();
      const nav::GlobalPlan plan = navigation.SetGoal(pose, goal.x(), goal.y(), 0.0, t, active_goal_z_m);
      if (!plan.IsUsable()) {
        out.reason = "refused: " + plan.reason;
        if (g_verbose) {
          for (const perception::Staircase& st : perception.Staircases()) {
            std::printf(
                "      staircase at (%.2f, %.2f, %.2f) yaw %.2f rise %.3f run %.3f width %.2f, %d steps\n",
                st.p_W_first_step.x(), st.p_W_first_step.y(), st.p_W_first_step.z(), st.yaw_rad, st.rise_m,
                st.run_m, st.width_m, st.num_steps);
          }
          PrintLevels(nav_map, {pose.x_m + 1.0, pose.y_m}, pose.z_m);
          PrintLevels(nav_map, {pose.x_m + 1.0, pose.y_m}, pose.z_m + 0.5);
        }
        return out;
      }
      goal_set = true;
    }
    perception.set_refresh_at_rest(goal_set);  // as the agent: a robot waiting on a goal watches the world
    if (!goal_set) {                           // standing still, sensing, until the next goal
      platform.CommandTwist(0.0, 0.0, t);
      out.contact = out.contact || platform.ReadStatus().in_contact;
      continue;
    }
    // Navigation, and the recovery tree when it gives up (as the agent's waypoint mode runs them), unless
    // --no-recovery.
    nav::NavigationStep step;
    if (recovery.active()) {
      step = recovery.Step(pose, t);
      // An attempt's plan comes from a worker: wait for it in wall time (the robot holds still).
      while (recovery.planning()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        step = recovery.Step(pose, t);
      }
    } else {
      step = navigation.StepWaypoint(pose, t);
      if (step.failed && g_recovery && recovery.enabled()) {
        if (g_verbose) std::printf("  t %.1f recovery after: %s\n", t, step.reason.c_str());
        ++out.recoveries;
        recovery.Start(goal.x(), goal.y(), 0.0, step.reason, active_goal_z_m);
        step = nav::NavigationStep{};
      }
    }
    platform.CommandTwist(step.linear_x_mps, step.angular_z_radps, t);
    if (platform.ReadStatus().in_contact && !out.contact) {
      const auto truth = platform.TrueState();
      std::printf(
          "  t %.2f CONTACT at true (%.2f, %.2f, %.2f) yaw %.2f, estimate (%.2f, %.2f, %.2f) yaw %.2f, cmd "
          "(%.2f, %.2f)\n",
          t, truth.x_m, truth.y_m, truth.z_m, truth.yaw_rad, pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad,
          step.linear_x_mps, step.angular_z_radps);
    }
    out.contact = out.contact || platform.ReadStatus().in_contact;
    out.highest_z_m = std::max(out.highest_z_m, platform.TrueState().z_m);
    if (g_verbose && std::fmod(t + 1e-9, 0.5) < kDt) {
      std::printf("    t %5.1f pose (%.2f, %.2f, %.2f) v %.2f w %.2f cmd (%.2f, %.2f) left %.1f local '%s'\n",
                  t, pose.x_m, pose.y_m, pose.yaw_rad, pose.v_mps, pose.w_radps, step.linear_x_mps,
                  step.angular_z_radps, navigation.distance_left_m(), navigation.local_status().c_str());
      const auto& path_W = navigation.global_plan().result.path_W;
      std::printf("      global path (%zu points):", path_W.size());
      for (std::size_t i = 0; i < path_W.size() && i < 6; ++i)
        std::printf(" (%.2f, %.2f)", path_W[i].x(), path_W[i].y());
      const nav::LocalPlanResult& local = navigation.local_result();
      std::printf("\n      local: %s free %.2f of %.2f m, %d free paths, end (%.2f, %.2f) frame B\n",
                  local.message.c_str(), local.free_length_m, local.required_free_length_m,
                  local.num_free_paths, local.path_B.empty() ? 0.0f : local.path_B.back().x(),
                  local.path_B.empty() ? 0.0f : local.path_B.back().y());
      if (std::fabs(t - 2.5) < 0.5 * kDt) PrintPicture(*truth_grid(), nav_map, pose, {pose.x_m, pose.y_m});
      // Obstacles within 1 m, frame M, and what the ground truth and the navigation map say there.
      const auto truth_now = truth_grid();
      for (const auto& p : points_B) {
        if (p.head<2>().norm() > 1.0) continue;
        const double c = std::cos(pose.yaw_rad), s = std::sin(pose.yaw_rad);
        const double x = pose.x_m + c * p.x() - s * p.y(), y = pose.y_m + s * p.x() + c * p.y();
        int ix = 0, iy = 0;
        const bool in_map = nav_map.grid().CellOf(x, y, &ix, &iy);
        const nav::TraversabilityGrid& grid = nav_map.grid();
        std::printf("      obstacle (%.2f, %.2f) z %.2f: truth %s, nav map %s ground %.2f%s%s\n", x, y, p.z(),
                    truth_now->IsTraversableAt(x, y) ? "traversable" : "blocked",
                    in_map ? nav::ToString(grid.State(ix, iy)) : "outside",
                    in_map ? grid.Ground(ix, iy) : NAN, in_map && grid.IsLethal(ix, iy) ? " lethal" : "",
                    in_map && grid.IsTraversable(ix, iy) ? " traversable" : "");
      }
    }
    // CAIRN_BENCH_DUMP="T X Y Z": the navigation map's surfaces around (X, Y) near height Z at time T
    // (debugging).
    if (static const char* dump = std::getenv("CAIRN_BENCH_DUMP"); dump != nullptr) {
      double dt = 0, dx = 0, dy = 0, dz = 0;
      if (std::sscanf(dump, "%lf %lf %lf %lf", &dt, &dx, &dy, &dz) == 4 && std::fabs(t - dt) < 0.5 * kDt) {
        std::printf("  map at t %.1f around (%.2f, %.2f) z %.2f:\n", t, dx, dy, dz);
        PrintLevels(nav_map, {dx, dy}, dz);
      }
    }
    out.time_s = t;
    if (step.arrived) {
      const auto truth = platform.TrueState();
      out.arrived = std::hypot(truth.x_m - goal.x(), truth.y_m - goal.y()) < 0.5;  // SLAM drift counted
      if (!out.arrived) out.reason = "arrived by its estimate but 0.5 m or more from the goal";
      if (out.arrived && next_goal < g_then_goals.size()) {
        std::printf("  arrived at (%.2f, %.2f) after %.1f s; next goal\n", goal.x(), goal.y(), t);
        goal = g_then_goals[next_goal++];
        goal_set = false;
        out.arrived = false;
        pause_until_s = t + g_pause_s;
        continue;
      }
      return out;
    }
    if (step.failed && next_goal < g_then_goals.size()) {
      std::printf("  failed at (%.2f, %.2f) after %.1f s, robot at (%.2f, %.2f) yaw %.2f: %s; next goal\n",
                  goal.x(), goal.y(), t, pose.x_m, pose.y_m, pose.yaw_rad, step.reason.c_str());
      goal = g_then_goals[next_goal++];
      goal_set = false;
      pause_until_s = t + g_pause_s;
      continue;
    }
    if (step.failed) {
      if (g_verbose) {
        // The navigation map from the robot to the goal, along x (rows: y), 0.1 m per character.
        const nav::TraversabilityGrid& grid = nav_map.grid();
        const double x0 = std::min(pose.x_m, goal.x()) - 1, x1 = std::max(pose.x_m, goal.x()) + 1;
        for (double y = 1.2; y > -1.3; y -= 0.1) {
          std::string row;
          for (double x = x0; x < x1; x += 0.1) {
            int ix = 0, iy = 0;
            char c = ' ';
            if (grid.CellOf(x, y, &ix, &iy)) {
              c = grid.IsLethal(ix, iy)                            ? '#'
                  : grid.State(ix, iy) == nav::CellState::kUnknown ? '?'
                  : grid.IsTraversable(ix, iy)                     ? '.'
                                                                   : '+';
            }
            row += c;
          }
          std::printf("      %s  y %.2f\n", row.c_str(), y);
        }
        std::printf("      (x from %.1f to %.1f)\n", x0, x1);
        PrintPicture(*truth_grid(), nav_map, pose, goal);
        for (const perception::Staircase& st : perception.Staircases()) {
          std::printf(
              "      staircase at (%.2f, %.2f, %.2f) yaw %.2f rise %.3f run %.3f width %.2f, %d steps\n",
              st.p_W_first_step.x(), st.p_W_first_step.y(), st.p_W_first_step.z(), st.yaw_rad, st.rise_m,
              st.run_m, st.width_m, st.num_steps);
        }
        // Around the end of the last plan (a partial plan's end: where the map showed no way on), at the
        // robot's height and half a metre above.
        const auto& last_path = navigation.global_plan().result.path_W;
        const Eigen::Vector2d end = last_path.empty() ? Eigen::Vector2d(pose.x_m, pose.y_m)
                                                      : Eigen::Vector2d(last_path.back().head<2>());
        PrintLevels(nav_map, end, pose.z_m);
        PrintLevels(nav_map, end, pose.z_m + 0.5);
        if (std::getenv("CAIRN_BENCH_AT_X"))
          PrintLevels(nav_map, {std::atof(std::getenv("CAIRN_BENCH_AT_X")), end.y()}, pose.z_m);
        for (double x = goal.x() - 0.35; x < goal.x() + 0.4; x += 0.1) {
          std::printf("      octomap x %.2f:", x);
          for (double z = -0.05; z < 0.4; z += 0.1) {
            std::printf(" z %.2f %d", z, static_cast<int>(perception.map()->Query({x, goal.y(), z})));
          }
          std::printf("\n");
        }
      }
      out.reason = step.reason;
      return out;
    }
  }
  out.reason = "timeout";
  return out;
}

// The ground-truth stack: the simulator's world is the map, its lethal cells the obstacles, the true pose.
Outcome RunGroundTruth(const std::string& world_spec, const core::PlanarPose& start,
                       const Eigen::Vector2d& goal, double timeout_s) {
  const agent::AgentOptions options = Options();
  auto world = std::make_shared<const sim::World>(sim::LoadWorld(world_spec));
  auto planner = std::make_shared<nav::GlobalPlanner>(
      world, std::vector<nav::PlatformProfile>{options.navigation.platform});
  const auto grid = planner->Grid("wheeled");
  nav::Navigation navigation(options.navigation, planner,
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
    const nav::NavigationStep step = navigation.StepWaypoint(base.state(), t);
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

// --floors N: a legged robot from N starts along builtin:building's floor-1 corridor to the foot of the
// stairwell, then to the room north of the corridor on floor 2 (z 3.2), with the staircase prior (detected
// flights' treads written into its navigation map) and without it (the baseline), in the same process.
int RunFloors(int starts) {
  g_platform = "legged";
  g_goal_z_m = 3.2;
  g_then_goals = {Eigen::Vector2d(15.1, 11.0)};
  struct Tally {
    int arrived = 0, contacts = 0, on_floor2 = 0;  // on_floor2: the body was at z >= 3.1 at some point
    double time_s = 0;
  };
  Tally with_prior, baseline;
  for (int k = 0; k < starts; ++k) {
    const core::PlanarPose start{8.0 + 9.0 * k / std::max(1, starts - 1), 7.1, 0.0};
    for (const bool prior : {true, false}) {
      g_stair_prior = prior;
      const Outcome o = RunOwnMap("builtin:building", start, {19.0, 6.5}, 240.0);
      Tally& t = prior ? with_prior : baseline;
      t.arrived += o.arrived ? 1 : 0;
      t.contacts += o.contact ? 1 : 0;
      t.on_floor2 += o.highest_z_m >= 3.1 ? 1 : 0;
      if (o.arrived) t.time_s += o.time_s;
      std::printf("start (%.1f, 7.1) %s: %s after %.1f s, highest z %.2f m%s %.150s\n", start.x_m,
                  prior ? "prior   " : "baseline", o.arrived ? "arrived" : "FAILED", o.time_s, o.highest_z_m,
                  o.contact ? " WITH CONTACT" : "", o.reason.c_str());
    }
  }
  std::printf(
      "goal on floor 2 reached: with the staircase prior %d/%d (mean %.1f s), baseline %d/%d\n"
      "body on floor 2 (z >= 3.1 m): with the staircase prior %d/%d, baseline %d/%d; contacts %d vs %d\n",
      with_prior.arrived, starts, with_prior.arrived ? with_prior.time_s / with_prior.arrived : 0.0,
      baseline.arrived, starts, with_prior.on_floor2, starts, baseline.on_floor2, starts, with_prior.contacts,
      baseline.contacts);
  return 0;
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
    } else if (!std::strcmp(argv[i], "--then") && i + 2 < argc) {
      g_then_goals.emplace_back(std::atof(argv[i + 1]), std::atof(argv[i + 2]));
      i += 2;
    } else if (!std::strcmp(argv[i], "--pause") && i + 1 < argc) {
      g_pause_s = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--platform") && i + 1 < argc) {
      g_platform = argv[++i];
    } else if (!std::strcmp(argv[i], "--z") && i + 1 < argc) {
      g_goal_z_m = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--verbose")) {
      g_verbose = true;
    } else if (!std::strcmp(argv[i], "--no-stair-prior")) {
      g_stair_prior = false;
    } else if (!std::strcmp(argv[i], "--no-recovery")) {
      g_recovery = false;
    } else if (!std::strcmp(argv[i], "--one") && i + 6 < argc) {  // --one WORLD SX SY SYAW GX GY
      const std::string world = argv[i + 1];
      const core::PlanarPose start{std::atof(argv[i + 2]), std::atof(argv[i + 3]), std::atof(argv[i + 4])};
      const Eigen::Vector2d goal(std::atof(argv[i + 5]), std::atof(argv[i + 6]));
      const Outcome own = RunOwnMap(world, start, goal, 240.0);
      std::printf("own map: %s after %.1f s%s %s\n", own.arrived ? "arrived" : "FAILED", own.time_s,
                  own.contact ? " WITH CONTACT" : "", own.reason.c_str());
      if (std::isfinite(g_goal_z_m)) return own.arrived && !own.contact ? 0 : 1;
      const Outcome gt = RunGroundTruth(world, start, goal, 120.0);
      std::printf("ground truth: %s after %.1f s %s\n", gt.arrived ? "arrived" : "FAILED", gt.time_s,
                  gt.reason.c_str());
      return own.arrived ? 0 : 1;
    } else if (!std::strcmp(argv[i], "--floors") && i + 1 < argc) {
      return RunFloors(std::max(1, std::atoi(argv[++i])));
    } else if (!std::strcmp(argv[i], "--world") && i + 1 < argc) {
      worlds.emplace_back(argv[++i]);
    } else {
      std::fprintf(stderr,
                   "usage: %s [--goals N] [--half-extent M] [--no-recovery] [--world builtin:NAME]...\n",
                   argv[0]);
      return 2;
    }
  }
  if (worlds.empty()) worlds = {"builtin:tunnels", "builtin:arena", "builtin:building"};
  for (const std::string& world : worlds) {
    const auto& info = sim::GetBuiltinWorldInfo(world.substr(8));
    const core::PlanarPose start = info.suggested_starts.front();
    // Fixed goals: free cells of the ground truth at least 4 m from the start, seeded.
    const nav::TraversabilityGrid truth(sim::LoadWorld(world),
                                        nav::GetPlatformProfile("wheeled").traversability);
    std::vector<Eigen::Vector2d> goals;
    for (const Eigen::Vector3d& p : nav::SampleFreeStarts(truth, 4 * goals_per_world, 1.5, /*seed=*/11)) {
      if (std::hypot(p.x() - start.x_m, p.y() - start.y_m) >= 4.0 &&
          static_cast<int>(goals.size()) < goals_per_world) {
        goals.emplace_back(p.x(), p.y());
      }
    }
    int own_ok = 0, truth_ok = 0, own_contacts = 0, truth_contacts = 0, recovered = 0;
    double own_time = 0, truth_time = 0;  // over goals both reached
    int both = 0;
    for (std::size_t g = 0; g < goals.size(); ++g) {
      const Outcome own = RunOwnMap(world, start, goals[g], 240.0);
      const Outcome gt = RunGroundTruth(world, start, goals[g], 240.0);
      own_ok += own.arrived;
      truth_ok += gt.arrived;
      own_contacts += own.contact;
      recovered += own.arrived && own.recoveries > 0;
      truth_contacts += gt.contact;
      if (own.arrived && gt.arrived) {
        own_time += own.time_s;
        truth_time += gt.time_s;
        ++both;
      }
      std::printf(
          "  %s goal %2zu (%5.1f, %5.1f): own map %s %5.1f s%s%s | ground truth %s %5.1f s%s\n",
          world.c_str(), g, goals[g].x(), goals[g].y(), own.arrived ? "arrived" : "FAILED ", own.time_s,
          own.recoveries > 0 ? (" after " + std::to_string(own.recoveries) + " recovery").c_str() : "",
          own.arrived ? "" : (" (" + own.reason + ")").c_str(), gt.arrived ? "arrived" : "FAILED ", gt.time_s,
          gt.arrived ? "" : (" (" + gt.reason + ")").c_str());
    }
    std::printf(
        "%s, %zu goals from (%.1f, %.1f): success own map %d/%zu (%d after a recovery), ground truth "
        "%d/%zu (ratio %.2f); contacts %d vs %d; mean time to goal on the %d both reached: own %.1f s, "
        "ground truth %.1f s (ratio %.2f)\n",
        world.c_str(), goals.size(), start.x_m, start.y_m, own_ok, goals.size(), recovered, truth_ok,
        goals.size(), truth_ok ? static_cast<double>(own_ok) / truth_ok : 0.0, own_contacts, truth_contacts,
        both, both ? own_time / both : 0.0, both ? truth_time / both : 0.0,
        truth_time > 0 ? own_time / truth_time : 0.0);
  }
  return 0;
}
