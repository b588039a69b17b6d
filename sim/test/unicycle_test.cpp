// Copyright Cairn authors.
#include "cairn/sim/unicycle.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "test_util.h"

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Flat ground at z = 0 with a raised floor (z = 0.1) for x in [5, 6) and a wall filling x >= 2 for
// y in [-1, 1]; the ground is unknown for y >= 50.
class FakeTerrain : public FootprintChecker {
 public:
  bool IsFootprintFree(double x_m, double y_m, double radius_m) const override {
    ++checks;
    const bool wall_band = y_m + radius_m > -1.0 && y_m - radius_m < 1.0;
    return !(wall_band && x_m + radius_m >= 2.0);
  }
  std::optional<double> GroundHeight(double x_m, double y_m) const override {
    if (y_m >= 50.0) return std::nullopt;
    return (x_m >= 5.0 && x_m < 6.0) ? 0.1 : 0.0;
  }
  mutable int checks = 0;
};

TEST(UnicycleLimitsTest, PresetsAreValid) {
  std::string why;
  EXPECT_TRUE(UnicycleLimits{}.IsValid(&why)) << why;
  EXPECT_TRUE(UnicycleLimits::Wheeled().IsValid(&why)) << why;
  const UnicycleLimits legged = UnicycleLimits::Legged();
  EXPECT_TRUE(legged.IsValid(&why)) << why;
  EXPECT_LT(legged.max_speed_mps, UnicycleLimits::Wheeled().max_speed_mps);
  EXPECT_LT(legged.max_yaw_rate_radps, UnicycleLimits::Wheeled().max_yaw_rate_radps);
}

TEST(UnicycleLimitsTest, InvalidFieldIsNamed) {
  UnicycleLimits limits;
  limits.max_accel_mps2 = -1.0;
  std::string why;
  EXPECT_FALSE(limits.IsValid(&why));
  EXPECT_CONTAINS(why, "VelocityLimits::max_accel_mps2 = -1 must be finite and in (0, 50]");
  limits = UnicycleLimits{};
  limits.max_yaw_rate_radps = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(limits.IsValid(&why));
  EXPECT_CONTAINS(why, "max_yaw_rate_radps");
  EXPECT_THROW(Unicycle robot(limits), std::invalid_argument);
  EXPECT_THROW(Unicycle robot(UnicycleLimits{}, -0.1), std::invalid_argument);
}

TEST(UnicycleTest, RespectsSpeedAndAccelerationLimits) {
  FakeTerrain terrain;
  UnicycleState start;
  start.y_m = 10.0;  // Away from the wall.
  Unicycle robot(UnicycleLimits{}, 0.25, start);
  UnicycleStepResult r = robot.Step(5.0, 9.0, 0.1, terrain);
  EXPECT_TRUE(r.command_clamped);
  EXPECT_FALSE(r.contact);
  EXPECT_NEAR(robot.state().v_mps, 0.1, 1e-12);    // 1 m/s^2 * 0.1 s.
  EXPECT_NEAR(robot.state().w_radps, 0.3, 1e-12);  // 3 rad/s^2 * 0.1 s.
  for (int i = 0; i < 50; ++i) robot.Step(5.0, 9.0, 0.1, terrain);
  EXPECT_NEAR(robot.state().v_mps, 1.0, 1e-12);    // max_speed_mps.
  EXPECT_NEAR(robot.state().w_radps, 1.5, 1e-12);  // max_yaw_rate_radps.
  for (int i = 0; i < 50; ++i) robot.Step(-5.0, 0.0, 0.1, terrain);
  EXPECT_NEAR(robot.state().v_mps, -0.5, 1e-12);  // max_reverse_speed_mps.
  EXPECT_NEAR(robot.state().w_radps, 0.0, 1e-12);
}

TEST(UnicycleTest, IntegratesStraightAndTurning) {
  FakeTerrain terrain;
  UnicycleState start;
  start.x_m = -10.0;
  start.v_mps = 0.5;
  start.yaw_rad = kPi / 2;
  Unicycle robot(UnicycleLimits{}, 0.25, start);
  for (int i = 0; i < 20; ++i) robot.Step(0.5, 0.0, 0.05, terrain);
  EXPECT_NEAR(robot.state().x_m, -10.0, 1e-9);
  EXPECT_NEAR(robot.state().y_m, 0.5, 1e-9);  // 0.5 m/s for 1 s, north.
  // Turning in place: yaw changes, position does not.
  Unicycle spinner(UnicycleLimits{}, 0.25, UnicycleState{});
  for (int i = 0; i < 100; ++i) spinner.Step(0.0, 1.0, 0.05, terrain);
  EXPECT_NEAR(spinner.state().x_m, 0.0, 1e-12);
  EXPECT_NEAR(spinner.state().y_m, 0.0, 1e-12);
  EXPECT_GT(std::abs(spinner.state().yaw_rad), 0.5);
  EXPECT_LE(std::abs(spinner.state().yaw_rad), kPi);
}

