// Copyright Cairn authors.
#include "cairn/sim/lidar.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "cairn/sim/builtin_worlds.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// 5 x 5 x 5 m grid of 0.5 m voxels, min corner at the origin, with a wall filling x in [3, 3.5].
World MakeWallWorld() {
  World world("wall", Eigen::Vector3d::Zero(), 0.5, Eigen::Vector3i(10, 10, 10));
  for (int iy = 0; iy < 10; ++iy) {
    for (int iz = 0; iz < 10; ++iz) world.SetOccupied(Eigen::Vector3i(6, iy, iz));
  }
  return world;
}

// Reference: smallest entry range over the boxes of all occupied voxels (slab test per voxel), and the axis
// of the entry face; O(voxels) per ray. Returns nullopt if no box is entered within max_range_m.
std::optional<RayHit> BruteForceCast(const World& world, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                     double max_range_m) {
  std::optional<RayHit> best;
  const Eigen::Vector3i dims = world.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3i index(ix, iy, iz);
        if (!world.IsOccupiedIndex(index)) continue;
        const Eigen::Vector3d lo = world.p_W_min() + index.cast<double>() * world.resolution_m();
        const Eigen::Vector3d hi = lo + Eigen::Vector3d::Constant(world.resolution_m());
        double t_in = 0.0;
        double t_out = std::numeric_limits<double>::infinity();
        int axis = -1;
        bool miss = false;
        for (int k = 0; k < 3 && !miss; ++k) {
          if (d[k] == 0.0) {
            miss = o[k] < lo[k] || o[k] >= hi[k];
            continue;
          }
          double t0 = (lo[k] - o[k]) / d[k];
          double t1 = (hi[k] - o[k]) / d[k];
          if (t0 > t1) std::swap(t0, t1);
          if (t0 > t_in) {
            t_in = t0;
            axis = k;
          }
          t_out = std::min(t_out, t1);
        }
        if (miss || t_in >= t_out || t_in > max_range_m) continue;
        if (!best || t_in < best->range_m) {
          best = RayHit{t_in, o + t_in * d, axis};
        }
      }
    }
  }
  return best;
}

TEST(CastRayTest, HitsTheNearFaceAtTheExactRange) {
  const World world = MakeWallWorld();
  // Straight along +x: enters the wall through its x = 3 face.
  auto hit = CastRay(world, Eigen::Vector3d(1.1, 2.3, 2.7), Eigen::Vector3d::UnitX(), 10.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_DOUBLE_EQ(hit->range_m, 1.9);
  EXPECT_EQ(hit->axis, 0);
  EXPECT_TRUE(hit->p_W.isApprox(Eigen::Vector3d(3.0, 2.3, 2.7), 1e-12));
  // Along -x from behind the wall: the x = 3.5 face.
  hit = CastRay(world, Eigen::Vector3d(4.9, 2.2, 0.1), -Eigen::Vector3d::UnitX(), 10.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->range_m, 1.4, 1e-12);
  EXPECT_EQ(hit->p_W.x(), 3.5);
  // Oblique in x-y: reaches x = 3 at y = 2.2 after |(2, 1.2)| metres.
  const Eigen::Vector3d d = Eigen::Vector3d(2.0, 1.2, 0.0).normalized();
  hit = CastRay(world, Eigen::Vector3d(1.0, 1.0, 2.25), d, 10.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->range_m, std::hypot(2.0, 1.2), 1e-12);
  EXPECT_TRUE(hit->p_W.isApprox(Eigen::Vector3d(3.0, 2.2, 2.25), 1e-12));
  EXPECT_EQ(hit->axis, 0);
}

TEST(CastRayTest, FloorSeenFromAboveHasAxisZ) {
  World world("floor", Eigen::Vector3d(-1.0, -1.0, -0.2), 0.1, Eigen::Vector3i(20, 20, 20));
  for (int ix = 0; ix < 20; ++ix) {
    for (int iy = 0; iy < 20; ++iy) world.SetOccupied(Eigen::Vector3i(ix, iy, 1));  // z in [-0.1, 0].
  }
  const Eigen::Vector3d d = Eigen::Vector3d(1.0, 0.5, -1.0).normalized();
  const auto hit = CastRay(world, Eigen::Vector3d(-0.5, -0.5, 0.8), d, 5.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->axis, 2);
  EXPECT_NEAR(hit->p_W.z(), 0.0, 1e-12);
  EXPECT_NEAR(hit->range_m, 0.8 / std::abs(d.z()), 1e-12);
}

TEST(CastRayTest, MaxRangeIsInclusive) {
  const World world = MakeWallWorld();
  const Eigen::Vector3d o(1.0, 2.3, 2.7);
  EXPECT_FALSE(CastRay(world, o, Eigen::Vector3d::UnitX(), 1.99).has_value());
  EXPECT_TRUE(CastRay(world, o, Eigen::Vector3d::UnitX(), 2.0).has_value());
}

TEST(CastRayTest, LeavesTheGridOrNeverEntersIt) {
  const World world = MakeWallWorld();
  // Away from the wall, out of the grid after 1 m: free, whatever the max range.
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(1.0, 2.3, 2.7), -Eigen::Vector3d::UnitX(), 100.0).has_value());
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(1.0, 2.3, 2.7), Eigen::Vector3d::UnitZ(), 100.0).has_value());
  // From outside, pointing past the grid.
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(-2.0, 2.0, 2.0), -Eigen::Vector3d::UnitX(), 100.0).has_value());
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(-2.0, 2.0, 7.0), Eigen::Vector3d::UnitX(), 100.0).has_value());
  // From outside, through the grid to the wall.
  const auto hit = CastRay(world, Eigen::Vector3d(-2.0, 2.0, 2.0), Eigen::Vector3d::UnitX(), 100.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->range_m, 5.0, 1e-12);
  // From outside onto a grid face that is occupied: the hit is on the grid boundary.
  const auto above = CastRay(world, Eigen::Vector3d(3.2, 2.0, 9.0), -Eigen::Vector3d::UnitZ(), 100.0);
  ASSERT_TRUE(above.has_value());
  EXPECT_NEAR(above->range_m, 4.0, 1e-12);
  EXPECT_EQ(above->axis, 2);
  EXPECT_NEAR(above->p_W.z(), 5.0, 1e-12);
}

