// Copyright Cairn authors.
#include "cairn/nav/local_planner.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <memory>
#include <new>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "../../sim/test/test_util.h"

// Allocation counter for the steady-state test: counts operator new calls while g_count_allocations is set.
namespace {
std::atomic<bool> g_count_allocations{false};
std::atomic<long> g_allocations{0};
void* CountedAlloc(std::size_t size) {
  if (g_count_allocations.load(std::memory_order_relaxed))
    g_allocations.fetch_add(1, std::memory_order_relaxed);
  void* p = std::malloc(size == 0 ? 1 : size);
  if (p == nullptr) throw std::bad_alloc();
  return p;
}
}  // namespace
void* operator new(std::size_t size) { return CountedAlloc(size); }
void* operator new[](std::size_t size) { return CountedAlloc(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace cairn::nav {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();
using Cloud = std::vector<Eigen::Vector3f>;

// The default library, built once for all tests (~0.4 s).
std::shared_ptr<const TrajectoryLibrary> DefaultLibrary() {
  static const std::shared_ptr<const TrajectoryLibrary> library = std::make_shared<const TrajectoryLibrary>();
  return library;
}

LocalPlanRequest GoalRequest(double x, double y) {
  LocalPlanRequest request;
  request.mode = LocalPlanMode::kGoal;
  request.goal_B = Eigen::Vector2d(x, y);
  return request;
}

LocalPlanRequest JoystickRequest(double x, double y) {
  LocalPlanRequest request;
  request.mode = LocalPlanMode::kJoystick;
  request.goal_B = Eigen::Vector2d(x, y);
  return request;
}

// Angle between two directions, radians, [0, pi].
double AngleBetween(double a, double b) { return std::abs(std::remainder(a - b, 2.0 * kPi)); }

bool IsObstacle(const Eigen::Vector3f& p, const TrajectoryLibraryOptions& o) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z()) &&
         p.z() >= o.obstacle_min_z_m && p.z() <= o.obstacle_max_z_m;
}

// Least planar distance from any obstacle point of `cloud` to the polyline path_B[1..] (the samples after the
// origin), checked every 5 mm along it: geometry only, no correspondence.
double ClosestApproachM(const std::vector<Eigen::Vector3f>& path_B, const Cloud& cloud,
                        const TrajectoryLibraryOptions& o) {
  double best = std::numeric_limits<double>::infinity();
  std::vector<Eigen::Vector2d> dense;
  for (std::size_t i = 1; i < path_B.size(); ++i) {
    const Eigen::Vector2d a = path_B[i].head<2>().cast<double>();
    if (i + 1 == path_B.size()) {
      dense.push_back(a);
      break;
    }
    const Eigen::Vector2d b = path_B[i + 1].head<2>().cast<double>();
    const int steps = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.005)));
    for (int k = 0; k < steps; ++k) dense.emplace_back(a + (b - a) * (static_cast<double>(k) / steps));
  }
  for (const Eigen::Vector3f& p : cloud) {
    if (!IsObstacle(p, o)) continue;
    const Eigen::Vector2d q = p.head<2>().cast<double>();
    for (const Eigen::Vector2d& d : dense) best = std::min(best, (d - q).norm());
  }
  return best;
}

// How far the polyline origin, path_B[1..] comes inside the distance each obstacle point of `cloud` must be
// kept at (metres, <= 0 when none is violated): collision_radius_m, or for a point within near_origin_m of
// the origin that the robot already stands closer to, that distance less 1 mm (see TrajectoryLibrary).
double WorstShortfallM(const std::vector<Eigen::Vector3f>& path_B, const Cloud& cloud,
                       const TrajectoryLibraryOptions& o, double near_origin_m) {
  double worst = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3f& p : cloud) {
    if (!IsObstacle(p, o)) continue;
    const Eigen::Vector2d q = p.head<2>().cast<double>();
    const double required =
        q.norm() < near_origin_m ? std::min(o.collision_radius_m, q.norm() - 1e-3) : o.collision_radius_m;
    for (std::size_t i = 1; i < path_B.size(); ++i) {
      const Eigen::Vector2d a = path_B[i - 1].head<2>().cast<double>(),
                            b = path_B[i].head<2>().cast<double>();
      const double len2 = (b - a).squaredNorm();
      const double t = len2 > 0 ? std::clamp((q - a).dot(b - a) / len2, 0.0, 1.0) : 0.0;
      worst = std::max(worst, required - (a + t * (b - a) - q).norm());
    }
  }
  return worst;
}

