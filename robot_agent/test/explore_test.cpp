// The explore mode without DDS: its options and task checks, and one robot that knows nothing exploring a
// built-in world on a simulated clock (SteppedRobot) until it reports complete, scored against the world's
// ground truth.
#include "cairn/agent/explore_mode.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <queue>
#include <thread>

#include "cairn/agent/stepped_robot.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

constexpr double kDt = 0.02;

TEST(ExploreModeOptionsTest, DefaultsAreValidAndBadValuesAreNamed) {
  std::string why;
  EXPECT_TRUE(ExploreModeOptions{}.IsValid(&why)) << why;
  ExploreModeOptions o;
  o.target_tolerance_m = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("explore.target_tolerance_m = 0"), std::string::npos) << why;
  o = {};
  o.frontiers.gain_radius_m = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("FrontierOptions::gain_radius_m = -1"), std::string::npos) << why;
  o = {};
  o.explorer.visited_radius_m = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("visited_radius_m"), std::string::npos) << why;
}

TEST(ExploreTaskTest, BadRegionsAndHeightsAreNamed) {
  ExploreTask task;
  EXPECT_EQ(CheckExploreTask(task), "");
  task.region_M = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(10, 5));
  EXPECT_EQ(CheckExploreTask(task), "");
  task.region_M = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(std::nan(""), 5));
  EXPECT_NE(CheckExploreTask(task).find("must be finite"), std::string::npos) << CheckExploreTask(task);
  task.region_M = Eigen::AlignedBox2d();
  task.region_M->min() << 10, 0;
  task.region_M->max() << 0, 5;
  EXPECT_NE(CheckExploreTask(task).find("x0 must be below x1"), std::string::npos) << CheckExploreTask(task);
  task.region_M.reset();
  task.min_z_m = 3.0;
  task.max_z_m = 1.0;
  EXPECT_NE(CheckExploreTask(task).find("z range (3, 1)"), std::string::npos) << CheckExploreTask(task);
  task.max_z_m = std::nan("");
  EXPECT_NE(CheckExploreTask(task).find("z range"), std::string::npos);
}

// Fraction of the floor a robot can reach from `start` (traversable ground-truth cells, 8-connected flood
// fill) that is known (not unknown) in `grid`, the robot's map.
double Coverage(const nav::TraversabilityGrid& truth, const nav::TraversabilityGrid& grid, double start_x,
                double start_y, int* reachable_cells) {
  int sx = 0, sy = 0;
  if (!truth.CellOf(start_x, start_y, &sx, &sy)) return 0.0;
  const int nx = truth.nx(), ny = truth.ny();
  std::vector<char> seen(static_cast<std::size_t>(nx) * ny, 0);
  std::queue<std::pair<int, int>> open;
  open.push({sx, sy});
  seen[static_cast<std::size_t>(sy) * nx + sx] = 1;
  int reachable = 0, known = 0;
  while (!open.empty()) {
    const auto [x, y] = open.front();
    open.pop();
    ++reachable;
    const Eigen::Vector2d c = truth.CellCenter(x, y);
    int gx = 0, gy = 0;
    if (grid.CellOf(c.x(), c.y(), &gx, &gy) && grid.State(gx, gy) != nav::CellState::kUnknown) ++known;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int u = x + dx, v = y + dy;
        if (u < 0 || v < 0 || u >= nx || v >= ny) continue;
        char& s = seen[static_cast<std::size_t>(v) * nx + u];
        if (s || !truth.IsTraversable(u, v)) continue;
        s = 1;
        open.push({u, v});
      }
    }
  }
  if (reachable_cells != nullptr) *reachable_cells = reachable;
  if (std::getenv("CAIRN_TEST_COVERAGE_MAP") != nullptr) {
    // 0.5 m per character: ' ' not reachable, '#' all known, '?' some unknown, 'U' mostly unknown.
    for (int y = ny - 5; y >= 0; y -= 5) {
      std::string row;
      for (int x = 0; x < nx; x += 5) {
        int r = 0, k = 0;
        for (int v = y; v < std::min(ny, y + 5); ++v) {
          for (int u = x; u < std::min(nx, x + 5); ++u) {
            if (!seen[static_cast<std::size_t>(v) * nx + u]) continue;
            ++r;
            const Eigen::Vector2d c = truth.CellCenter(u, v);
            int gx = 0, gy = 0;
            if (grid.CellOf(c.x(), c.y(), &gx, &gy) && grid.State(gx, gy) != nav::CellState::kUnknown) ++k;
          }
        }
        row += r == 0 ? ' ' : k == r ? '#' : 2 * k >= r ? '?' : 'U';
      }
      std::printf("%s\n", row.c_str());
    }
  }
  return reachable > 0 ? static_cast<double>(known) / reachable : 0.0;
}

TEST(ExploreTest, OneRobotExploresTheTunnelsUntilCompleteWithoutContact) {
  AgentOptions options;
  options.robot_id = "explorer";
  options.SetPlatform("wheeled");
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  const core::PlanarPose start_W = sim::GetBuiltinWorldInfo("tunnels").suggested_starts.front();
  sim_options.start_W = start_W;
  sim_options.SetProfile(options.navigation.platform);
  auto platform = std::make_shared<sim::SimulatedPlatform>(sim_options);
  SteppedRobot robot(options, platform, std::string(CAIRN_CONFIG_DIR) + "/mode_tree.xml");
  ASSERT_EQ(robot.Explore(ExploreTask{}, 0.0), "");
  double t = 0.0;
  constexpr double kTimeoutS = 1800.0;
  double next_report_s = 60.0;
  while (robot.explore().exploring() && t < kTimeoutS) {
    t += kDt;
    robot.Step(t);
    while (robot.planning()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    if (t >= next_report_s) {
      next_report_s += 60.0;
      const ExplorationStatus& s = robot.explore().status();
      std::printf("  t %4.0f s: %.0f m² explored, %d frontiers (%d reachable), %d reached, %d failed: %s\n", t,
                  s.explored_m2, s.frontier_clusters, s.reachable_frontiers, s.targets_reached, s.targets_failed,
                  s.reason.c_str());
    }
  }
  const ExplorationStatus& s = robot.explore().status();
  int reachable = 0;
  const double coverage = Coverage(*platform->terrain(), robot.nav_map().grid(), start_W.x_m, start_W.y_m,
                                   &reachable);
  std::printf("  after %.0f s: %s: %s; coverage %.1f %% of %d reachable cells, %.0f m² explored, %d targets "
              "reached, %d failed, %.0f m driven, %d frontier searches, %.1f ms each\n",
              t, ToString(s.state), s.reason.c_str(), 100 * coverage, reachable, s.explored_m2, s.targets_reached,
              s.targets_failed, platform->distance_travelled_m(), robot.frontier_searches(),
              1000 * robot.frontier_search_s() / std::max(1, robot.frontier_searches()));
  EXPECT_EQ(s.state, ExplorationState::kComplete) << s.reason;
  EXPECT_NE(s.reason.find("exploration complete: no reachable frontier"), std::string::npos) << s.reason;
  EXPECT_GE(coverage, 0.90);
  EXPECT_FALSE(robot.ever_in_contact());
  EXPECT_LT(platform->TrueState().v_mps, 0.05) << "the robot is at rest at the end";
}

}  // namespace
}  // namespace cairn::agent
