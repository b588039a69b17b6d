// The explore mode without DDS: its options and task checks, and one robot that knows nothing exploring a
// built-in world on a simulated clock (SteppedRobot) until it reports complete, scored against the world's
// ground truth.
#include "cairn/agent/explore_mode.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include "cairn/agent/stepped_robot.h"
#include "explore_team.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/simulated_platform.h"
#include "../../sim/test/test_util.h"

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

// Two robots from a gate explore the west half of the tunnels and the X junction (a region) as a team: they never
// go for the same frontier, both take part, the region ends up in their maps and every robot completes; with
// one robot gone for good 8 s in (or as soon after as it holds a claim), the other explores the branch it was going for and completes the region
// alone (what the gone robot saw before it went counts as seen: it reached its peers as map telemetry).
TEST(ExploreTest, TwoRobotsShareARegionWithoutSharingAFrontierAndOneTakesOverWhenTheOtherIsGone) {
  explore_team::TeamOptions o;
  o.starts = {{4.0, 20.0, 0.0}, {6.0, 20.0, 0.0}};
  o.task.region_M = Eigen::AlignedBox2d(Eigen::Vector2d(0, 15), Eigen::Vector2d(32, 25));
  explore_team::TeamRun team = explore_team::RunTeam(o);
  for (std::size_t i = 0; i < team.statuses.size(); ++i) {
    const ExplorationStatus& s = team.statuses[i];
    std::printf("  r%zu: %s: %s; %d reached, %d given up, %.0f m driven\n", i + 1, ToString(s.state), s.reason.c_str(),
                s.targets_reached, s.targets_failed, team.driven_m[i]);
    EXPECT_EQ(s.state, ExplorationState::kComplete) << s.reason;
    EXPECT_GT(team.driven_m[i], 5.0) << "every robot takes part";
  }
  std::printf("  two robots: %.1f %% of the region after %.0f s (90 %% after %.0f s), %d claim overlaps; %.0f s wall\n",
              100 * team.coverage, team.end_s, team.time_to_90_s, team.claim_overlaps, team.wall_s);
  EXPECT_GE(team.coverage, 0.9);
  EXPECT_EQ(team.claim_overlaps, 0);
  EXPECT_FALSE(team.contact);

  o.kill_index = 0;
  o.kill_at_s = 8.0;
  team = explore_team::RunTeam(o);
  ASSERT_TRUE(team.killed_claim.has_value()) << "r1 was going somewhere when it went";
  std::printf("  r1 gone at %.1f s going for (%.2f, %.2f): %.0f %% of the floor within 2 m of it in r2's own map; "
              "%.1f %% of the region after %.0f s; r2 %s: %s\n",
              team.killed_at_s, team.killed_claim->target_M.x(), team.killed_claim->target_M.y(), 100 * team.killed_branch_known,
              100 * team.coverage, team.end_s, ToString(team.statuses[1].state), team.statuses[1].reason.c_str());
  // r1's claim went with it: r2 explored the branch r1 was going for, itself.
  EXPECT_GE(team.killed_branch_known, 0.9);
  EXPECT_GE(team.coverage, 0.8);
  EXPECT_EQ(team.statuses[1].state, ExplorationState::kComplete) << team.statuses[1].reason;
  EXPECT_EQ(team.statuses[0].state, ExplorationState::kExploring) << "r1 stopped mid-way (its process gone)";
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
  const double coverage = explore_team::Coverage(*platform->terrain(), {&robot.nav_map().grid()}, start_W.x_m,
                                                 start_W.y_m, {}, &reachable);
  std::printf("  after %.0f s: %s: %s; coverage %.1f %% of %d reachable cells, %.0f m² explored, %d targets "
              "reached, %d failed, %.0f m driven, %d frontier searches, %.1f ms each\n",
              t, ToString(s.state), s.reason.c_str(), 100 * coverage, reachable, s.explored_m2, s.targets_reached,
              s.targets_failed, platform->distance_travelled_m(), robot.frontier_searches(),
              1000 * robot.frontier_search_s() / std::max(1, robot.frontier_searches()));
  std::printf("  wall time: platform %.1f s, perception %.1f s, navigation map %.1f s, frontiers %.1f s, explore %.1f s\n",
              robot.timing().platform_s, robot.timing().perception_s, robot.timing().nav_map_s,
              robot.frontier_search_s(), robot.timing().explore_s);
  EXPECT_EQ(s.state, ExplorationState::kComplete) << s.reason;
  EXPECT_NE(s.reason.find("exploration complete: no reachable frontier"), std::string::npos) << s.reason;
  EXPECT_GE(coverage, 0.90);
  EXPECT_FALSE(robot.ever_in_contact());
  EXPECT_LT(platform->TrueState().v_mps, 0.05) << "the robot is at rest at the end";
}

// The real scan geb079.bt (a 39 m office corridor, offices seen through their doors), from (-4, 0): the robot
// explores the corridor and the two side passages it reaches, which a 0.75 m door-frame narrowing at x = 11.3
// and the floor erased at grazing incidence (OccupancyMapOptions::floor_guard_layers) used to cut off at 44 %.
TEST(ExploreTest, OneRobotExploresTheRealGeb079ScanUntilComplete) {
  CAIRN_SKIP_WITHOUT_GEB079();
  explore_team::TeamOptions o;
  o.world = sim::testing::Geb079Path();
  o.starts = {{-4.0, 0.0, 0.0}};
  o.timeout_s = 900.0;
  const explore_team::TeamRun run = explore_team::RunTeam(o);
  const ExplorationStatus& s = run.statuses.at(0);
  std::printf("  geb079: %s: %s; %.1f %% of the reachable floor after %.0f s (90 %% after %.0f s), %d reached, "
              "%d given up, %.0f m driven; %.0f s wall\n",
              ToString(s.state), s.reason.c_str(), 100 * run.coverage, run.end_s, run.time_to_90_s, s.targets_reached,
              s.targets_failed, run.driven_m.at(0), run.wall_s);
  EXPECT_EQ(s.state, ExplorationState::kComplete) << s.reason;
  EXPECT_NE(s.reason.find("exploration complete: no reachable frontier"), std::string::npos) << s.reason;
  EXPECT_GE(run.coverage, 0.90);
  EXPECT_FALSE(run.contact);
}

}  // namespace
}  // namespace cairn::agent