// y where the path crosses x = x_m (first crossing), NaN if it does not.
double CrossingY(const std::vector<Eigen::Vector3f>& path_B, double x_m) {
  for (std::size_t i = 0; i + 1 < path_B.size(); ++i) {
    const double x0 = path_B[i].x();
    const double x1 = path_B[i + 1].x();
    if ((x0 - x_m) * (x1 - x_m) <= 0.0 && x0 != x1) {
      const double t = (x_m - x0) / (x1 - x0);
      return path_B[i].y() + t * (path_B[i + 1].y() - path_B[i].y());
    }
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Points on a vertical segment of wall from (x, y0) to (x, y1) every 2 cm, at z = 0, 0.5 and 1.0.
void AddWall(Cloud* cloud, double x0, double y0, double x1, double y1) {
  const double length = std::hypot(x1 - x0, y1 - y0);
  const int n = std::max(1, static_cast<int>(std::ceil(length / 0.02)));
  for (int i = 0; i <= n; ++i) {
    const double t = static_cast<double>(i) / n;
    for (float z : {0.0f, 0.5f, 1.0f}) {
      cloud->emplace_back(static_cast<float>(x0 + t * (x1 - x0)), static_cast<float>(y0 + t * (y1 - y0)), z);
    }
  }
}

void AddRing(Cloud* cloud, double radius_m) {
  for (int i = 0; i < 720; ++i) {
    const double a = 2.0 * kPi * i / 720;
    cloud->emplace_back(static_cast<float>(radius_m * std::cos(a)),
                        static_cast<float>(radius_m * std::sin(a)), 0.5f);
  }
}

// ---------------------------------------------------------------------------------------------------------
// Options

TEST(TrajectoryLibraryOptionsTest, DefaultsAreValidAndMessagesNameFieldAndValue) {
  std::string why;
  EXPECT_TRUE(TrajectoryLibraryOptions{}.IsValid(&why)) << why;

  TrajectoryLibraryOptions o;
  o.path_length_m = -1.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "TrajectoryLibraryOptions::path_length_m = -1 must be finite and in [0.1, 10]");
  EXPECT_THROW(TrajectoryLibrary{o}, std::invalid_argument);

  o = {};
  o.paths_per_group = 50;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "TrajectoryLibraryOptions::paths_per_group = 50 must be a square");

  o = {};
  o.collision_radius_m = std::nan("");
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "TrajectoryLibraryOptions::collision_radius_m = nan must be finite");

  o = {};
  o.obstacle_min_z_m = 2.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(
      why, "TrajectoryLibraryOptions::obstacle_min_z_m = 2 must be finite and < obstacle_max_z_m = 1.5");

  o = {};
  o.num_headings = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "TrajectoryLibraryOptions::num_headings = 0 must be in [1, 360]");

  o = {};
  o.sample_spacing_m = 0.01;  // 300 samples on 3 m.
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "TrajectoryLibraryOptions::sample_spacing_m = 0.01 gives 300 samples");

  o = {};
  o.num_headings = 360;
  o.paths_per_group = 225;  // 360 x 7 x (1 + 15 + 225) nodes.
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "path tree nodes; at most 65535 allowed");

  o = {};
  o.voxel_size_m = 0.02;
  o.path_length_m = 10.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(
      why, "TrajectoryLibraryOptions::voxel_size_m = 0.02 gives a blocking grid of 1040 voxels per side");

  o = {};
  o.clearance_voxel_size_m = 0.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why,
                  "TrajectoryLibraryOptions::clearance_voxel_size_m = 0 must be finite and in [0.02, 2]");
}

