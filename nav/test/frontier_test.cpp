// Copyright Cairn authors.
#include "cairn/nav/frontier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "cairn/nav/platform.h"
#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

// A robot-built map is read optimistically: unknown space is not lethal.
TraversabilityOptions RobotMapReading() {
  TraversabilityOptions o;
  o.unknown_is_lethal = false;
  return o;
}

// 20 x 10 m at 0.1 m: floor over x < 10.2 (room A, what the robot has seen), none beyond (unknown). A wall
// along x in [10.0, 10.2) with a 2 m door at y in [4, 6).
sim::World RoomWithADoor() {
  sim::World world = FlatWorld(20.0, 10.0, 0.1, 2.0);
  FillBox(&world, {10.2, 0.0, -0.2}, {20.0, 10.0, 0.0}, false);
  FillBox(&world, {10.0, 0.0, 0.0}, {10.2, 4.0, 2.0});
  FillBox(&world, {10.0, 6.0, 0.0}, {10.2, 10.0, 2.0});
  return world;
}

TEST(FrontierOptionsTest, DefaultsAreValidAndMessagesNameTheField) {
  std::string why;
  EXPECT_TRUE(FrontierOptions{}.IsValid(&why)) << why;
  FrontierOptions o;
  o.gain_radius_m = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::gain_radius_m = 0 must be in (0, 100]");
  o = FrontierOptions{};
  o.min_cells = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::min_cells = 0 must be in [1, 10000]");
  o = FrontierOptions{};
  o.min_z_m = 2;
  o.max_z_m = 1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::min_z_m = 2 must be <= max_z_m = 1");
  const TraversabilityGrid grid(RoomWithADoor(), RobotMapReading());
  EXPECT_THROW(FindFrontiers(grid, {2, 5}, o), std::invalid_argument);
}

TEST(FrontierTest, ADoorIntoUnknownSpaceIsOneReachableClusterAndAFloorHoleIsNone) {
  sim::World world = RoomWithADoor();
  FillBox(&world, {5.0, 2.0, -0.2}, {5.4, 2.4, 0.0}, false);  // a 0.4 m hole in the floor (a sparse scan)
  const TraversabilityGrid grid(world, RobotMapReading());
  const FrontierSet set = FindFrontiers(grid, {2.0, 5.0});
  EXPECT_TRUE(set.robot_on_grid);
  ASSERT_EQ(set.clusters.size(), 1u);
  const FrontierCluster& door = set.clusters[0];
  EXPECT_TRUE(door.reachable());
  EXPECT_NEAR(door.target_M.x(), 10.15, 1e-9);  // the last floor cells of the doorway
  EXPECT_NEAR(door.target_M.y(), 5.0, 0.1);
  EXPECT_NEAR(door.target_ground_z_m, 0.0, 1e-9);
  EXPECT_NEAR(door.travel_cost_m, 8.15, 0.15);
  // What a lidar in the 2 m door sees of the room beyond: a half disc of radius 5 m (39 m²), a little more
  // through the doorway's depth.
  EXPECT_GT(door.gain_m2, 37.0);
  EXPECT_LT(door.gain_m2, 45.0);
  EXPECT_NEAR(door.utility, door.gain_m2 / (door.travel_cost_m + 1.0), 1e-9);
  EXPECT_GT(set.frontier_cells, door.cells);  // the hole's rim is frontier, its cluster gains too little
  EXPECT_NEAR(set.known_free_m2, 10.2 * 10.0 - 0.4 * 0.4 - 0.2 * 8.0, 0.5);
}

