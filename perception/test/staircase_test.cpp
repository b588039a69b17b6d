// Copyright Cairn authors.
//
// Staircase detection on simulated lidar scans (cairn::sim::SimulatedLidar) accumulated in a LocalCloud, as
// the robot agent does: the staircase of builtin:tunnels seen from its foot (straight and at 30 deg) and from
// its top, a rotated narrow staircase; no staircase in stair-free stretches of builtin:tunnels and of the
// real scan geb079.bt, on the 0.1 m plate of builtin:arena, a ramp, a curb, a two-step podium and a table;
// sparse, noisy scans of one or two steps before a cabinet (no staircase) and of three (a staircase); bad
// input; the local cloud's bounds; registry merging. Prints FIGURE lines (errors, detection times).
#include "cairn/perception/staircase.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/build_paths.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"
#include "cairn/sim/survey_scan.h"
#include "cairn/sim/world.h"

namespace cairn::perception {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Sensor pose on the robot: position (metres, frame W), heading (radians about +z of W) and pitch (radians,
// positive looking down).
struct SensorPose {
  double x_m, y_m, z_m, yaw_rad, pitch_rad = 0.0;
};

Eigen::Isometry3d ToIsometry(const SensorPose& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(p.x_m, p.y_m, p.z_m);
  T.linear() = (Eigen::AngleAxisd(p.yaw_rad, Eigen::Vector3d::UnitZ()) *
                Eigen::AngleAxisd(p.pitch_rad, Eigen::Vector3d::UnitY()))
                   .toRotationMatrix();
  return T;
}

// Scans `world` with a VLP-16-like SimulatedLidar (1 cm range noise) from each true pose (one scan every
// 0.5 s) and feeds each scan to `cloud` with the pose as SLAM would give it: the true pose plus a seeded
// random-walk drift (3 mm and 0.05 deg of yaw per scan in each axis). Returns the last true sensor position.
Eigen::Vector3d AccumulateScans(const sim::World& world, const std::vector<SensorPose>& poses,
                                std::uint32_t seed, LocalCloud* cloud) {
  sim::SimulatedLidar lidar(sim::LidarOptions{}, seed);
  std::mt19937 rng(seed);
  std::normal_distribution<double> step_m(0.0, 0.003), step_yaw_rad(0.0, 0.05 * kDeg);
  sim::LidarScan scan;
  double stamp_s = 100.0;
  SensorPose drift{0.0, 0.0, 0.0, 0.0};
  for (const SensorPose& pose : poses) {
    lidar.Scan(world, ToIsometry(pose), &scan);
    drift.x_m += step_m(rng);
    drift.y_m += step_m(rng);
    drift.z_m += step_m(rng);
    drift.yaw_rad += step_yaw_rad(rng);
    SensorPose slam = pose;
    slam.x_m += drift.x_m;
    slam.y_m += drift.y_m;
    slam.z_m += drift.z_m;
    slam.yaw_rad += drift.yaw_rad;
    cloud->AddScan(scan.points_S, ToIsometry(slam), stamp_s);
    stamp_s += 0.5;
  }
  return Eigen::Vector3d(poses.back().x_m, poses.back().y_m, poses.back().z_m);
}

// Poses from (x0, y0) to (x1, y1), `n` of them, heading along the segment, sensor at `z_m` pitched down by
// `pitch_rad`.
std::vector<SensorPose> Line(double x0, double y0, double x1, double y1, int n, double z_m = 0.5,
                             double pitch_rad = 0.0) {
  std::vector<SensorPose> poses;
  const double yaw = std::atan2(y1 - y0, x1 - x0);
  for (int i = 0; i < n; ++i) {
    const double a = n == 1 ? 1.0 : static_cast<double>(i) / (n - 1);
    poses.push_back({x0 + a * (x1 - x0), y0 + a * (y1 - y0), z_m, yaw, pitch_rad});
  }
  return poses;
}

double AngleError(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * kPi)); }

const sim::World& Tunnels() {
  static const sim::World* world = new sim::World(sim::MakeBuiltinWorld("tunnels"));
  return *world;
}

// Ground truth of the builtin:tunnels staircase: risers at x = 50, 50.5, ..., 52 (0.2 m rise, 0.5 m run),
// from the open drop-off at y = 22.5 to the rough room wall. The width is measured on the World: for every
// column x in [50, 52.5) the run of free columns (free at z = 1.5 m, above the steps) from y = 22.5 on.
struct StairsTruth {
  double width_m = 0;
  double centre_y_m = 0;
};

StairsTruth TunnelsStairsTruth() {
  const sim::World& w = Tunnels();
  const double res = w.resolution_m();
  double sum = 0;
  int n = 0;
  for (double x = 50.0 + 0.5 * res; x < 52.5; x += res) {
    double y = 22.5 + 0.5 * res;
    while (!w.IsOccupied(Eigen::Vector3d(x, y, 1.5)) && y < 26.0) y += res;
    sum += (y - 0.5 * res) - 22.5;
    ++n;
  }
  StairsTruth t;
  t.width_m = sum / n;
  t.centre_y_m = 22.5 + 0.5 * t.width_m;
  return t;
}

void PrintFigure(const char* name, const Staircase& s, const StairsTruth& truth, const DetectStats& stats) {
  std::printf(
      "FIGURE %s rise_err_m %.4f run_err_m %.4f width_err_m %.4f first_step_err_m %.4f yaw_err_deg %.2f "
      "num_steps %d confidence %.2f points %lld detect_ms %.2f (filter %.2f projection %.2f fit %.2f)\n",
      name, s.rise_m - 0.2, s.run_m - 0.5, s.width_m - truth.width_m,
      (s.p_W_first_step - Eigen::Vector3d(50.0, truth.centre_y_m, 0.0)).norm(),
      AngleError(s.yaw_rad, 0.0) / kDeg, s.num_steps, s.confidence, static_cast<long long>(stats.points_in),
      stats.total_ms, stats.filter_ms, stats.projection_ms, stats.fit_ms);
}

void ExpectTunnelsStairs(const std::vector<Staircase>& found, const StairsTruth& truth) {
  ASSERT_EQ(found.size(), 1u);
  const Staircase& s = found[0];
  EXPECT_EQ(s.num_steps, 5);
  EXPECT_NEAR(s.rise_m, 0.2, 0.01);
  EXPECT_NEAR(s.run_m, 0.5, 0.01);
  EXPECT_NEAR(s.width_m, truth.width_m, 0.05);
  EXPECT_NEAR(s.p_W_first_step.x(), 50.0, 0.02);
  EXPECT_NEAR(s.p_W_first_step.y(), truth.centre_y_m, 0.05);
  EXPECT_NEAR(s.p_W_first_step.z(), 0.0, 0.01);
  EXPECT_LT(AngleError(s.yaw_rad, 0.0), 1.0 * kDeg);
  EXPECT_GT(s.confidence, 0.3);
  EXPECT_LE(s.confidence, 1.0);
  EXPECT_GT(s.support_points, 500);
}

// ---- Options ---------------------------------------------------------------------------------------------

TEST(StaircaseOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(StaircaseDetectorOptions{}.IsValid(&why)) << why;
  EXPECT_TRUE(LocalCloudOptions{}.IsValid(&why)) << why;
  EXPECT_TRUE(StaircaseRegistryOptions{}.IsValid(&why)) << why;
}

TEST(StaircaseOptionsTest, InvalidOptionsNameTheField) {
  std::string why;
  StaircaseDetectorOptions o;
  o.min_rise_m = 0.3;  // Above max_rise_m.
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("min_rise_m = 0.3"), std::string::npos) << why;
  EXPECT_THROW(StaircaseDetector{o}, std::invalid_argument);
  o = StaircaseDetectorOptions{};
  o.fit_voxel_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("fit_voxel_m = nan"), std::string::npos) << why;
  o = StaircaseDetectorOptions{};
  o.min_risers = 2;  // Two steps are no staircase.
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("min_risers = 2"), std::string::npos) << why;
  o = StaircaseDetectorOptions{};
  o.riser_rise_tolerance_m = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("riser_rise_tolerance_m = 0"), std::string::npos) << why;
  EXPECT_FALSE(o.IsValid(nullptr));

  LocalCloudOptions l;
  l.window_s = 0.0;
  EXPECT_FALSE(l.IsValid(&why));
  EXPECT_NE(why.find("LocalCloudOptions::window_s = 0"), std::string::npos) << why;
  EXPECT_THROW(LocalCloud{l}, std::invalid_argument);

  StaircaseRegistryOptions r;
  r.min_overlap_fraction = 1.5;
  EXPECT_FALSE(r.IsValid(&why));
  EXPECT_NE(why.find("min_overlap_fraction = 1.5"), std::string::npos) << why;
  EXPECT_THROW(StaircaseRegistry{r}, std::invalid_argument);
}

// ---- Bad input -------------------------------------------------------------------------------------------

TEST(StaircaseDetectorTest, EmptyAndNonFiniteCloudsGiveNoDetection) {
  const StaircaseDetector detector;
  DetectStats stats;
  EXPECT_TRUE(detector.Detect({}, Eigen::Vector3d(0, 0, 0.5), &stats).empty());
  EXPECT_EQ(stats.points_in, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<Eigen::Vector3f> all_nan(1000, Eigen::Vector3f(nan, nan, nan));
  EXPECT_TRUE(detector.Detect(all_nan, Eigen::Vector3d(0, 0, 0.5), &stats).empty());
  EXPECT_EQ(stats.points_non_finite, 1000);
  EXPECT_EQ(stats.points_filtered, 0);
  std::vector<Eigen::Vector3f> mixed;
  for (int i = 0; i < 3000; ++i) {
    const int row = i / 100;  // A floor patch, 1 cm grid, 100 points a row.
    mixed.emplace_back(0.01f * static_cast<float>(i % 100), 0.01f * static_cast<float>(row), 0.0f);
    if (i % 3 == 0) mixed.emplace_back(nan, 1.0f, 0.0f);
    if (i % 5 == 0) mixed.emplace_back(1.0f, -inf, 0.0f);
  }
  EXPECT_TRUE(detector.Detect(mixed, Eigen::Vector3d(0, 0, 0.5), &stats).empty());
  EXPECT_EQ(stats.points_non_finite, 1000 + 600);
  EXPECT_EQ(stats.points_cropped, 3000);
  // A non-finite robot position: nothing to crop around.
  EXPECT_TRUE(detector.Detect(mixed, Eigen::Vector3d(nan, 0, 0), nullptr).empty());
}

// ---- The staircase of builtin:tunnels ---------------------------------------------------------------------

class TunnelsStairsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { truth_ = TunnelsStairsTruth(); }
  static StairsTruth truth_;
  const StaircaseDetector detector_;
};
StairsTruth TunnelsStairsTest::truth_;

