// Map telemetry benchmark: bits per second per robot of the coarse DELTA stream (perception/map_telemetry.h)
// while a synthetic robot explores, beside the baseline of sending the whole robot OctoMap (writeBinary +
// zstd) every period, measured in the same run; plus encode/decode/apply time per message and the size of a
// late joiner's snapshot.
//
// Scene: a rough-walled corridor (x in [0, 40] m, ~3 m wide, ~3 m high) opening into a 20 x 20 x 4 m room
// with pillars and boxes. A ground robot drives along y = 0 at --speed m/s; a simulated 16-beam lidar (+-15
// deg, --points-per-beam points per beam, 30 m) is inserted into a 0.1 m octomap::OcTree every
// --insert-period s (config/agent.yaml: 0.2 s). Every 0.5 s (map_period_s) the coarse voxels at
// 0.1 * 2^--levels m that changed are handed to MapTelemetrySender (what the mapping library's
// TakeCoarseChanges() returns).
//
// Usage: cairn_bench_map_telemetry [--points-per-beam N] [--insert-period S] [--levels L] [--speed MPS]
#include "cairn/perception/map_telemetry.h"

#include <fcntl.h>
#include <octomap/OcTree.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <unordered_map>
#include <vector>

namespace {

using cairn::perception::CoarseState;
using cairn::perception::CoarseVoxel;
using cairn::perception::MapTelemetryOptions;
using cairn::perception::MapTelemetrySender;
using cairn::perception::MapUpdate;
using Clock = std::chrono::steady_clock;

double Us(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::micro>(b - a).count();
}

struct Box {
  double x0, x1, y0, y1, z0, z1;
  bool Contains(double x, double y, double z) const {
    return x >= x0 && x < x1 && y >= y0 && y < y1 && z >= z0 && z < z1;
  }
};

// Free space of the scene: the corridor (with rough walls and ceiling) and the room, minus obstacles.
class Scene {
 public:
  Scene() {
    // Wall roughness: a smooth random profile per 0.1 m of x (seeded, deterministic).
    std::uint32_t s = 12345;
    const auto rnd = [&s] {
      s = s * 1664525u + 1013904223u;
      return static_cast<double>(s >> 8) / static_cast<double>(1u << 24);
    };
    double a = 0.0, b = 0.0, c = 0.0;
    for (int i = 0; i < 420; ++i) {
      a = 0.8 * a + 0.2 * (rnd() - 0.5) * 0.6;
      b = 0.8 * b + 0.2 * (rnd() - 0.5) * 0.6;
      c = 0.8 * c + 0.2 * (rnd() - 0.5) * 0.6;
      left_.push_back(1.5 + a);
      right_.push_back(-1.5 + b);
      ceiling_.push_back(3.0 + c);
    }
    obstacles_ = {{44, 45, -6, -5, 0, 4},       {50, 51, 3, 4, 0, 4},          {55, 56, -2, -1, 0, 4},
                  {47, 48.2, 6, 7.5, 0, 0.8},   {53, 54, -8, -7.2, 0, 1.2},    {42, 43.5, 8, 9, 0, 2.0},
                  {20, 20.4, 1.0, 1.4, 0, 1.0}, {30, 30.6, -1.3, -0.9, 0, 0.6}};
  }

  bool Free(double x, double y, double z) const {
    bool inside = false;
    if (x >= 0.0 && x < 40.0 && z >= 0.0) {
      const auto i = static_cast<std::size_t>(x * 10.0);
      inside = y < left_[i] && y > right_[i] && z < ceiling_[i];
    } else if (x >= 40.0 && x < 60.0) {
      inside = y > -10.0 && y < 10.0 && z >= 0.0 && z < 4.0;
    }
    if (!inside) return false;
    for (const Box& o : obstacles_) {
      if (o.Contains(x, y, z)) return false;
    }
    return true;
  }

