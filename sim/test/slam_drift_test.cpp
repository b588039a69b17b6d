// Copyright Cairn authors.
#include "cairn/sim/slam_drift.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include "test_util.h"

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Isometry3d PlanarPose(double x_m, double y_m, double yaw_rad) {
  Eigen::Isometry3d T_W_B = Eigen::Isometry3d::Identity();
  T_W_B.translation() = Eigen::Vector3d(x_m, y_m, 0.3);
  T_W_B.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T_W_B;
}

// Drives `drift` along +x from x = 0 in steps of `step_m` and returns the horizontal position error (metres)
// at each distance in `checkpoints_m` (increasing multiples of step_m).
std::vector<double> DriveStraight(SlamDrift* drift, double step_m, const std::vector<double>& checkpoints_m) {
  std::vector<double> errors;
  drift->Update(PlanarPose(0.0, 0.0, 0.0));
  const int steps = static_cast<int>(std::lround(checkpoints_m.back() / step_m));
  std::size_t next = 0;
  for (int i = 1; i <= steps; ++i) {
    const Eigen::Isometry3d T_W_B = PlanarPose(i * step_m, 0.0, 0.0);
    const Eigen::Isometry3d T_W_B_est = drift->Update(T_W_B);
    if (next < checkpoints_m.size() && std::abs(i * step_m - checkpoints_m[next]) < 1e-9) {
      errors.push_back((T_W_B_est.translation() - T_W_B.translation()).head<2>().norm());
      ++next;
    }
  }
  return errors;
}

// Root mean square of the horizontal error at each checkpoint over `runs` seeds.
std::vector<double> RmsErrors(const SlamDriftOptions& options, int runs, double step_m,
                              const std::vector<double>& checkpoints_m) {
  std::vector<double> sum_sq(checkpoints_m.size(), 0.0);
  for (int seed = 1; seed <= runs; ++seed) {
    SlamDrift drift(options, static_cast<std::uint32_t>(seed));
    const std::vector<double> e = DriveStraight(&drift, step_m, checkpoints_m);
    for (std::size_t k = 0; k < e.size(); ++k) sum_sq[k] += e[k] * e[k];
  }
  for (double& v : sum_sq) v = std::sqrt(v / runs);
  return sum_sq;
}

TEST(SlamDriftOptionsTest, DefaultsAreValidAndInvalidFieldsAreNamed) {
  std::string why;
  EXPECT_TRUE(SlamDriftOptions{}.IsValid(&why)) << why;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (const char* field : {"position_drift_per_sqrt_m", "yaw_drift_rad_per_sqrt_m", "z_drift_per_sqrt_m",
                            "yaw_drift_rad_per_sqrt_rad"}) {
    for (const double bad : {-0.001, 2.0, nan}) {
      SlamDriftOptions options;
      const std::string name = field;
      if (name == "position_drift_per_sqrt_m") options.position_drift_per_sqrt_m = bad;
      if (name == "yaw_drift_rad_per_sqrt_m") options.yaw_drift_rad_per_sqrt_m = bad;
      if (name == "z_drift_per_sqrt_m") options.z_drift_per_sqrt_m = bad;
      if (name == "yaw_drift_rad_per_sqrt_rad") options.yaw_drift_rad_per_sqrt_rad = bad;
      EXPECT_FALSE(options.IsValid(&why)) << field << " = " << bad;
      EXPECT_CONTAINS(why, "::" + name + " = ");
      try {
        SlamDrift drift(options, 1);
        ADD_FAILURE() << "no throw for " << field;
      } catch (const std::invalid_argument& e) {
        EXPECT_CONTAINS(std::string(e.what()), name);
      }
    }
  }
}

TEST(SlamDriftTest, FirstUpdateIsExactAndRestDoesNotDrift) {
  SlamDrift drift(SlamDriftOptions{}, 3);
  const Eigen::Isometry3d start = PlanarPose(2.0, -1.0, 0.4);
  EXPECT_TRUE(drift.Estimate(start).isApprox(start, 1e-15));  // Before any update: identity drift.
  EXPECT_TRUE(drift.Update(start).isApprox(start, 1e-15));
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(drift.Update(start).isApprox(start, 1e-15));
  EXPECT_EQ(drift.distance_travelled_m(), 0.0);

  // Move 20 m, then stand still for a long time: the error stays what it was.
  for (int i = 1; i <= 200; ++i) drift.Update(PlanarPose(2.0 + 0.1 * i, -1.0, 0.4));
  const Eigen::Isometry3d end = PlanarPose(22.0, -1.0, 0.4);
  const Eigen::Isometry3d T_W_B_est = drift.Update(end);
  EXPECT_FALSE(T_W_B_est.isApprox(end, 1e-9));  // It did drift while moving.
  for (int i = 0; i < 1000; ++i) EXPECT_TRUE(drift.Update(end).isApprox(T_W_B_est, 1e-15));
  EXPECT_NEAR(drift.distance_travelled_m(), 20.0, 1e-9);
}