TEST_F(TunnelsStairsTest, TruthIsSane) {
  EXPECT_GT(truth_.width_m, 2.2);
  EXPECT_LT(truth_.width_m, 2.5);
}

TEST_F(TunnelsStairsTest, StraightApproach) {
  LocalCloud cloud;
  const Eigen::Vector3d p = AccumulateScans(Tunnels(), Line(46.5, 23.5, 49.0, 23.5, 6), 11, &cloud);
  DetectStats stats;
  const std::vector<Staircase> found = detector_.Detect(cloud.Points(), p, &stats);
  ExpectTunnelsStairs(found, truth_);
  if (!found.empty()) PrintFigure("stairs_straight", found[0], truth_, stats);
}

TEST_F(TunnelsStairsTest, ApproachAtThirtyDegrees) {
  LocalCloud cloud;
  const double yaw = 30.0 * kDeg;
  const Eigen::Vector3d p = AccumulateScans(
      Tunnels(), Line(46.8, 21.5, 46.8 + 2.6 * std::cos(yaw), 21.5 + 2.6 * std::sin(yaw), 6), 12, &cloud);
  DetectStats stats;
  const std::vector<Staircase> found = detector_.Detect(cloud.Points(), p, &stats);
  ExpectTunnelsStairs(found, truth_);
  if (!found.empty()) PrintFigure("stairs_yaw30", found[0], truth_, stats);
}

// Driving past 3.5 m from the foot (heading +y, the stairs to the right): the lidar's beams, 2 deg apart,
// pass over one riser between two they hit, so no edge blob marks it. The flight is still found (the chain
// seeds across the unobserved riser, whose points the fit then finds), with its true rise and run.
TEST_F(TunnelsStairsTest, ARiserBetweenTwoBeamsDoesNotHideTheFlight) {
  LocalCloud cloud;
  const Eigen::Vector3d p = AccumulateScans(Tunnels(), Line(46.5, 22.25, 46.5, 23.75, 4), 13, &cloud);
  DetectStats stats;
  const std::vector<Staircase> found = detector_.Detect(cloud.Points(), p, &stats);
  ASSERT_EQ(found.size(), 1u) << "rejections: " << ::testing::PrintToString(stats.rejections);
  const Staircase& s = found[0];
  EXPECT_GE(s.num_steps, 3);
  EXPECT_NEAR(s.rise_m, 0.2, 0.01);
  EXPECT_NEAR(s.run_m, 0.5, 0.01);
  EXPECT_NEAR(s.p_W_first_step.x(), 50.0, 0.03);
  EXPECT_NEAR(s.p_W_first_step.z(), 0.0, 0.02);
  EXPECT_LT(AngleError(s.yaw_rad, 0.0), 2.0 * kDeg);
  PrintFigure("stairs_riser_between_beams", s, truth_, stats);
}

// Seen from the 1 m platform, walking towards the top of the stairs (-x). A level VLP-16 sees nothing of
// stairs going down (their 22 deg slope is steeper than its lowest beam, -15 deg): as on a legged robot about
// to descend, the sensor is pitched 30 deg down.
std::vector<SensorPose> TopApproach() { return Line(54.0, 23.7, 52.6, 23.7, 5, 1.5, 30.0 * kDeg); }

TEST_F(TunnelsStairsTest, SeenFromTheTopIsDescribedAscending) {
  LocalCloud cloud;
  const Eigen::Vector3d p = AccumulateScans(Tunnels(), TopApproach(), 13, &cloud);
  DetectStats stats;
  const std::vector<Staircase> found = detector_.Detect(cloud.Points(), p, &stats);
  ASSERT_EQ(found.size(), 1u) << stats.last_rejection;
  const Staircase& s = found[0];
  PrintFigure("stairs_from_top", s, truth_, stats);
  EXPECT_EQ(s.num_steps, 5);
  EXPECT_LT(AngleError(s.yaw_rad, 0.0), 2.0 * kDeg);
  EXPECT_NEAR(s.rise_m, 0.2, 0.015);
  EXPECT_NEAR(s.run_m, 0.5, 0.02);
  EXPECT_NEAR(s.p_W_first_step.x(), 50.0, 0.05);
  EXPECT_NEAR(s.p_W_first_step.z(), 0.0, 0.02);
  EXPECT_NEAR(s.width_m, truth_.width_m,
              0.2);  // The pitched beams reach the far sides of the lower treads only partly.
}

// Another staircase, not axis-aligned, on a 2 cm voxel floor: 7 steps of 0.18 m rise and 0.28 m run, 1.2 m
// wide, ascending towards yaw 45 deg from (4, 4), then a 1 m landing; open on both sides.
TEST(StaircaseDetectorTest, RotatedNarrowStaircase) {
  constexpr double kRes = 0.02, kRise = 0.18, kRun = 0.28, kWidth = 1.2, kYaw = 45.0 * kDeg;
  constexpr int kSteps = 7;
  sim::World world("rotated_stairs", Eigen::Vector3d(0.0, 0.0, -0.1), kRes, Eigen::Vector3i(400, 400, 75));
  const Eigen::Vector2d origin(4.0, 4.0), u(std::cos(kYaw), std::sin(kYaw)), v(-u.y(), u.x());
  for (int ix = 0; ix < world.dims().x(); ++ix) {
    for (int iy = 0; iy < world.dims().y(); ++iy) {
      const Eigen::Vector2d d = world.CenterOf({ix, iy, 0}).head<2>() - origin;
      const double s = u.dot(d);
      double top = 0.0;
      if (std::abs(v.dot(d)) <= 0.5 * kWidth && s >= 0.0 && s < kSteps * kRun + 1.0) {
        top = s < kSteps * kRun ? kRise * (std::floor(s / kRun) + 1.0) : kSteps * kRise;
      }
      for (int iz = 0; iz < world.dims().z() && world.CenterOf({ix, iy, iz}).z() < top; ++iz) {
        world.SetOccupied({ix, iy, iz});
      }
    }
  }
  std::vector<SensorPose> poses;
  for (int i = 0; i < 6; ++i) {  // From 4 m to 2 m before the first riser, 0.2 m off its centre line.
    const Eigen::Vector2d p = origin - (4.0 - 0.4 * i) * u + 0.2 * v;
    poses.push_back({p.x(), p.y(), 0.5, kYaw});
  }
  LocalCloud cloud;
  const Eigen::Vector3d p = AccumulateScans(world, poses, 31, &cloud);
  DetectStats stats;
  const std::vector<Staircase> found = StaircaseDetector().Detect(cloud.Points(), p, &stats);
  ASSERT_EQ(found.size(), 1u) << stats.last_rejection;
  const Staircase& s = found[0];
  std::printf(
      "FIGURE stairs_rotated45 rise_err_m %.4f run_err_m %.4f width_err_m %.4f first_step_err_m %.4f "
      "yaw_err_deg %.2f num_steps %d detect_ms %.2f\n",
      s.rise_m - kRise, s.run_m - kRun, s.width_m - kWidth,
      (s.p_W_first_step - Eigen::Vector3d(4.0, 4.0, 0.0)).norm(), AngleError(s.yaw_rad, kYaw) / kDeg,
      s.num_steps, stats.total_ms);
  EXPECT_EQ(s.num_steps, kSteps);
  EXPECT_NEAR(s.rise_m, kRise, 0.01);
  EXPECT_NEAR(s.run_m, kRun, 0.01);
  EXPECT_NEAR(s.width_m, kWidth, 0.05);
  EXPECT_LT((s.p_W_first_step - Eigen::Vector3d(4.0, 4.0, 0.0)).norm(), 0.03);
  EXPECT_LT(AngleError(s.yaw_rad, kYaw), 1.0 * kDeg);
}

// ---- No staircase -----------------------------------------------------------------------------------------

// Accumulates scans along each stretch and expects no detection; prints the slowest detection.
void ExpectNoStairs(const sim::World& world, const std::vector<std::vector<SensorPose>>& stretches,
                    const char* figure) {
  const StaircaseDetector detector;
  double worst_ms = 0;
  std::uint32_t seed = 100;
  for (const std::vector<SensorPose>& stretch : stretches) {
    LocalCloud cloud;
    const Eigen::Vector3d p = AccumulateScans(world, stretch, ++seed, &cloud);
    DetectStats stats;
    const std::vector<Staircase> found = detector.Detect(cloud.Points(), p, &stats);
    worst_ms = std::max(worst_ms, stats.total_ms);
    EXPECT_TRUE(found.empty()) << "false staircase near (" << p.x() << ", " << p.y()
                               << "): " << found[0].num_steps << " steps, rise " << found[0].rise_m
                               << ", run " << found[0].run_m << ", at ("
                               << found[0].p_W_first_step.transpose() << ")";
    EXPECT_GT(stats.points_filtered, 1000) << "nothing seen at (" << p.x() << ", " << p.y() << ")";
  }
  std::printf("FIGURE %s stretches %zu false_detections checked, worst_detect_ms %.2f\n", figure,
              stretches.size(), worst_ms);
}

