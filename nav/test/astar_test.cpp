// Copyright Cairn authors.
#include "cairn/nav/astar.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

constexpr double kSqrt2 = 1.41421356237309504880;

// Plain shortest paths: no clearance preference, no shortcuts.
AStarOptions GridOptions() {
  AStarOptions options;
  options.clearance_cost = 0.0;
  options.simplify_path = false;
  return options;
}

// Expects every segment of `path` to cross traversable cells only (from `first` on).
void ExpectPathTraversable(const TraversabilityGrid& grid, const std::vector<Eigen::Vector3d>& path,
                           std::size_t first = 0) {
  for (std::size_t i = first; i + 1 < path.size(); ++i) {
    EXPECT_TRUE(SegmentTraversable(grid, path[i].head<2>(), path[i + 1].head<2>()))
        << "segment " << i << ": (" << path[i].transpose() << ") -> (" << path[i + 1].transpose() << ")";
  }
}

TEST(AStarOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(AStarOptions{}.IsValid(&why)) << why;
  AStarOptions options;
  options.step_height_cost = -1.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "AStarOptions::step_height_cost = -1 must be finite and in [0, 100]");
  const TraversabilityGrid grid(FlatWorld(2.0, 2.0));
  EXPECT_THROW(PlanPath(grid, {1.0, 1.0}, {1.0, 1.0}, options), std::invalid_argument);
}

TEST(AStarTest, StraightLineInOpenSpace) {
  const TraversabilityGrid grid(FlatWorld(10.0, 10.0));
  const PlanResult r = PlanPath(grid, {1.05, 5.05}, {8.05, 5.05}, GridOptions());
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.length_m, 7.0, 1e-9);
  EXPECT_EQ(r.path_W.size(), 71u);
  EXPECT_TRUE(r.path_W.front().isApprox(Eigen::Vector3d(1.05, 5.05, 0.0), 1e-9));
  EXPECT_TRUE(r.path_W.back().isApprox(Eigen::Vector3d(8.05, 5.05, 0.0), 1e-9));
  EXPECT_FALSE(r.used_start_escape);
  EXPECT_GT(r.expansions, 0);
  EXPECT_CONTAINS(r.message, "7.00 m");

  AStarOptions simplify = GridOptions();
  simplify.simplify_path = true;
  const PlanResult s = PlanPath(grid, {1.05, 5.05}, {8.05, 5.05}, simplify);
  ASSERT_TRUE(s.IsUsable()) << s.message;
  EXPECT_EQ(s.path_W.size(), 2u);
  EXPECT_NEAR(s.length_m, 7.0, 1e-9);
}

TEST(AStarTest, DiagonalIsOctile) {
  const TraversabilityGrid grid(FlatWorld(10.0, 10.0));
  // 30 cells in x, 10 in y: 20 straight + 10 diagonal moves.
  const PlanResult r = PlanPath(grid, {1.05, 1.05}, {4.05, 2.05}, GridOptions());
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.length_m, (20.0 + 10.0 * kSqrt2) * 0.1, 1e-9);
  AStarOptions simplify = GridOptions();
  simplify.simplify_path = true;
  const PlanResult s = PlanPath(grid, {1.05, 1.05}, {4.05, 2.05}, simplify);
  ASSERT_TRUE(s.IsUsable()) << s.message;
  EXPECT_NEAR(s.length_m, std::sqrt(10.0), 1e-9);  // Straight line after shortcutting.
}

// 10 x 10 m, with a wall x in [5.0, 5.2), y in [0, 7.0) touching the south border: paths from west to east go
// round its north end. With the 0.3 m inflation, cells (50, iy) and (51, iy) are traversable from iy = 73 on,
// and the shortest 8-connected path from cell (10, 60) to cell (90, 60) is
// octile((10,60),(50,73)) + 1 + octile((51,73),(90,60)) = (27 + 13 sqrt2) + 1 + (26 + 13 sqrt2) cells:
// every path crosses columns 50 and 51 at iy >= 73, octile distance is a lower bound of each part and is
// achieved (13 diagonal moves, then straight along row 73, then 13 diagonal moves).
TEST(AStarTest, AroundAWallMatchesAnalyticOctileLength) {
  sim::World world = FlatWorld(10.0, 10.0);
  FillBox(&world, {5.0, 0.0, 0.0}, {5.2, 7.0, 1.5});
  const TraversabilityGrid grid(world);
  const PlanResult r = PlanPath(grid, {1.05, 6.05}, {9.05, 6.05}, GridOptions());
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.length_m, (54.0 + 26.0 * kSqrt2) * 0.1, 1e-9);
  ExpectPathTraversable(grid, r.path_W);
  double max_y = 0.0;
  for (const Eigen::Vector3d& p : r.path_W) max_y = std::max(max_y, p.y());
  EXPECT_NEAR(max_y, 7.35, 1e-9);  // Row 73.

  // Shortcuts and the clearance preference keep the path valid; shortcuts never lengthen it.
  AStarOptions simplify = GridOptions();
  simplify.simplify_path = true;
  const PlanResult s = PlanPath(grid, {1.05, 6.05}, {9.05, 6.05}, simplify);
  ASSERT_TRUE(s.IsUsable()) << s.message;
  EXPECT_LE(s.length_m, r.length_m + 1e-9);
  EXPECT_GT(s.length_m, 8.0);
  ExpectPathTraversable(grid, s.path_W);
  const PlanResult d = PlanPath(grid, {1.05, 6.05}, {9.05, 6.05});
  ASSERT_TRUE(d.IsUsable()) << d.message;
  ExpectPathTraversable(grid, d.path_W);
  EXPECT_GE(d.length_m, s.length_m - 1e-9);
}

