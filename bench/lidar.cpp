// Simulated sensor benchmark: rays per second of the simulated lidar (cairn/sim/lidar.h, exact voxel
// traversal, Amanatides & Woo 1987) for full 16 x 1800 scans at several poses in builtin:tunnels and the real
// scan geb079.bt, beside a baseline measured in the same run on the same rays: naive fixed-step ray marching
// (step = resolution / 4, World::IsOccupied() at every step). Also ms per full scan, the fraction of one
// core a robot's lidar at 10 Hz needs, and ms per 320 x 240 shaded depth frame (cairn/sim/camera.h).
// One thread, thread CPU time. Usage: cairn_bench_lidar [path/to/geb079.bt] [--repeats N]
#include "cairn/sim/lidar.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/core/build_paths.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/camera.h"
#include "cairn/sim/world.h"

namespace {

using cairn::bench::Median;

// CPU time of the calling thread: time spent descheduled on a shared machine does not count, so the
// figures are per core actually used (cache sharing with other processes still shows).
struct Clock {
  using time_point = std::chrono::duration<double, std::milli>;
  static time_point now() {
    timespec ts{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return time_point(ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6);
  }
};
using cairn::sim::World;

double Ms(Clock::time_point a, Clock::time_point b) { return (b - a).count(); }

// Baseline: march along the ray in fixed steps of resolution / 4 and return the first sample's range that
// falls in an occupied voxel (overshoots the true range by up to one step; may skip voxel corners).
std::optional<double> NaiveMarch(const World& world, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                 double max_range_m) {
  const double step_m = world.resolution_m() / 4.0;
  for (double t = 0.0; t <= max_range_m; t += step_m) {
    if (world.IsOccupied(o + t * d)) return t;
  }
  return std::nullopt;
}

struct Case {
  const char* name;
  const World* world;
  Eigen::Vector3d p_W_S;
  double yaw_rad;
};

struct Totals {
  double rays = 0.0;
  double dda_ms = 0.0;
  double naive_ms = 0.0;
  std::vector<double> scan_ms;
  std::vector<double> frame_ms;
  double best_scan_ms = 1e300;  // Fastest single scan over all poses and repeats: least disturbed by load.
};

void RunCase(const Case& c, int repeats, Totals* totals) {
  Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
  T_W_S.translation() = c.p_W_S;
  T_W_S.linear() = Eigen::AngleAxisd(c.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  if (c.world->IsOccupied(c.p_W_S)) std::printf("warning: %s: sensor inside an occupied voxel\n", c.name);

  // Full scans as a robot would run them (noise, points in S), and the same rays through CastRay() alone
  // and through the naive march, interleaved so that all three see the same load on a shared machine.
  cairn::sim::SimulatedLidar lidar(cairn::sim::LidarOptions{});
  cairn::sim::LidarScan scan;
  const double max_range_m = lidar.options().max_range_m;
  std::vector<Eigen::Vector3d> dirs_W;
  for (const Eigen::Vector3d& d_S : lidar.directions_S()) dirs_W.emplace_back(T_W_S.linear() * d_S);
  std::vector<double> dda_ranges(dirs_W.size(), -1.0);
  std::vector<double> naive_ranges(dirs_W.size(), -1.0);
  std::vector<double> scan_ms;
  std::vector<double> dda_ms;
  std::vector<double> naive_ms;
  for (int r = 0; r < repeats; ++r) {
    auto a = Clock::now();
    lidar.Scan(*c.world, T_W_S, &scan);
    scan_ms.push_back(Ms(a, Clock::now()));
    a = Clock::now();
    for (std::size_t i = 0; i < dirs_W.size(); ++i) {
      const auto hit = cairn::sim::CastRay(*c.world, c.p_W_S, dirs_W[i], max_range_m);
      dda_ranges[i] = hit ? hit->range_m : -1.0;
    }
    dda_ms.push_back(Ms(a, Clock::now()));
    if (r % 4 != 0) continue;  // The baseline is slow: every 4th repeat.
    a = Clock::now();
    for (std::size_t i = 0; i < dirs_W.size(); ++i) {
      naive_ranges[i] = NaiveMarch(*c.world, c.p_W_S, dirs_W[i], max_range_m).value_or(-1.0);
    }
    naive_ms.push_back(Ms(a, Clock::now()));
  }
  // Agreement: both miss, or both hit with the naive range in [exact, exact + step].
  int agree = 0;
  const double step_m = c.world->resolution_m() / 4.0;
  for (std::size_t i = 0; i < dirs_W.size(); ++i) {
    const double e = dda_ranges[i];
    const double n = naive_ranges[i];
    if ((e < 0.0 && n < 0.0) || (e >= 0.0 && n >= e - 1e-9 && n <= e + step_m + 1e-9)) ++agree;
  }

  // Camera frames from the same pose.
  cairn::sim::GrayImage image;
  std::vector<double> frame_ms;
  for (int r = 0; r < repeats; ++r) {
    const auto a = Clock::now();
    cairn::sim::RenderShadedDepth(*c.world, T_W_S, cairn::sim::CameraOptions{}, &image);
    frame_ms.push_back(Ms(a, Clock::now()));
  }

  const double rays = static_cast<double>(dirs_W.size());
  const double scan_median_ms = Median(scan_ms);
  const double dda = Median(dda_ms);
  const double naive = Median(naive_ms);
  std::printf("%-18s %7.1f%% %9.2f %11.2f %12.2f %9.2f %8.1fx %7.2f%% %9.2f\n", c.name,
              100.0 * scan.returns / rays, scan_median_ms, rays / dda * 1e-3, rays / naive * 1e-3, naive,
              naive / dda, 100.0 * agree / rays, Median(frame_ms));
  totals->rays += rays;
  totals->dda_ms += dda;
  totals->naive_ms += naive;
  totals->scan_ms.push_back(scan_median_ms);
  totals->best_scan_ms = std::min(totals->best_scan_ms, *std::min_element(scan_ms.begin(), scan_ms.end()));
  totals->frame_ms.push_back(Median(frame_ms));
}

}  // namespace

int main(int argc, char** argv) {
  std::string geb079_path = cairn::core::SourceDir() + "/data/geb079.bt";
  int repeats = 20;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else if (argv[i][0] == '-') {
      std::fprintf(stderr, "usage: %s [path/to/geb079.bt] [--repeats N]\n", argv[0]);
      return 2;
    } else {
      geb079_path = argv[i];
    }
  }