TEST(StaircaseFalsePositiveTest, TunnelsWithoutStairs) {
  ExpectNoStairs(Tunnels(),
                 {Line(8.0, 20.0, 11.0, 20.0, 4),    // Straight tunnel.
                  Line(27.0, 20.0, 30.0, 20.0, 4),   // Into the X junction.
                  Line(30.0, 14.0, 30.0, 17.5, 4),   // X junction from the south.
                  Line(30.0, 8.0, 30.0, 5.0, 4),     // Into the south L bend.
                  Line(30.0, 32.0, 29.0, 35.0, 4),   // North L bend.
                  Line(43.0, 20.0, 47.0, 18.0, 4)},  // Into the room, away from the stairs.
                 "tunnels_no_stairs");
}

TEST(StaircaseFalsePositiveTest, ArenaPlateIsNotAStaircase) {
  const sim::World arena = sim::MakeBuiltinWorld("arena");
  ExpectNoStairs(arena,
                 {Line(1.0, 3.5, 2.5, 3.5, 4), Line(4.5, 7.0, 4.5, 5.6, 4), Line(7.5, 1.0, 6.4, 2.0, 4)},
                 "arena_plate_no_stairs");
}

// An open floor (no walls) at 2 cm voxels with things that are not staircases: a 15 deg ramp up to 0.8 m, a
// 0.15 m curb, a podium of two 0.15 m steps and a table (0.75 m top on four legs).
sim::World MakeClutterWorld() {
  constexpr double kRes = 0.02;
  sim::World world("clutter", Eigen::Vector3d(0.0, 0.0, -0.1), kRes, Eigen::Vector3i(400, 300, 100));
  auto fill = [&world](double x0, double x1, double y0, double y1, double z0, double z1) {
    for (double x = x0 + 0.5 * kRes; x < x1; x += kRes) {
      for (double y = y0 + 0.5 * kRes; y < y1; y += kRes) {
        for (double z = z0 + 0.5 * kRes; z < z1; z += kRes) world.SetOccupiedAt(Eigen::Vector3d(x, y, z));
      }
    }
  };
  fill(0.0, 8.0, 0.0, 6.0, -0.1, 0.0);        // Floor, surface at z = 0.
  for (double x = 3.0; x < 6.0; x += kRes) {  // Ramp along +x, 1.5 m wide.
    fill(x, x + kRes, 0.5, 2.0, 0.0, (x + 0.5 * kRes - 3.0) * std::tan(15.0 * kDeg));
  }
  fill(3.0, 3.2, 3.5, 5.5, 0.0, 0.15);  // Curb.
  fill(5.0, 5.8, 3.5, 5.0, 0.0, 0.15);  // Podium: two steps.
  fill(5.4, 5.8, 3.5, 5.0, 0.15, 0.30);
  fill(4.0, 5.0, 2.3, 2.9, 0.72, 0.76);  // Table top and legs.
  for (double lx : {4.0, 4.96}) {
    for (double ly : {2.3, 2.86}) fill(lx, lx + 0.04, ly, ly + 0.04, 0.0, 0.72);
  }
  return world;
}

TEST(StaircaseFalsePositiveTest, RampCurbPodiumAndTableAreNotStaircases) {
  const sim::World world = MakeClutterWorld();
  ExpectNoStairs(world,
                 {Line(0.8, 3.0, 2.3, 3.0, 4), Line(1.5, 1.2, 2.5, 1.2, 4), Line(7.5, 4.2, 6.5, 4.2, 4)},
                 "clutter_no_stairs");
}

std::string Geb079Path() { return cairn::core::SourceDir() + "/data/geb079.bt"; }

TEST(StaircaseFalsePositiveTest, Geb079CorridorWithoutStairs) {
  const std::string path = Geb079Path();
  if (!std::ifstream(path).good()) {
    GTEST_SKIP() << "real scan " << path << " is absent (it ships in data/)";
  }
  const sim::World world = sim::LoadWorld(path);
  // The corridor runs along x at y ~ 0 with its floor surface at z = 0 (see nav/test/geb079_nav_test.cpp).
  // Stretches of 1.5 m every 3 m, alternating directions, on free floor cells (floor voxel below, free
  // above).
  auto free_floor = [&world](double x, double y) {
    return world.IsOccupied(Eigen::Vector3d(x, y, -0.04)) && !world.IsOccupied(Eigen::Vector3d(x, y, 0.3)) &&
           !world.IsOccupied(Eigen::Vector3d(x, y, 1.0));
  };
  std::vector<std::vector<SensorPose>> stretches;
  for (double x = -4.0; x <= 24.0; x += 3.0) {
    double y = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < 24 && std::isnan(y); ++i) {  // y = 0, 0.08, -0.08, 0.16, ...
      const int k = (i + 1) / 2;                     // 0, 1, 1, 2, 2, ...
      const double candidate = (i % 2 == 0 ? 1.0 : -1.0) * 0.08 * k;
      if (free_floor(x, candidate) && free_floor(x + 1.5, candidate)) y = candidate;
    }
    ASSERT_FALSE(std::isnan(y)) << "no free floor near x = " << x;
    const bool east = static_cast<int>(std::lround(x / 3.0)) % 2 == 0;
    stretches.push_back(east ? Line(x, y, x + 1.5, y, 4) : Line(x + 1.5, y, x, y, 4));
  }
  ExpectNoStairs(world, stretches, "geb079_no_stairs");
}

// ---- Walls, crates, flights seen side-on; 0.25 m runs -------------------------------------
// Scenes at 1 cm voxels: an 8 x 8 m floor (surface z = 0) and what stands on it. bench/staircase_accuracy.cpp
// scores the same kinds of scene over many views.

// Fills the voxels whose centres lie over the rectangle [s0, s1) x [t0, t1) of the frame at `origin` rotated
// by `yaw_rad`, from z = 0 (or `z0`) up to top(s).
void FillPrism(sim::World* w, const Eigen::Vector2d& origin, double yaw_rad, double s0, double s1, double t0,
               double t1, const std::function<double(double)>& top, double z0 = -0.05) {
  const Eigen::Vector2d u(std::cos(yaw_rad), std::sin(yaw_rad)), v(-u.y(), u.x());
  for (int ix = 0; ix < w->dims().x(); ++ix) {
    for (int iy = 0; iy < w->dims().y(); ++iy) {
      const Eigen::Vector2d d = w->CenterOf({ix, iy, 0}).head<2>() - origin;
      const double s = u.dot(d), t = v.dot(d);
      if (s < s0 || s >= s1 || t < t0 || t >= t1) continue;
      for (int iz = 0; iz < w->dims().z() && w->CenterOf({ix, iy, iz}).z() < top(s); ++iz) {
        if (w->CenterOf({ix, iy, iz}).z() >= z0) w->SetOccupied({ix, iy, iz});
      }
    }
  }
}

sim::World FloorScene(const char* name) {
  sim::World w(name, Eigen::Vector3d(0.0, 0.0, -0.05), 0.01, Eigen::Vector3i(800, 800, 250));
  FillPrism(&w, {0.0, 0.0}, 0.0, 0.0, 8.0, 0.0, 8.0, [](double) { return 0.0; });
  return w;
}

// A flight of 8 steps (run 0.25 m) and a 1 m landing from `foot` towards `yaw_rad`, solid to the floor,
// optionally between two 0.1 m walls 1 m above the nosing line.
void AddFlight(sim::World* w, const Eigen::Vector2d& foot, double yaw_rad, double rise_m, double width_m,
               bool walls) {
  constexpr double kRun = 0.25, kLen = 8 * kRun;
  FillPrism(w, foot, yaw_rad, 0.0, kLen + 1.0, -0.5 * width_m, 0.5 * width_m,
            [rise_m](double s) { return rise_m * (s < kLen ? std::floor(s / kRun) + 1.0 : 8.0); });
  if (!walls) return;
  for (double t0 : {0.5 * width_m, -0.5 * width_m - 0.1}) {
    FillPrism(w, foot, yaw_rad, 0.0, kLen + 1.0, t0, t0 + 0.1,
              [rise_m](double s) { return 1.0 + rise_m * std::min(s, 8 * 0.25) / 0.25; });
  }
}

// Detections from a 1.5 m drive (4 scans, true poses) ending at `end` heading `yaw_rad`.
std::vector<Staircase> DetectAfterDrive(const sim::World& world, const Eigen::Vector2d& end, double yaw_rad,
                                        std::uint32_t seed, DetectStats* stats) {
  const Eigen::Vector2d start = end - 1.5 * Eigen::Vector2d(std::cos(yaw_rad), std::sin(yaw_rad));
  LocalCloud cloud;
  sim::SimulatedLidar lidar(sim::LidarOptions{}, seed);
  sim::LidarScan scan;
  const std::vector<SensorPose> poses = Line(start.x(), start.y(), end.x(), end.y(), 4);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    lidar.Scan(world, ToIsometry(poses[i]), &scan);
    cloud.AddScan(scan.points_S, ToIsometry(poses[i]), 0.5 * static_cast<double>(i));
  }
  return StaircaseDetector().Detect(cloud.Points(), Eigen::Vector3d(end.x(), end.y(), 0.5), stats);
}

TEST(StaircaseRejectionTest, WallIsNotAStaircase) {
  sim::World world = FloorScene("wall");
  FillPrism(&world, {5.0, 2.0}, 0.5 * kPi, 0.0, 4.0, -0.2, 0.0, [](double) { return 2.5; });  // x in [5, 5.2]
  std::uint32_t seed = 1;
  for (double d : {1.5, 2.5}) {
    for (double a : {0.0, 30.0 * kDeg}) {
      const Eigen::Vector2d end = Eigen::Vector2d(5.0, 4.0) - d * Eigen::Vector2d(std::cos(a), std::sin(a));
      DetectStats stats;
      EXPECT_TRUE(DetectAfterDrive(world, end, a, ++seed, &stats).empty()) << "wall from " << end.transpose();
      EXPECT_GT(stats.edge_cells, 0);  // The wall's foot and the floor give edge cells, never a chain.
    }
  }
}

