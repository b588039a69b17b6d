// The explore mode without DDS: its options and task checks, and robots that know nothing exploring the
// built-in worlds and the real geb079 scan on a simulated clock (the agent stepped, explore_team::RunTeam)
// until they report complete, scored against the world's ground truth: one robot, teams of two and three (one
// of them gone mid-way), a legged robot over two floors.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "../../sim/test/test_util.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/nav/platform.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"
#include "explore_team.h"

namespace cairn::agent {
namespace {

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
  o = {};
  o.tight_gap_stall_s = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("explore.tight_gap_stall_s = 0"), std::string::npos) << why;
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

void PrintTeam(const char* label, const explore_team::TeamRun& run) {
  for (std::size_t i = 0; i < run.statuses.size(); ++i) {
    const ExplorationStatus& s = run.statuses[i];
    std::printf("  %s r%zu: %s: %s; %d reached, %d given up, %.0f m driven\n", label, i + 1,
                ToString(s.state), s.reason.c_str(), s.targets_reached, s.targets_failed, run.driven_m[i]);
  }
  std::printf(
      "  %s: %.1f %% after %.0f s (90 %% after %.0f s), %d claim overlaps, robots %.2f m apart at the "
      "closest; %.0f s wall\n",
      label, 100 * run.coverage, run.end_s, run.time_to_90_s, run.claim_overlaps, run.closest_peer_m,
      run.wall_s);
}

// Two robots' centres closer than this touch (wheeled footprints).
double TouchingM() { return 2 * nav::GetPlatformProfile("wheeled").footprint_radius_m; }

// Three robots 2 m apart at the gate of builtin:tunnels, frame W.
std::vector<core::PlanarPose> TunnelTeamStarts() {
  return {{4.0, 20.0, 0.0}, {6.0, 20.0, 0.0}, {8.0, 20.0, 0.0}};
}

// Two robots from a gate explore the west half of the tunnels and the X junction (a region) as a team: they
// never go for the same frontier, both take part, the region ends up in their maps and every robot completes.
TEST(ExploreTest, TwoRobotsShareARegionWithoutSharingAFrontier) {
  explore_team::TeamOptions o;
  o.starts = {{4.0, 20.0, 0.0}, {6.0, 20.0, 0.0}};
  o.task.region_M = Eigen::AlignedBox2d(Eigen::Vector2d(0, 15), Eigen::Vector2d(32, 25));
  const explore_team::TeamRun team = explore_team::RunTeam(o);
  PrintTeam("two robots", team);
  for (std::size_t i = 0; i < team.statuses.size(); ++i) {
    EXPECT_EQ(team.statuses[i].state, ExplorationState::kComplete) << team.statuses[i].reason;
    EXPECT_GT(team.driven_m[i], 5.0) << "every robot takes part";
  }
  EXPECT_GE(team.coverage, 0.9);
  EXPECT_EQ(team.claim_overlaps, 0);
  EXPECT_FALSE(team.contact);
  EXPECT_GT(team.closest_peer_m, TouchingM()) << "the robots keep clear of each other (peers)";
}

// The whole of builtin:tunnels from its gate, three robots 2 m apart that know nothing: 90 % of the reachable
// floor is in their maps within 95 s of simulated time, never going for the same frontier, each taking part,
// with no contact (the team stops at 95 %; exploring to completion, and standing at rest then, is the geb079
// test's and the two-robot test's). One robot alone needs 170 s (2026-11-29), so 95 s is the team at least
// 1.8x sooner than one; the ratio itself, against one robot run in the same process, is the exploration
// bench's (build/bench/cairn_bench_explore --robots 1,3).
TEST(ExploreTest, ThreeRobotsExploreNinetyPercentOfTheTunnelsWithin95s) {
  explore_team::TeamOptions o;
  o.starts = TunnelTeamStarts();
  o.stop_at_coverage = 0.95;  // the 90 % figure and a little beyond; the rest is the last corners
  const explore_team::TeamRun three = explore_team::RunTeam(o);
  PrintTeam("three robots", three);
  ASSERT_GT(three.time_to_90_s, 0.0);
  EXPECT_LE(three.time_to_90_s, 95.0);
  EXPECT_EQ(three.claim_overlaps, 0);
  EXPECT_FALSE(three.contact);
  EXPECT_GT(three.closest_peer_m, TouchingM()) << "the robots keep clear of one another (peers)";
  for (std::size_t i = 0; i < three.statuses.size(); ++i)
    EXPECT_GT(three.driven_m[i], 5.0) << "every robot takes part";
}

// The same team with r2 gone for good 30 s in (at the first cycle after that in which it holds a claim): the
// two others explore the branch it was going for (what it saw before it went counts: it reached its peers as
// map telemetry) and reach 95 %.
TEST(ExploreTest, TwoRobotsTakeOverTheBranchOfAGoneThird) {
  explore_team::TeamOptions o;
  o.starts = TunnelTeamStarts();
  o.stop_at_coverage = 0.95;
  o.kill_index = 1;
  o.kill_at_s = 30.0;
  const explore_team::TeamRun gone = explore_team::RunTeam(o);
  PrintTeam("r2 gone", gone);
  ASSERT_TRUE(gone.killed_claim.has_value()) << "r2 was going somewhere when it went";
  std::printf(
      "  r2 gone at %.1f s going for (%.2f, %.2f): %.0f %% of the floor within 2 m of it in the others' "
      "own maps\n",
      gone.killed_at_s, gone.killed_claim->target_M.x(), gone.killed_claim->target_M.y(),
      100 * gone.killed_branch_known);
  EXPECT_GE(gone.killed_branch_known, 0.9);
  EXPECT_GE(gone.coverage, 0.95);
  EXPECT_EQ(gone.statuses[1].state, ExplorationState::kExploring) << "r2 stopped mid-way (its process gone)";
  EXPECT_FALSE(gone.contact);
}

// The real scan geb079.bt (a 39 m office corridor, offices seen through their doors), from (-4, 0): the robot
// explores the corridor and the two side passages it reaches, which a 0.75 m door-frame narrowing at x = 11.3
// and the floor erased at grazing incidence (OccupancyMapOptions::floor_guard_layers) used to cut off at 44
// %.
TEST(ExploreTest, OneRobotExploresTheRealGeb079ScanUntilComplete) {
  CAIRN_SKIP_WITHOUT_GEB079();
  explore_team::TeamOptions o;
  o.world = sim::testing::Geb079Path();
  o.starts = {{-4.0, 0.0, 0.0}};
  // Complete at 404 s of simulated time on an idle machine. Global plans are searched on a worker thread, so
  // on a starved machine they arrive more steps later and the robot's choices differ: a clean-clone run under
  // a rebuild of every sanitizer tree gave up 6 targets instead of 2 and still explored (99.4 %) at 900 s.
  o.timeout_s = 1500.0;
  const explore_team::TeamRun run = explore_team::RunTeam(o);
  const ExplorationStatus& s = run.statuses.at(0);
  std::printf(
      "  geb079: %s: %s; %.1f %% of the reachable floor after %.0f s (90 %% after %.0f s), %d reached, "
      "%d given up, %.0f m driven; %.0f s wall\n",
      ToString(s.state), s.reason.c_str(), 100 * run.coverage, run.end_s, run.time_to_90_s, s.targets_reached,
      s.targets_failed, run.driven_m.at(0), run.wall_s);
  EXPECT_EQ(s.state, ExplorationState::kComplete) << s.reason;
  EXPECT_NE(s.reason.find("exploration complete: no reachable frontier"), std::string::npos) << s.reason;
  EXPECT_GE(run.coverage, 0.90);
  EXPECT_FALSE(run.contact);
  EXPECT_LT(run.end_speed_mps, 0.05) << "the robot is at rest at the end";
}

// A legged robot at builtin:building's first suggested start, scored on both floors.
explore_team::TeamOptions LeggedInTheBuilding() {
  explore_team::TeamOptions o;
  o.world = "builtin:building";
  o.platform = "legged";
  o.starts = {sim::GetBuiltinWorldInfo("building").suggested_starts.front()};
  o.level_bands = {{-0.5, 0.5}, {2.7, 3.7}};
  o.timeout_s = 1500.0;
  // The shipping lidar: at half its columns the second flight, seen from the landing, is too sparse for the
  // staircase detector and the robot completes on floor 1.
  o.lidar_points_per_beam = sim::LidarOptions{}.points_per_beam;
  return o;
}

// A legged robot on floor 1 of builtin:building (24 x 14 m, six rooms and a corridor a floor) explores the
// building on the shipping agent (stepped): it finds the switchback stairs on its own map, climbs the first
// flight, looks up the second from the landing (the upper flight's frontiers are seen but no surface of them
// is reachable yet: FrontierOptions::viewpoint_radius_m), detects it, climbs to floor 2 and explores it too
// (>= 90 % of each floor's reachable surfaces, scored over the world's levels), comes back down to what it
// left on floor 1, and completes without contact.
TEST(ExploreLeggedTest, ALeggedRobotFindsTheStairsAndExploresBothFloors) {
  const explore_team::TeamOptions o = LeggedInTheBuilding();
  const explore_team::TeamRun run = explore_team::RunTeam(o);
  PrintTeam("legged agent", run);
  std::printf(
      "  floor 1 %.1f %%, floor 2 %.1f %% of their reachable surfaces; highest ground stood "
      "on z %.2f m\n",
      100 * run.level_coverage.at(0), 100 * run.level_coverage.at(1), run.highest_z_m);
  EXPECT_EQ(run.statuses[0].state, ExplorationState::kComplete) << run.statuses[0].reason;
  EXPECT_GT(run.highest_z_m, 3.0) << "it climbed to floor 2 (z 3.2 m)";
  EXPECT_GE(run.level_coverage.at(0), 0.9);
  EXPECT_GE(run.level_coverage.at(1), 0.9);
  EXPECT_FALSE(run.contact);
}

}  // namespace
}  // namespace cairn::agent