TEST(PeerCoverageTest, APeersSeenFloorMakesTheDoorWorthNothingAndBadBitmapsAreNamed) {
  // The peer has seen the room beyond the door (the whole world); this robot only room A.
  const TraversabilityGrid peer_grid(FlatWorld(20.0, 10.0, 0.1, 2.0), RobotMapReading());
  const CoverageBitmap bitmap = SeenCoverage(peer_grid, 0.5);
  EXPECT_EQ(bitmap.Check(), "");
  EXPECT_EQ(bitmap.nx, 40);
  EXPECT_EQ(bitmap.ny, 20);
  EXPECT_EQ(bitmap.CountCovered(), 800);
  // Room A only: the coarse cells of x >= 10 are unseen (x in [10, 10.5) is 2 of 5 columns seen: a minority).
  const TraversabilityGrid own_grid(RoomWithADoor(), RobotMapReading());
  const CoverageBitmap own = SeenCoverage(own_grid, 0.5);
  EXPECT_EQ(own.CountCovered(), 20 * 20);
  EXPECT_TRUE(own.Covered(19, 0));
  EXPECT_FALSE(own.Covered(20, 0));

  PeerCoverage peers(0.5);
  peers.Add(bitmap);
  EXPECT_EQ(peers.size(), 800u);
  EXPECT_TRUE(peers.Covered({15.2, 5.1}));
  EXPECT_FALSE(peers.Covered({25.0, 5.0}));
  const FrontierSet alone = FindFrontiers(own_grid, {2.0, 5.0});
  ASSERT_EQ(alone.clusters.size(), 1u);
  FrontierOptions lenient;
  lenient.min_gain_m2 = 0.0;  // keep the cluster to see its gain
  const FrontierSet with_peer = FindFrontiers(own_grid, {2.0, 5.0}, lenient, &peers);
  ASSERT_EQ(with_peer.clusters.size(), 1u);
  EXPECT_LT(with_peer.clusters[0].gain_m2, 1.0);
  EXPECT_TRUE(FindFrontiers(own_grid, {2.0, 5.0}, FrontierOptions{}, &peers).clusters.empty());

  CoverageBitmap bad = bitmap;
  bad.bits.pop_back();
  EXPECT_EQ(bad.Check(), "bits has 99 bytes, 100 expected for 40 x 20 cells");
  EXPECT_THROW(peers.Add(bad), std::invalid_argument);
  bad = bitmap;
  bad.cell_m = 0.25;
  EXPECT_THROW(peers.Add(bad), std::invalid_argument);  // another cell size
  bad = bitmap;
  bad.nx = -1;
  EXPECT_EQ(bad.Check(), "nx = -1, ny = 20 must not be negative");
  EXPECT_THROW(SeenCoverage(peer_grid, 0.05), std::invalid_argument);  // finer than the grid
}

TEST(FrontierTest, AWideOpeningIsCutIntoPiecesAndTheNearestPieceComesFirst) {
  sim::World world = FlatWorld(20.0, 10.0, 0.1, 2.0);
  FillBox(&world, {10.2, 0.0, -0.2}, {20.0, 10.0, 0.0}, false);  // all of x >= 10.2 unknown
  const TraversabilityGrid grid(world, RobotMapReading());
  const FrontierSet set = FindFrontiers(grid, {9.0, 5.0});
  ASSERT_EQ(set.clusters.size(), 3u);  // 10 m of frontier in pieces of at most 4 m
  for (const FrontierCluster& c : set.clusters) {
    EXPECT_TRUE(c.reachable());
    EXPECT_LE(c.cells, 40);
  }
  EXPECT_GT(set.clusters[0].target_M.y(), 4.0);  // the piece in front of the robot
  EXPECT_LT(set.clusters[0].target_M.y(), 8.0);
  EXPECT_GE(set.clusters[0].utility, set.clusters[1].utility);
  EXPECT_GE(set.clusters[1].utility, set.clusters[2].utility);
}