// A pallet (1.2 x 1.0 m, 0.15 m high) with a 0.8 m cube set back on it: two edges 0.15 m and 0.8 m high, a
// single 0.45 m crate beside: no three risers of one rise.
TEST(StaircaseRejectionTest, CratesAreNotAStaircase) {
  sim::World world = FloorScene("crates");
  FillPrism(&world, {5.0, 3.0}, 0.0, 0.0, 1.0, 0.0, 1.2, [](double) { return 0.15; });
  FillPrism(&world, {5.1, 3.2}, 0.0, 0.1, 0.9, 0.0, 0.8, [](double) { return 0.95; });
  FillPrism(&world, {5.0, 5.0}, 0.0, 0.0, 0.4, 0.0, 0.6, [](double) { return 0.45; });
  std::uint32_t seed = 10;
  for (double d : {1.5, 2.5}) {
    for (double a : {0.0, -30.0 * kDeg}) {
      const Eigen::Vector2d end = Eigen::Vector2d(5.0, 3.6) - d * Eigen::Vector2d(std::cos(a), std::sin(a));
      DetectStats stats;
      EXPECT_TRUE(DetectAfterDrive(world, end, a, ++seed, &stats).empty())
          << "crates from " << end.transpose();
    }
  }
}

// A real flight seen side-on (the lidar looks across its run, at its sawtooth side): it is either found with
// its own ascending direction, at its own risers, or not at all; never a staircase along the viewing ray,
// never one of its parts described with wrong heights.
TEST(StaircaseRejectionTest, FlightSeenSideOnIsNeverAStaircaseAlongTheRay) {
  constexpr double kRise = 0.18;
  sim::World world = FloorScene("side_on");
  AddFlight(&world, {2.5, 4.0}, 0.0, kRise, 1.2, false);
  std::uint32_t seed = 20;
  int views = 0;
  for (int side : {1, -1}) {
    for (double along : {3.0, 3.5, 4.0}) {
      for (double d : {1.5, 2.5}) {
        const Eigen::Vector2d end(along, 4.0 + side * (0.6 + d));
        const std::vector<Staircase> found = DetectAfterDrive(world, end, -side * 0.5 * kPi, ++seed, nullptr);
        ++views;
        ASSERT_LE(found.size(), 1u) << "one flight, several staircases, from " << end.transpose();
        for (const Staircase& s : found) {
          EXPECT_LT(AngleError(s.yaw_rad, 0.0), 10.0 * kDeg) << "wrong axis from " << end.transpose();
          const double k = std::round((s.p_W_first_step.x() - 2.5) / 0.25);
          EXPECT_NEAR(s.p_W_first_step.x(), 2.5 + 0.25 * k, 0.1) << end.transpose();
          EXPECT_NEAR(s.p_W_first_step.z(), kRise * k, 0.05) << end.transpose();
          EXPECT_NEAR(s.rise_m, kRise, 0.02) << end.transpose();
        }
      }
    }
  }
  EXPECT_EQ(views, 12);
}

// Run error on 0.25 m runs (target <= 2 cm): flights of rise 0.17-0.20 m between walls, straight and at
// 30 deg, approached from 1.5 m and 2.5 m; one detection per flight.
TEST(StaircaseDetectorTest, QuarterMetreRunsWithinTwoCentimetres) {
  std::uint32_t seed = 40;
  double worst_run_err = 0.0;
  for (const auto& [rise, yaw] : {std::pair<double, double>{0.17, 0.0}, {0.19, 30.0 * kDeg}, {0.20, 0.0}}) {
    sim::World world = FloorScene("quarter_runs");
    const Eigen::Vector2d foot(3.0, 3.0), u(std::cos(yaw), std::sin(yaw));
    AddFlight(&world, foot, yaw, rise, 1.0, true);
    for (double d : {1.5, 2.5}) {
      DetectStats stats;
      const std::vector<Staircase> found = DetectAfterDrive(world, foot - d * u, yaw, ++seed, &stats);
      ASSERT_EQ(found.size(), 1u) << "rise " << rise << " from " << d << " m: " << stats.last_rejection;
      const Staircase& s = found[0];
      worst_run_err = std::max(worst_run_err, std::abs(s.run_m - 0.25));
      EXPECT_NEAR(s.run_m, 0.25, 0.02) << "rise " << rise << " from " << d << " m";
      EXPECT_NEAR(s.rise_m, rise, 0.01) << "rise " << rise << " from " << d << " m";
      EXPECT_LT(AngleError(s.yaw_rad, yaw), 2.0 * kDeg);
      EXPECT_LT((s.p_W_first_step.head<2>() - foot).norm(), 0.05);
    }
  }
  std::printf("FIGURE stairs_quarter_runs worst_run_err_m %.4f\n", worst_run_err);
}

// A 2 m wide flight split along its axis by a wall (a dividing wall or a solid balustrade down the middle of
// a public stairway, 1 m above the nosing line): the wall stands inside the step edges' lateral extent and
// lends the fit points at every tread height and riser position; left out of the fit (lateral bins with more
// points a rise above the treads than on them), it does not bend the run or the rise.
TEST(StaircaseDetectorTest, AWallDownTheMiddleOfAFlightDoesNotBendTheFit) {
  constexpr double kRise = 0.19;
  sim::World world = FloorScene("divided");
  const Eigen::Vector2d foot(3.0, 4.0);
  AddFlight(&world, foot, 0.0, kRise, 2.0, false);
  FillPrism(&world, foot, 0.0, 0.0, 8 * 0.25 + 1.0, -0.05, 0.05,
            [](double s) { return 1.0 + kRise * std::min(s, 8 * 0.25) / 0.25; });
  std::uint32_t seed = 60;
  int found_views = 0;
  double worst_run_err = 0.0, worst_rise_err = 0.0;
  for (double a : {0.0, 15.0 * kDeg, -15.0 * kDeg, 30.0 * kDeg, -30.0 * kDeg}) {
    for (double d : {1.5, 2.5}) {
      const Eigen::Vector2d end = foot - d * Eigen::Vector2d(std::cos(a), std::sin(a));
      DetectStats stats;
      const std::vector<Staircase> found = DetectAfterDrive(world, end, a, ++seed, &stats);
      ASSERT_LE(found.size(), 2u) << "from " << end.transpose();  // one per half at most
      for (const Staircase& s : found) {
        ++found_views;
        worst_run_err = std::max(worst_run_err, std::abs(s.run_m - 0.25));
        worst_rise_err = std::max(worst_rise_err, std::abs(s.rise_m - kRise));
        EXPECT_NEAR(s.run_m, 0.25, 0.01) << "from " << end.transpose();
        EXPECT_NEAR(s.rise_m, kRise, 0.01) << "from " << end.transpose();
      }
    }
  }
  EXPECT_GE(found_views, 8);
  std::printf("FIGURE stairs_divided_flight detections %d worst_run_err_m %.4f worst_rise_err_m %.4f\n",
              found_views, worst_run_err, worst_rise_err);
}

// ---- Sparse, noisy scans: one step with clutter is no staircase ------------------------------------------
// A low-resolution scan of a building (a survey scan, a far or sparse lidar) sampled directly from boxes
// standing on a floor, fed to the detector as it is, or loaded as a world (as `--world FILE.pcd` does) and
// scanned by the robot's lidar.

// An axis-aligned box, corners in metres, frame W.
struct Box {
  Eigen::Vector3d lo, hi;
};

// A site scanned sparsely: boxes on the floor z = 0 (x in [-4, 6], y in [-3, 3]), and how they are sampled.
struct SparseSite {
  std::vector<Box> boxes;
  double density_per_m2 = 200.0;  // Points per m^2 of every surface.
  double noise_m = 0.015;         // Gaussian noise on each axis, metres.
  int strays = 30;                // Points uniformly in the volume up to 2 m (dust, reflections, people).
  double z_offset_m = 0.0;        // Height of the floor in the scan's frame, metres (the floor of a real scan
                                  // is at no particular place in the loader's 0.1 m voxels).
  std::uint32_t seed = 1;
};

// The points of `site`, metres, frame W: uniformly at density_per_m2 (a Poisson count per face) over the
// floor and every face of every box but its bottom, except where another box covers the face (the point moved
// 1 mm out of its face lies inside another box); each moved by the noise; then the strays; all raised by
// z_offset_m. Seeded: the same site gives the same points (one draw per statement, in a fixed order).
std::vector<Eigen::Vector3f> SparseScan(const SparseSite& site) {
  std::mt19937 rng(site.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, site.noise_m);
  std::vector<Eigen::Vector3f> points;
  auto covered = [&site](const Eigen::Vector3d& p) {
    return std::any_of(site.boxes.begin(), site.boxes.end(), [&p](const Box& b) {
      return (p.array() > b.lo.array()).all() && (p.array() < b.hi.array()).all();
    });
  };
  const Eigen::Vector3d up(0.0, 0.0, site.z_offset_m);
  // The face spanned by `a` and `b` from `corner`, outward normal `n`.
  auto face = [&](const Eigen::Vector3d& corner, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                  const Eigen::Vector3d& n) {
    std::poisson_distribution<int> count(site.density_per_m2 * a.norm() * b.norm());
    for (int i = count(rng); i > 0; --i) {
      const double along_b = unit(rng);
      const double along_a = unit(rng);
      const Eigen::Vector3d p = corner + along_a * a + along_b * b;
      if (covered(p + 0.001 * n)) continue;
      Eigen::Vector3d e;
      for (int axis = 2; axis >= 0; --axis) e[axis] = noise(rng);
      points.emplace_back((p + up + e).cast<float>());
    }
  };
  const Eigen::Vector3d x = Eigen::Vector3d::UnitX(), y = Eigen::Vector3d::UnitY(),
                        z = Eigen::Vector3d::UnitZ();
  face({-4.0, -3.0, 0.0}, 10.0 * x, 6.0 * y, z);
  for (const Box& b : site.boxes) {
    const Eigen::Vector3d d = b.hi - b.lo;
    face({b.lo.x(), b.lo.y(), b.hi.z()}, d.x() * x, d.y() * y, z);  // Top.
    face(b.lo, d.y() * y, d.z() * z, -x);
    face({b.hi.x(), b.lo.y(), b.lo.z()}, d.y() * y, d.z() * z, x);
    face(b.lo, d.x() * x, d.z() * z, -y);
    face({b.lo.x(), b.hi.y(), b.lo.z()}, d.x() * x, d.z() * z, y);
  }
  for (int i = 0; i < site.strays; ++i) {
    Eigen::Vector3d p;
    for (int axis = 2; axis >= 0; --axis) p[axis] = unit(rng);
    points.emplace_back(
        (Eigen::Vector3d(-4.0 + 10.0 * p.x(), -3.0 + 6.0 * p.y(), 2.0 * p.z()) + up).cast<float>());
  }
  return points;
}

