// Copyright Cairn authors.
#include "cairn/nav/traversability.h"

#include <gtest/gtest.h>

#include "cairn/sim/builtin_worlds.h"
#include "nav_test_util.h"

namespace cairn::nav {
namespace {

using testing::FillBox;
using testing::FlatWorld;

// 4 x 3 m at 0.1 m, floor top z = 0, grid top z = 2.3, with:
//  - a wall x in [2.0, 2.2), y in [0, 1.5) up to the top of the grid (an obstacle);
//  - a climbable 0.1 m plate x in [0.5, 1.5), y in [2, 3);
//  - a 0.3 m block x in [3.0, 3.5), y in [2.0, 2.5) (too high a step);
//  - a one-cell hole in the floor at (1.05, 0.55) (filled by hole filling);
//  - no floor for x in [3.5, 4), y in [0, 1) (unknown);
//  - a shelf at z in [1.2, 1.3) over x in [0.2, 0.6), y in [0.2, 0.6) (a second ground level).
sim::World HandMadeWorld() {
  sim::World world = FlatWorld(4.0, 3.0, 0.1, 2.3);
  FillBox(&world, {2.0, 0.0, 0.0}, {2.2, 1.5, 2.3});
  FillBox(&world, {0.5, 2.0, 0.0}, {1.5, 3.0, 0.1});
  FillBox(&world, {3.0, 2.0, 0.0}, {3.5, 2.5, 0.3});
  FillBox(&world, {1.0, 0.5, -0.2}, {1.1, 0.6, 0.0}, false);
  FillBox(&world, {3.5, 0.0, -0.2}, {4.0, 1.0, 0.0}, false);
  FillBox(&world, {0.2, 0.2, 1.2}, {0.6, 0.6, 1.3});
  return world;
}

// Cell queries by coordinates.
struct At {
  const TraversabilityGrid& grid;
  int ix = 0;
  int iy = 0;
  At(const TraversabilityGrid& g, double x, double y) : grid(g) { EXPECT_TRUE(g.CellOf(x, y, &ix, &iy)); }
  CellState state() const { return grid.State(ix, iy); }
  double ground() const { return grid.Ground(ix, iy); }
  bool lethal() const { return grid.IsLethal(ix, iy); }
  bool traversable() const { return grid.IsTraversable(ix, iy); }
  double clearance() const { return grid.ClearanceM(ix, iy); }
};

TEST(TraversabilityOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(TraversabilityOptions{}.IsValid(&why)) << why;
}

TEST(TraversabilityOptionsTest, InvalidFieldsAreNamed) {
  TraversabilityOptions options;
  options.robot_height_m = 0.0;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "robot_height_m = 0");
  options = TraversabilityOptions{};
  options.ground_search_min_z_m = 1.0;
  options.ground_search_max_z_m = 0.5;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "ground_search_min_z_m = 1 must be < ground_search_max_z_m = 0.5");
  options = TraversabilityOptions{};
  options.cell_size_m = 0.15;
  try {
    TraversabilityGrid grid(HandMadeWorld(), options);
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_CONTAINS(std::string(e.what()), "cell_size_m = 0.15 must be 0 or an integer multiple");
  }
}

