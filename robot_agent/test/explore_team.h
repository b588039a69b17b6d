// A team of robots exploring a simulated world in process on a simulated clock, each the shipping agent
// stepped (RobotAgent::Stepped over an InProcessTeam, team_testing::AgentTeam) and sent `explore` by the
// operator: each live robot's explore claims (every claim_period_s, with its seen floor every
// coverage_period_s) and peer states go to the others as its agent sends them, delivered at once. Scored
// against the world's ground truth. Used by cairn_agent_explore_test and cairn_bench_explore; the simulator's
// truth is for scoring only.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "agent_team.h"
#include "cairn/agent/communication/in_process_link.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent::explore_team {

using team_testing::AgentTeam;

/// Fraction of the floor a robot can reach from (start_x, start_y) (traversable ground-truth cells,
/// 8-connected flood fill; only those inside `region` when it is not empty) that is known (not unknown) in
/// any of `grids`.
inline double Coverage(const nav::TraversabilityGrid& truth,
                       const std::vector<const nav::TraversabilityGrid*>& grids, double start_x,
                       double start_y, const Eigen::AlignedBox2d& region = {},
                       int* reachable_cells = nullptr) {
  int sx = 0, sy = 0;
  if (!truth.CellOf(start_x, start_y, &sx, &sy)) return 0.0;
  const int nx = truth.nx(), ny = truth.ny();
  std::vector<char> seen(static_cast<std::size_t>(nx) * ny, 0);
  std::vector<std::pair<int, int>> open = {{sx, sy}};
  seen[static_cast<std::size_t>(sy) * nx + sx] = 1;
  int reachable = 0, known = 0;
  while (!open.empty()) {
    const auto [x, y] = open.back();
    open.pop_back();
    const Eigen::Vector2d c = truth.CellCenter(x, y);
    if (region.isEmpty() || region.contains(c)) {
      ++reachable;
      for (const nav::TraversabilityGrid* grid : grids) {
        int gx = 0, gy = 0;
        if (grid->CellOf(c.x(), c.y(), &gx, &gy) && grid->State(gx, gy) != nav::CellState::kUnknown) {
          ++known;
          break;
        }
      }
    }
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= nx || v >= ny) continue;
        char& s = seen[static_cast<std::size_t>(v) * nx + u];
        if (s || !truth.IsTraversable(u, v)) continue;
        s = 1;
        open.push_back({u, v});
      }
    }
  }
  if (reachable_cells != nullptr) *reachable_cells = reachable;
  return reachable > 0 ? static_cast<double>(known) / reachable : 0.0;
}

/// Fraction of the walkable surfaces (every level) a robot can reach from `start` (x, y, ground z; metres)
/// on `truth` (ground truth; connected traversable surfaces, 8-neighbouring columns, flood fill) whose
/// heights lie in [min_z_m, max_z_m] (and whose cell centre lies in `region`, frame W, unless it is empty)
/// that any of `maps` knows: a surface within 0.3 m of its height in that column, or the column seen at that
/// height (not MultiLevelGrid::IsUnknownAt). `reachable_surfaces`: how many there are.
inline double CoverageOnLevels(const nav::MultiLevelGrid& truth,
                               const std::vector<const nav::MultiLevelGrid*>& maps,
                               const Eigen::Vector3d& start, double min_z_m, double max_z_m,
                               const Eigen::AlignedBox2d& region = Eigen::AlignedBox2d(),
                               int* reachable_surfaces = nullptr) {
  int sx = 0, sy = 0;
  if (!truth.CellOf(start.x(), start.y(), &sx, &sy)) return 0.0;
  const int start_node = truth.NodeNear(sx, sy, start.z(), 0.5);
  if (start_node < 0) return 0.0;
  std::vector<char> seen(static_cast<std::size_t>(truth.node_count()), 0);
  std::vector<int> open = {start_node};
  seen[static_cast<std::size_t>(start_node)] = 1;
  int reachable = 0, known = 0;
  while (!open.empty()) {
    const int node = open.back();
    open.pop_back();
    const int x = truth.NodeColumn(node) % truth.nx(), y = truth.NodeColumn(node) / truth.nx();
    const double z = truth.NodeZ(node);
    const Eigen::Vector2d c = truth.CellCenter(x, y);
    if (z >= min_z_m && z <= max_z_m && (region.isEmpty() || region.contains(c))) {
      ++reachable;
      for (const nav::MultiLevelGrid* map : maps) {
        int gx = 0, gy = 0;
        if (map->CellOf(c.x(), c.y(), &gx, &gy) &&
            (map->NodeNear(gx, gy, z, 0.3) >= 0 || !map->IsUnknownAt(gx, gy, z))) {
          ++known;
          break;
        }
      }
    }
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int m = truth.NodeNear(x + dx, y + dy, z, truth.options().max_step_m);
        if (m < 0 || seen[static_cast<std::size_t>(m)] || !truth.IsTraversable(m)) continue;
        seen[static_cast<std::size_t>(m)] = 1;
        open.push_back(m);
      }
    }
  }
  if (reachable_surfaces != nullptr) *reachable_surfaces = reachable;
  return reachable > 0 ? static_cast<double>(known) / reachable : 0.0;
}

