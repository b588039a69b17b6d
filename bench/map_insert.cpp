// Map insertion benchmark: points per second of cairn::perception::OccupancyMap::InsertScan against the
// baseline of plain octomap::OcTree::insertPointCloud(cloud_W, origin_W, max_range_m) on the same scans, same
// resolution and sensor model, measured in the same run, plus the agreement of the two maps (occupied and
// known voxels); also InsertScan with one_ray_per_endpoint_voxel = false, which must agree exactly. Data
// sets:
//  - spherical_scan: OctoMap's ScanGraph data/spherical_scan.graph (one scan of 10201 points,
//    inserted --scans times; skipped when absent);
//  - tunnels: a simulated VLP-16 (16 x 1800 rays, 30 m, 1 cm noise; cairn::sim::SimulatedLidar) driven
//    through builtin:tunnels;
//  - hall: the same lidar with 60 m range in an 80 x 24 x 6 m hall with pillars, so that some returns lie
//    beyond the map's 30 m max range (clipped rays); --scans / 2 scans, each ~10x the work of a tunnel scan.
// Prints FIGURE lines. Usage: cairn_bench_map_insert [--scans N] [--resolution M] [--graph PATH] [--reps N]
#include <octomap/OcTree.h>
#include <octomap/ScanGraph.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "cairn/core/build_paths.h"
#include "cairn/perception/occupancy_map.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"
#include "cairn/sim/world.h"

namespace {

using Clock = std::chrono::steady_clock;
using cairn::perception::OccupancyMap;
using cairn::perception::OccupancyMapOptions;

struct Scan {
  std::vector<Eigen::Vector3f> points_S;
  Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
};

struct DataSet {
  std::string name;
  std::vector<Scan> scans;
  std::int64_t points = 0;
};

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

std::string GraphPath() { return cairn::core::SourceDir() + "/data/spherical_scan.graph"; }

Eigen::Isometry3d Pose(double x, double y, double z, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, y, z);
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return T;
}

// The graph's scans, repeated `repeats` times (a static sensor scanning again: the graph holds one scan).
bool LoadGraph(const std::string& path, int repeats, DataSet* set) {
  if (!std::ifstream(path).good()) return false;
  octomap::ScanGraph graph;
  if (!graph.readBinary(path)) return false;
  set->name = "spherical_scan";
  for (int r = 0; r < repeats; ++r) {
    for (const octomap::ScanNode* node : graph) {
      Scan scan;
      const octomath::Quaternion& q = node->pose.rot();
      scan.T_W_S.linear() = Eigen::Quaterniond(q.u(), q.x(), q.y(), q.z()).normalized().toRotationMatrix();
      scan.T_W_S.translation() = Eigen::Vector3d(node->pose.x(), node->pose.y(), node->pose.z());
      for (const octomap::point3d& p : *node->scan) scan.points_S.emplace_back(p.x(), p.y(), p.z());
      set->points += static_cast<std::int64_t>(scan.points_S.size());
      set->scans.push_back(std::move(scan));
    }
  }
  return true;
}

// A drive along builtin:tunnels' main tunnel (y = 20) into the room, sensor 0.5 m above the floor, with a
// small yaw wobble.
DataSet TunnelScans(int num_scans) {
  DataSet set;
  set.name = "tunnels";
  const cairn::sim::World world = cairn::sim::MakeBuiltinWorld("tunnels", 1);
  cairn::sim::SimulatedLidar lidar(cairn::sim::LidarOptions{}, 7);
  cairn::sim::LidarScan out;
  for (int i = 0; i < num_scans; ++i) {
    const double x = 4.0 + 46.0 * i / std::max(1, num_scans - 1);
    Scan scan;
    scan.T_W_S = Pose(x, 20.0, 0.5, 0.15 * std::sin(0.7 * i));
    lidar.Scan(world, scan.T_W_S, &out);
    scan.points_S = out.points_S;
    set.points += static_cast<std::int64_t>(scan.points_S.size());
    set.scans.push_back(std::move(scan));
  }
  return set;
}

