// Local planner benchmark: one LocalPlanner::Plan() cycle (FALCO-style trajectory library with the voxel ->
// path correspondence, cairn/nav/local_planner.h) beside the brute-force reference BruteForceFreeLengths()
// on the same clouds, computing the same per-path free lengths and clearances without the correspondence
// (every path, every point in the bounding box of each arc, every sample of the arc), measured in the same
// process on one thread. "agree" counts paths whose free length and clearance are identical in both. Clouds
// are seeded and look like a mine tunnel seen by a 3D lidar: rough walls, floor and roof (outside the
// obstacle z band), and clutter (boxes), all within the sensor range.
//
// Usage: cairn_bench_local_planner [--runs N] [--brute-runs M] [--range R_m]
//   N: Plan() cycles per cloud size (default 300), M: brute-force runs per cloud size (default 3),
//   R: sensor range (default 10 m).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/nav/local_planner.h"

namespace {

using cairn::bench::Median;

using Clock = std::chrono::steady_clock;
using cairn::nav::BruteForceFreeLengths;
using cairn::nav::LocalPlanner;
using cairn::nav::LocalPlanRequest;
using cairn::nav::LocalPlanResult;
using cairn::nav::TrajectoryLibrary;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

double Percentile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * v.size()))];
}

// A tunnel along x (frame B: robot 0.45 m above the floor, looking along the tunnel), `n` points within
// `range_m` (planar) of the robot. Shares: walls 45 %, floor 25 %, roof 10 %, clutter 20 %.
std::vector<Eigen::Vector3f> TunnelCloud(int n, double range_m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.03);
  auto half_width = [](double x) { return 1.9 + 0.35 * std::sin(0.37 * x) + 0.15 * std::sin(1.3 * x + 1.0); };
  struct Box {
    double x, y, sx, sy, h;
  };
  std::vector<Box> boxes;
  while (boxes.size() < 14) {
    Box b;
    b.x = (u01(rng) * 2.0 - 1.0) * range_m;
    b.sx = 0.2 + 0.6 * u01(rng);
    b.sy = 0.2 + 0.6 * u01(rng);
    b.h = 0.3 + 1.5 * u01(rng);
    b.y = (u01(rng) * 2.0 - 1.0) * (half_width(b.x) - 0.3);
    if (std::hypot(b.x, b.y) < 1.2) continue;  // Not on the robot.
    boxes.push_back(b);
  }
  std::vector<Eigen::Vector3f> cloud;
  cloud.reserve(static_cast<std::size_t>(n));
  while (static_cast<int>(cloud.size()) < n) {
    const double kind = u01(rng);
    double x = (u01(rng) * 2.0 - 1.0) * range_m;
    double y = 0.0;
    double z = 0.0;
    if (kind < 0.45) {  // Walls, up to the roof.
      y = (u01(rng) < 0.5 ? -1.0 : 1.0) * half_width(x) + noise(rng);
      z = -0.45 + 3.0 * u01(rng);
      x += noise(rng);
    } else if (kind < 0.70) {  // Floor (below the obstacle band).
      y = (u01(rng) * 2.0 - 1.0) * half_width(x);
      z = -0.45 + 0.3 * noise(rng);
    } else if (kind < 0.80) {  // Roof (above the band).
      y = (u01(rng) * 2.0 - 1.0) * half_width(x);
      z = 2.55 + noise(rng);
    } else {  // Clutter: box surfaces.
      const Box& b = boxes[static_cast<std::size_t>(u01(rng) * boxes.size())];
      const double side = u01(rng);
      const double t = u01(rng) * 2.0 - 1.0;
      if (side < 0.25) {
        x = b.x - b.sx / 2, y = b.y + t * b.sy / 2;
      } else if (side < 0.5) {
        x = b.x + b.sx / 2, y = b.y + t * b.sy / 2;
      } else if (side < 0.75) {
        x = b.x + t * b.sx / 2, y = b.y - b.sy / 2;
      } else {
        x = b.x + t * b.sx / 2, y = b.y + b.sy / 2;
      }
      x += noise(rng) * 0.3;
      y += noise(rng) * 0.3;
      z = -0.45 + b.h * u01(rng);
    }
    if (std::hypot(x, y) > range_m) continue;
    cloud.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  }
  return cloud;
}

}  // namespace