TEST(CastRayTest, OriginInAWallGivesRangeZero) {
  const World world = MakeWallWorld();
  const Eigen::Vector3d o(3.2, 1.0, 1.0);
  const auto hit = CastRay(world, o, -Eigen::Vector3d::UnitX(), 10.0);
  ASSERT_TRUE(hit.has_value());
  EXPECT_EQ(hit->range_m, 0.0);
  EXPECT_EQ(hit->p_W, o);
  EXPECT_EQ(hit->axis, 0);
}

TEST(CastRayTest, NonFiniteInputsMiss) {
  const World world = MakeWallWorld();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(nan, 1, 1), Eigen::Vector3d::UnitX(), 10.0).has_value());
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(1, 1, 1), Eigen::Vector3d(nan, 0, 0), 10.0).has_value());
  EXPECT_FALSE(CastRay(world, Eigen::Vector3d(1, 1, 1), Eigen::Vector3d::UnitX(), nan).has_value());
}

TEST(CastRayTest, MatchesBruteForceOnRandomRays) {
  // Sparse random voxels: rays pass corners and edges at all angles, from inside and outside the grid.
  World world("random", Eigen::Vector3d(-0.7, 0.3, -1.1), 0.25, Eigen::Vector3i(12, 9, 7));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);
  for (int ix = 0; ix < 12; ++ix) {
    for (int iy = 0; iy < 9; ++iy) {
      for (int iz = 0; iz < 7; ++iz) {
        if (unit(rng) < 0.08) world.SetOccupied(Eigen::Vector3i(ix, iy, iz));
      }
    }
  }
  const Eigen::Vector3d lo = world.p_W_min() - Eigen::Vector3d::Constant(1.0);
  const Eigen::Vector3d span = world.p_W_max() - world.p_W_min() + Eigen::Vector3d::Constant(2.0);
  int hits = 0;
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Vector3d o = lo + span.cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
    const Eigen::Vector3d d = Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const double max_range_m = 5.0 * unit(rng);
    const auto expected = BruteForceCast(world, o, d, max_range_m);
    const auto actual = CastRay(world, o, d, max_range_m);
    ASSERT_EQ(actual.has_value(), expected.has_value()) << "ray " << i;
    if (!expected) continue;
    ++hits;
    EXPECT_NEAR(actual->range_m, expected->range_m, 1e-9) << "ray " << i;
    EXPECT_TRUE(actual->p_W.isApprox(expected->p_W, 1e-9)) << "ray " << i;
    if (expected->axis >= 0) {
      EXPECT_EQ(actual->axis, expected->axis) << "ray " << i;
    }
  }
  EXPECT_GT(hits, 300);  // The comparison covered many hits, not only misses.
}