TEST(UnicycleTest, StopsAtWallWithContact) {
  FakeTerrain terrain;
  Unicycle robot(UnicycleLimits{}, 0.25, UnicycleState{});
  bool contact = false;
  for (int i = 0; i < 200; ++i) {
    const UnicycleStepResult r = robot.Step(1.0, 0.0, 0.05, terrain);
    if (r.contact) {
      contact = true;
      EXPECT_EQ(robot.state().v_mps, 0.0);
    }
    ASSERT_LT(robot.state().x_m + 0.25, 2.0) << "footprint entered the wall at step " << i;
  }
  EXPECT_TRUE(contact);
  EXPECT_GT(robot.state().x_m, 1.6);  // Got close to the wall before stopping.
  // Turning in place at the wall is allowed and reports no contact.
  const UnicycleStepResult turn = robot.Step(0.0, 1.0, 0.05, terrain);
  EXPECT_FALSE(turn.contact);
}

TEST(UnicycleTest, NonFiniteCommandMeansNoMotion) {
  FakeTerrain terrain;
  Unicycle robot(UnicycleLimits{}, 0.25, UnicycleState{});
  for (const double bad : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    const UnicycleStepResult r = robot.Step(bad, bad, 0.1, terrain);
    EXPECT_TRUE(r.command_non_finite);
    EXPECT_EQ(robot.state().x_m, 0.0);
    EXPECT_EQ(robot.state().y_m, 0.0);
    EXPECT_EQ(robot.state().yaw_rad, 0.0);
    EXPECT_EQ(robot.state().v_mps, 0.0);
  }
  EXPECT_THROW(robot.Step(0.1, 0.0, 0.0, terrain), std::invalid_argument);
  EXPECT_THROW(robot.Step(0.1, 0.0, std::nan(""), terrain), std::invalid_argument);
}

TEST(UnicycleTest, ZFollowsGround) {
  FakeTerrain terrain;
  UnicycleState start;
  start.x_m = 4.0;
  start.y_m = 10.0;
  Unicycle robot(UnicycleLimits{}, 0.25, start);
  while (robot.state().x_m < 5.5) robot.Step(1.0, 0.0, 0.05, terrain);
  EXPECT_DOUBLE_EQ(robot.state().z_m, 0.1);
  while (robot.state().x_m < 6.5) robot.Step(1.0, 0.0, 0.05, terrain);
  EXPECT_DOUBLE_EQ(robot.state().z_m, 0.0);
  // Unknown ground keeps the last height.
  UnicycleState north = robot.state();
  north.x_m = 5.5;
  north.y_m = 49.9;
  north.yaw_rad = kPi / 2;
  north.z_m = 0.1;
  robot.set_state(north);
  for (int i = 0; i < 10; ++i) robot.Step(1.0, 0.0, 0.05, terrain);
  EXPECT_GT(robot.state().y_m, 50.0);
  EXPECT_DOUBLE_EQ(robot.state().z_m, 0.1);
}

TEST(UnicycleTest, LongStepsAreCheckedAlongTheWay) {
  // One 1 s step at 1 m/s is checked every <= 0.05 m (20 checks), so thin walls are not tunnelled through.
  FakeTerrain terrain;
  UnicycleState start;
  start.y_m = 10.0;
  start.v_mps = 1.0;
  Unicycle robot(UnicycleLimits{}, 0.25, start);
  robot.Step(1.0, 0.0, 1.0, terrain);
  EXPECT_EQ(terrain.checks, 20);
}

TEST(WrapAngleTest, WrapsToHalfOpenInterval) {
  EXPECT_NEAR(WrapAngle(3 * kPi / 2), -kPi / 2, 1e-12);
  EXPECT_NEAR(WrapAngle(-kPi), kPi, 1e-12);
  EXPECT_NEAR(WrapAngle(kPi), kPi, 1e-12);
  EXPECT_NEAR(WrapAngle(0.25), 0.25, 1e-12);
}

}  // namespace
}  // namespace cairn::sim