// Steps of `rise_m` and `run_m` ascending along +x from x = x0_m across y in [-width_m / 2, width_m / 2], one
// box per step (the last one `top_depth_m` deep), then a 1.8 m tall cabinet box (`cabinet_width_m` wide,
// `cabinet_depth_m` deep) right behind them; with `walls`, a 2.5 m wall behind the cabinet and along both
// sides (y = +-3 m).
std::vector<Box> StepsBeforeACabinet(int steps, double rise_m, double run_m, double top_depth_m,
                                     double width_m = 1.6, double cabinet_width_m = 1.2,
                                     double cabinet_depth_m = 0.6, bool walls = false, double x0_m = 2.0) {
  std::vector<Box> boxes;
  double x = x0_m;
  for (int k = 0; k < steps; ++k) {
    const double depth = k + 1 == steps ? top_depth_m : run_m;
    boxes.push_back({{x, -0.5 * width_m, 0.0}, {x + depth, 0.5 * width_m, (k + 1) * rise_m}});
    x += depth;
  }
  boxes.push_back({{x, -0.5 * cabinet_width_m, 0.0}, {x + cabinet_depth_m, 0.5 * cabinet_width_m, 1.8}});
  x += cabinet_depth_m;
  if (walls) {
    boxes.push_back({{x, -3.0, 0.0}, {x + 0.2, 3.0, 2.5}});
    boxes.push_back({{-4.0, -3.0, 0.0}, {x, -2.8, 2.5}});
    boxes.push_back({{-4.0, 2.8, 0.0}, {x, 3.0, 2.5}});
  }
  return boxes;
}

// The world a low-resolution scan of a site gives: `points` written as a PCD and loaded at 0.1 m with the
// loader's default clean-up, as a user's scan is.
sim::World LoadScan(const std::vector<Eigen::Vector3f>& points) {
  char pattern[] = "/tmp/cairn_staircase_test_XXXXXX";
  const char* dir = ::mkdtemp(pattern);
  EXPECT_NE(dir, nullptr);
  const std::string path = std::string(dir != nullptr ? dir : "/tmp") + "/scan.pcd";
  sim::WritePcd(path, points);
  sim::World world = sim::LoadWorld(path);
  std::remove(path.c_str());
  if (dir != nullptr) ::rmdir(dir);
  return world;
}

// Every detection while driving from `start` to `end` (sensor 0.5 m up, heading along the drive) as the
// robot's perception pipeline sees it: a scan every 0.1 s at 0.5 m/s into a LocalCloud, the detector every
// second and at the end, at the base's position (on the floor, z = 0).
std::vector<Staircase> DetectWhileDriving(const sim::World& world, const Eigen::Vector2d& start,
                                          const Eigen::Vector2d& end, std::uint32_t seed) {
  LocalCloud cloud;
  sim::SimulatedLidar lidar(sim::LidarOptions{}, seed);
  sim::LidarScan scan;
  const int n = std::max(2, static_cast<int>((end - start).norm() / 0.05) + 1);
  const std::vector<SensorPose> poses = Line(start.x(), start.y(), end.x(), end.y(), n);
  const StaircaseDetector detector;
  std::vector<Staircase> found;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    lidar.Scan(world, ToIsometry(poses[i]), &scan);
    cloud.AddScan(scan.points_S, ToIsometry(poses[i]), 0.1 * static_cast<double>(i));
    if (i % 10 != 9 && i + 1 != poses.size()) continue;
    const std::vector<Staircase> now = detector.Detect(cloud.Points(), {poses[i].x_m, poses[i].y_m, 0.0});
    found.insert(found.end(), now.begin(), now.end());
  }
  return found;
}

std::string Describe(const std::vector<Staircase>& found) {
  std::string out;
  for (const Staircase& s : found) {
    char line[160];
    std::snprintf(line, sizeof line, "[%d steps, rise %.3f m, run %.3f m, confidence %.2f at (%.2f, %.2f)] ",
                  s.num_steps, s.rise_m, s.run_m, s.confidence, s.p_W_first_step.x(), s.p_W_first_step.y());
    out += line;
  }
  return out;
}

// Sparse scans of `boxes` (densities 100 and 300 points/m^2, noise 1 and 2 cm (only 1 cm with
// `one_cm_noise`), the floor at each of `floor_heights_m` in the scan's frame, 100 strays), each loaded as a
// world and driven up to from 1.5 and 2.5 m before x = 2, heading +x and +-30 deg (DetectAfterDrive()). Calls
// `check` with each view's detections and a description of it.
void ForEachLoadedSparseScan(
    const std::vector<Box>& boxes, const std::vector<double>& floor_heights_m, bool one_cm_noise,
    std::uint32_t seed, const std::function<void(const std::vector<Staircase>&, const std::string&)>& check) {
  for (double density : {100.0, 300.0}) {
    for (double noise_m : {0.01, 0.02}) {
      if (one_cm_noise && noise_m > 0.01) continue;
      for (double z_offset_m : floor_heights_m) {
        const sim::World world = LoadScan(SparseScan({boxes, density, noise_m, 100, z_offset_m, ++seed}));
        for (double d : {1.5, 2.5}) {
          for (double a : {0.0, 30.0 * kDeg, -30.0 * kDeg}) {
            const Eigen::Vector2d end =
                Eigen::Vector2d(2.0, 0.0) - d * Eigen::Vector2d(std::cos(a), std::sin(a));
            char view[160];
            std::snprintf(view, sizeof view,
                          "density %.0f /m^2, noise %.2f m, floor at %.3f m, seed %u, from (%.2f, %.2f)",
                          density, noise_m, z_offset_m, seed, end.x(), end.y());
            check(DetectAfterDrive(world, end, a, seed, nullptr), view);
          }
        }
      }
    }
  }
}

// A 0.15 m platform, 0.6 to 1.2 m deep, in front of a 1.8 m cabinet: one riser, then a tall face. Whatever
// terraces the loader's 0.1 m voxels and the sparse points make of it, it is no flight of risers. The first
// two scenes were found by sweeping the ranges of the field report (platform 0.13-0.17 m high, 0.6-1.2 m
// deep, 100-300 points/m^2, 1-2 cm noise, 30-300 strays; seeded) and are kept exact, since their points
// depend on every digit: before risers were counted where the points show them, the detector reported 4 steps
// of 0.10-0.11 m rise in each.
TEST(StaircaseSparseScanTest, OnePlatformBeforeACabinetIsNotAStaircase) {
  {  // Loaded as a world, seen while driving up to it at 34 deg.
    SparseSite site{StepsBeforeACabinet(1, 0.14900377274298679, 0.0, 0.80773490230990508, 1.0632768303433302,
                                        1.0632768303433302, 0.69146272171901901),
                    206.66118640418665,
                    0.011440279962110295,
                    255,
                    0.061679547310589333,
                    30093};
    const double a = 0.59882584809887685;
    const Eigen::Vector2d dir(std::cos(a), std::sin(a));
    const Eigen::Vector2d end = Eigen::Vector2d(2.0, 0.12189558287417929) - 0.93519554264768268 * dir;
    const std::vector<Staircase> found =
        DetectWhileDriving(LoadScan(SparseScan(site)), end - 2.0 * dir, end, 931);
    EXPECT_TRUE(found.empty()) << "loaded scan: " << Describe(found);
  }
  {  // The points as they are, in a room, the detector 3 m away at -16 deg.
    SparseSite site{StepsBeforeACabinet(1, 0.14940743192551142, 0.0, 0.80156474746628403, 1.5066494378285902,
                                        1.5066494378285902, 0.47603866188303923, true),
                    230.05590335585714,
                    0.018529456664019648,
                    75,
                    0.04587051355719475,
                    134234};
    const double d = 2.9889178670059664, a = -0.27916914275656934;
    const Eigen::Vector3d p(2.0 - d * std::cos(a), -d * std::sin(a), site.z_offset_m + 0.5);
    DetectStats stats;
    const std::vector<Staircase> found = StaircaseDetector().Detect(SparseScan(site), p, &stats);
    EXPECT_TRUE(found.empty()) << "points: " << Describe(found);
    EXPECT_GE(stats.chains_fitted, 1);  // The chain is still formed; its risers are what is counted now.
  }
  std::uint32_t seed = 200;
  for (double depth_m : {0.6, 0.9, 1.2}) {
    ForEachLoadedSparseScan(StepsBeforeACabinet(1, 0.15, 0.0, depth_m), {0.0, 0.05}, false, seed += 100,
                            [&](const std::vector<Staircase>& found, const std::string& scan) {
                              EXPECT_TRUE(found.empty())
                                  << "platform " << depth_m << " m deep, " << scan << ": " << Describe(found);
                            });
  }
}