TEST(LidarOptionsTest, DefaultsAreValidAndVlp16Like) {
  const LidarOptions options;
  std::string why;
  EXPECT_TRUE(options.IsValid(&why)) << why;
  EXPECT_EQ(options.RaysPerScan(), 16 * 1800);
  EXPECT_NEAR(options.max_elevation_rad, 15.0 * kPi / 180.0, 1e-12);
}

TEST(LidarOptionsTest, InvalidFieldsAreNamed) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  struct Case {
    const char* field;
    void (*breaks)(LidarOptions*);
  };
  const Case cases[] = {
      {"num_beams = 0", [](LidarOptions* o) { o->num_beams = 0; }},
      {"min_elevation_rad", [](LidarOptions* o) { o->min_elevation_rad = -2.0; }},
      {"max_elevation_rad", [](LidarOptions* o) { o->max_elevation_rad = o->min_elevation_rad - 0.1; }},
      {"max_elevation_rad", [](LidarOptions* o) { o->max_elevation_rad = o->min_elevation_rad; }},
      {"points_per_beam = -3", [](LidarOptions* o) { o->points_per_beam = -3; }},
      {"min_range_m", [](LidarOptions* o) { o->min_range_m = 40.0; }},
      {"max_range_m", [](LidarOptions* o) { o->max_range_m = 0.0; }},
      {"range_noise_stddev_m", [](LidarOptions* o) { o->range_noise_stddev_m = -0.01; }},
      {"rate_hz", [](LidarOptions* o) { o->rate_hz = 0.0; }},
  };
  for (const Case& c : cases) {
    LidarOptions options;
    c.breaks(&options);
    std::string why;
    EXPECT_FALSE(options.IsValid(&why)) << c.field;
    EXPECT_CONTAINS(why, c.field);
    try {
      SimulatedLidar lidar(options);
      ADD_FAILURE() << "no throw for " << c.field;
    } catch (const std::invalid_argument& e) {
      EXPECT_CONTAINS(std::string(e.what()), c.field);
    }
  }
  LidarOptions options;
  options.max_range_m = nan;
  EXPECT_FALSE(options.IsValid(nullptr));
  // One beam may have min == max elevation.
  options = LidarOptions{};
  options.num_beams = 1;
  options.min_elevation_rad = options.max_elevation_rad = 0.0;
  EXPECT_TRUE(options.IsValid(nullptr));
}

TEST(SimulatedLidarTest, DirectionsAreUnitAndSpanTheFieldOfView) {
  const SimulatedLidar lidar(LidarOptions{});
  const auto& dirs = lidar.directions_S();
  ASSERT_EQ(static_cast<std::int64_t>(dirs.size()), lidar.options().RaysPerScan());
  double min_el = 1.0;
  double max_el = -1.0;
  for (const Eigen::Vector3d& d : dirs) {
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    min_el = std::min(min_el, std::asin(d.z()));
    max_el = std::max(max_el, std::asin(d.z()));
  }
  EXPECT_NEAR(min_el, -15.0 * kPi / 180.0, 1e-9);
  EXPECT_NEAR(max_el, 15.0 * kPi / 180.0, 1e-9);
  EXPECT_TRUE(dirs[0].isApprox(Eigen::Vector3d(std::cos(min_el), 0.0, std::sin(min_el)), 1e-12));
  // Column 450 of 1800 looks along +y (azimuth 90 deg, counter-clockwise).
  EXPECT_NEAR(dirs[std::size_t{450} * 16].y(), std::cos(min_el), 1e-12);
}

TEST(SimulatedLidarTest, PoseIsApplied) {
  // Sensor yawed +90 deg: the wall at +x of W is on its right (-y of S), 2 m away.
  const World world = MakeWallWorld();
  LidarOptions options;
  options.range_noise_stddev_m = 0.0;
  SimulatedLidar lidar(options);
  Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
  T_W_S.translation() = Eigen::Vector3d(1.0, 2.5, 2.5);
  T_W_S.linear() = Eigen::AngleAxisd(kPi / 2.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  LidarScan scan;
  lidar.Scan(world, T_W_S, &scan);
  ASSERT_GT(scan.returns, 0);
  for (const Eigen::Vector3f& p : scan.points_S) EXPECT_NEAR(p.y(), -2.0f, 1e-5f);
}

// Lidar in builtin:tunnels, in the west tunnel at (4, 20), 0.5 m above the floor.
class TunnelLidarTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { world_ = new World(MakeBuiltinWorld("tunnels")); }
  static void TearDownTestSuite() {
    delete world_;
    world_ = nullptr;
  }
  static Eigen::Isometry3d Pose() {
    Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
    T_W_S.translation() = Eigen::Vector3d(4.0, 20.0, 0.5);
    T_W_S.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    return T_W_S;
  }
  static World* world_;
};
World* TunnelLidarTest::world_ = nullptr;