TEST(FrontierTest, AFrontierBehindAWallIsUnreachableAndARegionOrAHeightBandLeavesFrontiersOut) {
  sim::World world = RoomWithADoor();
  FillBox(&world, {0.0, 8.0, 0.0}, {10.0, 8.2, 2.0});          // a wall across room A
  FillBox(&world, {1.0, 8.6, -0.2}, {4.0, 10.0, 0.0}, false);  // unknown floor behind it
  const TraversabilityGrid grid(world, RobotMapReading());
  FrontierSet set = FindFrontiers(grid, {2.0, 5.0});
  ASSERT_EQ(set.clusters.size(), 2u);
  EXPECT_TRUE(set.clusters[0].reachable());  // the door first
  EXPECT_GT(set.clusters[0].target_M.x(), 10.0);
  EXPECT_FALSE(set.clusters[1].reachable());  // then the one it cannot get to
  EXPECT_EQ(set.clusters[1].utility, 0.0);
  EXPECT_GT(set.clusters[1].target_M.y(), 8.2);

  FrontierOptions room_only;
  room_only.region_M = Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(9.5, 10));
  set = FindFrontiers(grid, {2.0, 5.0}, room_only);
  ASSERT_EQ(set.clusters.size(), 1u);
  EXPECT_FALSE(set.clusters[0].reachable());
  FrontierOptions upstairs;
  upstairs.min_z_m = 2.0;
  upstairs.max_z_m = 4.0;
  set = FindFrontiers(grid, {2.0, 5.0}, upstairs);
  EXPECT_TRUE(set.clusters.empty());
  EXPECT_EQ(set.known_free_m2, 0.0);
}

// A sparse lidar's far floor: a patch seen across a 1 m gap of unseen floor is reached through the gap (at
// the unknown cost), one across a 5 m gap is not (beyond unknown_reach_m of known ground).
TEST(FrontierTest, AGapOfUnseenFloorIsCrossedOnlyWhenNarrow) {
  sim::World world = FlatWorld(30.0, 10.0, 0.1, 2.0);
  FillBox(&world, {8.0, 0.0, -0.2}, {9.0, 10.0, 0.0}, false);    // a 1 m gap
  FillBox(&world, {14.0, 0.0, -0.2}, {19.0, 10.0, 0.0}, false);  // a 5 m gap
  FillBox(&world, {25.0, 0.0, -0.2}, {30.0, 10.0, 0.0}, false);  // unseen beyond
  const TraversabilityGrid grid(world, RobotMapReading());
  const FrontierSet set = FindFrontiers(grid, {2.0, 5.0});
  int across_narrow = 0, across_wide = 0;
  for (const FrontierCluster& c : set.clusters) {
    if (c.target_M.x() > 9.0 && c.target_M.x() < 14.0) {  // the far side of the 1 m gap, or its near side
      ++across_narrow;
      EXPECT_TRUE(c.reachable()) << c.target_M.transpose();
      EXPECT_LT(c.travel_cost_m, 1.5 * (c.target_M.x() - 2.0) + 1.0) << c.target_M.transpose();
    }
    if (c.target_M.x() > 19.0) {
      ++across_wide;
      EXPECT_FALSE(c.reachable()) << c.target_M.transpose();
    }
  }
  EXPECT_GT(across_narrow, 0);
  EXPECT_GT(across_wide, 0);
}

TEST(FrontierTest, ARobotOffTheMapReachesNothingAndAnExploredMapHasNoFrontier) {
  const TraversabilityGrid grid(RoomWithADoor(), RobotMapReading());
  FrontierSet set = FindFrontiers(grid, {50.0, 50.0});
  EXPECT_FALSE(set.robot_on_grid);
  ASSERT_EQ(set.clusters.size(), 1u);
  EXPECT_FALSE(set.clusters[0].reachable());
  // Standing in the wall (next to it): the nearest traversable cell within 1 m is the start.
  set = FindFrontiers(grid, {10.1, 2.0});
  EXPECT_TRUE(set.robot_on_grid);
  EXPECT_TRUE(set.clusters.at(0).reachable());

  const TraversabilityGrid explored(FlatWorld(10.0, 10.0, 0.1, 2.0), RobotMapReading());
  set = FindFrontiers(explored, {5.0, 5.0});
  EXPECT_TRUE(set.clusters.empty());
  EXPECT_EQ(set.frontier_cells, 0);
  EXPECT_NEAR(set.known_free_m2, 100.0, 1e-6);
}