// An 80 x 24 x 6 m hall (walls, floor and ceiling 0.2 m thick) with a row of 0.6 m pillars every 10 m, seen
// by a 60 m lidar driven down its middle.
DataSet HallScans(int num_scans) {
  DataSet set;
  set.name = "hall";
  const double res = 0.1;
  cairn::sim::World world("hall", Eigen::Vector3d(-0.2, -0.2, -0.2), res, Eigen::Vector3i(804, 244, 64));
  const Eigen::Vector3i& dims = world.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const bool shell =
            ix < 2 || iy < 2 || iz < 2 || ix >= dims.x() - 2 || iy >= dims.y() - 2 || iz >= dims.z() - 2;
        const Eigen::Vector3d c = world.CenterOf({ix, iy, iz});
        const double px = std::fmod(c.x(), 10.0);
        const bool pillar =
            c.x() > 5.0 && c.x() < 75.0 && px > 4.7 && px < 5.3 && c.y() > 15.7 && c.y() < 16.3;
        if (shell || pillar) world.SetOccupied({ix, iy, iz});
      }
    }
  }
  cairn::sim::LidarOptions options;
  options.max_range_m = 60.0;
  cairn::sim::SimulatedLidar lidar(options, 11);
  cairn::sim::LidarScan out;
  for (int i = 0; i < num_scans; ++i) {
    Scan scan;
    scan.T_W_S = Pose(5.0 + 70.0 * i / std::max(1, num_scans - 1), 12.0, 1.0, 0.3 * std::sin(0.5 * i));
    lidar.Scan(world, scan.T_W_S, &out);
    scan.points_S = out.points_S;
    set.points += static_cast<std::int64_t>(scan.points_S.size());
    set.scans.push_back(std::move(scan));
  }
  return set;
}

// Finest voxels known in `tree`, each (x | y << 16 | z << 32) << 1 | occupied, sorted (coarse leaves
// expanded).
std::vector<std::uint64_t> TreeKnown(const octomap::OcTree& tree) {
  std::vector<std::uint64_t> known;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    const std::uint64_t occupied = tree.isNodeOccupied(*it) ? 1u : 0u;
    const int n = 1 << (tree.getTreeDepth() - it.getDepth());
    const octomap::OcTreeKey base = it.getIndexKey();
    for (int x = 0; x < n; ++x) {
      for (int y = 0; y < n; ++y) {
        for (int z = 0; z < n; ++z) {
          const std::uint64_t key = std::uint64_t{base[0] + static_cast<unsigned>(x)} |
                                    (std::uint64_t{base[1] + static_cast<unsigned>(y)} << 16) |
                                    (std::uint64_t{base[2] + static_cast<unsigned>(z)} << 32);
          known.push_back((key << 1) | occupied);
        }
      }
    }
  }
  std::sort(known.begin(), known.end());
  return known;
}

// Finest voxels known in `map`, in TreeKnown's form.
std::vector<std::uint64_t> MapKnown(const OccupancyMap& map) {
  std::vector<std::uint64_t> known;
  for (const auto& v : map.CoarseSnapshot(0)) {
    const std::uint64_t key = std::uint64_t(v.ix + 32768) | (std::uint64_t(v.iy + 32768) << 16) |
                              (std::uint64_t(v.iz + 32768) << 32);
    known.push_back((key << 1) | (v.state == cairn::perception::CoarseState::kOccupied ? 1u : 0u));
  }
  std::sort(known.begin(), known.end());
  return known;
}

// Differences between two TreeKnown-form voxel lists.
struct Agreement {
  std::size_t occupied_a = 0, occupied_b = 0;  // Occupied voxels of a and of b.
  std::size_t only_a_occupied = 0;             // Occupied in a, free or unknown in b.
  std::size_t only_b_occupied = 0;             // Occupied in b, free or unknown in a.
  std::size_t only_a_known = 0, only_b_known = 0;
};

Agreement Compare(const std::vector<std::uint64_t>& a, const std::vector<std::uint64_t>& b) {
  Agreement g;
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() || j < b.size()) {
    const bool take_a = j == b.size() || (i < a.size() && (a[i] >> 1) < (b[j] >> 1));
    const bool take_b = i == a.size() || (j < b.size() && (b[j] >> 1) < (a[i] >> 1));
    if (take_a) {
      g.occupied_a += a[i] & 1u;
      g.only_a_occupied += a[i] & 1u;
      ++g.only_a_known;
      ++i;
    } else if (take_b) {
      g.occupied_b += b[j] & 1u;
      g.only_b_occupied += b[j] & 1u;
      ++g.only_b_known;
      ++j;
    } else {
      g.occupied_a += a[i] & 1u;
      g.occupied_b += b[j] & 1u;
      g.only_a_occupied += (a[i] & 1u) && !(b[j] & 1u);
      g.only_b_occupied += (b[j] & 1u) && !(a[i] & 1u);
      ++i;
      ++j;
    }
  }
  return g;
}

