// Global planner benchmark on the real scan geb079.bt: the Cairn path service (2.5D traversability per
// platform, A* with step and clearance costs, line-of-sight shortcuts) beside a plain 2D grid A* baseline
// (binary occupancy projected from the same voxels: a cell is blocked if any voxel in the robot's height
// band above the floor is occupied; 8-connected, unit costs, octile heuristic, no inflation, no shortcuts),
// on the same start/goal pairs, measured in the same run.
//
// Usage: cairn_bench_global_planner [path/to/geb079.bt] [--repeats N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <queue>
#include <string>
#include <vector>

#include "bench_util.h"
#include "cairn/core/build_paths.h"
#include "cairn/nav/global_planner.h"
#include "cairn/sim/world.h"

namespace {

using cairn::bench::Median;

using Clock = std::chrono::steady_clock;
using cairn::nav::GlobalPlanner;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Plain 2D occupancy grid at the world resolution.
struct Grid2D {
  int nx = 0, ny = 0;
  double res = 0, x0 = 0, y0 = 0;
  std::vector<std::uint8_t> blocked;
};

Grid2D Project(const cairn::sim::World& world, double floor_z_m, double band_lo_m, double band_hi_m) {
  Grid2D g;
  g.nx = world.dims().x();
  g.ny = world.dims().y();
  g.res = world.resolution_m();
  g.x0 = world.p_W_min().x();
  g.y0 = world.p_W_min().y();
  g.blocked.assign(static_cast<std::size_t>(g.nx) * g.ny, 0);
  for (int ix = 0; ix < g.nx; ++ix) {
    for (int iy = 0; iy < g.ny; ++iy) {
      for (int iz = 0; iz < world.dims().z(); ++iz) {
        const double z = world.CenterOf({ix, iy, iz}).z();
        if (z < floor_z_m + band_lo_m || z > floor_z_m + band_hi_m) continue;
        if (world.IsOccupiedIndex({ix, iy, iz})) {
          g.blocked[static_cast<std::size_t>(ix) + static_cast<std::size_t>(g.nx) * iy] = 1;
          break;
        }
      }
    }
  }
  return g;
}

// 8-connected A* with unit/diagonal costs; returns the path length in metres or -1.
double PlainAStar(const Grid2D& g, double sx, double sy, double gx, double gy, int* expansions) {
  const int si = static_cast<int>((sx - g.x0) / g.res), sj = static_cast<int>((sy - g.y0) / g.res);
  const int gi = static_cast<int>((gx - g.x0) / g.res), gj = static_cast<int>((gy - g.y0) / g.res);
  const auto index = [&](int i, int j) {
    return static_cast<std::size_t>(i) + static_cast<std::size_t>(g.nx) * j;
  };
  std::vector<double> cost(g.blocked.size(), 1e300);
  std::vector<std::uint8_t> closed(g.blocked.size(), 0);
  using Item = std::pair<double, std::size_t>;
  std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
  const auto h = [&](int i, int j) {
    const int dx = std::abs(i - gi), dy = std::abs(j - gj);
    return std::max(dx, dy) + (std::sqrt(2.0) - 1.0) * std::min(dx, dy);
  };
  cost[index(si, sj)] = 0;
  open.emplace(h(si, sj), index(si, sj));
  *expansions = 0;
  while (!open.empty()) {
    const std::size_t c = open.top().second;
    open.pop();
    if (closed[c]) continue;
    closed[c] = 1;
    ++*expansions;
    const int i = static_cast<int>(c % g.nx), j = static_cast<int>(c / g.nx);
    if (i == gi && j == gj) return cost[c] * g.res;
    for (int di = -1; di <= 1; ++di) {
      for (int dj = -1; dj <= 1; ++dj) {
        if (di == 0 && dj == 0) continue;
        const int ni = i + di, nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= g.nx || nj >= g.ny || g.blocked[index(ni, nj)]) continue;
        const double nc = cost[c] + ((di != 0 && dj != 0) ? std::sqrt(2.0) : 1.0);
        if (nc < cost[index(ni, nj)]) {
          cost[index(ni, nj)] = nc;
          open.emplace(nc + h(ni, nj), index(ni, nj));
        }
      }
    }
  }
  return -1;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = cairn::core::SourceDir() + "/data/geb079.bt";
  int repeats = 20;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc) {
      repeats = std::max(1, std::atoi(argv[++i]));
    } else {
      path = argv[i];
    }
  }
  if (!std::filesystem::exists(path)) {
    std::printf("global planner bench: %s is absent (no data/ in the repository); nothing measured\n",
                path.c_str());
    return 0;
  }
  const auto t_load = Clock::now();
  auto world = std::make_shared<const cairn::sim::World>(cairn::sim::LoadWorld(path));
  const auto t_loaded = Clock::now();
  std::printf("geb079: %d x %d x %d voxels at %.2f m, loaded in %.0f ms\n", world->dims().x(),
              world->dims().y(), world->dims().z(), world->resolution_m(), Ms(t_load, t_loaded));

  struct Pair {
    double sx, sy, gx, gy;
  };
  const std::vector<Pair> pairs = {
      {-4.0, 0.0, 24.0, 0.0}, {24.0, 0.0, -4.0, 0.0}, {2.0, 0.0, 13.0, 0.0}, {-4.0, 0.0, 13.0, 0.0}};

  // Cold: a new planner per run (traversability grid built inside the first request).
  std::vector<double> cold_ms;
  for (int r = 0; r < std::max(1, repeats / 5); ++r) {
    GlobalPlanner planner(world, {cairn::nav::GetPlatformProfile("wheeled")});
    const auto a = Clock::now();
    const auto plan = planner.Plan({{pairs[0].sx, pairs[0].sy}, {pairs[0].gx, pairs[0].gy}, "wheeled"});
    cold_ms.push_back(Ms(a, Clock::now()));
    if (!plan.IsUsable()) std::printf("cold plan failed: %s\n", plan.reason.c_str());
  }
  // Warm: the service's steady state, grid cached.
  GlobalPlanner planner(world, {cairn::nav::GetPlatformProfile("wheeled")});
  planner.Grid("wheeled");
  const Grid2D grid2d = Project(*world, 0.0, 0.1, 0.8);
  std::printf("%-26s %12s %12s %12s %12s %10s\n", "start -> goal", "cairn ms", "cairn m", "2D A* ms",
              "2D A* m", "ratio");
  std::vector<double> all_cairn, all_plain;
  for (const Pair& p : pairs) {
    std::vector<double> cairn_ms, plain_ms;
    double cairn_len = 0, plain_len = 0;
    int expansions = 0;
    for (int r = 0; r < repeats; ++r) {
      auto a = Clock::now();
      const auto plan = planner.Plan({{p.sx, p.sy}, {p.gx, p.gy}, "wheeled"});
      cairn_ms.push_back(Ms(a, Clock::now()));
      cairn_len = plan.IsUsable() ? plan.result.length_m : -1;
      a = Clock::now();
      plain_len = PlainAStar(grid2d, p.sx, p.sy, p.gx, p.gy, &expansions);
      plain_ms.push_back(Ms(a, Clock::now()));
    }
    char label[64];
    std::snprintf(label, sizeof(label), "(%.0f,%.0f) -> (%.0f,%.0f)", p.sx, p.sy, p.gx, p.gy);
    std::printf("%-26s %12.2f %12.2f %12.2f %12.2f %9.2fx\n", label, Median(cairn_ms), cairn_len,
                Median(plain_ms), plain_len, Median(cairn_ms) / std::max(1e-9, Median(plain_ms)));
    all_cairn.insert(all_cairn.end(), cairn_ms.begin(), cairn_ms.end());
    all_plain.insert(all_plain.end(), plain_ms.begin(), plain_ms.end());
  }
  std::printf("median over all pairs: cairn %.2f ms, plain 2D A* %.2f ms, ratio %.2fx (goal <= 20 ms: %s)\n",
              Median(all_cairn), Median(all_plain), Median(all_cairn) / std::max(1e-9, Median(all_plain)),
              Median(all_cairn) <= 20.0 ? "met" : "NOT met");
  std::printf("cold request (traversability grid built inside): median %.1f ms over %zu runs\n",
              Median(cold_ms), cold_ms.size());
  std::printf(
      "note: the 2D baseline has no inflation and no step test, so its paths touch walls and would cross "
      "stairs; its length is a lower bound\n");
  return 0;
}