// A 0.4 m door (the walls' cells 0.5 m apart, centre to centre) into a room seen 2 m deep: no cell in it has
// more than 0.2 m of clearance, so the room's frontier is unreachable for a 0.3 m radius unless travel may
// pass tight cells (FrontierOptions::tight_radius_m, here 0.15 m); then it is reachable, flagged as through a
// tight gap, and the door's cells cost tight_cost more per metre.
TEST(FrontierTest, ATightDoorIsPassedOnlyWithATightRadiusAndIsFlagged) {
  sim::World world = FlatWorld(20.0, 10.0, 0.1, 2.0);
  FillBox(&world, {12.0, 0.0, -0.2}, {20.0, 10.0, 0.0}, false);  // unseen beyond 2 m into room B
  FillBox(&world, {10.0, 0.0, 0.0}, {10.2, 4.8, 2.0});
  FillBox(&world, {10.0, 5.2, 0.0}, {10.2, 10.0, 2.0});
  const auto truth = std::make_shared<const core::VoxelGrid>(world);
  const TraversabilityGrid grid(world, RobotMapReading());
  const MultiLevelGrid levels(truth, RobotMapReading());
  FrontierOptions tight;
  tight.tight_radius_m = 0.15;
  for (const bool multi_level : {false, true}) {
    SCOPED_TRACE(multi_level ? "FindFrontiersMultiLevel" : "FindFrontiers");
    auto find = [&](const FrontierOptions& o) {
      return multi_level ? FindFrontiersMultiLevel(levels, {2.0, 5.0, 0.0}, o)
                         : FindFrontiers(grid, {2.0, 5.0}, o);
    };
    const FrontierSet strict = find(FrontierOptions{});
    ASSERT_FALSE(strict.clusters.empty());
    for (const FrontierCluster& c : strict.clusters) EXPECT_FALSE(c.reachable()) << c.target_M.transpose();
    const FrontierSet passed = find(tight);
    ASSERT_EQ(passed.clusters.size(), strict.clusters.size());
    const FrontierCluster& best = passed.clusters.front();
    EXPECT_TRUE(best.reachable());
    EXPECT_TRUE(best.through_tight_gap);
    EXPECT_GT(best.target_M.x(), 11.5);
    // At least the straight line to it, plus tight_cost per metre over the door's 0.2 m.
    const double straight_m = (best.target_M - Eigen::Vector2d(2.0, 5.0)).norm();
    EXPECT_GT(best.travel_cost_m, straight_m + 0.2 * tight.tight_cost - 0.05);
    EXPECT_LT(best.travel_cost_m, straight_m + 2.0);
    FrontierOptions free_of_charge = tight;
    free_of_charge.tight_cost = 0.0;
    EXPECT_LT(find(free_of_charge).clusters.front().travel_cost_m, best.travel_cost_m);
  }
  FrontierOptions bad;
  bad.tight_radius_m = 0.0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::tight_radius_m = 0 must be > 0 (infinity: off)");
  // A door the footprint fits through is no tight gap.
  const FrontierSet door =
      FindFrontiers(TraversabilityGrid(RoomWithADoor(), RobotMapReading()), {2.0, 5.0}, tight);
  ASSERT_EQ(door.clusters.size(), 1u);
  EXPECT_FALSE(door.clusters[0].through_tight_gap);
}