TEST(TraversabilityGridTest, HandMadeWorldStates) {
  const TraversabilityGrid grid(HandMadeWorld());
  EXPECT_EQ(grid.nx(), 40);
  EXPECT_EQ(grid.ny(), 30);
  EXPECT_DOUBLE_EQ(grid.cell_size_m(), 0.1);
  EXPECT_NEAR(grid.summary().reference_height_m, 0.0, 1e-9);

  const At floor(grid, 0.75, 1.25);
  EXPECT_EQ(floor.state(), CellState::kFree);
  EXPECT_NEAR(floor.ground(), 0.0, 1e-9);
  EXPECT_FALSE(floor.lethal());
  EXPECT_TRUE(floor.traversable());

  const At wall(grid, 2.05, 0.75);
  EXPECT_EQ(wall.state(), CellState::kObstacle);
  EXPECT_TRUE(wall.lethal());
  EXPECT_FALSE(wall.traversable());
  EXPECT_TRUE(std::isnan(wall.ground()));

  const At beside_wall(grid, 1.95, 0.75);  // Free but within the robot radius of the wall.
  EXPECT_EQ(beside_wall.state(), CellState::kFree);
  EXPECT_FALSE(beside_wall.lethal());
  EXPECT_NEAR(beside_wall.clearance(), 0.1, 1e-9);
  EXPECT_FALSE(beside_wall.traversable());
  const At clear_of_wall(grid, 1.65, 0.75);
  EXPECT_NEAR(clear_of_wall.clearance(), 0.4, 1e-9);
  EXPECT_TRUE(clear_of_wall.traversable());

  const At plate(grid, 1.0, 2.45);  // Climbable 0.1 m step.
  EXPECT_EQ(plate.state(), CellState::kFree);
  EXPECT_NEAR(plate.ground(), 0.1, 1e-9);
  EXPECT_FALSE(plate.lethal());
  EXPECT_TRUE(plate.traversable());
  EXPECT_FALSE(At(grid, 0.45, 2.45).lethal());  // Lower side of the plate's edge.

  // 0.3 m block: the cells on its rim (the high side of a too high step) are lethal; its inner cells are
  // not, but lie within the robot radius of the rim; the floor beside it is not lethal either.
  const At block(grid, 3.25, 2.25);
  EXPECT_EQ(block.state(), CellState::kFree);
  EXPECT_NEAR(block.ground(), 0.3, 1e-9);
  EXPECT_FALSE(block.lethal());
  EXPECT_FALSE(block.traversable());
  EXPECT_TRUE(At(grid, 3.05, 2.25).lethal());
  EXPECT_TRUE(At(grid, 3.45, 2.45).lethal());
  const At beside_block(grid, 2.95, 2.25);
  EXPECT_FALSE(beside_block.lethal());
  EXPECT_FALSE(beside_block.traversable());

  const At no_floor(grid, 3.75, 0.45);
  EXPECT_EQ(no_floor.state(), CellState::kUnknown);
  EXPECT_TRUE(no_floor.lethal());

  const At hole(grid, 1.05, 0.55);  // Filled from its 8 neighbours.
  EXPECT_EQ(hole.state(), CellState::kFree);
  EXPECT_TRUE(grid.IsInferred(hole.ix, hole.iy));
  EXPECT_NEAR(hole.ground(), 0.0, 1e-9);
  EXPECT_TRUE(hole.traversable());

  const At under_shelf(grid, 0.45, 0.45);  // Floor (nearest the automatic reference) rather than shelf.
  EXPECT_NEAR(under_shelf.ground(), 0.0, 1e-9);

  const TraversabilitySummary& s = grid.summary();
  EXPECT_EQ(s.cells_total, 1200);
  EXPECT_EQ(s.cells_unknown + s.cells_obstacle + s.cells_free, s.cells_total);
  EXPECT_EQ(s.cells_unknown, 50);   // The 0.5 x 1.0 m strip without floor.
  EXPECT_EQ(s.cells_obstacle, 30);  // The 0.2 x 1.5 m wall.
  EXPECT_EQ(s.cells_inferred, 1);
  EXPECT_EQ(s.cells_lethal, 50 + 30 + 16);  // + the 16 rim cells of the 5 x 5 cell block.
}

TEST(TraversabilityGridTest, FootprintAndGroundQueries) {
  const TraversabilityGrid grid(HandMadeWorld());
  EXPECT_TRUE(grid.IsFootprintFree(1.65, 0.75, 0.25));
  EXPECT_FALSE(grid.IsFootprintFree(1.85, 0.75, 0.25));
  EXPECT_TRUE(grid.IsFootprintFree(1.95, 0.75, 0.0));  // Only the centre cell.
  EXPECT_FALSE(grid.IsFootprintFree(-1.0, 0.75, 0.25));
  EXPECT_FALSE(grid.IsFootprintFree(0.1, 1.5, 0.25));  // The disk leaves the map.
  EXPECT_NEAR(grid.GroundHeight(1.0, 2.5).value_or(-1.0), 0.1, 1e-9);
  EXPECT_FALSE(grid.GroundHeight(2.05, 0.75).has_value());
  EXPECT_FALSE(grid.GroundHeight(-1.0, 0.0).has_value());
  EXPECT_FALSE(grid.GroundHeight(std::nan(""), 0.0).has_value());
  EXPECT_TRUE(grid.IsTraversableAt(0.75, 1.25));
  EXPECT_FALSE(grid.IsTraversableAt(40.0, 1.25));
}