struct Run {
  double total_ms = 0.0;
  double max_scan_ms = 0.0;
};

Run RunOurs(const DataSet& set, OccupancyMap* map, cairn::perception::InsertStats* totals) {
  Run run;
  *totals = {};
  for (const Scan& scan : set.scans) {
    const auto t0 = Clock::now();
    const cairn::perception::InsertStats s = map->InsertScan(scan.points_S, scan.T_W_S);
    const double ms = Ms(t0, Clock::now());
    run.total_ms += ms;
    run.max_scan_ms = std::max(run.max_scan_ms, ms);
    totals->unique_endpoints += s.unique_endpoints;
    totals->free_updates += s.free_updates;
    totals->clipped_max_range += s.clipped_max_range;
  }
  return run;
}

// Baseline: the caller's transform to W (same arithmetic as InsertScan) is timed too, as InsertScan's is.
Run RunOctomap(const DataSet& set, const OccupancyMapOptions& options, octomap::OcTree* tree) {
  Run run;
  octomap::Pointcloud cloud;
  for (const Scan& scan : set.scans) {
    const auto t0 = Clock::now();
    cloud.clear();
    for (const auto& p_S : scan.points_S) {
      const Eigen::Vector3d p_W = scan.T_W_S.linear() * p_S.cast<double>() + scan.T_W_S.translation();
      cloud.push_back(static_cast<float>(p_W.x()), static_cast<float>(p_W.y()), static_cast<float>(p_W.z()));
    }
    const Eigen::Vector3d o = scan.T_W_S.translation();
    tree->insertPointCloud(
        cloud,
        octomap::point3d(static_cast<float>(o.x()), static_cast<float>(o.y()), static_cast<float>(o.z())),
        options.max_range_m);
    const double ms = Ms(t0, Clock::now());
    run.total_ms += ms;
    run.max_scan_ms = std::max(run.max_scan_ms, ms);
  }
  return run;
}

void PrintAgreement(const std::string& name, const char* what, const Agreement& g) {
  std::printf(
      "FIGURE map_insert %s agreement %s vs octomap: occupied %zu vs %zu, only-cairn %zu only-octomap %zu "
      "(%.3f %% of octomap's); known only-cairn %zu only-octomap %zu\n",
      name.c_str(), what, g.occupied_a, g.occupied_b, g.only_a_occupied, g.only_b_occupied,
      g.occupied_b ? 100.0 * static_cast<double>(g.only_a_occupied + g.only_b_occupied) /
                         static_cast<double>(g.occupied_b)
                   : 0.0,
      g.only_a_known, g.only_b_known);
}