 private:
  std::vector<double> left_, right_, ceiling_;
  std::vector<Box> obstacles_;
};

// A 16-beam lidar scan from `origin`: the hit points (rays that leave free space), up to max_range_m.
octomap::Pointcloud Scan(const Scene& scene, const octomap::point3d& origin, int points_per_beam,
                         double max_range_m) {
  octomap::Pointcloud cloud;
  const double step_m = 0.1;
  for (int beam = 0; beam < 16; ++beam) {
    const double elevation = (-15.0 + 2.0 * beam) * M_PI / 180.0;
    for (int k = 0; k < points_per_beam; ++k) {
      const double azimuth = 2.0 * M_PI * (k + 0.5 * (beam % 2)) / points_per_beam;
      const double dx = std::cos(elevation) * std::cos(azimuth);
      const double dy = std::cos(elevation) * std::sin(azimuth);
      const double dz = std::sin(elevation);
      double lo = 0.0, hi = -1.0;
      for (double r = step_m; r <= max_range_m; r += step_m) {
        if (!scene.Free(origin.x() + r * dx, origin.y() + r * dy, origin.z() + r * dz)) {
          hi = r;
          break;
        }
        lo = r;
      }
      if (hi < 0.0) continue;           // No return within range.
      for (int it = 0; it < 7; ++it) {  // Bisection to ~1 mm.
        const double mid = 0.5 * (lo + hi);
        (scene.Free(origin.x() + mid * dx, origin.y() + mid * dy, origin.z() + mid * dz) ? lo : hi) = mid;
      }
      cloud.push_back(static_cast<float>(origin.x() + hi * dx), static_cast<float>(origin.y() + hi * dy),
                      static_cast<float>(origin.z() + hi * dz));
    }
  }
  return cloud;
}

std::uint64_t Key(const CoarseVoxel& v) {
  return (static_cast<std::uint64_t>(v.ix + (1 << 20)) << 42) |
         (static_cast<std::uint64_t>(v.iy + (1 << 20)) << 21) | static_cast<std::uint64_t>(v.iz + (1 << 20));
}

// The coarse map of `tree`, `levels` above its resolution: a coarse voxel is occupied if its node is
// (OctoMap's max-of-children rule), free if known and not occupied.
std::vector<CoarseVoxel> CoarseMap(const octomap::OcTree& tree, int levels) {
  const double coarse_m = tree.getResolution() * (1 << levels);
  const unsigned depth = tree.getTreeDepth() - static_cast<unsigned>(levels);
  std::vector<CoarseVoxel> out;
  for (auto it = tree.begin_leafs(depth), end = tree.end_leafs(); it != end; ++it) {
    const CoarseState state = tree.isNodeOccupied(*it) ? CoarseState::kOccupied : CoarseState::kFree;
    const double size = it.getSize();
    const int n = std::max(1, static_cast<int>(std::lround(size / coarse_m)));
    const octomap::point3d c = it.getCoordinate();
    const double x0 = c.x() - 0.5 * size, y0 = c.y() - 0.5 * size, z0 = c.z() - 0.5 * size;
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b)
        for (int d = 0; d < n; ++d) {
          CoarseVoxel v;
          v.ix = static_cast<std::int32_t>(std::floor((x0 + (a + 0.5) * coarse_m) / coarse_m));
          v.iy = static_cast<std::int32_t>(std::floor((y0 + (b + 0.5) * coarse_m) / coarse_m));
          v.iz = static_cast<std::int32_t>(std::floor((z0 + (d + 0.5) * coarse_m) / coarse_m));
          v.state = state;
          out.push_back(v);
        }
  }
  return out;
}

std::size_t ZstdSize(const std::string& bytes, int level) {
  std::vector<char> out(ZSTD_compressBound(bytes.size()));
  const std::size_t n = ZSTD_compress(out.data(), out.size(), bytes.data(), bytes.size(), level);
  return ZSTD_isError(n) ? 0 : n;
}

struct Percentiles {
  double median = 0, p99 = 0, max = 0;
};
Percentiles Summarize(std::vector<double> v) {
  Percentiles p;
  if (v.empty()) return p;
  std::sort(v.begin(), v.end());
  p.median = v[v.size() / 2];
  p.p99 = v[std::min(v.size() - 1, v.size() * 99 / 100)];
  p.max = v.back();
  return p;
}

// Largest number of bits in any window of `window_s` seconds of (time, bits) samples.
double PeakBits(const std::vector<std::pair<double, double>>& samples, double window_s) {
  double peak = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    double bits = 0.0;
    for (std::size_t j = i; j < samples.size() && samples[j].first < samples[i].first + window_s; ++j) {
      bits += samples[j].second;
    }
    peak = std::max(peak, bits);
  }
  return peak;
}

}  // namespace