// A wall across the map with a 0.6 m gap (x in [5.0, 5.2), gap y in [4.7, 5.3)): lethal cell centres 0.7 m
// apart, so no cell centre is more than the grid's 0.3 m robot radius from both sides: closed for the grid.
// A plan with a reduced radius (a recovery's last attempt) goes through it, and never through a lethal cell.
TEST(AStarTest, AReducedRobotRadiusOpensAGapTheGridClosed) {
  sim::World world = FlatWorld(10.0, 10.0);
  FillBox(&world, {5.0, 0.0, 0.0}, {5.2, 4.7, 1.5});
  FillBox(&world, {5.0, 5.3, 0.0}, {5.2, 10.0, 1.5});
  const TraversabilityGrid grid(world);
  AStarOptions options = GridOptions();
  const PlanResult closed = PlanPath(grid, {2.05, 5.05}, {8.05, 5.05}, options);
  EXPECT_EQ(closed.status, PlanResult::Status::kUnreachable) << closed.message;
  options.robot_radius_m = 0.2;
  const PlanResult open = PlanPath(grid, {2.05, 5.05}, {8.05, 5.05}, options);
  ASSERT_TRUE(open.IsUsable()) << open.message;
  for (const Eigen::Vector3d& p : open.path_W) {
    int ix = 0, iy = 0;
    ASSERT_TRUE(grid.CellOf(p.x(), p.y(), &ix, &iy));
    EXPECT_FALSE(grid.IsLethal(ix, iy));
    EXPECT_GT(grid.ClearanceM(ix, iy), 0.2);
  }
  options.robot_radius_m = -1.0;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("robot_radius_m = -1"), std::string::npos) << why;
}

TEST(AStarTest, StepHeightsAreInPathAndCost) {
  sim::World world = FlatWorld(10.0, 4.0);
  FillBox(&world, {4.0, 0.0, 0.0}, {6.0, 4.0, 0.1});  // A 0.1 m plateau across the map.
  const TraversabilityGrid grid(world);
  const PlanResult r = PlanPath(grid, {1.05, 2.05}, {9.05, 2.05}, GridOptions());
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.length_m, 8.0, 1e-9);
  bool on_plateau = false;
  for (const Eigen::Vector3d& p : r.path_W) {
    if (p.x() > 4.0 && p.x() < 6.0) {
      EXPECT_NEAR(p.z(), 0.1, 1e-9);
      on_plateau = true;
    } else {
      EXPECT_NEAR(p.z(), 0.0, 1e-9);
    }
  }
  EXPECT_TRUE(on_plateau);
}

