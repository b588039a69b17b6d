// Copyright Cairn authors.
//
// Get-out-of-the-way spots on hand-made worlds: a 2 m tunnel with a side passage, the same tunnel
// without one, and a room.
#include "cairn/nav/yield_spot.h"

#include <gtest/gtest.h>

#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

// A 2 m wide tunnel along x (y in [9, 11]) over 20 m, with (side = true) a 2 m wide side passage going north
// at x in [11, 13] to y = 16. Walls are 1.6 m high.
sim::World Tunnel(bool side) {
  sim::World w = FlatWorld(20, 16);
  FillBox(&w, {0, 0, 0}, {20, 9, 1.6});
  FillBox(&w, {0, 11, 0}, {20, 16, 1.6});
  if (side) FillBox(&w, {11, 11, 0}, {13, 15.5, 1.6}, /*occupied=*/false);
  return w;
}

YieldSpotRequest PassingAlongTheTunnel(const Eigen::Vector2d& from_W) {
  YieldSpotRequest r;
  r.from_W = from_W;
  r.keep_clear_W = {{1.0, 10.0},
                    {20.0, 10.0}};  // the passing robot, at its west end, drives the whole tunnel
  r.clearance_m = 0.9;              // two 0.3 m footprints and 0.3 m
  r.robot_radius_m = 0.3;
  return r;
}

// B stands in the tunnel 3 m west of the side passage: the nearest spot clear of A's path is in the passage,
// about 3 m east and 1 m north of B, 0.9 m or more from the tunnel's centre line.
TEST(YieldSpotTest, ARobotInANarrowTunnelStandsAsideInTheSidePassage) {
  const TraversabilityGrid grid(Tunnel(true));
  const YieldSpot spot = FindYieldSpot(grid, PassingAlongTheTunnel({8.0, 10.0}));
  ASSERT_TRUE(spot.found) << spot.reason;
  EXPECT_GE(spot.p_W.x(), 11.0);
  EXPECT_LE(spot.p_W.x(), 13.0);
  EXPECT_GE(spot.p_W.y(), 10.9);
  EXPECT_GE(spot.clearance_m, 0.9);
  EXPECT_NEAR(spot.drive_m, 3.9, 0.8) << "about 3.3 m east and 0.9 m north, on 8-connected cells";
  EXPECT_TRUE(grid.IsFootprintFree(spot.p_W.x(), spot.p_W.y(), 0.3));
  // The way there starts at the robot, ends at the spot, steps from cell to cell and stays drivable.
  ASSERT_GE(spot.path_W.size(), 2u);
  EXPECT_EQ(spot.path_W.front(), Eigen::Vector2d(8.0, 10.0));
  EXPECT_EQ(spot.path_W.back(), spot.p_W);
  double length_m = 0.0;
  for (std::size_t i = 1; i < spot.path_W.size(); ++i) {
    const double step_m = (spot.path_W[i] - spot.path_W[i - 1]).norm();
    // Cell to cell (8-connected); the first step is from the robot to its cell's neighbour.
    EXPECT_LE(step_m, grid.cell_size_m() * (i == 1 ? 2.2 : 1.5)) << i;
    length_m += step_m;
    EXPECT_TRUE(grid.IsFootprintFree(spot.path_W[i].x(), spot.path_W[i].y(), 0.3)) << i;
  }
  EXPECT_NEAR(length_m, spot.drive_m, grid.cell_size_m());
}

