// The simulator's own ground truth for a body: where it stands, what it touches, which steps it climbs, on
// small voxel worlds built here (0.1 m voxels, a floor whose top is z = 0).
#include "cairn/sim/body_terrain.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

namespace cairn::sim {
namespace {

constexpr double kRadius_m = 0.3;

// An 8 x 4 x 3 m world (x from 0, y from 0, z from -0.2) with a 0.2 m floor slab.
std::shared_ptr<World> Floor() {
  auto world =
      std::make_shared<World>("test", Eigen::Vector3d(0.0, 0.0, -0.2), 0.1, Eigen::Vector3i(80, 40, 30));
  for (int ix = 0; ix < 80; ++ix) {
    for (int iy = 0; iy < 40; ++iy) {
      world->SetOccupied({ix, iy, 0});
      world->SetOccupied({ix, iy, 1});
    }
  }
  return world;
}

// Sets the voxels whose centres lie in the box (metres, frame W).
void Box(World* world, double x0, double x1, double y0, double y1, double z0, double z1,
         bool occupied = true) {
  for (int ix = 0; ix < world->dims().x(); ++ix) {
    for (int iy = 0; iy < world->dims().y(); ++iy) {
      for (int iz = 0; iz < world->dims().z(); ++iz) {
        const Eigen::Vector3d c = world->CenterOf({ix, iy, iz});
        if (c.x() > x0 && c.x() < x1 && c.y() > y0 && c.y() < y1 && c.z() > z0 && c.z() < z1)
          world->SetOccupied({ix, iy, iz}, occupied);
      }
    }
  }
}

BodyOptions Wheeled() { return BodyOptions{0.15, 0.8}; }
BodyOptions Legged() { return BodyOptions{0.30, 0.8}; }

TEST(BodyTerrainTest, AFloorHoldsTheBodyAndAWallStopsItAtItsFootprint) {
  auto world = Floor();
  Box(world.get(), 3.0, 3.2, 0.0, 4.0, 0.0, 2.8);
  const BodyTerrain truth(world, Wheeled());
  EXPECT_NEAR(truth.GroundHeight(1.0, 1.0).value_or(-9), 0.0, 1e-9);
  EXPECT_TRUE(truth.IsFootprintFree(1.0, 1.0, kRadius_m));
  EXPECT_TRUE(truth.IsFootprintFree(2.6, 1.0, kRadius_m));
  EXPECT_FALSE(truth.IsFootprintFree(2.85, 1.0, kRadius_m)) << "the wall is within the footprint";
  EXPECT_FALSE(truth.GroundHeight(3.1, 1.0).has_value()) << "no body stands inside a wall";
  EXPECT_FALSE(truth.IsFootprintFree(0.1, 1.0, kRadius_m)) << "the edge of the world is a wall";
  EXPECT_FALSE(truth.IsFootprintFree(-1.0, 1.0, kRadius_m));
  EXPECT_FALSE(truth.IsFootprintFree(NAN, 1.0, kRadius_m));
}

TEST(BodyTerrainTest, AStepUpToTheBodysLimitIsClimbedAndAHigherOneStopsIt) {
  auto world = Floor();
  Box(world.get(), 2.0, 8.0, 0.0, 2.0, 0.0, 0.1);  // a 0.1 m plate (south half)
  Box(world.get(), 2.0, 8.0, 2.0, 4.0, 0.0, 0.2);  // a 0.2 m plate (north half)
  const BodyTerrain wheeled(world, Wheeled());
  const BodyTerrain legged(world, Legged());
  EXPECT_NEAR(wheeled.GroundHeightNear(2.5, 1.0, 0.0).value_or(-9), 0.1, 1e-9);
  EXPECT_TRUE(wheeled.IsFootprintFreeNear(1.9, 1.0, 0.0, kRadius_m)) << "0.1 m: a step the wheels take";
  EXPECT_FALSE(wheeled.IsFootprintFreeNear(1.9, 3.0, 0.0, kRadius_m)) << "0.2 m: a wall to wheels";
  EXPECT_FALSE(wheeled.GroundHeightNear(2.5, 3.0, 0.0).has_value());
  EXPECT_TRUE(legged.IsFootprintFreeNear(1.9, 3.0, 0.0, kRadius_m)) << "0.2 m: a step to legs";
  EXPECT_NEAR(legged.GroundHeightNear(2.5, 3.0, 0.0).value_or(-9), 0.2, 1e-9);
  // On the plate, the body stands on it and the floor is a step down.
  EXPECT_TRUE(wheeled.IsFootprintFreeNear(2.5, 1.0, 0.1, kRadius_m));
}

// A flight of eight 0.2 m risers, 0.3 m treads, 1.2 m wide, up +x to a landing 1.6 m high: a legged body
// walks up it centre line on every 5 cm with its height following the treads; a wheeled one stops at the
// first riser.
TEST(BodyTerrainTest, ALeggedBodyClimbsAFlightAWheeledOneStopsAtItsFoot) {
  auto world = Floor();
  for (int k = 0; k < 8; ++k) Box(world.get(), 2.0 + 0.3 * k, 8.0, 1.0, 2.2, 0.0, 0.2 * (k + 1));
  const BodyTerrain legged(world, Legged());
  const BodyTerrain wheeled(world, Wheeled());
  double z = 0.0;
  for (double x = 1.0; x <= 5.0; x += 0.05) {
    ASSERT_TRUE(legged.IsFootprintFreeNear(x, 1.6, z, kRadius_m)) << "x " << x << " z " << z;
    z = legged.GroundHeightNear(x, 1.6, z).value_or(NAN);
  }
  EXPECT_NEAR(z, 1.6, 1e-9);
  EXPECT_TRUE(wheeled.IsFootprintFreeNear(1.65, 1.6, 0.0, kRadius_m));
  EXPECT_FALSE(wheeled.IsFootprintFreeNear(1.8, 1.6, 0.0, kRadius_m));
}

TEST(BodyTerrainTest, ABeamAtBodyHeightBlocksAndOneAboveTheBodyDoesNot) {
  auto world = Floor();
  Box(world.get(), 2.0, 2.2, 0.0, 2.0, 0.5, 0.6);  // south: 0.5 m up
  Box(world.get(), 2.0, 2.2, 2.0, 4.0, 0.9, 1.0);  // north: 0.9 m up, over a 0.8 m body
  const BodyTerrain truth(world, Wheeled());
  EXPECT_FALSE(truth.IsFootprintFree(2.1, 1.0, kRadius_m));
  EXPECT_TRUE(truth.IsFootprintFree(2.1, 3.0, kRadius_m));
}

TEST(BodyTerrainTest, AOneVoxelHoleHoldsTheBodyALedgeDeeperThanAStepDoesNot) {
  auto world = Floor();
  world->SetOccupied({10, 10, 0}, false);  // a hole a scan left in the floor, at (1.05, 1.05)
  world->SetOccupied({10, 10, 1}, false);
  Box(world.get(), 4.0, 8.0, 0.0, 4.0, -0.3, 0.1, false);  // the floor ends at x = 4: a shaft beyond
  const BodyTerrain truth(world, Wheeled());
  EXPECT_NEAR(truth.GroundHeight(1.05, 1.05).value_or(-9), 0.0, 1e-9);
  EXPECT_TRUE(truth.IsFootprintFree(1.05, 1.05, kRadius_m));
  EXPECT_TRUE(truth.IsFootprintFreeNear(3.95, 2.0, 0.0, kRadius_m)) << "the centre on the edge";
  EXPECT_FALSE(truth.IsFootprintFreeNear(4.3, 2.0, 0.0, kRadius_m)) << "nothing under the centre";
}

TEST(BodyTerrainTest, ABodyStandsOnTheLevelNearestItsHeight) {
  auto world = Floor();
  Box(world.get(), 4.0, 8.0, 0.0, 4.0, 1.4, 1.6);  // a floor above: top 1.6, 1.4 m of room under it
  const BodyTerrain truth(world, Legged());
  EXPECT_NEAR(truth.GroundHeightNear(5.0, 2.0, 0.0).value_or(-9), 0.0, 1e-9);
  EXPECT_NEAR(truth.GroundHeightNear(5.0, 2.0, 1.6).value_or(-9), 1.6, 1e-9);
  EXPECT_NEAR(truth.GroundHeight(5.0, 2.0).value_or(-9), 0.0, 1e-9) << "the single-level query: the lowest";
  EXPECT_TRUE(truth.IsFootprintFreeNear(5.0, 2.0, 1.6, kRadius_m));
  EXPECT_FALSE(truth.GroundHeightNear(5.0, 2.0, 0.8).has_value())
      << "a body between floors stands on neither";
}

TEST(BodyTerrainTest, StartsAreFreeApartDeterministicAndNeverOnAPlatformOfTheirOwn) {
  auto world = Floor();
  Box(world.get(), 5.0, 7.0, 1.0, 3.0, 0.0, 0.5);  // a 0.5 m platform no wheeled body reaches
  const BodyTerrain truth(world, Wheeled());
  const auto starts = truth.SampleFreeStarts(6, 1.0, kRadius_m, 42);
  ASSERT_EQ(starts.size(), 6u);
  EXPECT_EQ(starts, truth.SampleFreeStarts(6, 1.0, kRadius_m, 42));
  for (std::size_t i = 0; i < starts.size(); ++i) {
    EXPECT_TRUE(truth.IsFootprintFree(starts[i].x(), starts[i].y(), kRadius_m));
    EXPECT_NEAR(starts[i].z(), 0.0, 1e-9) << "on the floor, not the platform";
    for (std::size_t j = 0; j < i; ++j) EXPECT_GE((starts[i] - starts[j]).head<2>().norm(), 1.0);
  }
  EXPECT_THROW(truth.SampleFreeStarts(-1, 1.0, kRadius_m, 1), std::invalid_argument);
  EXPECT_THROW(truth.SampleFreeStarts(1, NAN, kRadius_m, 1), std::invalid_argument);
}

TEST(BodyTerrainTest, BadOptionsAndANullWorldAreNamed) {
  try {
    [[maybe_unused]] const BodyTerrain terrain(Floor(), BodyOptions{0.15, 0.0});
    ADD_FAILURE() << "a zero body height was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("body.body_height_m = 0"), std::string::npos) << e.what();
  }
  EXPECT_THROW(BodyTerrain(nullptr, Wheeled()), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::sim