TEST(AStarTest, FailureStatusesNameTheValues) {
  sim::World world = FlatWorld(10.0, 10.0);
  FillBox(&world, {5.0, 0.0, 0.0}, {5.2, 7.0, 1.5});
  const TraversabilityGrid grid(world);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  using Status = PlanResult::Status;

  PlanResult r = PlanPath(grid, {1.0, 1.0}, {nan, 3.0});
  EXPECT_EQ(r.status, Status::kInvalidGoal);
  EXPECT_CONTAINS(r.message, "goal (nan, 3.00) is not finite");
  EXPECT_FALSE(r.IsUsable());
  EXPECT_TRUE(r.path_W.empty());

  r = PlanPath(grid, {inf, 1.0}, {2.0, 3.0});
  EXPECT_EQ(r.status, Status::kInvalidStart);
  EXPECT_CONTAINS(r.message, "start (inf, 1.00) is not finite");

  r = PlanPath(grid, {1.0, 1.0}, {120.0, 3.0});
  EXPECT_EQ(r.status, Status::kOutOfMap);
  EXPECT_CONTAINS(r.message, "goal (120.00, 3.00) is outside the map x in [0.00, 10.00], y in [0.00, 10.00]");

  r = PlanPath(grid, {-1.0, 1.0}, {2.0, 3.0});
  EXPECT_EQ(r.status, Status::kOutOfMap);
  EXPECT_CONTAINS(r.message, "start (-1.00, 1.00) is outside the map");

  r = PlanPath(grid, {1.0, 1.0}, {5.1, 3.0});
  EXPECT_EQ(r.status, Status::kGoalBlocked);
  EXPECT_CONTAINS(r.message, "goal (5.10, 3.00) is not traversable (cell state obstacle)");

  r = PlanPath(grid, {1.0, 1.0}, {4.85, 3.0});
  EXPECT_EQ(r.status, Status::kGoalBlocked);
  EXPECT_CONTAINS(r.message, "clearance 0.20 m <= robot_radius_m 0.30 m");

  r = PlanPath(grid, {5.1, 3.0}, {1.0, 1.0});
  EXPECT_EQ(r.status, Status::kStartBlocked);
  EXPECT_CONTAINS(r.message,
                  "start (5.10, 3.00) is not traversable (cell state obstacle) and the robot body");

  AStarOptions no_escape;
  no_escape.start_escape_radius_m = 0.0;
  r = PlanPath(grid, {4.75, 3.05}, {1.0, 1.0}, no_escape);
  EXPECT_EQ(r.status, Status::kStartBlocked);
  EXPECT_CONTAINS(r.message, "no traversable cell lies within start_escape_radius_m 0");

  // A wall across the whole map: no path.
  sim::World split = FlatWorld(10.0, 10.0);
  FillBox(&split, {5.0, 0.0, 0.0}, {5.2, 10.0, 1.5});
  const TraversabilityGrid split_grid(split);
  r = PlanPath(split_grid, {1.0, 1.0}, {9.0, 9.0});
  EXPECT_EQ(r.status, Status::kUnreachable);
  EXPECT_CONTAINS(r.message, "goal (9.00, 9.00) is unreachable from start (1.00, 1.00)");
  EXPECT_GT(r.expansions, 1000);
  EXPECT_STREQ(ToString(r.status), "kUnreachable");
}

TEST(AStarTest, StartInsideInflationEscapes) {
  sim::World world = FlatWorld(10.0, 10.0);
  FillBox(&world, {5.0, 0.0, 0.0}, {5.2, 7.0, 1.5});
  const TraversabilityGrid grid(world);
  // Cell (47, 30) at x = 4.75 is 0.3 m from the wall cells (x = 5.05): not traversable, but a 0.25 m body
  // there is free; cell (46, 30) at x = 4.65 is traversable.
  int ix = 0;
  int iy = 0;
  ASSERT_TRUE(grid.CellOf(4.75, 3.05, &ix, &iy));
  ASSERT_FALSE(grid.IsTraversable(ix, iy));
  ASSERT_TRUE(grid.IsFootprintFree(4.75, 3.05, 0.25));
  const PlanResult r = PlanPath(grid, {4.75, 3.05}, {1.05, 3.05}, GridOptions());
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_TRUE(r.used_start_escape);
  EXPECT_CONTAINS(r.message, "escape");
  EXPECT_TRUE(r.path_W.front().isApprox(Eigen::Vector3d(4.75, 3.05, 0.0), 1e-9));
  EXPECT_TRUE(
      r.path_W[1].head<2>().isApprox(Eigen::Vector2d(4.65, 3.05), 1e-9));  // Nearest traversable cell.
  EXPECT_NEAR(r.length_m, 3.7, 1e-9);
  ExpectPathTraversable(grid, r.path_W, 1);
}

TEST(AStarTest, BuiltinTunnelsPathsStayTraversable) {
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("tunnels"));
  const sim::BuiltinWorldInfo& info = sim::GetBuiltinWorldInfo("tunnels");
  const Eigen::Vector2d goal(info.far_goal.x_m, info.far_goal.y_m);
  for (const sim::PlanarPose& start : info.suggested_starts) {
    const Eigen::Vector2d s(start.x_m, start.y_m);
    const PlanResult r = PlanPath(grid, s, goal);
    ASSERT_TRUE(r.IsUsable()) << r.message;
    EXPECT_GE(r.length_m, (goal - s).norm() - 1e-9);
    EXPECT_LT(r.planning_time_s, 1.0);
    ExpectPathTraversable(grid, r.path_W);
  }
  // The platform above the stairs is not reachable for the default 0.15 m step.
  const PlanResult r = PlanPath(grid, {4.0, 20.0}, {54.5, 24.0});
  EXPECT_EQ(r.status, PlanResult::Status::kUnreachable) << r.message;
}

}  // namespace
}  // namespace cairn::nav