// Two risers of one rise (a two-step podium before a cabinet) are still no staircase: as points, and loaded
// with its surfaces inside the loader's 0.1 m voxels (floor 2.5 cm up, risers 5 cm into a voxel), so that the
// world keeps two risers. (A surface a voxel boundary cuts reads as a patchwork of two heights 0.1 m apart
// whose edges are 0.1 m steps of their own: the loaded world then has three risers.)
TEST(StaircaseSparseScanTest, TwoStepsBeforeACabinetAreNotAStaircase) {
  std::uint32_t seed = 600;
  for (double depth_m : {0.6, 1.2}) {
    ForEachLoadedSparseScan(StepsBeforeACabinet(2, 0.15, 0.3, depth_m, 1.6, 1.2, 0.6, false, 2.05), {0.025},
                            true, seed += 100,
                            [&](const std::vector<Staircase>& found, const std::string& scan) {
                              EXPECT_TRUE(found.empty()) << "two steps, top " << depth_m << " m deep, "
                                                         << scan << ": " << Describe(found);
                            });
  }
  for (std::uint32_t k = 0; k < 20; ++k) {  // The points as they are, from 1-3 m at up to 30 deg.
    const SparseSite site{StepsBeforeACabinet(2, 0.15, 0.3, 0.6 + 0.03 * k, 1.6, 1.2, 0.6, k % 2 == 0),
                          100.0 + 10.0 * k,
                          0.01 + 0.0005 * k,
                          30 + 10 * static_cast<int>(k),
                          0.0,
                          900 + k};
    const double d = 1.0 + 0.1 * k, a = (static_cast<double>(k % 5) - 2.0) * 15.0 * kDeg;
    const std::vector<Staircase> found =
        StaircaseDetector().Detect(SparseScan(site), {2.0 - d * std::cos(a), -d * std::sin(a), 0.5});
    EXPECT_TRUE(found.empty()) << "two steps, points " << k << ": " << Describe(found);
  }
}

// Three risers of one rise (0.18 m rise, 0.3 m run, 1.2 m wide, a 1 m landing, then a 1.8 m cabinet) in a
// 1 cm world, seen by the lidar (1 cm range noise) from 1.0 and 1.5 m at 0 and +-30 deg: a staircase of three
// steps with that rise and run in every view. (From 2.5 m the beams leave too few step edges on so short a
// flight to chain: it is found closer.)
TEST(StaircaseSparseScanTest, ThreeRisersBeforeACabinetAreAStaircase) {
  constexpr double kRise = 0.18, kRun = 0.3;
  sim::World world = FloorScene("three_risers");
  const Eigen::Vector2d foot(3.0, 4.0);
  FillPrism(&world, foot, 0.0, 0.0, 3 * kRun + 1.0, -0.6, 0.6,
            [](double s) { return kRise * std::min(std::floor(s / kRun) + 1.0, 3.0); });
  FillPrism(&world, foot, 0.0, 3 * kRun + 1.0, 3 * kRun + 1.6, -0.6, 0.6, [](double) { return 1.8; });
  std::uint32_t seed = 70;
  for (double d : {1.0, 1.5}) {
    for (double a : {0.0, 30.0 * kDeg, -30.0 * kDeg}) {
      const Eigen::Vector2d end = foot - d * Eigen::Vector2d(std::cos(a), std::sin(a));
      DetectStats stats;
      const std::vector<Staircase> found = DetectAfterDrive(world, end, a, ++seed, &stats);
      EXPECT_EQ(found.size(), 1u) << "from " << end.transpose() << ": " << Describe(found) << " rejections "
                                  << ::testing::PrintToString(stats.rejections);
      if (found.empty()) continue;
      const Staircase& s = found[0];
      EXPECT_EQ(s.num_steps, 3) << "from " << end.transpose();
      EXPECT_NEAR(s.rise_m, kRise, 0.01) << "from " << end.transpose();
      EXPECT_NEAR(s.run_m, kRun, 0.02) << "from " << end.transpose();
      EXPECT_LT((s.p_W_first_step - Eigen::Vector3d(foot.x(), foot.y(), 0.0)).norm(), 0.05);
      EXPECT_LT(AngleError(s.yaw_rad, 0.0), 2.0 * kDeg);
    }
  }
}

// ---- LocalCloud ------------------------------------------------------------------------------------------