  const World tunnels = cairn::sim::MakeBuiltinWorld("tunnels");
  std::vector<Case> cases = {
      {"tunnels/tunnel", &tunnels, {4.0, 20.0, 0.5}, 0.0},
      {"tunnels/junction", &tunnels, {30.0, 20.0, 0.5}, 0.3},
      {"tunnels/room", &tunnels, {49.0, 19.0, 0.5}, 0.5},
  };
  std::optional<World> geb079;
  if (std::filesystem::exists(geb079_path)) {
    geb079.emplace(cairn::sim::LoadWorld(geb079_path));
    cases.push_back({"geb079/west", &*geb079, {-4.0, 0.0, 0.5}, 0.0});
    cases.push_back({"geb079/middle", &*geb079, {6.0, 0.0, 0.5}, 0.0});
    cases.push_back({"geb079/east", &*geb079, {20.0, 0.0, 0.5}, 3.1});
  } else {
    std::printf("geb079: %s is absent (no data/ in the repository); measuring builtin:tunnels only\n",
                geb079_path.c_str());
  }

  const cairn::sim::LidarOptions lidar_options;
  std::printf(
      "lidar %d x %d rays per scan, 0.3-30 m, one thread, thread CPU time, median of %d repeats "
      "(naive: %d)\n",
      lidar_options.num_beams, lidar_options.points_per_beam, repeats, (repeats + 3) / 4);
  std::printf("%-18s %8s %9s %11s %12s %9s %9s %8s %9s\n", "pose", "returns", "scan ms", "DDA Mray/s",
              "naive Mray/s", "naive ms", "speedup", "agree", "frame ms");
  Totals totals;
  for (const Case& c : cases) RunCase(c, repeats, &totals);

  const double rays_per_s = totals.rays / totals.dda_ms * 1e3;
  const double ratio = totals.naive_ms / totals.dda_ms;
  const double scan_ms = Median(totals.scan_ms);
  const double core_fraction = scan_ms * lidar_options.rate_hz / 1e3;
  std::printf(
      "all poses: DDA %.2f Mrays/s, naive march %.2f Mrays/s, ratio %.1fx; scan %.2f ms median, %.2f ms "
      "fastest (%.1f%% of one core per robot at %.0f Hz); camera %.2f ms per 320x240 frame median\n",
      rays_per_s * 1e-6, totals.rays / totals.naive_ms * 1e-3, ratio, scan_ms, totals.best_scan_ms,
      100.0 * core_fraction, lidar_options.rate_hz, Median(totals.frame_ms));
  // A robot standing still (most of a real-time test's robots, most of the time): the simulator's scans of a
  // shared world from an unchanged pose reuse the true ranges and draw only the noise.
  {
    const auto shared = std::make_shared<const World>(tunnels);
    Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
    T_W_S.translation() = cases.front().p_W_S;
    cairn::sim::SimulatedLidar still(lidar_options);
    cairn::sim::SimulatedLidar casting(lidar_options);
    cairn::sim::LidarScan scan;
    std::vector<double> still_ms;
    std::vector<double> cast_ms;
    for (int r = 0; r < repeats; ++r) {
      auto a = Clock::now();
      still.Scan(shared, T_W_S, &scan);
      still_ms.push_back(Ms(a, Clock::now()));
      a = Clock::now();
      casting.Scan(*shared, T_W_S, &scan);
      cast_ms.push_back(Ms(a, Clock::now()));
    }
    std::printf("still sensor (%s): %.2f ms per scan reusing its true ranges, %.2f ms casting: %.1fx\n",
                cases.front().name, Median(still_ms), Median(cast_ms), Median(cast_ms) / Median(still_ms));
    std::printf("FIGURE lidar_still_ms_per_scan %.3f\n", Median(still_ms));
    std::printf("FIGURE lidar_still_speedup %.2f\n", Median(cast_ms) / Median(still_ms));
  }
  std::printf("FIGURE lidar_rays_per_s %.0f\n", rays_per_s);
  std::printf("FIGURE lidar_speedup_vs_naive_march %.2f\n", ratio);
  std::printf("FIGURE lidar_ms_per_scan %.3f\n", scan_ms);
  std::printf("FIGURE lidar_ms_per_scan_fastest %.3f\n", totals.best_scan_ms);
  std::printf("FIGURE lidar_core_fraction_at_10hz %.4f\n", core_fraction);
  std::printf("FIGURE camera_ms_per_frame %.3f\n", Median(totals.frame_ms));
  std::printf(
      "note: 'agree' counts rays where the naive march hits within one step behind the exact hit (or both "
      "miss); the rest are voxel corners it stepped over or hits it found one step late at a face\n");
  return 0;
}
