// The simulated platform behind core::PlatformIO: what the autonomy gets (estimated pose, registered scans,
// frames), the driver watchdog, bad commands, and rockfalls.
#include "cairn/sim/simulated_platform.h"

#include <gtest/gtest.h>

#include <cmath>

#include "cairn/sim/platform_profile.h"
#include "cairn/sim/survey_scan.h"
#include "sparse_corridor.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

// A body on the floor (z = 0) at (x_m, y_m), by the platform's ground truth.
bool FreeOnTheFloor(const SimulatedPlatform& platform, double x_m, double y_m, double radius_m) {
  return platform.ground_truth()->IsFootprintFreeNear(x_m, y_m, 0.0, radius_m);
}

SimulatedPlatformOptions Arena() {
  SimulatedPlatformOptions o;
  o.world = "builtin:arena";
  o.start_W = core::PlanarPose{8.0, 11.0, 0.0};
  sim::ApplyPlatformProfile(nav::GetPlatformProfile("wheeled"), &o);
  return o;
}

TEST(SimulatedPlatformTest, DrivesOnCommandAndStopsWhenCommandsStop) {
  SimulatedPlatform platform(Arena());
  EXPECT_EQ(platform.Capabilities().driver, "sim");
  EXPECT_TRUE(platform.Capabilities().has_lidar);
  platform.Update(0.0);
  EXPECT_NEAR(platform.ReadPose().PlanarState().x_m, 8.0, 1e-9);  // the map frame starts at the true start
  for (int k = 1; k <= 100; ++k) {                                // 2 s at 0.5 m/s, a command every 20 ms
    platform.CommandTwist(0.5, 0.0, 0.02 * k);
    platform.Update(0.02 * k);
  }
  const double x_driving = platform.TrueState().x_m;
  EXPECT_GT(x_driving, 8.7);
  EXPECT_NEAR(platform.ReadPose().PlanarState().x_m, x_driving, 0.05);  // the estimate drifts, a little
  for (int k = 101; k <= 200; ++k) platform.Update(0.02 * k);           // commands stop: the watchdog brakes
  EXPECT_EQ(platform.TrueState().v_mps, 0.0);
  EXPECT_LT(platform.TrueState().x_m - x_driving, 0.5);
  const double x_stopped = platform.TrueState().x_m;
  for (int k = 201; k <= 300; ++k) {  // a non-finite command never moves the robot
    platform.CommandTwist(std::nan(""), std::nan(""), 0.02 * k);
    platform.Update(0.02 * k);
  }
  EXPECT_EQ(platform.TrueState().x_m, x_stopped);
}

TEST(SimulatedPlatformTest, ScansAreRegisteredAndARockfallIsSeenAndBlocks) {
  SimulatedPlatform platform(Arena());
  platform.Update(0.0);
  core::LidarScan scan;
  ASSERT_TRUE(platform.ReadLidarScan(0.0, &scan));
  EXPECT_FALSE(platform.ReadLidarScan(0.05, &scan)) << "a second scan before the lidar period";
  EXPECT_GT(scan.points_S.size(), 1000u);
  EXPECT_NEAR(scan.T_MS.translation().z() - scan.T_BS.translation().z(), 0.0, 1e-9);
  // A rock 1.5 m ahead: scans then hit it, and the ground truth blocks the base there.
  auto hits_near = [&](const core::LidarScan& s, double x, double y) {
    int n = 0;
    for (const auto& p_S : s.points_S) {
      const Eigen::Vector3d p_M = s.T_MS * p_S.cast<double>();
      n += std::abs(p_M.x() - x) < 0.3 && std::abs(p_M.y() - y) < 0.6 && p_M.z() > 0.05;
    }
    return n;
  };
  EXPECT_EQ(hits_near(scan, 9.5, 11.0), 0);
  core::CameraImage before;
  ASSERT_TRUE(platform.ReadCameraImage(0.0, &before));
  EXPECT_GT(
      platform.DropRock(Eigen::AlignedBox2d(Eigen::Vector2d(9.3, 10.5), Eigen::Vector2d(9.7, 11.5)), 0.6), 0);
  // The robot has not moved; its sensors (which reuse what a still sensor saw in an unchanged world) show
  // the rock at once, the camera exactly as a fresh render of the new world.
  ASSERT_TRUE(platform.ReadLidarScan(0.2, &scan));
  EXPECT_GT(hits_near(scan, 9.5, 11.0), 20);
  core::CameraImage after;
  ASSERT_TRUE(platform.ReadCameraImage(0.2, &after));
  SimulatedPlatform rendering_once(Arena());  // the same robot, its first frame rendered after the rock
  rendering_once.Update(0.0);
  rendering_once.DropRock(Eigen::AlignedBox2d(Eigen::Vector2d(9.3, 10.5), Eigen::Vector2d(9.7, 11.5)), 0.6);
  core::CameraImage fresh;
  ASSERT_TRUE(rendering_once.ReadCameraImage(0.2, &fresh));
  EXPECT_NE(after.pixels, before.pixels) << "the camera did not see the rock";
  EXPECT_EQ(after.pixels, fresh.pixels);
  EXPECT_EQ(after.seq, before.seq + 1);
  EXPECT_FALSE(FreeOnTheFloor(platform, 9.5, 11.0, 0.3));
}