/// What to run.
struct TeamOptions {
  std::string world = "builtin:tunnels";
  std::string platform = "wheeled";
  std::vector<core::PlanarPose> starts;  ///< one per robot, frame W (the team's map frame)
  ExploreTask task;                      ///< every robot's
  /// This robot stops for good (no step, no claim) at the first cycle at or after kill_at_s in which it holds
  /// a claim (it goes while going somewhere; not while it waits for a peer).
  int kill_index = -1;
  double kill_at_s = 0.0;
  double stop_at_coverage = 2.0;  ///< stop once the team's coverage reaches this (> 1: when all have ended)
  double timeout_s = 1800.0;
  double score_period_s = 10.0;  ///< coverage is scored this often, simulated seconds
  bool verbose = false;          ///< coverage every minute
  /// Height bands (metres, frame W; e.g. the floors of a building) scored at the end over the map's levels
  /// (CoverageOnLevels, from the first start's ground at z 0, in the task's region): TeamRun::level_coverage.
  std::vector<std::pair<double, double>> level_bands;
  /// The simulated lidar's columns per beam (LidarOptions::points_per_beam); benches set the shipping 1800.
  int lidar_points_per_beam = team_testing::AgentTeam::kLidarPointsPerBeam;
};

/// What happened.
struct TeamRun {
  double time_to_90_s = -1;                                   ///< first score at or above 90 % (-1: never)
  double end_s = 0;                                           ///< simulated seconds run
  double coverage = 0;                                        ///< at the end
  std::vector<std::pair<double, double>> coverage_over_time;  ///< (t, coverage) at each score
  int claim_overlaps = 0;  ///< control cycles with two claims within 1.5 m of each other
  bool contact = false;
  std::vector<ExplorationStatus> statuses;     ///< each robot's at the end
  std::vector<double> driven_m;                ///< each robot's distance travelled
  std::optional<nav::PeerClaim> killed_claim;  ///< the killed robot's claim when it went (if it had one)
  double killed_at_s = -1;                     ///< when it went, simulated seconds (-1: it did not)
  /// Fraction of the floor cells within 2 m of killed_claim's target known in the live robots' own maps at
  /// the end (the branch it was going for, taken over by the others), -1 without a claim.
  double killed_branch_known = -1;
  double wall_s = 0;
  int claims_sent = 0;                  ///< claims all robots sent
  std::size_t coverage_bytes_sent = 0;  ///< their compressed coverage, bytes
  std::vector<double> level_coverage;   ///< per TeamOptions::level_bands, at the end
  double highest_z_m = 0;               ///< the highest ground any robot stood on (true pose), metres
  double end_speed_mps = 0;             ///< the fastest live robot's true speed at the end, m/s
  /// The least distance between two live robots' centres over the run (true poses), metres (infinity with
  /// one robot).
  double closest_peer_m = std::numeric_limits<double>::infinity();
};