int main(int argc, char** argv) {
  int points_per_beam = 180;  // config/agent.yaml has 1800; 180 keeps the bench near a minute.
  double insert_period_s = 0.2;
  int levels = 1;
  double speed_mps = 1.0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--points-per-beam") && i + 1 < argc) {
      points_per_beam = std::max(8, std::atoi(argv[++i]));
    } else if (!std::strcmp(argv[i], "--insert-period") && i + 1 < argc) {
      insert_period_s = std::max(0.05, std::atof(argv[++i]));
    } else if (!std::strcmp(argv[i], "--levels") && i + 1 < argc) {
      levels = std::clamp(std::atoi(argv[++i]), 0, 4);
    } else if (!std::strcmp(argv[i], "--speed") && i + 1 < argc) {
      speed_mps = std::clamp(std::atof(argv[++i]), 0.1, 5.0);
    } else {
      std::fprintf(stderr, "usage: %s [--points-per-beam N] [--insert-period S] [--levels L] [--speed MPS]\n",
                   argv[0]);
      return 2;
    }
  }
  const double fine_m = 0.1;
  const double coarse_m = fine_m * (1 << levels);
  const double period_s = 0.5;
  const double end_x_m = 57.0;
  const double duration_s = (end_x_m - 1.0) / speed_mps;
  const int overhead_bytes = MapTelemetryOptions{}.per_message_overhead_bytes;
  const std::size_t max_message_bytes = MapTelemetryOptions{}.max_message_bytes;

  Scene scene;
  octomap::OcTree tree(fine_m);
  MapTelemetryOptions unlimited_options;
  unlimited_options.budget_bits_per_s = 1e8;  // Demand: what the stream would use without a budget.
  MapTelemetrySender unlimited("r1", coarse_m, unlimited_options);
  MapTelemetrySender budgeted("r1", coarse_m);  // Defaults: 100 kbit/s.
  cairn::perception::FleetMap base;
  std::unordered_map<std::uint64_t, CoarseState> coarse;  // The robot's coarse map at the last period.

  std::vector<std::pair<double, double>> delta_bits, budget_bits, octree_bits, coarse_full_bits;
  std::vector<double> insert_ms, extract_ms, baseline_ms, encode_us, decode_us, apply_us, voxels_per_msg;
  std::size_t max_pending = 0;
  double octree_payload_total = 0.0, changes_total = 0.0;
  const auto t_start = Clock::now();
  double next_insert_s = 0.0;
  double next_period_s = period_s;
  double t = 0.0;
  const double dt = 0.05;
  for (int step = 0; t <= duration_s + 1e-9; ++step, t = step * dt) {
    if (t + 1e-9 >= next_insert_s) {
      next_insert_s += insert_period_s;
      const octomap::point3d origin(static_cast<float>(1.0 + speed_mps * t), 0.0f, 0.5f);
      const auto a = Clock::now();
      const octomap::Pointcloud cloud = Scan(scene, origin, points_per_beam, 30.0);
      tree.insertPointCloud(cloud, origin, 30.0, false, true);
      insert_ms.push_back(Us(a, Clock::now()) / 1000.0);
    }
    if (t + 1e-9 < next_period_s) continue;
    next_period_s += period_s;
    // TakeCoarseChanges(): diff of the coarse map against the previous period.
    const auto a = Clock::now();
    const std::vector<CoarseVoxel> now = CoarseMap(tree, levels);
    std::vector<CoarseVoxel> changes;
    for (const CoarseVoxel& v : now) {
      auto [it, inserted] = coarse.try_emplace(Key(v), v.state);
      if (inserted || it->second != v.state) {
        it->second = v.state;
        changes.push_back(v);
      }
    }
    extract_ms.push_back(Us(a, Clock::now()) / 1000.0);
    changes_total += static_cast<double>(changes.size());
    unlimited.AddChanges(changes);
    budgeted.AddChanges(changes);
    for (const MapUpdate& u : unlimited.Poll(t)) {
      delta_bits.emplace_back(t, 8.0 * static_cast<double>(u.data.size() + overhead_bytes));
    }
    for (const MapUpdate& u : budgeted.Poll(t)) {
      budget_bits.emplace_back(t, 8.0 * static_cast<double>(u.data.size() + overhead_bytes));
      std::vector<CoarseVoxel> voxels;
      std::string error;
      const auto d0 = Clock::now();
      const bool ok = cairn::perception::DecodeCoarseVoxels(
          u.data.data(), u.data.size(), cairn::perception::kMaxVoxelsPerUpdate, &voxels, &error);
      const auto d1 = Clock::now();
      if (!ok) std::printf("decode failed: %s\n", error.c_str());
      const std::vector<std::uint8_t> again = cairn::perception::EncodeCoarseVoxels(voxels);
      const auto d2 = Clock::now();
      if (!base.Apply(u.robot_id, u, &error)) std::printf("apply failed: %s\n", error.c_str());
      const auto d3 = Clock::now();
      decode_us.push_back(Us(d0, d1));
      encode_us.push_back(Us(d1, d2));
      apply_us.push_back(Us(d2, d3));
      voxels_per_msg.push_back(static_cast<double>(voxels.size()));
    }
    max_pending = std::max(max_pending, budgeted.stats().voxels_pending);
    // Baseline 1: the whole fine octree, as a .bt stream (max-likelihood, pruned) compressed by zstd.
    const auto b0 = Clock::now();
    octomap::OcTree copy(tree);
    std::ostringstream bt;
    {  // OctoMap's writeBinary prints "Writing N nodes..." on stderr: silenced.
      std::fflush(stderr);
      const int saved = dup(2);
      const int null_fd = open("/dev/null", O_WRONLY);
      dup2(null_fd, 2);
      copy.writeBinary(bt);
      std::fflush(stderr);
      dup2(saved, 2);
      close(null_fd);
      close(saved);
    }
    const double bytes = static_cast<double>(ZstdSize(bt.str(), 3));
    const double messages = std::ceil(bytes / static_cast<double>(max_message_bytes));
    octree_bits.emplace_back(t, 8.0 * (bytes + messages * overhead_bytes));
    octree_payload_total += bytes;
    baseline_ms.push_back(Us(b0, Clock::now()) / 1000.0);
    // Baseline 2: the whole coarse map every period, same codec.
    const double coarse_bytes = static_cast<double>(cairn::perception::EncodeCoarseVoxels(now).size());
    coarse_full_bits.emplace_back(
        t, 8.0 * (coarse_bytes +
                  std::ceil(coarse_bytes / static_cast<double>(max_message_bytes)) * overhead_bytes));
  }
  // Let the budgeted sender finish.
  double drained_s = t;
  while (budgeted.stats().voxels_pending > 0 && drained_s < t + 600.0) {
    drained_s += period_s;
    for (const MapUpdate& u : budgeted.Poll(drained_s)) {
      std::string error;
      budget_bits.emplace_back(drained_s, 8.0 * static_cast<double>(u.data.size() + overhead_bytes));
      if (!base.Apply(u.robot_id, u, &error)) std::printf("apply failed: %s\n", error.c_str());
    }
  }
  const double wall_s = Us(t_start, Clock::now()) / 1e6;

  const auto mean_bps = [&](const std::vector<std::pair<double, double>>& s) {
    double sum = 0.0;
    for (const auto& p : s) sum += p.second;
    return sum / duration_s;
  };
  const double delta_bps = mean_bps(delta_bits);
  const double octree_bps = mean_bps(octree_bits);
  const double coarse_full_bps = mean_bps(coarse_full_bits);
  const double budget_bps = mean_bps(budget_bits);
  // Check: the basestation's copy equals the robot's coarse map.
  std::vector<CoarseVoxel> robot_map;
  for (const auto& [key, state] : coarse) {
    CoarseVoxel v;
    v.ix = static_cast<std::int32_t>((key >> 42) & ((1u << 21) - 1)) - (1 << 20);
    v.iy = static_cast<std::int32_t>((key >> 21) & ((1u << 21) - 1)) - (1 << 20);
    v.iz = static_cast<std::int32_t>(key & ((1u << 21) - 1)) - (1 << 20);
    v.state = state;
    robot_map.push_back(v);
  }
  std::sort(robot_map.begin(), robot_map.end(),
            [](const CoarseVoxel& x, const CoarseVoxel& y) { return Key(x) < Key(y); });
  const bool equal = base.Voxels("r1") == robot_map;

  // A late joiner's snapshot of the final map.
  budgeted.RequestSnapshot();
  double snap_t = drained_s + period_s;
  std::size_t snap_chunks = 0, snap_bytes = 0;
  double snap_done_s = snap_t;
  const auto s0 = Clock::now();
  for (; budgeted.stats().snapshot_chunks_queued > 0 || snap_chunks == 0; snap_t += period_s) {
    for (const MapUpdate& u : budgeted.Poll(snap_t)) {
      ++snap_chunks;
      snap_bytes += u.data.size();
      snap_done_s = snap_t;
    }
  }
  const double snap_cpu_ms = Us(s0, Clock::now()) / 1000.0;

  const Percentiles ins = Summarize(insert_ms), ext = Summarize(extract_ms);
  const Percentiles enc = Summarize(encode_us), dec = Summarize(decode_us), app = Summarize(apply_us);
  const Percentiles vpm = Summarize(voxels_per_msg);
  std::printf(
      "map telemetry: corridor 40 m + room 20 x 20 m, robot at %.1f m/s for %.0f s; lidar 16 x %d points, "
      "30 m, inserted every %.2f s into a %.1f m OcTree; coarse voxels %.1f m; period %.1f s; "
      "%d B overhead per message\n",
      speed_mps, duration_s, points_per_beam, insert_period_s, fine_m, coarse_m, period_s, overhead_bytes);
  std::printf(
      "  map at the end: %zu fine leaves, %zu coarse voxels, %.0f coarse changes in total (%.0f per s); "
      "insert median %.1f ms, coarse extraction median %.1f ms, octree baseline (copy, writeBinary, zstd) "
      "median %.1f ms; bench ran %.1f s\n",
      tree.getNumLeafNodes(), coarse.size(), changes_total, changes_total / duration_s, ins.median,
      ext.median, Summarize(baseline_ms).median, wall_s);
  std::printf(
      "FIGURE map_telemetry_delta_bits_per_s %.0f  (coarse DELTA stream, payload + overhead, mean; peak "
      "over 1 s: %.0f bits)\n",
      delta_bps, PeakBits(delta_bits, 1.0));
  std::printf(
      "FIGURE map_telemetry_octree_baseline_bits_per_s %.0f  (whole %.1f m OcTree, .bt + zstd-3, every "
      "%.1f s; last one %.0f kB)\n",
      octree_bps, fine_m, period_s, octree_bits.back().second / 8000.0);
  std::printf("FIGURE map_telemetry_ratio_octree_over_delta %.1fx\n", octree_bps / delta_bps);
  std::printf(
      "FIGURE map_telemetry_coarse_full_baseline_bits_per_s %.0f  (whole coarse map every period, same "
      "codec; ratio over delta %.1fx)\n",
      coarse_full_bps, coarse_full_bps / delta_bps);
  std::printf(
      "FIGURE map_telemetry_budgeted_bits_per_s %.0f  (default sender, 100 kbit/s budget; peak over 1 s: "
      "%.0f bits; most voxels pending %zu; all sent %.1f s after the run ended)\n",
      budget_bps, PeakBits(budget_bits, 1.0), max_pending, drained_s - t);
  std::printf("FIGURE map_telemetry_voxels_per_message median %.0f max %.0f\n", vpm.median, vpm.max);
  std::printf("FIGURE map_telemetry_encode_us median %.0f p99 %.0f max %.0f  (per DELTA message)\n",
              enc.median, enc.p99, enc.max);
  std::printf("FIGURE map_telemetry_decode_us median %.0f p99 %.0f max %.0f\n", dec.median, dec.p99, dec.max);
  std::printf(
      "FIGURE map_telemetry_fleet_apply_us median %.0f p99 %.0f max %.0f  (FleetMap::Apply, decode "
      "included)\n",
      app.median, app.p99, app.max);
  std::printf(
      "FIGURE map_telemetry_snapshot %zu coarse voxels in %zu chunks, %zu bytes (%.3f B/voxel), sent in "
      "%.1f s at 100 kbit/s, built in %.1f ms\n",
      coarse.size(), snap_chunks, snap_bytes, static_cast<double>(snap_bytes) / coarse.size(),
      snap_done_s - drained_s, snap_cpu_ms);
  std::printf(
      "  check: basestation map equals the robot's coarse map: %s; whole-octree payload total %.0f kB\n",
      equal ? "yes" : "NO", octree_payload_total / 1000.0);
  return equal ? 0 : 1;
}