TEST(SlamDriftTest, DeterministicPerSeed) {
  SlamDrift a(SlamDriftOptions{}, 11);
  SlamDrift b(SlamDriftOptions{}, 11);
  SlamDrift c(SlamDriftOptions{}, 12);
  Eigen::Isometry3d est_a;
  Eigen::Isometry3d est_c;
  for (int i = 0; i <= 100; ++i) {
    const Eigen::Isometry3d T_W_B = PlanarPose(0.2 * i, 0.05 * i, 0.01 * i);
    est_a = a.Update(T_W_B);
    EXPECT_TRUE(est_a.isApprox(b.Update(T_W_B), 0.0));
    est_c = c.Update(T_W_B);
  }
  EXPECT_FALSE(est_a.isApprox(est_c, 1e-9));
}

TEST(SlamDriftTest, PositionErrorGrowsWithTheSquareRootOfDistanceNotWithTime) {
  SlamDriftOptions options;
  options.yaw_drift_rad_per_sqrt_m = 0.0;  // Pure position random walk: rms = p * sqrt(2 s).
  options.yaw_drift_rad_per_sqrt_rad = 0.0;
  options.position_drift_per_sqrt_m = 0.01;
  const std::vector<double> rms = RmsErrors(options, 400, 0.5, {25.0, 100.0});
  EXPECT_NEAR(rms[0], 0.01 * std::sqrt(2.0 * 25.0), 0.01 * std::sqrt(2.0 * 25.0) * 0.1);
  EXPECT_NEAR(rms[1], 0.01 * std::sqrt(2.0 * 100.0), 0.01 * std::sqrt(2.0 * 100.0) * 0.1);
  EXPECT_NEAR(rms[1] / rms[0], 2.0, 0.2);  // 4 x distance -> 2 x error.
  // Ten times more updates over the same path (a faster simulation rate) drift the same.
  const std::vector<double> fine = RmsErrors(options, 400, 0.05, {100.0});
  EXPECT_NEAR(fine[0] / rms[1], 1.0, 0.12);
}

TEST(SlamDriftTest, DefaultsDriftAsDocumentedOver100Metres) {
  const SlamDriftOptions options;
  const std::vector<double> rms = RmsErrors(options, 300, 0.5, {10.0, 100.0});
  const auto documented = [&](double s) {
    const double p = options.position_drift_per_sqrt_m;
    const double y = options.yaw_drift_rad_per_sqrt_m;
    return std::sqrt(2.0 * p * p * s + y * y * s * s * s / 3.0);
  };
  EXPECT_NEAR(rms[0], documented(10.0), documented(10.0) * 0.15);
  EXPECT_NEAR(rms[1], documented(100.0), documented(100.0) * 0.15);
  // 0.1 - 0.5 % of the distance, typical of lidar-inertial odometry.
  EXPECT_GT(rms[1], 0.1);
  EXPECT_LT(rms[1], 0.5);
}

TEST(SlamDriftTest, EstimateIsLocallyConsistent) {
  // After 100 m the absolute error is decimetres, but one metre of motion is still measured to millimetres.
  int large_absolute = 0;
  for (int seed = 1; seed <= 20; ++seed) {
    SlamDrift drift(SlamDriftOptions{}, static_cast<std::uint32_t>(seed));
    Eigen::Isometry3d est_prev;
    Eigen::Isometry3d true_prev;
    for (int i = 0; i <= 1010; ++i) {
      // A wiggly path: the heading changes along the way.
      const double s = 0.1 * i;
      const Eigen::Isometry3d T_W_B = PlanarPose(s, 2.0 * std::sin(0.1 * s), 0.2 * std::cos(0.1 * s));
      const Eigen::Isometry3d T_W_B_est = drift.Update(T_W_B);
      if (i == 1000) {
        est_prev = T_W_B_est;
        true_prev = T_W_B;
      }
      if (i == 1010) {
        const Eigen::Isometry3d rel_est = est_prev.inverse() * T_W_B_est;
        const Eigen::Isometry3d rel_true = true_prev.inverse() * T_W_B;
        EXPECT_LT((rel_est.translation() - rel_true.translation()).norm(), 0.02) << "seed " << seed;
        if ((T_W_B_est.translation() - T_W_B.translation()).norm() > 0.05) ++large_absolute;
      }
    }
  }
  EXPECT_GE(large_absolute, 10);
}

TEST(SlamDriftTest, TurningInPlaceDriftsTheHeadingOnly) {
  SlamDriftOptions options;
  options.yaw_drift_rad_per_sqrt_rad = 0.01;
  SlamDrift drift(options, 5);
  const Eigen::Isometry3d start = PlanarPose(5.0, 3.0, 0.0);
  drift.Update(start);
  Eigen::Isometry3d T_W_B_est = start;
  for (int i = 1; i <= 400; ++i) T_W_B_est = drift.Update(PlanarPose(5.0, 3.0, 0.05 * i));
  EXPECT_EQ(drift.distance_travelled_m(), 0.0);
  EXPECT_NEAR(drift.yaw_turned_rad(), 20.0, 1e-9);
  EXPECT_TRUE(T_W_B_est.translation().isApprox(start.translation(), 1e-12));
  const double yaw_error =
      std::remainder(std::atan2(T_W_B_est.linear()(1, 0), T_W_B_est.linear()(0, 0)) - 0.05 * 400, 2.0 * kPi);
  EXPECT_GT(std::abs(yaw_error), 1e-4);  // rms 0.01 * sqrt(20) = 0.045 rad; a 1e-4 draw is unlikely.
  EXPECT_THROW(drift.Update(PlanarPose(std::nan(""), 0.0, 0.0)), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::sim