int main(int argc, char** argv) {
  int runs = 300;
  int brute_runs = 3;
  double range_m = 10.0;
  cairn::nav::TrajectoryLibraryOptions library_options;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--runs") && i + 1 < argc) {
      runs = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--brute-runs") && i + 1 < argc) {
      brute_runs = std::max(1, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--range") && i + 1 < argc) {
      range_m = std::atof(argv[++i]);
    } else if (!std::strcmp(argv[i], "--voxel") && i + 1 < argc) {
      library_options.voxel_size_m = std::atof(argv[++i]);  // the agent ships 0.05 m (config/agent.yaml)
    } else if (!std::strcmp(argv[i], "--collision-radius") && i + 1 < argc) {
      library_options.collision_radius_m = std::atof(argv[++i]);  // the agent: footprint 0.3 + margin 0.03
    } else {
      std::fprintf(stderr,
                   "usage: %s [--runs N] [--brute-runs M] [--range R_m] [--voxel M] [--collision-radius M]\n",
                   argv[0]);
      return 2;
    }
  }

  std::string why;
  if (!library_options.IsValid(&why)) {
    std::fprintf(stderr, "%s\n", why.c_str());
    return 2;
  }
  auto library = std::make_shared<const TrajectoryLibrary>(library_options);
  std::printf(
      "library: %d paths (%d headings x %d), %d samples each, %d tree nodes, %d x %d voxels of %.2f m\n",
      library->num_paths(), library->num_kept_headings(), library->paths_per_heading(),
      library->samples_per_path(), library->num_nodes(), library->grid_size(), library->grid_size(),
      library->options().voxel_size_m);
  std::printf("library: build %.3f s, memory %.1f MB (%zu blocking + %zu band entries)\n",
              library->build_time_s(), library->memory_bytes() / 1e6, library->num_blocking_entries(),
              library->num_band_entries());
  LocalPlanner planner(library);
  LocalPlanRequest request;
  request.goal_B = Eigen::Vector2d(8.0, 0.0);
  LocalPlanResult result;

  std::printf(
      "\nPlan(): one cycle (median / 99th percentile of %d). brute: BruteForceFreeLengths() with the\n"
      "clearances (the same outputs as Plan() before scoring; median of %d); brute-free: free lengths\n"
      "only (it stops at a path's first blocked sample). Ratios: brute time / Plan() time.\n",
      runs, brute_runs);
  std::printf("\n%7s %6s %6s %9s %9s %10s %8s %11s %8s %11s\n", "points", "used", "voxels", "plan ms",
              "p99 ms", "brute ms", "ratio", "brute-free", "ratio", "agree");
  for (int n : {10000, 20000, 50000}) {
    const std::vector<Eigen::Vector3f> cloud = TunnelCloud(n, range_m, 1000u + static_cast<std::uint32_t>(n));
    // Warm-up (caches, and the CPU clock, which needs a few hundred ms to ramp up on some machines).
    for (const auto t0 = Clock::now(); Seconds(t0, Clock::now()) < 0.5;)
      planner.Plan(cloud, request, &result);
    std::vector<double> plan_s;
    plan_s.reserve(static_cast<std::size_t>(runs));
    for (int r = 0; r < runs; ++r) {
      const auto t0 = Clock::now();
      planner.Plan(cloud, request, &result);
      plan_s.push_back(Seconds(t0, Clock::now()));
    }
    std::vector<double> brute_s;
    std::vector<double> brute_free_s;
    std::vector<double> brute;
    std::vector<double> brute_clearance;
    for (int r = 0; r < brute_runs; ++r) {
      auto t0 = Clock::now();
      brute = BruteForceFreeLengths(*library, cloud, result.required_free_length_m, &brute_clearance);
      brute_s.push_back(Seconds(t0, Clock::now()));
      t0 = Clock::now();
      const std::vector<double> free_only =
          BruteForceFreeLengths(*library, cloud, result.required_free_length_m);
      brute_free_s.push_back(Seconds(t0, Clock::now()));
      if (free_only != brute) std::printf("brute force free lengths differ with and without clearances\n");
    }
    int agree = 0;
    for (int p = 0; p < library->num_paths(); ++p) {
      const std::size_t i = static_cast<std::size_t>(p);
      agree += brute[i] == planner.free_length_m(p) && brute_clearance[i] == planner.clearance_m(p);
    }
    const double plan_ms = Median(plan_s) * 1e3;
    const double brute_ms = Median(brute_s) * 1e3;
    const double brute_free_ms = Median(brute_free_s) * 1e3;
    std::printf("%7d %6d %6d %9.3f %9.3f %10.1f %8.0f %11.1f %8.0f %5d/%d\n", n, result.num_points_used,
                result.num_occupied_voxels, plan_ms, Percentile(plan_s, 0.99) * 1e3, brute_ms,
                brute_ms / plan_ms, brute_free_ms, brute_free_ms / plan_ms, agree, library->num_paths());
    std::printf("        -> %s: %s\n", cairn::nav::ToString(result.status), result.message.c_str());
  }

  // Points near the robot (within near_origin_radius_m()) are tested against every path's first samples
  // exactly instead of through the correspondence. Their cost, in two tight spots added to the 20k tunnel
  // cloud: the robot 0.1 m off the centre of a 1.0 m doorway (jambs 0.4 and 0.6 m away), and wedged 0.32 m
  // from a wall's end (inside the collision radius). Baseline: the same cloud without the spot's points.
  // Paths must be free for 1.5 m, as the agent's.
  std::printf("\nnear points (within %.3f m): Plan() median of %d, same cloud without the spot = baseline\n",
              library->near_origin_radius_m(), runs);
  std::printf("%-26s %6s %9s %9s %9s %7s %s\n", "spot", "near", "plan ms", "p99 ms", "base ms", "ratio",
              "outcome");
  const std::vector<Eigen::Vector3f> tunnel = TunnelCloud(20000, range_m, 21000u);
  struct Spot {
    const char* name;
    std::vector<Eigen::Vector3f> points;
  };
  Spot doorway{"doorway 1.0 m, 0.1 m off", {}};
  Spot wedge{"wedged 0.32 m from a wall", {}};
  for (double x = -0.1; x <= 0.1 + 1e-9; x += 0.02) {
    for (double z = -0.3; z <= 1.0; z += 0.05) {
      doorway.points.emplace_back(x, 0.4, z);
      doorway.points.emplace_back(x, -0.6, z);
    }
  }
  for (double x = -1.5; x <= 0.0 + 1e-9; x += 0.02) {  // a wall ending at x = 0, 0.32 m to the left
    for (double z = -0.3; z <= 1.0; z += 0.05) wedge.points.emplace_back(x, 0.32, z);
  }
  request.max_required_free_length_m = 1.5;  // the agent's navigation.required_free_length_m
  for (const Spot& spot : {doorway, wedge}) {
    std::vector<Eigen::Vector3f> cloud = tunnel;
    cloud.insert(cloud.end(), spot.points.begin(), spot.points.end());
    auto median_ms = [&](const std::vector<Eigen::Vector3f>& c, double* p99_ms) {
      for (int r = 0; r < 20; ++r) planner.Plan(c, request, &result);
      std::vector<double> s;
      for (int r = 0; r < runs; ++r) {
        const auto t0 = Clock::now();
        planner.Plan(c, request, &result);
        s.push_back(Seconds(t0, Clock::now()));
      }
      if (p99_ms != nullptr) *p99_ms = Percentile(s, 0.99) * 1e3;
      return Median(s) * 1e3;
    };
    const double base_ms = median_ms(tunnel, nullptr);
    double p99_ms = 0.0;
    const double spot_ms = median_ms(cloud, &p99_ms);
    int near = 0;
    for (const auto& p : cloud) {
      near += p.z() >= library->options().obstacle_min_z_m && p.z() <= library->options().obstacle_max_z_m &&
              p.head<2>().norm() < library->near_origin_radius_m();
    }
    std::printf("%-26s %6d %9.3f %9.3f %9.3f %7.2f %s\n", spot.name, near, spot_ms, p99_ms, base_ms,
                spot_ms / base_ms, result.message.c_str());
  }
  return 0;
}