TEST(LocalCloudTest, DeduplicatesAndStaysBounded) {
  LocalCloudOptions o;
  o.voxel_size_m = 0.025;
  o.radius_m = 8.0;
  o.window_s = 3.0;
  LocalCloud cloud(o);
  sim::SimulatedLidar lidar(sim::LidarOptions{}, 5);
  sim::LidarScan scan;
  std::size_t first = 0;
  double worst_ms = 0;
  for (int i = 0; i < 12; ++i) {  // The same pose 12 times: same surfaces, no growth beyond noise.
    lidar.Scan(Tunnels(), ToIsometry({10.0, 20.0, 0.5, 0.0}), &scan);
    const auto t0 = std::chrono::steady_clock::now();
    cloud.AddScan(scan.points_S, ToIsometry({10.0, 20.0, 0.5, 0.0}), 0.1 * i);
    worst_ms = std::max(
        worst_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (i == 0) first = cloud.size();
  }
  EXPECT_GT(first, 5000u);
  EXPECT_LT(cloud.size(), first * 2);  // Range noise spills into neighbouring voxels, nothing more.
  for (const Eigen::Vector3f& p : cloud.Points()) {
    EXPECT_LE((p.cast<double>() - Eigen::Vector3d(10.0, 20.0, 0.5)).norm(), 8.0 + 0.05);
  }
  EXPECT_EQ(cloud.p_W_latest_sensor(), Eigen::Vector3d(10.0, 20.0, 0.5));
  const std::size_t static_size = cloud.size();
  // Driving 20 m down the tunnel at 10 m/s (a scan per metre): only the last 8 m are kept.
  std::size_t largest = 0;
  for (int i = 1; i <= 20; ++i) {
    const Eigen::Isometry3d T_W_S = ToIsometry({10.0 + i, 20.0, 0.5, 0.0});
    lidar.Scan(Tunnels(), T_W_S, &scan);
    const auto t0 = std::chrono::steady_clock::now();
    cloud.AddScan(scan.points_S, T_W_S, 1.1 + 0.1 * i);
    worst_ms = std::max(
        worst_ms, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    largest = std::max(largest, cloud.size());
  }
  for (const Eigen::Vector3f& p : cloud.Points()) {
    EXPECT_LE((p.cast<double>() - Eigen::Vector3d(30.0, 20.0, 0.5)).norm(), 8.0 + 0.05);
  }
  // 16 m of tunnel lie within the radius: about 105k voxels of 2.5 cm are seen; the 28 m driven would give
  // about 185k without the radius rule.
  EXPECT_LT(largest, 130000u);
  std::printf("FIGURE local_cloud_points static %zu driving_max %zu scan_points %zu worst_add_scan_ms %.2f\n",
              static_size, largest, scan.points_S.size(), worst_ms);
}

TEST(LocalCloudTest, ForgetsOldAndFarPointsAndSkipsNonFinite) {
  LocalCloud cloud;  // window 3 s, radius 8 m.
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();
  cloud.AddScan({{1, 0, 0}, {2, 0, 0}, {nan, 0, 0}, {0, 0, std::numeric_limits<float>::infinity()}}, origin,
                0.0);
  EXPECT_EQ(cloud.size(), 2u);
  cloud.AddScan({{1, 0, 0}}, origin, 2.0);  // Refreshes (1, 0, 0) only.
  EXPECT_EQ(cloud.size(), 2u);
  cloud.AddScan({{3, 0, 0}}, origin, 3.5);  // (2, 0, 0) last seen at 0.0: expired.
  EXPECT_EQ(cloud.size(), 2u);
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() = Eigen::Vector3d(20.0, 0.0, 0.0);
  cloud.AddScan({{0, 0, 0}}, far, 3.6);  // Points near the origin are now 17+ m away.
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_NEAR(cloud.Points()[0].x(), 20.0, 1e-5);
  cloud.Clear();
  EXPECT_EQ(cloud.size(), 0u);
}

// A low point the sensor drove up to lies under its lowest beam: kept for the blind window, forgotten once
// the sensor could see it again (backed off) or after the blind window; ForgetVisible() keeps it, drops the
// rest.
TEST(LocalCloudTest, KeepsWhatTheLowestBeamCannotSeeAgain) {
  LocalCloudOptions options;  // window 3 s
  options.blind_below_elevation_rad = -15.0 * kDeg;
  options.blind_window_s = 30.0;
  LocalCloud cloud(options);
  Eigen::Isometry3d at = Eigen::Isometry3d::Identity();
  at.translation() = Eigen::Vector3d(0.0, 0.0, 0.5);  // sensor 0.5 m up, level
  // A riser top 0.8 m ahead, 0.4 m below the sensor (elevation -26.6 deg), and a wall point at sensor height.
  const Eigen::Vector3f riser_W(0.8f, 0.0f, 0.1f), wall_W(0.8f, 1.0f, 0.5f);
  cloud.AddScan({riser_W - Eigen::Vector3f(0, 0, 0.5f), wall_W - Eigen::Vector3f(0, 0, 0.5f)}, at, 0.0);
  ASSERT_EQ(cloud.size(), 2u);
  cloud.AddScan({}, at, 10.0);  // 10 s later, seen by neither scan since
  ASSERT_EQ(cloud.size(), 1u);
  EXPECT_LT((cloud.Points()[0] - riser_W).norm(), 0.03);
  cloud.AddScan({riser_W - Eigen::Vector3f(0, 0, 0.5f), wall_W - Eigen::Vector3f(0, 0, 0.5f)}, at, 11.0);
  ASSERT_EQ(cloud.size(), 2u);
  cloud.ForgetVisible();
  ASSERT_EQ(cloud.size(), 1u);  // the wall went, the riser in the blind zone stayed
  EXPECT_LT((cloud.Points()[0] - riser_W).norm(), 0.03);
  // Backed off 2 m the riser is in view again (-8 deg): an ordinary point, gone after the window.
  Eigen::Isometry3d back = at;
  back.translation().x() = -2.0;
  cloud.AddScan({}, back, 13.0);
  EXPECT_EQ(cloud.size(), 1u);
  cloud.AddScan({}, back, 14.5);
  EXPECT_EQ(cloud.size(), 0u);
  // In the blind zone but not seen for longer than the blind window: forgotten.
  cloud.AddScan({riser_W - Eigen::Vector3f(0, 0, 0.5f)}, at, 20.0);
  cloud.AddScan({}, at, 49.0);
  EXPECT_EQ(cloud.size(), 1u);
  cloud.AddScan({}, at, 50.5);
  EXPECT_EQ(cloud.size(), 0u);
  // Without a blind zone (the default) ForgetVisible forgets everything, like Clear().
  LocalCloud plain;
  plain.AddScan({riser_W - Eigen::Vector3f(0, 0, 0.5f)}, at, 0.0);
  plain.ForgetVisible();
  EXPECT_EQ(plain.size(), 0u);
  options.blind_window_s = 1.0;  // shorter than the window
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("blind_window_s"), std::string::npos) << why;
}

// ---- Registry --------------------------------------------------------------------------------------------

Staircase Noisy(const Staircase& s, std::mt19937* rng, double scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  Staircase out = s;
  out.p_W_first_step += scale * Eigen::Vector3d(0.03 * n(*rng), 0.05 * n(*rng), 0.01 * n(*rng));
  out.yaw_rad += scale * 1.5 * kDeg * n(*rng);
  out.rise_m += scale * 0.005 * n(*rng);
  out.run_m += scale * 0.01 * n(*rng);
  out.width_m += scale * 0.05 * n(*rng);
  return out;
}

Staircase TunnelsStairs() {
  Staircase s;
  s.p_W_first_step = Eigen::Vector3d(50.0, 23.7, 0.0);
  s.yaw_rad = 0.0;
  s.rise_m = 0.2;
  s.run_m = 0.5;
  s.width_m = 2.4;
  s.num_steps = 5;
  s.confidence = 0.6;
  s.support_points = 2000;
  return s;
}

// The tunnels' staircase as one view measured it (a logged detection): first riser's foot, rise, run, width.
Staircase TunnelsStairsSeenAs(const Eigen::Vector3d& p_W_first_step, double rise_m, double run_m,
                              double width_m) {
  Staircase s = TunnelsStairs();
  s.p_W_first_step = p_W_first_step;
  s.rise_m = rise_m;
  s.run_m = run_m;
  s.width_m = width_m;
  return s;
}

TEST(StaircaseRegistryTest, SameStairsMergeOtherStairsGetNewIds) {
  StaircaseRegistry registry;
  std::mt19937 rng(3);
  const Staircase truth = TunnelsStairs();
  const auto first = registry.Add(Noisy(truth, &rng, 1.0), "r1");
  EXPECT_TRUE(first.is_new);
  EXPECT_TRUE(first.changed);
  EXPECT_EQ(first.id, 1);
  for (int i = 0; i < 20; ++i) {
    const auto again = registry.Add(Noisy(truth, &rng, 1.0), i % 2 == 0 ? "r1" : "r2");
    EXPECT_FALSE(again.is_new);
    EXPECT_EQ(again.id, first.id);
  }
  // Partial views of the same stairs: the lower 3 steps, and the upper 3 steps (first riser 2 steps up, as
  // seen from the top): merged, re-indexed onto the entry's first riser; num_steps stays 5.
  Staircase lower = truth;
  lower.num_steps = 3;
  lower.support_points = 300;
  EXPECT_EQ(registry.Add(lower, "r3").id, first.id);
  Staircase upper = truth;
  upper.p_W_first_step += Eigen::Vector3d(2 * 0.5, 0.0, 2 * 0.2);
  upper.num_steps = 3;
  upper.support_points = 300;
  EXPECT_EQ(registry.Add(upper, "r3").id, first.id);
  // Elsewhere: a new staircase.
  Staircase other = truth;
  other.p_W_first_step = Eigen::Vector3d(10.0, 5.0, -3.0);
  other.yaw_rad = kPi / 2;
  const auto second = registry.Add(other, "r2");
  EXPECT_TRUE(second.is_new);
  EXPECT_EQ(second.id, 2);
  // Same place, one floor up: new.
  Staircase upstairs = truth;
  upstairs.p_W_first_step.z() += 3.0;
  EXPECT_TRUE(registry.Add(upstairs, "r1").is_new);

  const std::vector<StaircaseRegistry::Entry> entries = registry.Entries();
  ASSERT_EQ(entries.size(), 3u);
  const StaircaseRegistry::Entry& e = entries[0];
  EXPECT_EQ(e.detections, 23);
  EXPECT_EQ(e.sources, (std::vector<std::string>{"r1", "r2", "r3"}));
  EXPECT_EQ(e.staircase.num_steps, 5);
  EXPECT_NEAR(e.staircase.p_W_first_step.x(), 50.0, 0.03);
  EXPECT_NEAR(e.staircase.p_W_first_step.y(), 23.7, 0.05);
  EXPECT_NEAR(e.staircase.rise_m, 0.2, 0.003);
  EXPECT_NEAR(e.staircase.run_m, 0.5, 0.005);
  EXPECT_LT(AngleError(e.staircase.yaw_rad, 0.0), 1.0 * kDeg);
  EXPECT_NEAR(e.staircase.p_W_first_step.z(), 0.0, 0.01);
  EXPECT_EQ(e.staircase.support_points, 21 * 2000 + 2 * 300);
  std::printf("FIGURE registry_merged_error x_m %.4f y_m %.4f rise_m %.4f run_m %.4f yaw_deg %.2f\n",
              e.staircase.p_W_first_step.x() - 50.0, e.staircase.p_W_first_step.y() - 23.7,
              e.staircase.rise_m - 0.2, e.staircase.run_m - 0.5, AngleError(e.staircase.yaw_rad, 0.0) / kDeg);
}

TEST(StaircaseRegistryTest, UpperPartFirstThenWholeFlight) {
  // A robot at the top sees only the upper 3 steps; another at the foot then sees all 5: one entry, described
  // from the real first riser.
  StaircaseRegistry registry;
  const Staircase whole = TunnelsStairs();
  Staircase upper = whole;
  upper.p_W_first_step += Eigen::Vector3d(2 * 0.5, 0.0, 2 * 0.2);
  upper.num_steps = 3;
  const auto a = registry.Add(upper, "r1");
  const auto b = registry.Add(whole, "r2");
  EXPECT_TRUE(a.is_new);
  EXPECT_FALSE(b.is_new);
  EXPECT_TRUE(b.changed);
  ASSERT_EQ(registry.size(), 1u);
  const Staircase merged = registry.Entries()[0].staircase;
  EXPECT_EQ(merged.num_steps, 5);
  EXPECT_NEAR((merged.p_W_first_step - whole.p_W_first_step).norm(), 0.0, 1e-9);
}

TEST(StaircaseRegistryTest, APartialViewFromOnTheStairsWithALowFloorMerges) {
  // Logged by the perception integration test (it counted the staircase twice): the whole flight, then a
  // robot standing on it saw 3 steps from the 2nd riser, one run further, its floor 8 cm below the 1st tread.
  StaircaseRegistry registry;
  const Staircase whole = TunnelsStairsSeenAs({50.00, 23.72, -0.01}, 0.200, 0.499, 2.41);
  Staircase partial = TunnelsStairsSeenAs({50.50, 23.73, 0.11}, 0.216, 0.500, 2.43);
  partial.num_steps = 3;
  EXPECT_TRUE(registry.Add(whole, "leg1").is_new);
  EXPECT_FALSE(registry.Add(partial, "leg1").is_new);
  ASSERT_EQ(registry.size(), 1u);
  EXPECT_EQ(registry.Entries()[0].staircase.num_steps, 5);
  // Two views of the same first riser must still agree on the floor: 8 cm apart at k = 0 is another flight.
  Staircase other_floor = whole;
  other_floor.p_W_first_step.z() += 0.08;
  EXPECT_TRUE(registry.Add(other_floor, "leg2").is_new);
}

TEST(StaircaseRegistryTest, AWholeViewWithALowFloorButTheSameTopMerges) {
  // Logged by the perception integration test (it counted the staircase twice): a legged robot at the foot
  // saw the whole flight with its floor 8 cm low and its rise 14 mm high; the flight's top agrees to 1 cm.
  StaircaseRegistry registry;
  Staircase first = TunnelsStairsSeenAs({50.000, 23.722, -0.004}, 0.2001, 0.4997, 2.406);
  first.confidence = 0.63;
  Staircase low = TunnelsStairsSeenAs({49.989, 23.697, -0.085}, 0.2142, 0.5024, 2.465);
  low.confidence = 0.37;
  EXPECT_TRUE(registry.Add(first, "leg1").is_new);
  EXPECT_FALSE(registry.Add(low, "leg1").is_new);
  ASSERT_EQ(registry.size(), 1u);
  EXPECT_NEAR(registry.Entries()[0].staircase.rise_m, 0.2, 0.01);
  EXPECT_TRUE(MatchStaircases(first, low, StaircaseRegistryOptions{}).same);
  // The same low floor with the first view's rise ends 8 cm low: another flight.
  Staircase lower_flight = low;
  lower_flight.rise_m = first.rise_m;
  EXPECT_FALSE(MatchStaircases(first, lower_flight, StaircaseRegistryOptions{}).same);
}

TEST(StaircaseRegistryTest, OppositeDirectionsAtTheSamePlaceStayApart) {
  // Detections are always described ascending (a view from the top gives the same yaw as one from the
  // foot, see SeenFromTheTopIsDescribedAscending), so opposite yaws at one place contradict each other: they
  // are kept as two entries and the consumer sees the conflict.
  StaircaseRegistry registry;
  const Staircase up = TunnelsStairs();
  Staircase down = up;
  down.yaw_rad = kPi;
  down.p_W_first_step.x() = 52.5;  // Same footprint, described from the other end.
  EXPECT_TRUE(registry.Add(up, "r1").is_new);
  const auto r = registry.Add(down, "r2");
  EXPECT_TRUE(r.is_new);
  EXPECT_EQ(registry.size(), 2u);
  // Re-adding the same detection changes nothing worth republishing.
  const auto same = registry.Add(up, "r1");
  EXPECT_FALSE(same.is_new);
  EXPECT_FALSE(same.changed);
}

TEST(StaircaseRegistryTest, RejectsUnusableDetections) {
  StaircaseRegistry registry;
  Staircase bad = TunnelsStairs();
  bad.rise_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(registry.Add(bad, "r1").id, 0);
  bad = TunnelsStairs();
  bad.num_steps = 0;
  EXPECT_EQ(registry.Add(bad, "r1").id, 0);
  EXPECT_EQ(registry.size(), 0u);
}

// A robot publishes its entries' ids as its staircase ids: an id names one staircase for good, also when a
// later view extends the entry down the flight, and a new staircase never gets an id given before.
TEST(StaircaseRegistryTest, AnEntryKeepsItsIdAsItGrowsAndIdsAreNeverReused) {
  StaircaseRegistry registry;
  const Staircase whole = TunnelsStairs();
  Staircase upper = whole;  // Risers 3-5 only, seen from the top.
  upper.p_W_first_step += Eigen::Vector3d(2 * 0.5, 0.0, 2 * 0.2);
  upper.num_steps = 3;
  Staircase other = whole;
  other.p_W_first_step = Eigen::Vector3d(10.0, 5.0, -3.0);
  other.yaw_rad = kPi / 2;
  EXPECT_EQ(registry.Add(upper, "scan").id, 1);
  EXPECT_EQ(registry.Add(other, "scan").id, 2);
  const auto grown = registry.Add(whole, "scan");
  EXPECT_FALSE(grown.is_new);
  EXPECT_EQ(grown.id, 1);
  Staircase upstairs = whole;
  upstairs.p_W_first_step.z() += 3.0;
  EXPECT_EQ(registry.Add(upstairs, "scan").id, 3);
  EXPECT_EQ(registry.Add(other, "scan").id, 2);
  const std::vector<StaircaseRegistry::Entry> entries = registry.Entries();
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_EQ(entries[0].id, 1);
  EXPECT_NEAR((entries[0].staircase.p_W_first_step - whole.p_W_first_step).norm(), 0.0, 1e-9);
  EXPECT_EQ(entries[0].staircase.num_steps, 5);
  EXPECT_EQ(entries[1].id, 2);
  EXPECT_NEAR((entries[1].staircase.p_W_first_step - other.p_W_first_step).norm(), 0.0, 1e-9);
  EXPECT_EQ(entries[2].id, 3);
  EXPECT_NEAR(entries[2].staircase.p_W_first_step.z(), 3.0, 1e-9);
}

TEST(StaircaseMatchTest, PartsOfOneFlightLineUpByWholeSteps) {
  const StaircaseRegistryOptions options;
  const Staircase whole = TunnelsStairs();
  Staircase upper = whole;  // Risers 3-5.
  upper.p_W_first_step += Eigen::Vector3d(2 * 0.5, 0.0, 2 * 0.2);
  upper.num_steps = 3;
  Staircase lower = whole;  // Risers 1-2.
  lower.num_steps = 2;
  StaircaseMatch m = MatchStaircases(whole, upper, options);
  EXPECT_TRUE(m.same);
  EXPECT_EQ(m.shift_steps, 2);
  EXPECT_NEAR(m.overlap, 1.0, 1e-9);
  m = MatchStaircases(upper, whole, options);
  EXPECT_TRUE(m.same);
  EXPECT_EQ(m.shift_steps, -2);
  // The two parts touch but do not overlap: by themselves, not (yet) one staircase.
  m = MatchStaircases(lower, upper, options);
  EXPECT_FALSE(m.same);
  EXPECT_EQ(m.shift_steps, 2);
  EXPECT_NEAR(m.overlap, 0.0, 1e-9);
  // The same footprint described descending contradicts it.
  Staircase down = whole;
  down.yaw_rad = kPi;
  down.p_W_first_step.x() = 52.5;
  EXPECT_FALSE(MatchStaircases(whole, down, options).same);
  Staircase bad = whole;
  bad.width_m = 0.0;
  EXPECT_FALSE(MatchStaircases(whole, bad, options).same);

  // Merged, the two parts are the whole flight, described from its foot.
  const Staircase merged = MergeStaircaseViews({upper, lower}, options);
  EXPECT_EQ(merged.num_steps, 5);
  EXPECT_NEAR((merged.p_W_first_step - whole.p_W_first_step).norm(), 0.0, 1e-9);
  EXPECT_NEAR(merged.rise_m, 0.2, 1e-9);
  EXPECT_NEAR(merged.run_m, 0.5, 1e-9);
  EXPECT_EQ(merged.support_points, 2 * whole.support_points);
  EXPECT_EQ(MergeStaircaseViews({bad}, options).num_steps, 0);
  EXPECT_EQ(MergeStaircaseViews({}, options).num_steps, 0);
}

TEST(StaircaseRegistryTest, BottomAndTopViewsOfTheTunnelsStairsMerge) {
  const StaircaseDetector detector;
  StaircaseRegistry registry;
  LocalCloud bottom, top;
  const Eigen::Vector3d pb = AccumulateScans(Tunnels(), Line(46.5, 23.5, 49.0, 23.5, 6), 21, &bottom);
  const Eigen::Vector3d pt = AccumulateScans(Tunnels(), TopApproach(), 22, &top);
  const std::vector<Staircase> from_bottom = detector.Detect(bottom.Points(), pb);
  const std::vector<Staircase> from_top = detector.Detect(top.Points(), pt);
  ASSERT_EQ(from_bottom.size(), 1u);
  ASSERT_EQ(from_top.size(), 1u);
  const auto a = registry.Add(from_bottom[0], "r1");
  const auto b = registry.Add(from_top[0], "r2");
  EXPECT_TRUE(a.is_new);
  EXPECT_FALSE(b.is_new);
  EXPECT_EQ(a.id, b.id);
  EXPECT_EQ(registry.Entries()[0].staircase.num_steps, 5);
}

// The flake of tests/perception_integration_test (one staircase counted twice): a robot already on the
// stairs sees only the flight above it. Real detections: the whole flight from its foot, then, for several
// seeds and positions on treads 1 and 2, the partial view from on the stairs; every one must join the entry.
TEST(StaircaseRegistryTest, PartialFlightSeenFromOnTheStairsMergesWithTheWholeFlight) {
  const StaircaseDetector detector;
  LocalCloud bottom;
  const Eigen::Vector3d pb = AccumulateScans(Tunnels(), Line(46.5, 23.5, 49.0, 23.5, 6), 21, &bottom);
  const std::vector<Staircase> whole = detector.Detect(bottom.Points(), pb);
  ASSERT_EQ(whole.size(), 1u);
  int partial_views = 0;
  for (int tread = 1; tread <= 2; ++tread) {
    for (std::uint32_t seed = 60; seed < 66; ++seed) {
      // Standing on tread `tread` (z = 0.2 * tread), lidar 0.5 m above it, walking up, drifting across.
      const double x0 = 50.0 + 0.5 * (tread - 1) + 0.1, y = 23.2 + 0.1 * (seed - 60);
      LocalCloud on_stairs;
      const Eigen::Vector3d p =
          AccumulateScans(Tunnels(), Line(x0, y, x0 + 0.3, y, 3, 0.2 * tread + 0.5), seed, &on_stairs);
      const std::vector<Staircase> partial = detector.Detect(on_stairs.Points(), p);
      if (partial.empty()) continue;
      const Staircase& d = partial[0];
      std::printf(
          "FIGURE stairs_partial_from_tread%d seed %u first_x %.3f first_z %.3f steps %d rise %.3f run %.3f "
          "width %.2f yaw_deg %.1f\n",
          tread, seed, d.p_W_first_step.x(), d.p_W_first_step.z(), d.num_steps, d.rise_m, d.run_m, d.width_m,
          d.yaw_rad / kDeg);
      ++partial_views;
      for (const bool whole_first : {true, false}) {
        StaircaseRegistry registry;
        const auto a = registry.Add(whole_first ? whole[0] : d, "r1");
        const auto b = registry.Add(whole_first ? d : whole[0], "r1");
        EXPECT_TRUE(a.is_new);
        EXPECT_FALSE(b.is_new) << "tread " << tread << " seed " << seed
                               << (whole_first ? " whole first" : " partial first");
        EXPECT_EQ(registry.size(), 1u);
        if (registry.size() == 1u) {
          const Staircase merged = registry.Entries()[0].staircase;
          EXPECT_EQ(merged.num_steps, 5);
          EXPECT_NEAR(merged.p_W_first_step.x(), 50.0, 0.05);
          EXPECT_NEAR(merged.p_W_first_step.z(), 0.0, 0.03);
        }
      }
    }
  }
  EXPECT_GE(partial_views, 4);  // The case must actually occur.
}

TEST(StaircaseRegistryTest, ConcurrentAddsAreSafe) {
  StaircaseRegistry registry;
  std::vector<std::thread> threads;
  threads.reserve(4);
  for (int t = 0; t < 4; ++t) {
    threads.emplace_back([&registry, t] {
      std::mt19937 rng(40 + t);
      for (int i = 0; i < 200; ++i) registry.Add(Noisy(TunnelsStairs(), &rng, 1.0), "r" + std::to_string(t));
    });
  }
  for (std::thread& th : threads) th.join();
  const auto entries = registry.Entries();
  ASSERT_EQ(entries.size(), 1u);
  EXPECT_EQ(entries[0].detections, 800);
  EXPECT_EQ(entries[0].sources.size(), 4u);
}

}  // namespace
}  // namespace cairn::perception