// The multi-level search on a map of one level finds what the single-level one finds.
TEST(MultiLevelFrontierTest, OnOneLevelTheDoorIsFoundAsByTheSingleLevelSearch) {
  const auto world = std::make_shared<const core::VoxelGrid>(RoomWithADoor());
  const MultiLevelGrid levels(world, RobotMapReading());
  const FrontierSet set = FindFrontiersMultiLevel(levels, {2.0, 5.0, 0.0});
  const FrontierSet flat = FindFrontiers(TraversabilityGrid(*world, RobotMapReading()), {2.0, 5.0});
  EXPECT_TRUE(set.robot_on_grid);
  ASSERT_EQ(set.clusters.size(), 1u);
  ASSERT_EQ(flat.clusters.size(), 1u);
  const FrontierCluster& door = set.clusters[0];
  EXPECT_NEAR(door.target_M.x(), 10.15, 1e-9);
  EXPECT_NEAR(door.target_M.y(), 5.0, 0.1);
  EXPECT_NEAR(door.target_ground_z_m, 0.0, 1e-6);
  EXPECT_NEAR(door.travel_cost_m, flat.clusters[0].travel_cost_m, 0.3);
  EXPECT_NEAR(door.gain_m2, flat.clusters[0].gain_m2, 0.1 * flat.clusters[0].gain_m2);
  EXPECT_NEAR(set.known_free_m2, flat.known_free_m2, 1.0);
  FrontierOptions o;
  o.peer_coverage_min_z_m = 1.0;
  o.peer_coverage_max_z_m = 0.0;
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::peer_coverage_min_z_m = 1 must be <= peer_coverage_max_z_m = 0");
  EXPECT_THROW(FindFrontiersMultiLevel(levels, {2.0, 5.0, 0.0}, o), std::invalid_argument);
}