TEST_F(TunnelLidarTest, ReturnsAreInRange) {
  const LidarOptions options;
  SimulatedLidar lidar(options);
  LidarScan scan;
  lidar.Scan(*world_, Pose(), &scan);
  EXPECT_EQ(scan.rays_cast, 16 * 1800);
  EXPECT_EQ(scan.returns, static_cast<std::int64_t>(scan.points_S.size()));
  // In a ~3 x 3 m tunnel nearly every ray meets a wall, floor or ceiling; only those along the axis miss.
  EXPECT_GT(scan.returns, scan.rays_cast * 8 / 10);
  EXPECT_LT(scan.returns, scan.rays_cast);
  for (const Eigen::Vector3f& p : scan.points_S) {
    EXPECT_GE(p.norm(), options.min_range_m);
    EXPECT_LE(p.norm(), options.max_range_m + 6.0 * options.range_noise_stddev_m);
  }
  // A blind zone of 2.5 m drops the floor returns of the lowest beams (~1.9 m away).
  LidarOptions blind = options;
  blind.min_range_m = 2.5;
  SimulatedLidar blind_lidar(blind);
  LidarScan blind_scan;
  blind_lidar.Scan(*world_, Pose(), &blind_scan);
  EXPECT_LT(blind_scan.returns, scan.returns);
  for (const Eigen::Vector3f& p : blind_scan.points_S) EXPECT_GE(p.norm(), 2.5f);
}

TEST_F(TunnelLidarTest, NoiseFreePointsLieOnOccupiedVoxelFaces) {
  LidarOptions options;
  options.range_noise_stddev_m = 0.0;
  SimulatedLidar lidar(options);
  LidarScan scan;
  const Eigen::Isometry3d T_W_S = Pose();
  lidar.Scan(*world_, T_W_S, &scan);
  ASSERT_GT(scan.returns, 1000);
  const double res = world_->resolution_m();
  int inside_after = 0;
  for (const Eigen::Vector3f& p_S : scan.points_S) {
    const Eigen::Vector3d p_W = T_W_S * p_S.cast<double>();
    const Eigen::Vector3d d_W = (p_W - T_W_S.translation()).normalized();
    // On a face plane: one coordinate is a multiple of the resolution from the grid corner (float rounding).
    const Eigen::Vector3d q = (p_W - world_->p_W_min()) / res;
    const double off_plane = (q - q.array().round().matrix()).cwiseAbs().minCoeff() * res;
    EXPECT_LT(off_plane, 1e-4) << p_W.transpose();
    // Free just before the face, occupied just after it (unless the ray only clips a voxel corner).
    EXPECT_FALSE(world_->IsOccupied(p_W - 1e-4 * d_W)) << p_W.transpose();
    if (world_->IsOccupied(p_W + 1e-4 * d_W)) ++inside_after;
  }
  EXPECT_GT(inside_after, scan.returns * 99 / 100);
}

// A noise-free scan's ranges are CastRay()'s, bit for bit, in directions_S() order, from poses in the
// tunnels, in the room, inside the rock, outside the grid looking in, tilted.
TEST_F(TunnelLidarTest, ScansCastExactlyCastRaysRanges) {
  LidarOptions options;
  options.range_noise_stddev_m = 0.0;
  options.min_range_m = 0.0;
  SimulatedLidar lidar(options);
  std::vector<Eigen::Isometry3d> poses = {Pose()};
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(30.0, 20.0, 0.5), Eigen::Vector3d(49.0, 19.0, 1.0),
                                   Eigen::Vector3d(4.0, 20.0, -0.15), Eigen::Vector3d(-5.0, 20.0, 0.5)}) {
    Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
    T_W_S.translation() = p;
    T_W_S.linear() =
        (Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()))
            .toRotationMatrix();
    poses.push_back(T_W_S);
  }
  ASSERT_TRUE(world_->IsOccupied(poses[3].translation())) << "one pose inside the rock";
  LidarScan scan;
  for (const Eigen::Isometry3d& T_W_S : poses) {
    lidar.Scan(*world_, T_W_S, &scan);
    std::vector<Eigen::Vector3f> expected;
    for (const Eigen::Vector3d& d_S : lidar.directions_S()) {
      const auto hit = CastRay(*world_, T_W_S.translation(), T_W_S.linear() * d_S, options.max_range_m);
      if (hit) expected.emplace_back((hit->range_m * d_S).cast<float>());
    }
    ASSERT_EQ(scan.points_S.size(), expected.size()) << T_W_S.translation().transpose();
    int differ = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) differ += scan.points_S[i] != expected[i] ? 1 : 0;
    EXPECT_EQ(differ, 0) << T_W_S.translation().transpose();
  }
}