void Bench(const DataSet& set, double resolution_m, int reps) {
  OccupancyMapOptions options;
  options.resolution_m = resolution_m;
  OccupancyMapOptions exact_options = options;
  exact_options.one_ray_per_endpoint_voxel = false;
  exact_options.floor_guard_layers = 0;
  Run best_ours;
  Run best_exact;
  Run best_octomap;
  best_ours.total_ms = best_exact.total_ms = best_octomap.total_ms = 1e300;
  cairn::perception::InsertStats totals;
  cairn::perception::InsertStats exact_totals;
  Agreement ours_vs_octomap;
  Agreement exact_vs_octomap;
  std::size_t ours_memory = 0;
  std::size_t octomap_memory = 0;
  for (int r = 0; r < reps; ++r) {
    OccupancyMap map(options);
    const Run ours = RunOurs(set, &map, &totals);
    if (ours.total_ms < best_ours.total_ms) best_ours = ours;
    OccupancyMap exact_map(exact_options);
    const Run exact = RunOurs(set, &exact_map, &exact_totals);
    if (exact.total_ms < best_exact.total_ms) best_exact = exact;
    octomap::OcTree tree(resolution_m);
    tree.setProbHit(options.probability_hit);
    tree.setProbMiss(options.probability_miss);
    tree.setClampingThresMin(options.clamping_min);
    tree.setClampingThresMax(options.clamping_max);
    const Run base = RunOctomap(set, options, &tree);
    if (base.total_ms < best_octomap.total_ms) best_octomap = base;
    if (r == 0) {
      const std::vector<std::uint64_t> octomap_known = TreeKnown(tree);
      ours_vs_octomap = Compare(MapKnown(map), octomap_known);
      exact_vs_octomap = Compare(MapKnown(exact_map), octomap_known);
      ours_memory = map.MemoryBytes();
      octomap_memory = tree.memoryUsage();
    }
  }
  const double n = static_cast<double>(set.scans.size());
  const double points = static_cast<double>(set.points);
  std::printf("%s: %zu scans, %.0f points/scan, resolution %.3f m, max range %.0f m, best of %d runs\n",
              set.name.c_str(), set.scans.size(), points / n, resolution_m, options.max_range_m, reps);
  std::printf(
      "FIGURE map_insert %s octomap_insertPointCloud ms_per_scan %.2f max_ms %.2f Mpoints_per_s %.3f\n",
      set.name.c_str(), best_octomap.total_ms / n, best_octomap.max_scan_ms,
      points / best_octomap.total_ms / 1e3);
  std::printf("FIGURE map_insert %s cairn_InsertScan ms_per_scan %.2f max_ms %.2f Mpoints_per_s %.3f\n",
              set.name.c_str(), best_ours.total_ms / n, best_ours.max_scan_ms,
              points / best_ours.total_ms / 1e3);
  std::printf(
      "FIGURE map_insert %s cairn_InsertScan_exact ms_per_scan %.2f max_ms %.2f Mpoints_per_s %.3f "
      "(one_ray_per_endpoint_voxel = false)\n",
      set.name.c_str(), best_exact.total_ms / n, best_exact.max_scan_ms, points / best_exact.total_ms / 1e3);
  std::printf("FIGURE map_insert %s speedup %.2f exact %.2f (octomap time / cairn time)\n", set.name.c_str(),
              best_octomap.total_ms / best_ours.total_ms, best_octomap.total_ms / best_exact.total_ms);
  PrintAgreement(set.name, "cairn", ours_vs_octomap);
  PrintAgreement(set.name, "cairn_exact", exact_vs_octomap);
  std::printf(
      "  per scan: %.0f end-point voxels (rays cast), %.0f free voxels updated (exact: %.0f), %.0f clipped "
      "rays; "
      "memory cairn %.1f MB (tree + scratch) octomap %.1f MB\n",
      static_cast<double>(totals.unique_endpoints) / n, static_cast<double>(totals.free_updates) / n,
      static_cast<double>(exact_totals.free_updates) / n, static_cast<double>(totals.clipped_max_range) / n,
      static_cast<double>(ours_memory) / 1e6, static_cast<double>(octomap_memory) / 1e6);
}

}  // namespace

int main(int argc, char** argv) {
  int num_scans = 20;
  int reps = 1;
  double resolution_m = 0.1;
  std::string graph = GraphPath();
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--scans") == 0 && has_value) {
      num_scans = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--reps") == 0 && has_value) {
      reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--resolution") == 0 && has_value) {
      resolution_m = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--graph") == 0 && has_value) {
      graph = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s [--scans N] [--resolution M] [--graph PATH] [--reps N]\n", argv[0]);
      return 2;
    }
  }
  if (num_scans < 1 || reps < 1 || !(resolution_m >= 0.01 && resolution_m <= 10.0)) {
    std::fprintf(stderr, "invalid arguments: --scans and --reps must be >= 1, --resolution in [0.01, 10]\n");
    return 2;
  }
  std::printf(
      "Map insertion: cairn OccupancyMap::InsertScan vs octomap OcTree::insertPointCloud (same scans, "
      "same sensor model, single thread)\n");
  DataSet spherical;
  if (LoadGraph(graph, num_scans, &spherical)) {
    Bench(spherical, resolution_m, reps);
  } else {
    std::printf("spherical_scan: skipped, %s is absent or unreadable\n", graph.c_str());
  }
  Bench(TunnelScans(num_scans), resolution_m, reps);
  Bench(HallScans((num_scans + 1) / 2), resolution_m, reps);  // Its scans are 10x heavier.
  return 0;
}