// A robot of radius 0.3 m cannot pass a peer of radius 0.3 m in the middle of the 2 m tunnel (it needs 0.9 m
// beside the peer's centre, and the walls leave 1.0 - 0.3 m), but can beside the side passage's mouth, and
// in a room.
TEST(YieldSpotTest, CanPassBesideAPeerOnlyWhereThePassageIsWideEnough) {
  const TraversabilityGrid tunnel(Tunnel(true));
  EXPECT_FALSE(CanPassBeside(tunnel, {8.0, 10.0}, {1.0, 0.0}, 0.9, 0.3));
  EXPECT_FALSE(CanPassBeside(tunnel, {8.0, 10.0}, {1.0, 0.0}, 0.9, 0.3, /*along_m=*/1.0));
  EXPECT_TRUE(CanPassBeside(tunnel, {12.0, 10.0}, {1.0, 0.0}, 0.9, 0.3));
  EXPECT_TRUE(CanPassBeside(tunnel, {9.5, 10.0}, {1.0, 0.0}, 0.9, 0.3, /*along_m=*/2.5))
      << "the passage's mouth 1.5 m on";
  EXPECT_FALSE(CanPassBeside(tunnel, {8.0, 10.0}, {0.0, 0.0}, 0.9, 0.3)) << "no direction: not assumed wide";
  EXPECT_FALSE(CanPassBeside(tunnel, {80.0, 10.0}, {1.0, 0.0}, 0.9, 0.3)) << "off the grid";
  const TraversabilityGrid room(FlatWorld(20, 16));
  EXPECT_TRUE(CanPassBeside(room, {8.0, 8.0}, {1.0, 1.0}, 0.9, 0.3));
}

// Without the side passage no spot in a 2 m tunnel clears the path (the tunnel's west end is behind the
// passing robot, which the robot cannot drive through): not found, and the reason says what was searched;
// the same when the spot is beyond max_drive_m.
TEST(YieldSpotTest, NoSpotInATunnelWithoutASidePassageOrBeyondTheLongestDrive) {
  const YieldSpot none = FindYieldSpot(TraversabilityGrid(Tunnel(false)), PassingAlongTheTunnel({8.0, 10.0}));
  EXPECT_FALSE(none.found);
  EXPECT_NE(none.reason.find("no spot 0.9 m clear of the path within 30 m of driving"), std::string::npos)
      << none.reason;
  YieldSpotRequest short_drive = PassingAlongTheTunnel({8.0, 10.0});
  short_drive.max_drive_m = 2.0;
  EXPECT_FALSE(FindYieldSpot(TraversabilityGrid(Tunnel(true)), short_drive).found);
}

// In a room the robot only steps aside: the spot is about clearance_m from the path, next to the robot.
// A robot already within keep_off_m of the passing robot (it drove up close) may still move away from it to
// a spot; it is never let closer.
TEST(YieldSpotTest, ARobotTooCloseToThePassingOneMovesAwayFromIt) {
  const TraversabilityGrid grid(Tunnel(true));
  YieldSpotRequest r = PassingAlongTheTunnel({8.0, 10.0});
  r.keep_clear_W = {{7.5, 10.0}, {20.0, 10.0}};  // the passing robot 0.5 m behind
  const YieldSpot spot = FindYieldSpot(grid, r);
  ASSERT_TRUE(spot.found) << spot.reason;
  EXPECT_GE(spot.p_W.x(), 11.0) << "in the side passage ahead";
  for (const Eigen::Vector2d& p : spot.path_W) EXPECT_GE(p.x(), 7.95) << "never back toward it";
}

TEST(YieldSpotTest, InARoomTheRobotStepsAside) {
  const TraversabilityGrid grid(FlatWorld(10, 10));
  YieldSpotRequest r;
  r.from_W = {5.0, 5.0};
  r.keep_clear_W = {{1.0, 5.0}, {9.0, 5.0}};
  const YieldSpot spot = FindYieldSpot(grid, r);
  ASSERT_TRUE(spot.found) << spot.reason;
  EXPECT_NEAR(std::abs(spot.p_W.y() - 5.0), 0.95, 0.1);
  EXPECT_LT(spot.drive_m, 1.2);
}

TEST(YieldSpotTest, ABadRequestIsNamed) {
  const TraversabilityGrid grid(FlatWorld(10, 10));
  YieldSpotRequest r;
  r.from_W = {5.0, 5.0};
  EXPECT_EQ(FindYieldSpot(grid, r).reason, "YieldSpotRequest::keep_clear_W is empty");
  r.keep_clear_W = {{1.0, 5.0}};
  r.clearance_m = -1;
  EXPECT_EQ(FindYieldSpot(grid, r).reason, "YieldSpotRequest::clearance_m = -1 must be finite and > 0");
  r.clearance_m = 0.9;
  r.from_W = {50.0, 5.0};
  EXPECT_EQ(FindYieldSpot(grid, r).reason, "the robot at (50, 5) is off its map");
}

}  // namespace
}  // namespace cairn::nav