TEST_F(TunnelLidarTest, RangeNoiseHasTheRequestedStatistics) {
  LidarOptions clean_options;
  clean_options.range_noise_stddev_m = 0.0;
  LidarOptions noisy_options;
  noisy_options.range_noise_stddev_m = 0.02;
  SimulatedLidar clean(clean_options);
  SimulatedLidar noisy(noisy_options, 42);
  LidarScan clean_scan;
  LidarScan noisy_scan;
  clean.Scan(*world_, Pose(), &clean_scan);
  noisy.Scan(*world_, Pose(), &noisy_scan);
  // No true range is near min_range_m, so both scans keep the same rays in the same order.
  ASSERT_EQ(clean_scan.returns, noisy_scan.returns);
  double sum = 0.0;
  double sum_sq = 0.0;
  const auto n = static_cast<double>(clean_scan.returns);
  for (std::size_t i = 0; i < clean_scan.points_S.size(); ++i) {
    const Eigen::Vector3d a = clean_scan.points_S[i].cast<double>();
    const Eigen::Vector3d b = noisy_scan.points_S[i].cast<double>();
    ASSERT_GT(a.normalized().dot(b.normalized()), 1.0 - 1e-9);  // Noise only along the ray.
    const double e = b.norm() - a.norm();
    sum += e;
    sum_sq += e * e;
  }
  const double mean = sum / n;
  const double stddev = std::sqrt(sum_sq / n - mean * mean);
  EXPECT_LT(std::abs(mean), 4.0 * 0.02 / std::sqrt(n));
  EXPECT_NEAR(stddev, 0.02, 0.02 * 0.03);

  // Same seed -> same scan, capacity reused; another seed -> another scan.
  SimulatedLidar again(noisy_options, 42);
  LidarScan again_scan = clean_scan;  // Holds points: must be replaced, not appended to.
  again.Scan(*world_, Pose(), &again_scan);
  ASSERT_EQ(again_scan.points_S.size(), noisy_scan.points_S.size());
  EXPECT_EQ(again_scan.points_S.front(), noisy_scan.points_S.front());
  EXPECT_EQ(again_scan.points_S.back(), noisy_scan.points_S.back());
  SimulatedLidar other(noisy_options, 43);
  LidarScan other_scan;
  other.Scan(*world_, Pose(), &other_scan);
  EXPECT_NE(other_scan.points_S.front(), noisy_scan.points_S.front());
}

// A sensor that has not moved in an unchanged world gets the scans a fresh cast would give (the same
// random draws), with new noise each time; a new pose or a new world is cast again.
TEST_F(TunnelLidarTest, AStillSensorReusesItsTrueRangesAndGetsTheScansACastWouldGive) {
  const auto shared = std::make_shared<const World>(*world_);
  SimulatedLidar reusing(LidarOptions{}, 9);
  SimulatedLidar casting(LidarOptions{}, 9);
  LidarScan a;
  LidarScan b;
  Eigen::Isometry3d moved = Pose();
  moved.translation().x() += 0.37;
  const auto other_world = std::make_shared<const World>(*world_);
  const std::vector<std::pair<std::shared_ptr<const World>, Eigen::Isometry3d>> sequence = {
      {shared, Pose()}, {shared, Pose()}, {shared, Pose()},
      {shared, moved},  {shared, moved},  {other_world, moved}};
  std::vector<Eigen::Vector3f> previous;
  for (std::size_t k = 0; k < sequence.size(); ++k) {
    reusing.Scan(sequence[k].first, sequence[k].second, &a);
    casting.Scan(*sequence[k].first, sequence[k].second, &b);
    ASSERT_EQ(a.points_S, b.points_S) << "scan " << k;
    EXPECT_EQ(a.rays_cast, b.rays_cast);
    EXPECT_EQ(a.returns, b.returns);
    EXPECT_NE(a.points_S, previous) << "scan " << k << ": the noise was not drawn again";
    previous = a.points_S;
  }
  EXPECT_EQ(reusing.reused_scans(), 3) << "reused: the 2nd and 3rd at Pose(), the 2nd at moved";
  EXPECT_EQ(casting.reused_scans(), 0);
  EXPECT_THROW(reusing.Scan(std::shared_ptr<const World>(), Pose(), &a), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::sim