TEST(LocalPlannerOptionsTest, DefaultsAreValidAndMessagesNameFieldAndValue) {
  std::string why;
  EXPECT_TRUE(LocalPlannerOptions{}.IsValid(&why)) << why;
  LocalPlannerOptions o;
  o.clearance_weight = -0.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "LocalPlannerOptions::clearance_weight = -0.5 must be finite and in [0, 100]");
  EXPECT_THROW(LocalPlanner(DefaultLibrary(), o), std::invalid_argument);
  o = {};
  o.max_joystick_deviation_rad = 4.0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why,
                  "LocalPlannerOptions::max_joystick_deviation_rad = 4 must be finite and in [0, 3.14159]");
  EXPECT_THROW(LocalPlanner(nullptr), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------------------
// Library

TEST(TrajectoryLibraryTest, DefaultSizeAndGeometry) {
  const TrajectoryLibrary& lib = *DefaultLibrary();
  ASSERT_EQ(lib.num_paths(), 12348);
  EXPECT_EQ(lib.num_kept_headings(), 36);
  EXPECT_EQ(lib.paths_per_heading(), 343);
  EXPECT_EQ(lib.samples_per_path(), 60);
  EXPECT_NEAR(lib.sample_spacing_m(), 0.05, 1e-12);
  EXPECT_EQ(lib.num_nodes(), 36 * (7 + 49 + 343));
  EXPECT_GT(lib.build_time_s(), 0.0);
  EXPECT_GT(lib.memory_bytes(), std::size_t{1} << 20);
  EXPECT_LT(lib.memory_bytes(), std::size_t{64} << 20);
  // The blocking grid reaches past path length + blocking radius, the clearance grid past path length +
  // collision radius + band + half its voxel diagonal.
  EXPECT_NEAR(lib.voxel_blocking_radius_m(), 0.35 + 0.025 + 0.1 * std::sqrt(0.5), 1e-12);
  EXPECT_LE(lib.grid_min_m(), -(3.0 + lib.voxel_blocking_radius_m()));
  EXPECT_LE(lib.clearance_grid_min_m(), -(3.0 + 0.35 + 0.5 + 0.2 * std::sqrt(0.5)));

  std::set<long> headings_deg;
  std::set<int> groups;
  for (int p = 0; p < lib.num_paths(); ++p) {
    const TrajectoryInfo& info = lib.info(p);
    const Eigen::Vector2f* s = lib.samples_B(p);
    // Starts at the origin, leaving along heading_rad.
    ASSERT_NEAR(s[0].norm(), 0.05, 1e-4) << "path " << p;
    ASSERT_LT(AngleBetween(std::atan2(s[0].y(), s[0].x()), info.heading_rad), 0.25) << "path " << p;
    // Polyline length from the origin ~ 3 m (chords of 5 cm arcs with curvature <= 0.47 / m).
    double length = s[0].norm();
    for (int i = 1; i < lib.samples_per_path(); ++i) {
      const double step = (s[i] - s[i - 1]).norm();
      ASSERT_NEAR(step, 0.05, 1e-4) << "path " << p << " sample " << i;
      length += step;
    }
    ASSERT_NEAR(length, 3.0, 2e-3) << "path " << p;
    ASSERT_NEAR(info.length_m, 3.0f, 1e-6f);
    ASSERT_TRUE(info.end_B.isApprox(s[lib.samples_per_path() - 1]));
    ASSERT_NEAR(info.end_bearing_rad, std::atan2(info.end_B.y(), info.end_B.x()), 1e-5);
    // Total turn at most 3 x 27 deg.
    ASSERT_LE(AngleBetween(info.end_heading_rad, info.heading_rad), 3 * 0.4713) << "path " << p;
    headings_deg.insert(std::lround(info.heading_rad * 180.0 / kPi));
    groups.insert(info.group);
  }
  // 36 headings every 10 degrees around the circle.
  EXPECT_EQ(headings_deg.size(), 36u);
  for (long h : headings_deg) EXPECT_EQ(((h % 10) + 10) % 10, 0) << h;
  EXPECT_EQ(*headings_deg.begin(), -170);
  EXPECT_EQ(*headings_deg.rbegin(), 180);
  EXPECT_EQ(groups.size(), 7u);
  // The straight path: heading 0, middle choices everywhere: id 3 * 49 + 3 * 7 + 3 = 171.
  EXPECT_NEAR(lib.info(171).end_B.x(), 3.0f, 1e-5f);
  EXPECT_NEAR(lib.info(171).end_B.y(), 0.0f, 1e-5f);
}

TEST(TrajectoryLibraryTest, HeadingRangeRestrictsHeadings) {
  TrajectoryLibraryOptions o;
  o.heading_range_rad = kPi / 2;
  o.num_groups = 3;
  o.paths_per_group = 9;  // Small library: the headings are the point.
  const TrajectoryLibrary lib(o);
  EXPECT_EQ(lib.num_kept_headings(), 19);  // -90 .. 90 deg every 10 deg.
  EXPECT_EQ(lib.num_paths(), 19 * 27);
  double lo = 0.0;
  double hi = 0.0;
  for (int p = 0; p < lib.num_paths(); ++p) {
    lo = std::min(lo, static_cast<double>(lib.info(p).heading_rad));
    hi = std::max(hi, static_cast<double>(lib.info(p).heading_rad));
  }
  EXPECT_NEAR(lo, -kPi / 2, 1e-6);
  EXPECT_NEAR(hi, kPi / 2, 1e-6);

  // A goal behind the robot: the best it can do is a path to the side, never one starting backwards.
  LocalPlanner planner(std::make_shared<const TrajectoryLibrary>(o));
  const LocalPlanResult r = planner.Plan({}, GoalRequest(-3.0, 0.2));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_LE(std::abs(planner.library().info(r.path_id).heading_rad), kPi / 2 + 1e-6);
  EXPECT_GT(planner.library().info(r.path_id).end_B.y(), 0.0f);  // Turns toward the goal side.
}

// A small library for the serialization tests (quick to build and to spot-check).
TrajectoryLibraryOptions SmallLibraryOptions() {
  TrajectoryLibraryOptions o;
  o.num_groups = 3;
  o.paths_per_group = 9;
  o.num_headings = 12;
  return o;
}

// Every row of both grids and every path sample of `a` and `b` are equal.
void ExpectSameLibrary(const TrajectoryLibrary& a, const TrajectoryLibrary& b) {
  ASSERT_EQ(a.num_paths(), b.num_paths());
  ASSERT_EQ(a.num_nodes(), b.num_nodes());
  ASSERT_EQ(a.num_voxels(), b.num_voxels());
  ASSERT_EQ(a.num_clearance_voxels(), b.num_clearance_voxels());
  ASSERT_EQ(a.num_blocking_entries(), b.num_blocking_entries());
  ASSERT_EQ(a.num_band_entries(), b.num_band_entries());
  for (int p = 0; p < a.num_paths(); ++p) {
    for (int i = 0; i < a.samples_per_path(); ++i)
      ASSERT_EQ(a.samples_B(p)[i], b.samples_B(p)[i]) << p << " " << i;
  }
  for (int v = 0; v < a.num_voxels(); ++v) {
    const auto ra = a.blocking_entries(v);
    const auto rb = b.blocking_entries(v);
    ASSERT_EQ(ra.size(), rb.size()) << v;
    for (std::size_t e = 0; e < ra.size(); ++e) {
      ASSERT_EQ(ra.first[e].node, rb.first[e].node);
      ASSERT_EQ(ra.first[e].first_sample, rb.first[e].first_sample);
    }
  }
  for (int v = 0; v < a.num_clearance_voxels(); ++v) {
    const auto ra = a.band_entries(v);
    const auto rb = b.band_entries(v);
    ASSERT_EQ(ra.size(), rb.size()) << v;
    for (std::size_t e = 0; e < ra.size(); ++e) {
      ASSERT_EQ(ra.first[e].node, rb.first[e].node);
      ASSERT_EQ(ra.first[e].closest_sample, rb.first[e].closest_sample);
      ASSERT_EQ(ra.first[e].clearance_bucket, rb.first[e].clearance_bucket);
    }
  }
}

TEST(TrajectoryLibraryTest, SerializedLibraryLoadsEqualAndPlansTheSame) {
  const TrajectoryLibraryOptions o = SmallLibraryOptions();
  const auto built = std::make_shared<const TrajectoryLibrary>(o);
  const std::string bytes = built->Serialize();
  std::string why;
  std::shared_ptr<const TrajectoryLibrary> loaded = TrajectoryLibrary::Deserialize(bytes, o, &why);
  ASSERT_NE(loaded, nullptr) << why;
  ExpectSameLibrary(*built, *loaded);
  EXPECT_EQ(loaded->Serialize(), bytes);
  // The same scene, the same choice.
  const Cloud wall = {{1.5f, -0.5f, 0.2f}, {1.5f, 0.0f, 0.2f}, {1.5f, 0.5f, 0.2f}};
  LocalPlanner from_built(built), from_loaded(loaded);
  const LocalPlanResult a = from_built.Plan(wall, GoalRequest(3.0, 0.0));
  const LocalPlanResult b = from_loaded.Plan(wall, GoalRequest(3.0, 0.0));
  ASSERT_TRUE(a.IsUsable()) << a.message;
  EXPECT_EQ(a.path_id, b.path_id);
  EXPECT_EQ(a.free_length_m, b.free_length_m);
}

TEST(TrajectoryLibraryTest, DeserializeRefusesOtherVersionsOptionsAndDamagedBytesNamingWhy) {
  const TrajectoryLibraryOptions o = SmallLibraryOptions();
  const TrajectoryLibrary built(o);
  const std::string bytes = built.Serialize();
  auto refusal_for = [](const std::string& b, const TrajectoryLibraryOptions& wanted) {
    std::string why;
    auto lib = TrajectoryLibrary::Deserialize(b, wanted, &why);
    return lib == nullptr ? why : std::string("loaded");
  };
  auto refusal = [&](const std::string& b) { return refusal_for(b, o); };
  EXPECT_EQ(refusal(""), "not a Cairn trajectory library (magic)");
  EXPECT_EQ(refusal("CAIRNTL"), "not a Cairn trajectory library (magic)");
  std::string other_version = bytes;
  other_version[8] = static_cast<char>(TrajectoryLibrary::kFormatVersion + 1);
  EXPECT_EQ(refusal(other_version), "format version 2, this build reads 1");
  TrajectoryLibraryOptions wider = o;
  wider.collision_radius_m = 0.4;
  EXPECT_EQ(refusal_for(bytes, wider),
            "built with collision_radius_m = 0.34999999999999998, wanted 0.40000000000000002");
  EXPECT_EQ(refusal(bytes.substr(0, 100)), "truncated in its options");
  EXPECT_EQ(refusal(bytes.substr(0, bytes.size() - 1)), "truncated in its correspondence");
  EXPECT_EQ(refusal(bytes + "x"), "longer than its contents");
  // Header (magic, version, byte order, 13 options) and the blocking offsets' count and values.
  const std::size_t blocking_at = 8 + 4 + 4 + 13 * 8 + 8 + 4 * (built.num_voxels() + 1) + 8;
  const BlockingEntry* first = built.blocking_entries(0).first;
  // A node id beyond the tree.
  std::string bad_node = bytes;
  bad_node[blocking_at] = bad_node[blocking_at + 1] = static_cast<char>(0xff);
  EXPECT_EQ(refusal(bad_node), "blocking rows out of range (sizes, offsets, node ids or samples)");
  // A first blocked sample changed to another valid one, in the heading the spot check builds again.
  const int slot_path = built.num_kept_headings() / 2 * built.paths_per_heading();
  const std::uint16_t node = built.path_nodes(slot_path)[2];
  std::ptrdiff_t index = -1;
  for (int v = 0; v < built.num_voxels() && index < 0; ++v) {
    for (const BlockingEntry& e : built.blocking_entries(v)) {
      if (e.node == node) index = &e - first;
    }
  }
  ASSERT_GE(index, 0);
  std::string bad_sample = bytes;
  char& sample = bad_sample[blocking_at + 4 * static_cast<std::size_t>(index) + 2];
  sample = static_cast<char>(sample == 0 ? 1 : sample - 1);
  EXPECT_EQ(refusal(bad_sample),
            "the correspondence of heading slot 6 differs from one built now (a file from "
            "another build, or damaged)");
  EXPECT_EQ(refusal(bytes), "loaded");
  TrajectoryLibraryOptions invalid = o;
  invalid.num_headings = 0;
  std::string why;
  EXPECT_THROW(TrajectoryLibrary::Deserialize(bytes, invalid, &why), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------------------
// Planning, hand-made scenes

TEST(LocalPlannerTest, EmptyCloudPicksThePathTowardTheGoal) {
  LocalPlanner planner(DefaultLibrary());
  LocalPlanResult r = planner.Plan({}, GoalRequest(5.0, 0.0));
  ASSERT_EQ(r.status, LocalPlanResult::Status::kPathFound) << r.message;
  EXPECT_EQ(r.path_id, 171);
  EXPECT_EQ(r.num_free_paths, 12348);
  EXPECT_EQ(r.num_candidate_paths, 12348);
  EXPECT_DOUBLE_EQ(r.free_length_m, 3.0);
  EXPECT_DOUBLE_EQ(r.required_free_length_m, 3.0);
  EXPECT_EQ(r.path_B.size(), 61u);
  EXPECT_TRUE(r.path_B.front().isZero());
  EXPECT_TRUE(std::isinf(r.nearest_obstacle_m));
  EXPECT_CONTAINS(r.message, "path 171");
  EXPECT_CONTAINS(r.message, "12348 of 12348 paths free, no obstacles");

  // Goal to the front left: the path ends toward it.
  r = planner.Plan({}, GoalRequest(2.0, 2.0));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_LT(AngleBetween(planner.library().info(r.path_id).end_bearing_rad, kPi / 4), 0.1);

  // Goal behind: a path that turns back.
  r = planner.Plan({}, GoalRequest(-3.0, 0.5));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  const TrajectoryInfo& info = planner.library().info(r.path_id);
  EXPECT_LT(info.end_B.x(), -2.5f);
  EXPECT_LT(AngleBetween(info.end_bearing_rad, std::atan2(0.5, -3.0)), 0.1);
}

TEST(LocalPlannerTest, ObstacleStraightAheadIsAvoided) {
  LocalPlanner planner(DefaultLibrary());
  Cloud cloud;
  for (int i = 0; i < 200; ++i) {  // A 0.3 m wide pillar 1.5 m ahead.
    const double a = 2.0 * kPi * i / 50;
    const int ring = i / 50;  // 50 points a ring, rings 0.25 m apart
    cloud.emplace_back(static_cast<float>(1.5 + 0.15 * std::cos(a)), static_cast<float>(0.15 * std::sin(a)),
                       0.25f * static_cast<float>(ring));
  }
  const LocalPlanResult r = planner.Plan(cloud, GoalRequest(5.0, 0.0));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NE(r.path_id, 171);
  EXPECT_FALSE(r.IsFree(171));
  EXPECT_DOUBLE_EQ(r.free_length_m, 3.0);
  EXPECT_GE(ClosestApproachM(r.path_B, cloud, planner.library().options()), 0.35);
  const TrajectoryInfo& info = planner.library().info(r.path_id);
  EXPECT_LT(std::abs(info.end_bearing_rad), 0.5);  // Still heading for the goal.
  EXPECT_NEAR(r.nearest_obstacle_m, 1.35, 0.01);
  EXPECT_EQ(r.num_points_used, 200);
}

// A robot that brushed past a wall's end stands 0.32 m from it, inside the collision radius (the agent's
// library: 0.3 m footprint + 0.03 m, 0.05 m voxels): paths leading away from the end or along it stay free,
// those passing closer to it do not. Through the end's voxel, every path's first samples were
// blocked and the robot could never leave (builtin:building's mid landing).
TEST(LocalPlannerTest, ARobotJustInsideTheCollisionRadiusOfAWallEndLeavesAlongOrAwayFromIt) {
  TrajectoryLibraryOptions agent;
  agent.collision_radius_m = 0.33;
  agent.voxel_size_m = 0.05;
  LocalPlanner planner(std::make_shared<const TrajectoryLibrary>(agent));
  const TrajectoryLibrary& lib = planner.library();
  Cloud cloud;
  AddWall(&cloud, -2.0, 0.32, 0.0, 0.32);  // a wall along x on the left, ending beside the robot
  LocalPlanRequest request = GoalRequest(3.0, 0.0);
  request.max_required_free_length_m = 1.5;
  const LocalPlanResult r = planner.Plan(cloud, request);
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_NEAR(r.nearest_obstacle_m, 0.32, 1e-3);
  // The chosen path never comes nearer the wall than the robot stands (0.32 m, less 1 mm).
  EXPECT_LE(WorstShortfallM(r.path_B, cloud, lib.options(), lib.near_origin_radius_m()), 1e-9);
  // A path whose first sample comes nearer the wall's end than the robot stands is blocked there; one that
  // runs along the wall at 0.32 m (straight ahead) is not.
  for (int p = 0; p < lib.num_paths(); ++p) {
    const Eigen::Vector2f s0 = lib.samples_B(p)[0];
    if (std::hypot(s0.x() - 0.0, s0.y() - 0.32) < 0.32 - 1e-3) {
      EXPECT_LT(planner.free_length_m(p), 1e-9)
          << "path " << p << " passes the wall's end closer than it stands";
    }
  }
  int ahead = -1;  // the straight path ahead (heading 0, no turn)
  for (int p = 0; p < lib.num_paths() && ahead < 0; ++p) {
    const Eigen::Vector2f end = lib.samples_B(p)[lib.samples_per_path() - 1];
    if (std::abs(end.y()) < 1e-3 && end.x() > 2.9f) ahead = p;
  }
  ASSERT_GE(ahead, 0);
  EXPECT_GT(planner.free_length_m(ahead), 1.5)
      << "the path along the wall, at the distance the robot stands, is blocked";
  // The brute-force reference agrees path for path.
  const std::vector<double> brute = BruteForceFreeLengths(lib, cloud, r.required_free_length_m);
  for (int p = 0; p < lib.num_paths(); ++p) {
    ASSERT_DOUBLE_EQ(planner.free_length_m(p), brute[static_cast<std::size_t>(p)]) << "path " << p;
  }
}

TEST(LocalPlannerTest, RingOfObstaclesBoxesIn) {
  LocalPlanner planner(DefaultLibrary());
  Cloud cloud;
  AddRing(&cloud, 1.0);
  const LocalPlanResult r = planner.Plan(cloud, GoalRequest(5.0, 0.0));
  EXPECT_EQ(r.status, LocalPlanResult::Status::kBoxedIn);
  EXPECT_FALSE(r.IsUsable());
  EXPECT_EQ(r.path_id, -1);
  EXPECT_TRUE(r.path_B.empty());
  EXPECT_EQ(r.num_free_paths, 0);
  EXPECT_CONTAINS(r.message, "boxed in: 0 of 12348 paths free for 3.00 m, nearest obstacle 1.00 m");

  // A goal inside the ring: paths blocked only beyond the goal are fine.
  const LocalPlanResult near = planner.Plan(cloud, GoalRequest(0.4, 0.0));
  ASSERT_TRUE(near.IsUsable()) << near.message;
  EXPECT_DOUBLE_EQ(near.required_free_length_m, 0.4);
  EXPECT_GE(near.free_length_m, 0.4);
  EXPECT_LT(near.free_length_m, 1.0);
  EXPECT_GE(ClosestApproachM(near.path_B, cloud, planner.library().options()), 0.35);
  // ... but not closer than min_free_length_m (0.3 m).
  const LocalPlanResult tiny = planner.Plan(cloud, GoalRequest(0.1, 0.0));
  EXPECT_DOUBLE_EQ(tiny.required_free_length_m, 0.3);
}

TEST(LocalPlannerTest, BadPointsAreCountedAndIgnored) {
  LocalPlanner planner(DefaultLibrary());
  Cloud cloud = {{kNaN, 0.0f, 0.0f},  {1.0f, kInf, 0.0f},  {1.0f, 0.0f, -kInf},  // non-finite
                 {1.0f, 0.0f, 2.0f},  {0.8f, 0.1f, -1.0f},                       // above / below the z band
                 {20.0f, 0.0f, 0.5f}, {0.0f, -4.5f, 0.5f}};                      // outside the grid
  LocalPlanResult r = planner.Plan(cloud, GoalRequest(5.0, 0.0));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_EQ(r.num_points_non_finite, 3);
  EXPECT_EQ(r.num_points_outside_z_band, 2);
  EXPECT_EQ(r.num_points_outside_grid, 2);
  EXPECT_EQ(r.num_points_used, 0);
  EXPECT_EQ(r.num_free_paths, 12348);
  EXPECT_EQ(r.path_id, 171);
  EXPECT_NEAR(r.nearest_obstacle_m, 4.5, 1e-6);

  cloud.emplace_back(1.5f, 0.0f, 0.5f);  // One real obstacle ahead.
  r = planner.Plan(cloud, GoalRequest(5.0, 0.0));
  ASSERT_TRUE(r.IsUsable()) << r.message;
  EXPECT_EQ(r.num_points_used, 1);
  EXPECT_EQ(r.num_occupied_voxels, 1);
  EXPECT_NE(r.path_id, 171);
  EXPECT_LT(r.num_free_paths, 12348);
}

TEST(LocalPlannerTest, InvalidRequestsAreReported) {
  LocalPlanner planner(DefaultLibrary());
  LocalPlanResult r = planner.Plan({}, GoalRequest(std::nan(""), 1.0));
  EXPECT_EQ(r.status, LocalPlanResult::Status::kInvalidInput);
  EXPECT_CONTAINS(r.message, "goal_B (nan, 1) must be finite");
  EXPECT_EQ(r.path_id, -1);

  r = planner.Plan({}, JoystickRequest(0.0, 0.0));
  EXPECT_EQ(r.status, LocalPlanResult::Status::kInvalidInput);
  EXPECT_CONTAINS(r.message, "joystick direction");

  LocalPlanRequest request = GoalRequest(1.0, 0.0);
  request.previous_path_id = 12348;
  r = planner.Plan({}, request);
  EXPECT_EQ(r.status, LocalPlanResult::Status::kInvalidInput);
  EXPECT_CONTAINS(r.message, "previous_path_id = 12348 must be -1 or in [0, 12347]");

  request = GoalRequest(1.0, 0.0);
  request.max_required_free_length_m = std::nan("");
  r = planner.Plan({}, request);
  EXPECT_EQ(r.status, LocalPlanResult::Status::kInvalidInput);
  EXPECT_CONTAINS(r.message, "max_required_free_length_m = nan must be > 0");
}

TEST(LocalPlannerTest, HysteresisKeepsTheSideOfThePreviousChoice) {
  LocalPlanner planner(DefaultLibrary());
  const TrajectoryLibrary& lib = planner.library();
  Cloud cloud;  // A wall segment straight ahead, symmetric about the x axis.
  AddWall(&cloud, 1.5, -0.6, 1.5, 0.6);
  const LocalPlanResult first = planner.Plan(cloud, GoalRequest(6.0, 0.0));
  ASSERT_TRUE(first.IsUsable()) << first.message;
  const float side = lib.info(first.path_id).end_B.y();
  ASSERT_NE(side, 0.0f);
  // The mirror image of the first choice (heading -k, mirrored turns) is free too, and scores the same
  // except for the tie-break; with it as the previous path the planner stays on its side.
  int mirror = -1;
  for (int p = 0; p < lib.num_paths(); ++p) {
    if (first.IsFree(p) &&
        (lib.info(p).end_B - Eigen::Vector2f(lib.info(first.path_id).end_B.x(), -side)).norm() < 1e-4f) {
      mirror = p;
    }
  }
  ASSERT_GE(mirror, 0);
  LocalPlanRequest request = GoalRequest(6.0, 0.0);
  request.previous_path_id = mirror;
  const LocalPlanResult second = planner.Plan(cloud, request);
  ASSERT_TRUE(second.IsUsable()) << second.message;
  EXPECT_LT(lib.info(second.path_id).end_B.y() * side, 0.0f);
}

// ---------------------------------------------------------------------------------------------------------
// Smart joystick

TEST(LocalPlannerTest, JoystickGoesThroughAnOffCentreDoorway) {
  LocalPlanner planner(DefaultLibrary());
  const TrajectoryLibraryOptions& o = planner.library().options();
  // Wall at x = 1.5 m with a 1.0 m doorway from y = -0.15 to y = 0.85 (centre +0.35).
  Cloud cloud;
  AddWall(&cloud, 1.5, -4.0, 1.5, -0.15);
  AddWall(&cloud, 1.5, 0.85, 1.5, 4.0);
  const LocalPlanResult r = planner.Plan(cloud, JoystickRequest(1.0, 0.0));
  ASSERT_EQ(r.status, LocalPlanResult::Status::kPathFound) << r.message;
  EXPECT_DOUBLE_EQ(r.free_length_m, 3.0);
  const double y = CrossingY(r.path_B, 1.5);
  ASSERT_FALSE(std::isnan(y)) << "the path does not reach the wall";
  EXPECT_LT(std::abs(y - 0.35), 0.5 - o.collision_radius_m) << "crosses the wall at y = " << y;
  EXPECT_GE(ClosestApproachM(r.path_B, cloud, o), o.collision_radius_m);
  const TrajectoryInfo& info = planner.library().info(r.path_id);
  EXPECT_LE(std::abs(info.heading_rad), kPi / 2 + 1e-6);
  EXPECT_LE(std::abs(info.end_bearing_rad), kPi / 2 + 1e-6);
  EXPECT_GT(r.path_B.back().x(), 1.5f);
}

TEST(LocalPlannerTest, JoystickAtASolidWallNeverDrivesIntoIt) {
  LocalPlanner planner(DefaultLibrary());
  const TrajectoryLibraryOptions& o = planner.library().options();
  Cloud cloud;
  AddWall(&cloud, 0.8, -4.0, 0.8, 4.0);
  for (const Eigen::Vector2d& joystick :
       {Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(1.0, 0.2), Eigen::Vector2d(1.0, -0.5)}) {
    const LocalPlanResult r = planner.Plan(cloud, JoystickRequest(joystick.x(), joystick.y()));
    ASSERT_NE(r.status, LocalPlanResult::Status::kInvalidInput) << r.message;
    if (r.status == LocalPlanResult::Status::kBoxedIn) {
      EXPECT_CONTAINS(r.message, "within 90 deg of the joystick direction");
      continue;
    }
    // Slides along the wall: never toward it, never more than 90 deg off the joystick.
    EXPECT_GE(ClosestApproachM(r.path_B, cloud, o), o.collision_radius_m);
    for (const Eigen::Vector3f& p : r.path_B) EXPECT_LT(p.x(), 0.8f - o.collision_radius_m);
    const TrajectoryInfo& info = planner.library().info(r.path_id);
    const double direction = std::atan2(joystick.y(), joystick.x());
    EXPECT_LE(AngleBetween(info.heading_rad, direction), kPi / 2 + 1e-5);
    EXPECT_LE(AngleBetween(info.end_bearing_rad, direction), kPi / 2 + 1e-5);
  }
  // Boxed in on three sides: stop rather than reverse.
  AddWall(&cloud, -4.0, 0.7, 0.8, 0.7);
  AddWall(&cloud, -4.0, -0.7, 0.8, -0.7);
  const LocalPlanResult r = planner.Plan(cloud, JoystickRequest(1.0, 0.0));
  EXPECT_EQ(r.status, LocalPlanResult::Status::kBoxedIn) << r.message;
  EXPECT_GT(r.num_free_paths, 0);  // Backwards would be free.
  EXPECT_EQ(r.num_candidate_paths, 0);
  EXPECT_CONTAINS(r.message, "boxed in: 0 of 12348 paths free for 3.00 m within 90 deg of the joystick");
}

// ---------------------------------------------------------------------------------------------------------
// Properties over random clouds

// A random cloud: uniform clutter, Gaussian clusters, wall segments, points outside the grid or the z band,
// and a few NaN/inf points.
Cloud RandomCloud(std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, 1.0);
  const int n = static_cast<int>(std::pow(u(*rng), 1.5) * 2000.0);
  Cloud cloud;
  cloud.reserve(static_cast<std::size_t>(n));
  const int kind = static_cast<int>(u(*rng) * 3.0);
  std::vector<Eigen::Vector2d> centres;
  for (int c = 0; c < 1 + static_cast<int>(u(*rng) * 8); ++c) {
    // NOLINTNEXTLINE(performance-inefficient-vector-operation): the bound is drawn anew on every pass
    centres.emplace_back((u(*rng) * 2 - 1) * 4.0, (u(*rng) * 2 - 1) * 4.0);
  }
  const double spread = 0.05 + 0.5 * u(*rng);
  while (static_cast<int>(cloud.size()) < n) {
    const double z = u(*rng) < 0.9 ? -0.2 + 1.6 * u(*rng) : (u(*rng) < 0.5 ? -1.0 : 2.0);
    double x = 0.0;
    double y = 0.0;
    const double pick = u(*rng);
    if (kind == 0 || pick < 0.2) {  // Uniform, some beyond the grid (+-4 m).
      x = (u(*rng) * 2 - 1) * 5.0;
      y = (u(*rng) * 2 - 1) * 5.0;
    } else if (kind == 1) {  // Clusters.
      const Eigen::Vector2d& c = centres[static_cast<std::size_t>(u(*rng) * centres.size())];
      x = c.x() + spread * g(*rng);
      y = c.y() + spread * g(*rng);
    } else {  // Wall segments through cluster centres.
      const std::size_t i = static_cast<std::size_t>(u(*rng) * centres.size());
      const Eigen::Vector2d& a = centres[i];
      const Eigen::Vector2d& b = centres[(i + 1) % centres.size()];
      const double t = u(*rng);
      x = a.x() + t * (b.x() - a.x()) + 0.02 * g(*rng);
      y = a.y() + t * (b.y() - a.y()) + 0.02 * g(*rng);
    }
    cloud.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  }
  if (n > 0 && u(*rng) < 0.3) {
    cloud[static_cast<std::size_t>(u(*rng) * n)] = Eigen::Vector3f(kNaN, 0.0f, 0.0f);
    cloud.emplace_back(1.0f, -kInf, 0.0f);
  }
  return cloud;
}

// Plans on `num_clouds` random clouds (seeded) with random goal / joystick requests and checks: the point
// counts add up; the chosen path, as far as its free length, keeps collision_radius_m from every obstacle
// point (geometry only); joystick choices stay within 90 deg; and, for every `brute_force_every`-th cloud,
// that the fast classification equals BruteForceFreeLengths(). Returns {found, boxed in} counts.
std::pair<int, int> CheckRandomClouds(LocalPlanner* planner, int num_clouds, int brute_force_every,
                                      std::uint32_t seed) {
  const TrajectoryLibrary& lib = planner->library();
  const TrajectoryLibraryOptions& o = lib.options();
  const double length_m = o.path_length_m;
  const double bucket_m = o.clearance_band_m / 254;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  LocalPlanResult r;
  int found = 0;
  int boxed = 0;
  for (int cloud_index = 0; cloud_index < num_clouds; ++cloud_index) {
    SCOPED_TRACE("cloud " + std::to_string(cloud_index));
    const Cloud cloud = RandomCloud(&rng);
    const double bearing = (u(rng) * 2 - 1) * kPi;
    const double distance = 0.2 + 5.0 * u(rng);
    LocalPlanRequest request = u(rng) < 0.7
                                   ? GoalRequest(distance * std::cos(bearing), distance * std::sin(bearing))
                                   : JoystickRequest(std::cos(bearing), std::sin(bearing));
    if (u(rng) < 0.3) request.previous_path_id = static_cast<int>(u(rng) * lib.num_paths());
    planner->Plan(cloud, request, &r);
    EXPECT_NE(r.status, LocalPlanResult::Status::kInvalidInput) << r.message;
    if (r.status == LocalPlanResult::Status::kInvalidInput) continue;
    EXPECT_EQ(
        r.num_points_used + r.num_points_outside_grid + r.num_points_outside_z_band + r.num_points_non_finite,
        static_cast<int>(cloud.size()));

    if (cloud_index % brute_force_every == 0) {
      // Fast classification == brute force (blocked-ness exact, free length and clearance to one step).
      std::vector<double> clearance;
      const std::vector<double> brute =
          BruteForceFreeLengths(lib, cloud, r.required_free_length_m, &clearance);
      int free_paths = 0;
      int mismatches = 0;
      for (int p = 0; p < lib.num_paths() && mismatches < 5; ++p) {
        const double fast = planner->free_length_m(p);
        const double ref = brute[static_cast<std::size_t>(p)];
        const bool ok =
            (fast < length_m - 1e-9) == (ref < length_m - 1e-9) &&
            std::abs(fast - ref) <= lib.sample_spacing_m() + 1e-9 &&
            std::abs(planner->clearance_m(p) - clearance[static_cast<std::size_t>(p)]) <= bucket_m + 1e-9;
        if (!ok) {
          ++mismatches;
          ADD_FAILURE() << "path " << p << ": fast free " << fast << " m clearance "
                        << planner->clearance_m(p) << " m, brute force free " << ref << " m clearance "
                        << clearance[static_cast<std::size_t>(p)] << " m";
        }
        if (ref >= r.required_free_length_m - 1e-9) ++free_paths;
        EXPECT_EQ(r.IsFree(p), fast >= r.required_free_length_m - 1e-9) << "path " << p;
      }
      EXPECT_EQ(r.num_free_paths, free_paths);
    }

    if (r.status == LocalPlanResult::Status::kBoxedIn) {
      ++boxed;
      EXPECT_EQ(r.num_candidate_paths, 0);
      EXPECT_CONTAINS(r.message, "boxed in: 0 of " + std::to_string(lib.num_paths()) + " paths free");
      continue;
    }
    ++found;
    // The chosen path, as far as its free length, keeps collision_radius_m from every obstacle point...
    EXPECT_EQ(r.path_B.size(),
              static_cast<std::size_t>(std::lround(r.free_length_m / lib.sample_spacing_m())) + 1);
    EXPECT_GE(r.free_length_m, r.required_free_length_m - 1e-9);
    // ... or, from a point the robot already stands inside that radius of, not closer than it stands.
    EXPECT_LE(WorstShortfallM(r.path_B, cloud, o, lib.near_origin_radius_m()), 1e-9) << "path " << r.path_id;
    if (request.mode == LocalPlanMode::kJoystick) {
      EXPECT_LE(AngleBetween(lib.info(r.path_id).heading_rad, bearing), kPi / 2 + 1e-5);
      EXPECT_LE(AngleBetween(lib.info(r.path_id).end_bearing_rad, bearing), kPi / 2 + 1e-5);
    }
  }
  return {found, boxed};
}

TEST(LocalPlannerPropertyTest, DefaultLibraryNeverCrossesAnObstacleAndMatchesBruteForce) {
  LocalPlanner planner(DefaultLibrary());
  // Brute force on every 5th cloud: it costs ~0.1 ms per point with 12,348 paths.
  const auto [found, boxed] = CheckRandomClouds(&planner, 200, 5, 20240611u);
  // The clouds exercise both outcomes.
  EXPECT_GT(found, 50);
  EXPECT_GT(boxed, 5);
}

TEST(LocalPlannerPropertyTest, OddSizedLibraryMatchesBruteForce) {
  // Arcs that do not end on samples (43 samples of 0.0698 m for 3 arcs), a coarser grid, other radii.
  TrajectoryLibraryOptions o;
  o.num_groups = 5;
  o.paths_per_group = 25;
  o.num_headings = 16;
  o.sample_spacing_m = 0.07;
  o.voxel_size_m = 0.15;
  o.clearance_voxel_size_m = 0.25;
  o.collision_radius_m = 0.3;
  o.clearance_band_m = 0.4;
  o.max_segment_turn_rad = 0.6;
  auto library = std::make_shared<const TrajectoryLibrary>(o);
  ASSERT_EQ(library->samples_per_path(), 43);
  ASSERT_EQ(library->num_paths(), 2000);
  LocalPlanner planner(library);
  const auto [found, boxed] = CheckRandomClouds(&planner, 200, 1, 777u);
  EXPECT_GT(found, 50);
  EXPECT_GT(boxed, 5);
}

TEST(LocalPlannerTest, SteadyStateCycleDoesNotAllocate) {
  LocalPlanner planner(DefaultLibrary());
  std::mt19937 rng(7);
  std::vector<Cloud> clouds;
  clouds.reserve(5);
  for (int i = 0; i < 5; ++i) clouds.push_back(RandomCloud(&rng));
  Cloud ring;
  AddRing(&ring, 1.0);
  clouds.push_back(ring);
  LocalPlanResult r;
  planner.Plan(clouds[0], GoalRequest(3.0, 1.0), &r);  // Grows the result's buffers.
  g_allocations = 0;
  g_count_allocations = true;
  for (const Cloud& cloud : clouds) {
    planner.Plan(cloud, GoalRequest(3.0, 1.0), &r);
    planner.Plan(cloud, JoystickRequest(-1.0, 0.0), &r);
    planner.Plan(cloud, GoalRequest(std::nan(""), 0.0), &r);
  }
  g_count_allocations = false;
  EXPECT_EQ(g_allocations.load(), 0);
}

}  // namespace
}  // namespace cairn::nav