inline TeamRun RunTeam(const TeamOptions& o) {
  const auto wall_start = std::chrono::steady_clock::now();
  TeamRun run;
  std::vector<std::pair<std::string, core::PlanarPose>> starts;
  for (std::size_t i = 0; i < o.starts.size(); ++i)
    starts.emplace_back("r" + std::to_string(i + 1), o.starts[i]);
  team_testing::AgentTeam team(
      o.world, starts, nav::PeerAvoidanceOptions{}.margin_m,
      [&](AgentOptions* options) { options->SetPlatform(o.platform); },
      [&](sim::SimulatedPlatformOptions* sim_options) {
        sim_options->lidar.points_per_beam = o.lidar_points_per_beam;
      });
  for (std::size_t i = 0; i < team.size(); ++i) {
    const std::string refused = team.Explore(i, o.task);
    if (!refused.empty()) std::printf("explore refused by %s: %s\n", team.id(i).c_str(), refused.c_str());
  }
  // The floor coverage is scored over: the true world's cells classified by navigation's traversability
  // rules (what counts as a cell of floor), never a robot's map. Collisions are the simulator's own
  // (SimulatedPlatform::ground_truth).
  const nav::NavigationOptions& navigation = team.robot(0).navigation().options();
  nav::TraversabilityOptions floor_options = navigation.platform.traversability;
  floor_options.robot_radius_m = navigation.platform.footprint_radius_m;
  const auto truth =
      std::make_shared<const nav::TraversabilityGrid>(*team.platform(0).world(), floor_options);
  const Eigen::AlignedBox2d region = o.task.region_M.value_or(Eigen::AlignedBox2d());
  auto score = [&] {
    std::vector<const nav::TraversabilityGrid*> grids;
    for (std::size_t i = 0; i < team.size(); ++i) grids.push_back(&team.robot(i).nav_map().grid());
    return Coverage(*truth, grids, o.starts[0].x_m, o.starts[0].y_m, region);
  };
  auto any_exploring = [&] {
    for (std::size_t i = 0; i < team.size(); ++i) {
      if (team.alive(i) && team.modes(i).explore().exploring()) return true;
    }
    return false;
  };
  double next_score_s = o.score_period_s;
  while (any_exploring() && team.now_s() < o.timeout_s) {
    const double t = team.now_s() + AgentTeam::kCycleS;
    const int k = o.kill_index;
    if (k >= 0 && team.alive(k) && t >= o.kill_at_s && team.modes(k).explore().OwnClaim(t)) {
      team.Stop(k);  // its process is gone: no step, no claim, no state from now on
      run.killed_claim = team.modes(k).explore().OwnClaim(t);
      run.killed_at_s = t;
    }
    // Each robot steps, sending its claims and peer states as its agent does (heard at once, no loss).
    team.StepOnce();
    std::vector<nav::PeerClaim> claims;
    for (std::size_t i = 0; i < team.size(); ++i) {
      if (!team.alive(i)) continue;
      run.highest_z_m = std::max(run.highest_z_m, team.truth(i).z_m);
      if (auto c = team.modes(i).explore().OwnClaim(t)) claims.push_back(*c);
      for (std::size_t j = i + 1; j < team.size(); ++j) {
        if (!team.alive(j)) continue;
        const sim::UnicycleState a = team.truth(i), b = team.truth(j);
        run.closest_peer_m = std::min(run.closest_peer_m, std::hypot(a.x_m - b.x_m, a.y_m - b.y_m));
      }
    }
    for (std::size_t a = 0; a < claims.size(); ++a) {
      for (std::size_t b = a + 1; b < claims.size(); ++b) {
        if ((claims[a].target_M - claims[b].target_M).norm() < 1.5) ++run.claim_overlaps;
      }
    }
    if (t >= next_score_s) {
      next_score_s += o.score_period_s;
      const double coverage = score();
      run.coverage_over_time.emplace_back(t, coverage);
      if (run.time_to_90_s < 0 && coverage >= 0.9) run.time_to_90_s = t;
      if (o.verbose && std::fmod(t + 1e-6, 60.0) < o.score_period_s - 1e-6) {
        std::printf("  t %4.0f s: team coverage %.1f %%\n", t, 100 * coverage);
      }
      if (coverage >= o.stop_at_coverage) break;
    }
  }
  const double t = team.now_s();
  run.coverage = score();
  if (run.time_to_90_s < 0 && run.coverage >= 0.9) run.time_to_90_s = t;
  std::shared_ptr<const nav::MultiLevelGrid> truth_levels;
  if (!o.level_bands.empty())
    truth_levels = std::make_shared<const nav::MultiLevelGrid>(team.platform(0).world(), floor_options);
  std::vector<const nav::MultiLevelGrid*> level_maps;
  for (std::size_t i = 0; i < team.size(); ++i) level_maps.push_back(&team.robot(i).nav_map().levels());
  for (const auto& [z0, z1] : o.level_bands) {
    run.level_coverage.push_back(
        CoverageOnLevels(*truth_levels, level_maps, {o.starts[0].x_m, o.starts[0].y_m, 0.0}, z0, z1, region));
  }
  run.end_s = t;
  for (std::size_t i = 0; i < team.size(); ++i) {
    run.contact = run.contact || team.ever_in_contact(i);
    run.statuses.push_back(team.modes(i).explore().status());
    run.driven_m.push_back(team.platform(i).distance_travelled_m());
    if (team.alive(i)) run.end_speed_mps = std::max(run.end_speed_mps, std::abs(team.truth(i).v_mps));
    const InProcessLink* link = team.links().Find(team.id(i));
    run.claims_sent += link->claims_sent();
    run.coverage_bytes_sent += link->coverage_bytes_sent();
  }
  if (run.killed_claim) {
    std::vector<const nav::TraversabilityGrid*> live;
    for (std::size_t i = 0; i < team.size(); ++i) {
      if (team.alive(i)) live.push_back(&team.robot(i).nav_map().grid());
    }
    const Eigen::Vector2d c = run.killed_claim->target_M;
    run.killed_branch_known =
        Coverage(*truth, live, o.starts[0].x_m, o.starts[0].y_m,
                 Eigen::AlignedBox2d(c - Eigen::Vector2d(2, 2), c + Eigen::Vector2d(2, 2)));
  }
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return run;
}

}  // namespace cairn::agent::explore_team