TEST(SimulatedPlatformTest, RockfallClearTimeParsesAndErrorsNameTheField) {
  const auto rocks = ParseRockfalls("2:0,0,1,1,1:9.5; 3:0,0,1,1,1");
  ASSERT_EQ(rocks.size(), 2u);
  EXPECT_EQ(rocks[0].clear_s.value_or(-1.0), 9.5);
  EXPECT_FALSE(rocks[1].clear_s.has_value());
  const std::pair<std::string, std::string> cases[] = {
      {"5:0,0,1,1,1:3", "CLEAR_S = 3 must be > AT_S = 5"},
      {"5:0,0,1,1,1:soon", "CLEAR_S = 'soon' is not a number"},
      {"1:3,0,1,1,1", "X0 = 3 must be < X1 = 1"},
      {"1:0,0,1,1,0", "HEIGHT_M = 0 must be in (0, 10]"},
      {"-1:0,0,1,1,1", "AT_S = -1 must be >= 0"},
      {"1:0,b,1,1,1", "Y0 = 'b' is not a number"}};
  for (const auto& [bad, message] : cases) {
    try {
      ParseRockfalls(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

TEST(SimulatedPlatformTest, RockfallIsClearedAtItsClearTime) {
  SimulatedPlatformOptions options;
  options.world = "builtin:tunnels";
  options.start_W = PlanarPose{4.0, 20.0, 0.0};
  options.rockfalls = ParseRockfalls("1:9.3,19.5,9.7,20.5,0.6:3");
  SimulatedPlatform platform(options);
  const std::int64_t occupied = platform.world()->CountOccupied();
  platform.Update(0.5);
  EXPECT_TRUE(FreeOnTheFloor(platform, 9.5, 20.0, 0.3));
  platform.Update(1.0);
  EXPECT_FALSE(FreeOnTheFloor(platform, 9.5, 20.0, 0.3));
  EXPECT_GT(platform.world()->CountOccupied(), occupied);
  platform.Update(2.9);
  EXPECT_FALSE(FreeOnTheFloor(platform, 9.5, 20.0, 0.3));
  platform.Update(3.0);
  EXPECT_TRUE(FreeOnTheFloor(platform, 9.5, 20.0, 0.3));
  EXPECT_EQ(platform.world()->CountOccupied(), occupied);  // Exactly the rock's voxels freed, the floor kept.
}

// A proximity-triggered rock falls when the robot comes within its distance (not before, whatever the time)
// and is cleared a given time after it fell.
TEST(SimulatedPlatformTest, ARockfallTriggeredByTheRobotsApproachFallsThenClears) {
  SimulatedPlatformOptions options;
  options.world = "builtin:tunnels";
  options.start_W = PlanarPose{4.0, 20.0, 0.0};
  options.rockfalls = ParseRockfalls("near 1.5:7.0,19.5,7.4,20.5,0.6:+2");
  ASSERT_EQ(options.rockfalls.size(), 1u);
  SimulatedPlatform platform(options);
  const std::int64_t occupied = platform.world()->CountOccupied();
  double t_s = 0.0;
  platform.Update(t_s);
  EXPECT_TRUE(FreeOnTheFloor(platform, 7.2, 20.0, 0.3));
  platform.Update(t_s += 30.0);  // time alone does not drop it
  EXPECT_TRUE(FreeOnTheFloor(platform, 7.2, 20.0, 0.3));
  // Drive along +x at 0.5 m/s until the rock is there; it falls between 5.5 and 5.6 m (1.5 m from x = 7.0).
  double fell_at_x_m = 0.0;
  double fell_at_s = 0.0;
  while (t_s < 60.0) {
    platform.CommandTwist(0.5, 0.0, t_s);
    platform.Update(t_s += 0.05);
    if (!FreeOnTheFloor(platform, 7.2, 20.0, 0.3)) {
      fell_at_x_m = platform.TrueState().x_m;
      fell_at_s = t_s;
      break;
    }
  }
  EXPECT_NEAR(fell_at_x_m, 5.5, 0.08);
  EXPECT_GT(platform.world()->CountOccupied(), occupied);
  platform.CommandTwist(0.0, 0.0, t_s);
  platform.Update(fell_at_s + 1.9);
  EXPECT_FALSE(FreeOnTheFloor(platform, 7.2, 20.0, 0.3));
  platform.Update(fell_at_s + 2.0);
  EXPECT_TRUE(FreeOnTheFloor(platform, 7.2, 20.0, 0.3));
  EXPECT_EQ(platform.world()->CountOccupied(), occupied);
  EXPECT_FALSE(platform.ReadStatus().in_contact);
}

TEST(SimulatedPlatformTest, ProximityRockfallsParseOrNameTheField) {
  const auto rocks = ParseRockfalls("near2:0,0,1,1,1:+4; 3:0,0,1,1,1:+1; 1:0,0,1,1,1");
  ASSERT_EQ(rocks.size(), 3u);
  EXPECT_EQ(rocks[0].at_s, 1.0);  // time triggers first, by time
  EXPECT_EQ(rocks[1].clear_after_s.value_or(-1.0), 1.0);
  EXPECT_EQ(rocks[2].near_m.value_or(-1.0), 2.0);
  EXPECT_EQ(rocks[2].clear_after_s.value_or(-1.0), 4.0);
  EXPECT_FALSE(rocks[2].clear_s.has_value());
  const std::pair<std::string, std::string> cases[] = {
      {"near0:0,0,1,1,1", "R_M = 0 must be in (0, 100]"},
      {"nearby:0,0,1,1,1", "R_M = 'by' is not a number"},
      {"near1:0,0,1,1,1:9", "CLEAR_S = 9 with a near trigger"},
      {"near1:0,0,1,1,1:+0", "CLEAR = '+0': S must be > 0"},
      {"2:0,0,1,1,1:+soon", "CLEAR (+S) = 'soon' is not a number"},
      {"near1:0,0,1,1", "needs 5 numbers after WHEN (X0,Y0,X1,Y1,HEIGHT_M), has 4"}};
  for (const auto& [bad, message] : cases) {
    try {
      ParseRockfalls(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("simulation.rockfalls entry '" + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

TEST(SimulatedPlatformTest, RockfallsParseOrNameTheEntry) {
  const auto rocks = ParseRockfalls("8:1,2,3,4,0.5; 2:0,0,1,1,1");
  ASSERT_EQ(rocks.size(), 2u);
  EXPECT_EQ(rocks[0].at_s, 2.0);  // sorted by time
  EXPECT_EQ(rocks[1].area_W.max().y(), 4.0);
  for (const std::string bad : {"1,2,3,4,5", "1:1,2,3", "1:3,0,1,1,1", "1:0,0,1,1,0", "-1:0,0,1,1,1",
                                "1:a,0,1,1,1", "5:0,0,1,1,1:3", "5:0,0,1,1,1:x", "5:0,0,1,1,1:6:7"}) {
    try {
      ParseRockfalls(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("simulation.rockfalls entry '" + bad + "'"), std::string::npos)
          << e.what();
    }
  }
}

// The body moves on every level of the world: up the building's lower flight (1.0 m wide, one ground per
// column) onto the mid landing, whose columns also hold the floor 1.6 m below it (a 2.5D ground reads the
// landing's edge as a 1.4 m wall), and on along the landing, with no contact.
TEST(SimulatedPlatformTest, LeggedBodyClimbsOntoALandingOverTheFloorBelow) {
  SimulatedPlatformOptions o;
  o.world = "builtin:building";
  o.start_W = core::PlanarPose{19.0, 6.5, 0.0};
  sim::ApplyPlatformProfile(nav::GetPlatformProfile("legged"), &o);
  SimulatedPlatform platform(o);
  platform.Update(0.0);
  ASSERT_NEAR(platform.TrueState().z_m, 0.0, 1e-9);
  bool contact = false;
  double t = 0.0;
  while (t < 20.0 && platform.TrueState().x_m < 22.6) {
    t += 0.02;
    platform.CommandTwist(0.4, 0.0, t);
    platform.Update(t);
    contact = contact || platform.ReadStatus().in_contact;
  }
  EXPECT_FALSE(contact) << "contact at x " << platform.TrueState().x_m << ", z " << platform.TrueState().z_m;
  EXPECT_GE(platform.TrueState().x_m, 22.6);
  EXPECT_NEAR(platform.TrueState().z_m, 1.6, 1e-6) << "not on the landing";
}

// A wheeled body on a corridor from a sparse survey scan (.pcd, default load options) whose floor has a strip
// of missing returns, 9 m long and 0.5 m wide, 0.6 m from the south wall: the body stands anywhere the walls
// leave it room, over the strip and beside it (the platform's own check), and drives the strip's length
// beside it (its edge 0.35 m from the body centre, where a robot on such a scan was held in contact) and on
// it.
TEST(SimulatedPlatformTest, WheeledBodyDrivesAlongAStripOfMissingFloorReturns) {
  testing::SparseCorridorOptions corridor;
  corridor.strip_width_m = 0.5;
  const testing::SparseCorridorScan scan = testing::MakeSparseCorridorScan(corridor, 7);
  SimulatedPlatformOptions o;
  o.world = testing::MakeTempDir() + "/corridor.pcd";
  WritePcd(o.world, scan.points_W);
  o.start_W = core::PlanarPose{1.0, 2.0, 0.0};
  sim::ApplyPlatformProfile(nav::GetPlatformProfile("wheeled"), &o);
  SimulatedPlatform platform(o);
  const double r = o.footprint_radius_m;
  const std::shared_ptr<const BodyTerrain> terrain = platform.ground_truth();
  int blocked = 0;
  for (double x = 0.5; x <= corridor.length_m - 0.5; x += 0.1) {
    for (double y = 0.45; y <= corridor.width_m - 0.45; y += 0.1) {
      if (!terrain->IsFootprintFreeNear(x, y, 0.0, r) && blocked++ < 5) {
        ADD_FAILURE() << "body blocked at " << x << ", " << y;
      }
    }
  }
  EXPECT_EQ(blocked, 0);
  const double beside_y = scan.strip_W.max().y() + 0.35;
  double t = 0.0;
  platform.Update(t);
  for (const double y : {beside_y, scan.strip_W.center().y()}) {
    platform.SetTrueState(UnicycleState{scan.strip_W.min().x() - 1.0, y, 0.0});
    bool contact = false;
    for (int k = 0; k < 1000 && platform.TrueState().x_m < scan.strip_W.max().x() + 1.0; ++k) {
      t += 0.02;
      platform.CommandTwist(0.8, 0.0, t);
      platform.Update(t);
      contact = contact || platform.ReadStatus().in_contact;
    }
    EXPECT_FALSE(contact) << "y " << y << ": contact at x " << platform.TrueState().x_m;
    EXPECT_GE(platform.TrueState().x_m, scan.strip_W.max().x() + 1.0) << "y " << y;
    EXPECT_NEAR(platform.TrueState().y_m, y, 1e-9);
    EXPECT_NEAR(platform.TrueState().z_m, 0.0, 0.1 + 1e-9) << "y " << y;
  }
}

}  // namespace
}  // namespace cairn::sim