TEST(TraversabilityGridTest, OptionsChangeTheAnalysis) {
  const sim::World world = HandMadeWorld();
  TraversabilityOptions options;
  options.fill_passes = 0;
  EXPECT_EQ(At(TraversabilityGrid(world, options), 1.05, 0.55).state(), CellState::kUnknown);

  options = TraversabilityOptions{};
  options.reference_height_m = 1.3;  // Prefer the shelf.
  const TraversabilityGrid shelf(world, options);
  EXPECT_NEAR(At(shelf, 0.45, 0.45).ground(), 1.3, 1e-9);
  EXPECT_TRUE(At(shelf, 0.25, 0.45).lethal());  // Rim of the shelf.

  options = TraversabilityOptions{};
  options.max_step_m = 0.35;  // A legged robot climbs the block.
  EXPECT_FALSE(At(TraversabilityGrid(world, options), 3.05, 2.25).lethal());

  options = TraversabilityOptions{};
  options.ground_search_min_z_m = 0.05;  // Only the plate and block tops are in the band.
  const TraversabilityGrid band(world, options);
  EXPECT_EQ(At(band, 0.75, 1.25).state(), CellState::kUnknown);
  EXPECT_EQ(At(band, 1.0, 2.45).state(), CellState::kFree);
  EXPECT_EQ(At(band, 2.05, 0.75).state(), CellState::kObstacle);

  options = TraversabilityOptions{};
  options.free_above_map = true;  // The wall top becomes (lethal) ground at the top of the map.
  const TraversabilityGrid open_sky(world, options);
  EXPECT_EQ(At(open_sky, 2.05, 0.75).state(), CellState::kFree);
  EXPECT_NEAR(At(open_sky, 2.05, 0.75).ground(), 2.3, 1e-9);
  EXPECT_TRUE(At(open_sky, 2.05, 0.75).lethal());

  options = TraversabilityOptions{};
  options.cell_size_m = 0.2;
  const TraversabilityGrid coarse(world, options);
  EXPECT_EQ(coarse.nx(), 20);
  EXPECT_EQ(coarse.ny(), 15);
  EXPECT_EQ(At(coarse, 2.1, 0.7).state(), CellState::kObstacle);
  EXPECT_NEAR(At(coarse, 1.0, 2.5).ground(), 0.1, 1e-9);
  EXPECT_TRUE(At(coarse, 1.0, 2.5).traversable());
}

TEST(TraversabilityGridTest, BuiltinTunnels) {
  const TraversabilityGrid grid(sim::MakeBuiltinWorld("tunnels"));
  const sim::BuiltinWorldInfo& info = sim::GetBuiltinWorldInfo("tunnels");
  for (const sim::PlanarPose& p : info.suggested_starts) {
    EXPECT_TRUE(grid.IsTraversableAt(p.x_m, p.y_m)) << p.x_m << ", " << p.y_m;
    EXPECT_NEAR(grid.GroundHeight(p.x_m, p.y_m).value_or(-1.0), 0.0, 1e-9);
  }
  EXPECT_TRUE(grid.IsTraversableAt(info.far_goal.x_m, info.far_goal.y_m));
  // Tunnel walls (reaching the top of the grid) are obstacles; stair steps (0.2 m) are lethal for the
  // default max_step_m = 0.15 m; the platform top is ground at 1.0 m.
  int ix = 0;
  int iy = 0;
  for (double x = 5.05; x < 25.0; x += 2.0) {  // North of the main tunnel's floor comes its wall.
    ASSERT_TRUE(grid.CellOf(x, 20.05, &ix, &iy));
    while (grid.State(ix, iy) == CellState::kFree) ++iy;
    EXPECT_EQ(grid.State(ix, iy), CellState::kObstacle) << x;
    EXPECT_GT(grid.CellCenter(ix, iy).y(), 21.15) << x;
    EXPECT_LT(grid.CellCenter(ix, iy).y(), 21.85) << x;
  }
  ASSERT_TRUE(grid.CellOf(51.05, 24.0, &ix, &iy));  // First cell of the third step.
  EXPECT_TRUE(grid.IsLethal(ix, iy));
  EXPECT_NEAR(grid.GroundHeight(54.0, 24.0).value_or(-1.0), 1.0, 1e-9);
  EXPECT_FALSE(grid.IsTraversableAt(2.0, 2.0));  // Outside the tunnels: no ground.
}