// A 60 x 6 m hall seen from its west end, unknown beyond two doors: one 4 m from the robot, one 50 m away.
// With a 20 m search horizon the far door lies beyond it (unreachable for this search, which stops early);
// with the near door too small to keep (min_cells), the search runs again over the whole map and finds the
// far one.
TEST(MultiLevelFrontierTest, TheSearchStopsAtItsHorizonUnlessNothingUsableLiesWithinIt) {
  sim::World world = FlatWorld(60.0, 10.0, 0.1, 2.0);
  FillBox(&world, {0.0, 6.2, -0.2}, {60.0, 10.0, 0.0}, false);  // beyond the north wall: unknown
  FillBox(&world, {0.0, 6.0, 0.0}, {60.0, 6.2, 2.0});           // the north wall...
  FillBox(&world, {4.0, 6.0, 0.0}, {4.2, 6.2, 2.0}, false);     // ...with a 0.2 m slot at x = 4
  FillBox(&world, {50.0, 6.0, 0.0}, {52.0, 6.2, 2.0}, false);   // ...and a 2 m door at x = 50
  const auto grid = std::make_shared<const core::VoxelGrid>(std::move(world));
  TraversabilityOptions reading = RobotMapReading();
  reading.robot_radius_m = 0.05;  // the slot is a frontier too
  const MultiLevelGrid levels(grid, reading);
  FrontierOptions whole;
  whole.search_horizon_m = std::numeric_limits<double>::infinity();
  whole.min_cells = 1;
  whole.min_gain_m2 = 0.0;
  const FrontierSet all = FindFrontiersMultiLevel(levels, {1.0, 3.0, 0.0}, whole);
  EXPECT_FALSE(std::isfinite(all.searched_to_cost_m));
  ASSERT_EQ(all.reachable(), 2) << all.clusters.size() << " clusters";
  FrontierOptions near = whole;
  near.search_horizon_m = 20.0;
  const FrontierSet cut = FindFrontiersMultiLevel(levels, {1.0, 3.0, 0.0}, near);
  EXPECT_LT(cut.searched_to_cost_m, 30.0);
  ASSERT_EQ(cut.reachable(), 1);
  EXPECT_NEAR(cut.clusters[0].target_M.x(), 4.1, 0.2);
  for (const FrontierCluster& c : cut.clusters) {
    if (c.target_M.x() > 40) {
      EXPECT_FALSE(c.reachable()) << "beyond the horizon";
    }
  }
  // The slot's cluster is two cells: with min_cells 3 nothing usable lies within the horizon.
  near.min_cells = 3;
  const FrontierSet again = FindFrontiersMultiLevel(levels, {1.0, 3.0, 0.0}, near);
  ASSERT_EQ(again.reachable(), 1);
  EXPECT_NEAR(again.clusters[0].target_M.x(), 51.0, 1.0);
  near.search_horizon_m = 0.0;
  std::string why;
  EXPECT_FALSE(near.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::search_horizon_m = 0 must be > 0 (infinity: no horizon)");
}

// A 0.5 m plateau (x in [10, 11]) a legged robot cannot step onto, unknown beyond it: its frontier is seen
// but no surface of it is reachable. Its target becomes a viewpoint, the nearest reachable floor in sight of
// it within viewpoint_radius_m; with that off, or with a wall hiding the plateau, it stays unreachable.
TEST(MultiLevelFrontierTest, AnUnreachableFrontierInSightIsLookedAtFromTheNearestReachableFloor) {
  sim::World world = FlatWorld(20.0, 10.0, 0.1, 2.0);
  FillBox(&world, {10.0, 0.0, 0.0}, {11.0, 10.0, 0.5});          // the plateau
  FillBox(&world, {11.0, 0.0, -0.2}, {20.0, 10.0, 0.0}, false);  // unknown beyond it
  TraversabilityOptions legged = GetPlatformProfile("legged").traversability;
  legged.unknown_is_lethal = false;
  const auto grid = std::make_shared<const core::VoxelGrid>(world);
  const MultiLevelGrid levels(grid, legged);
  const Eigen::Vector3d robot_M(5.0, 5.0, 0.0);
  FrontierOptions off;
  off.viewpoint_radius_m = 0.0;
  const FrontierSet unseen = FindFrontiersMultiLevel(levels, robot_M, off);
  ASSERT_FALSE(unseen.clusters.empty());
  for (const FrontierCluster& c : unseen.clusters) {
    EXPECT_FALSE(c.reachable()) << c.target_M.transpose();
    EXPECT_FALSE(c.viewpoint);
    EXPECT_NEAR(c.target_ground_z_m, 0.5, 0.05);
  }

  const FrontierSet set = FindFrontiersMultiLevel(levels, robot_M);
  ASSERT_EQ(set.clusters.size(), unseen.clusters.size());
  for (const FrontierCluster& c : set.clusters) {
    ASSERT_TRUE(c.reachable()) << c.target_M.transpose();
    EXPECT_TRUE(c.viewpoint);
    // On the floor, as near the plateau as the footprint's clearance lets it.
    EXPECT_NEAR(c.target_ground_z_m, 0.0, 0.05);
    EXPECT_NEAR(c.target_M.x(), 9.7, 0.1);
    // The cluster is still on the plateau (at both its edges: without a seen-free map the floor beside it is
    // unknown at its height).
    EXPECT_GT(c.centroid_M.x(), 10.0);
    EXPECT_LT(c.centroid_M.x(), 11.0);
    EXPECT_LE(std::hypot(c.target_M.x() - c.centroid_M.x(), 0.5), FrontierOptions{}.viewpoint_radius_m);
    EXPECT_NEAR(c.travel_cost_m, 5.5, 1.0);
    EXPECT_GT(c.utility, 0.0);
  }

  FillBox(&world, {9.5, 0.0, 0.0}, {9.6, 10.0, 2.0});  // a wall in front of the plateau
  const MultiLevelGrid walled(std::make_shared<const core::VoxelGrid>(world), legged);
  const FrontierSet hidden = FindFrontiersMultiLevel(walled, {5.0, 5.0, 0.0});
  ASSERT_FALSE(hidden.clusters.empty());
  for (const FrontierCluster& c : hidden.clusters) EXPECT_FALSE(c.reachable()) << c.target_M.transpose();

  off.viewpoint_radius_m = 11.0;
  std::string why;
  EXPECT_FALSE(off.IsValid(&why));
  EXPECT_EQ(why, "FrontierOptions::viewpoint_radius_m = 11 must be in [0, 10]");
}

// The two-floor building as a legged robot on floor 1 has seen it (everything up to 2.0 m, and the free space
// over the flights up to 2.8 m, as rays passing over the treads): the stairs lead on into unknown space, a
// reachable frontier above the robot's floor; a wheeled robot cannot climb to it. Peers' coverage of floor 1
// leaves the stairs' gain alone when it is counted on floor 1's band only. Seen whole, the building has no
// frontier left.
TEST(MultiLevelFrontierTest, TheStairsAreAFrontierOnlyALeggedRobotReaches) {
  const auto truth = std::make_shared<const core::VoxelGrid>(sim::MakeBuiltinWorld("building"));
  std::shared_ptr<core::VoxelGrid> world, seen_free;
  testing::SeenBelow(*truth, 2.0, &world, &seen_free, 2.8);
  TraversabilityOptions legged = GetPlatformProfile("legged").traversability;
  legged.unknown_is_lethal = false;
  const MultiLevelGrid levels(world, legged, seen_free);
  const Eigen::Vector3d robot_M(2.0, 7.1, 0.0);
  const FrontierSet set = FindFrontiersMultiLevel(levels, robot_M);
  ASSERT_TRUE(set.robot_on_grid);
  const auto stairs = std::find_if(set.clusters.begin(), set.clusters.end(), [](const FrontierCluster& c) {
    return c.reachable() && c.target_ground_z_m > 1.0;
  });
  ASSERT_NE(stairs, set.clusters.end()) << set.clusters.size() << " clusters, none reachable above floor 1";
  std::printf(
      "  %zu clusters; stairs: target (%.2f, %.2f, z %.2f), %.1f m², %.1f m away; %.0f m² of surfaces\n",
      set.clusters.size(), stairs->target_M.x(), stairs->target_M.y(), stairs->target_ground_z_m,
      stairs->gain_m2, stairs->travel_cost_m, set.known_free_m2);
  EXPECT_GT(stairs->target_M.x(), 18.0);  // in the stairwell
  EXPECT_LT(stairs->target_ground_z_m, 2.1);
  EXPECT_GT(stairs->travel_cost_m, 17.0);  // at least the walk along the corridor
  EXPECT_GE(stairs->gain_m2, FrontierOptions{}.min_gain_m2);

  TraversabilityOptions wheeled = GetPlatformProfile("wheeled").traversability;
  wheeled.unknown_is_lethal = false;
  const FrontierSet rolling = FindFrontiersMultiLevel(MultiLevelGrid(world, wheeled, seen_free), robot_M);
  for (const FrontierCluster& c : rolling.clusters) {
    EXPECT_FALSE(c.reachable() && c.target_ground_z_m > 0.5)
        << c.target_M.transpose() << " z " << c.target_ground_z_m;
  }

  PeerCoverage peers(0.5);
  for (double x = 0.25; x < 24.0; x += 0.5) {
    for (double y = 0.25; y < 14.0; y += 0.5) peers.Mark({x, y});
  }
  FrontierOptions floor1_band;
  floor1_band.peer_coverage_min_z_m = -1.0;
  floor1_band.peer_coverage_max_z_m = 1.5;
  const FrontierSet with_peers = FindFrontiersMultiLevel(levels, robot_M, floor1_band, &peers);
  EXPECT_TRUE(
      std::any_of(with_peers.clusters.begin(), with_peers.clusters.end(),
                  [](const FrontierCluster& c) { return c.reachable() && c.target_ground_z_m > 1.0; }));
  const FrontierSet everywhere = FindFrontiersMultiLevel(levels, robot_M, {}, &peers);
  EXPECT_TRUE(everywhere.clusters.empty()) << everywhere.clusters.size();

  std::shared_ptr<core::VoxelGrid> all, all_free;
  testing::SeenBelow(*truth, 100.0, &all, &all_free);
  const FrontierSet done = FindFrontiersMultiLevel(MultiLevelGrid(all, legged, all_free), robot_M);
  EXPECT_EQ(done.reachable(), 0)
      << done.clusters.size() << " clusters, the first at "
      << (done.clusters.empty() ? Eigen::Vector2d::Zero() : done.clusters[0].target_M).transpose();
  EXPECT_GT(done.known_free_m2, 1.8 * set.known_free_m2 * 0.9);  // two floors
}

}  // namespace
}  // namespace cairn::nav