// A robot's own map: what its lidar saw of a wall 0.7 m away is only its lower part (up to 0.8 m), with
// nothing observed above; the floor beside the wall was never hit (too close under the lidar). Without the
// seen-free voxels the wall's seen top reads as raised ground among unseen floor; with them it is an
// obstacle, while floor a ray came down onto stays ground.
TEST(TraversabilityGridTest, OwnMapGroundNeedsSpaceSeenFreeAboveIt) {
  sim::World world = FlatWorld(4.0, 3.0, 0.1, 2.3);
  FillBox(&world, {0.0, 0.0, -0.2}, {4.0, 3.0, 0.0}, false);  // no floor seen anywhere...
  FillBox(&world, {0.0, 0.0, -0.1}, {1.5, 3.0, 0.0});         // ...but here, far from the wall
  FillBox(&world, {3.0, 0.0, 0.0}, {3.2, 3.0, 0.8});          // the wall's seen part
  sim::World seen_free("seen free", world.p_W_min(), world.resolution_m(), world.dims());
  FillBox(&seen_free, {0.0, 0.0, 0.0}, {1.5, 3.0, 0.5});  // rays came down onto that floor
  FillBox(&seen_free, {1.5, 0.0, 0.3}, {3.0, 3.0, 0.8});  // and ran to the wall below 0.8 m
  TraversabilityOptions options;
  options.unknown_is_lethal = false;
  options.reference_height_m = 0.0;
  options.fill_passes = 0;
  const TraversabilityGrid blind(world, options);
  EXPECT_EQ(At(blind, 3.05, 1.5).state(), CellState::kFree);  // the failure this guards against
  EXPECT_NEAR(At(blind, 3.05, 1.5).ground(), 0.8, 1e-9);
  const TraversabilityGrid own(world, options, &seen_free);
  EXPECT_EQ(At(own, 3.05, 1.5).state(), CellState::kObstacle);
  EXPECT_TRUE(At(own, 3.05, 1.5).lethal());
  EXPECT_EQ(At(own, 0.75, 1.5).state(), CellState::kFree);
  EXPECT_NEAR(At(own, 0.75, 1.5).ground(), 0.0, 1e-9);
  EXPECT_EQ(At(own, 2.25, 1.5).state(), CellState::kUnknown);  // unseen floor stays optimistic
  // Update() with the same voxels gives the same grid; a different geometry is refused, naming it.
  TraversabilityGrid updated(world, options, &seen_free);
  updated.Update(world, &seen_free,
                 {Eigen::AlignedBox2d(Eigen::Vector2d(2.5, 0.5), Eigen::Vector2d(3.5, 2.5))});
  EXPECT_EQ(At(updated, 3.05, 1.5).state(), CellState::kObstacle);
  const sim::World other("other", world.p_W_min(), world.resolution_m(),
                         world.dims() + Eigen::Vector3i(1, 0, 0));
  try {
    updated.Update(world, &other,
                   {Eigen::AlignedBox2d(Eigen::Vector2d(2.5, 0.5), Eigen::Vector2d(3.5, 2.5))});
    ADD_FAILURE() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_CONTAINS(std::string(e.what()), "seen_free");
  }
}

}  // namespace
}  // namespace cairn::nav
