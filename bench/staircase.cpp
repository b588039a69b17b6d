// Staircase detection benchmark: StaircaseDetector::Detect() on accumulated simulated lidar clouds
// (VLP-16-like SimulatedLidar scans in a LocalCloud, as on the robot) near the staircase of builtin:tunnels
// and in a stair-free tunnel, beside a baseline measured in the same run on the same cropped clouds: the
// usual front end of plane-based staircase detectors, PCL normal estimation (k = 15 neighbours, kd-tree) +
// PCL region growing (smoothness 5 deg), i.e. only the segmentation into planar patches that such detectors
// start from. Also LocalCloud::AddScan() per 28,800-point scan. One thread. Wall and thread CPU times are
// both given: on a shared machine the CPU time is the cost, the wall time includes waiting for a core (load
// average printed). Usage: cairn_bench_staircase [--repeats N (>= 5, default 40)]
#include "cairn/perception/staircase.h"

#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/segmentation/region_growing.h>
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"

namespace {

using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// CPU time of the calling thread, milliseconds.
double ThreadCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double LoadAverage() {
  double load = -1.0;
  if (FILE* f = std::fopen("/proc/loadavg", "r")) {
    if (std::fscanf(f, "%lf", &load) != 1) load = -1.0;
    std::fclose(f);
  }
  return load;
}

struct Stats {
  double median_ms = 0, p90_ms = 0;
};

Stats Summarize(std::vector<double> samples_ms) {
  std::sort(samples_ms.begin(), samples_ms.end());
  Stats s;
  s.median_ms = samples_ms[samples_ms.size() / 2];
  s.p90_ms = samples_ms[std::min(samples_ms.size() - 1, samples_ms.size() * 9 / 10)];
  return s;
}

struct Scene {
  const char* name;
  std::vector<Eigen::Vector3f> points_W;
  Eigen::Vector3d p_W_robot;
};

// Six scans 0.5 m apart along a line (sensor 0.5 m above the floor, heading along the line) in a LocalCloud.
Scene Accumulate(const char* name, const cairn::sim::World& world, double x0, double y0, double x1, double y1,
                 std::vector<double>* add_scan_ms, std::vector<double>* add_scan_cpu_ms) {
  cairn::perception::LocalCloud cloud;
  cairn::sim::SimulatedLidar lidar(cairn::sim::LidarOptions{}, 7);
  cairn::sim::LidarScan scan;
  const double yaw = std::atan2(y1 - y0, x1 - x0);
  Eigen::Vector3d p;
  for (int i = 0; i < 6; ++i) {
    const double a = i / 5.0;
    p = Eigen::Vector3d(x0 + a * (x1 - x0), y0 + a * (y1 - y0), 0.5);
    Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
    T_W_S.translation() = p;
    T_W_S.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    lidar.Scan(world, T_W_S, &scan);
    const Clock::time_point t0 = Clock::now();
    const double c0 = ThreadCpuMs();
    cloud.AddScan(scan.points_S, T_W_S, 0.5 * i);
    add_scan_cpu_ms->push_back(ThreadCpuMs() - c0);
    add_scan_ms->push_back(MsSince(t0));
  }
  return {name, cloud.Points(), p};
}

// Baseline: PCL normals + region growing on the points the detector keeps (same crop).
double BaselineMs(const Scene& scene, const cairn::perception::StaircaseDetectorOptions& o,
                  std::size_t* clusters) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  for (const Eigen::Vector3f& p : scene.points_W) {
    const double dx = p.x() - scene.p_W_robot.x();
    const double dy = p.y() - scene.p_W_robot.y();
    if (dx * dx + dy * dy > o.crop_radius_m * o.crop_radius_m) continue;
    if (p.z() < scene.p_W_robot.z() - o.crop_below_m || p.z() > scene.p_W_robot.z() + o.crop_above_m)
      continue;
    cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  }
  const Clock::time_point t0 = Clock::now();
  pcl::search::KdTree<pcl::PointXYZ>::Ptr tree(new pcl::search::KdTree<pcl::PointXYZ>);
  pcl::PointCloud<pcl::Normal>::Ptr normals(new pcl::PointCloud<pcl::Normal>);
  pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> ne;
  ne.setSearchMethod(tree);
  ne.setInputCloud(cloud);
  ne.setKSearch(15);
  ne.compute(*normals);
  pcl::RegionGrowing<pcl::PointXYZ, pcl::Normal> rg;
  rg.setMinClusterSize(30);
  rg.setSearchMethod(tree);
  rg.setNumberOfNeighbours(15);
  rg.setInputCloud(cloud);
  rg.setInputNormals(normals);
  rg.setSmoothnessThreshold(static_cast<float>(5.0 * kPi / 180.0));
  rg.setCurvatureThreshold(0.05f);
  std::vector<pcl::PointIndices> segments;
  rg.extract(segments);
  *clusters = segments.size();
  return MsSince(t0);
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 40;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc) {
      repeats = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--repeats N (>= 5)]\n", argv[0]);
      return 2;
    }
  }
  if (repeats < 5) {
    std::fprintf(stderr, "--repeats must be >= 5\n");
    return 2;
  }
  const cairn::sim::World world = cairn::sim::MakeBuiltinWorld("tunnels");
  std::vector<double> add_ms, add_cpu_ms;
  const std::vector<Scene> scenes = {
      Accumulate("stairs_straight", world, 46.5, 23.5, 49.0, 23.5, &add_ms, &add_cpu_ms),
      Accumulate("stairs_yaw30", world, 46.8, 21.5, 46.8 + 2.6 * std::cos(kPi / 6),
                 21.5 + 2.6 * std::sin(kPi / 6), &add_ms, &add_cpu_ms),
      Accumulate("tunnel_no_stairs", world, 8.0, 20.0, 10.5, 20.0, &add_ms, &add_cpu_ms),
      Accumulate("x_junction_no_stairs", world, 27.5, 20.0, 30.0, 20.0, &add_ms, &add_cpu_ms),
  };
  const cairn::perception::StaircaseDetector detector;
  std::printf(
      "Staircase detection, %d runs per cloud, one thread (baseline: PCL normals k=15 + region growing, "
      "%d runs); load average %.2f\n",
      repeats, std::max(3, repeats / 10), LoadAverage());
  for (const Scene& scene : scenes) {
    std::vector<double> ours, ours_cpu;
    cairn::perception::DetectStats stats;
    std::size_t found = 0;
    for (int r = 0; r < repeats; ++r) {
      const double c0 = ThreadCpuMs();
      found = detector.Detect(scene.points_W, scene.p_W_robot, &stats).size();
      ours_cpu.push_back(ThreadCpuMs() - c0);
      ours.push_back(stats.total_ms);
    }
    std::vector<double> base, base_cpu;
    std::size_t clusters = 0;
    for (int r = 0; r < std::max(3, repeats / 10); ++r) {
      const double c0 = ThreadCpuMs();
      base.push_back(BaselineMs(scene, detector.options(), &clusters));
      base_cpu.push_back(ThreadCpuMs() - c0);
    }
    const Stats so = Summarize(ours), soc = Summarize(ours_cpu);
    const Stats sb = Summarize(base), sbc = Summarize(base_cpu);
    std::printf(
        "FIGURE staircase_detect_%s points %zu cropped %lld detections %zu cpu_median_ms %.2f cpu_p90_ms "
        "%.2f "
        "wall_median_ms %.2f wall_p90_ms %.2f | baseline cpu_median_ms %.1f wall_median_ms %.1f segments %zu "
        "| ratio(cpu median) %.0fx\n",
        scene.name, scene.points_W.size(), static_cast<long long>(stats.points_cropped), found, soc.median_ms,
        soc.p90_ms, so.median_ms, so.p90_ms, sbc.median_ms, sb.median_ms, clusters,
        sbc.median_ms / soc.median_ms);
  }
  // What the Ceres model fit adds over the step edges alone, on the two clouds near the builtin:tunnels
  // staircase (truth: first riser at x = 50 m, floor z = 0, yaw 0, rise 0.2 m, run 0.5 m).
  cairn::perception::StaircaseDetectorOptions edges_only;
  edges_only.refine_with_ceres = false;
  const cairn::perception::StaircaseDetector edges_detector(edges_only);
  const std::pair<const char*, const cairn::perception::StaircaseDetector*> variants[] = {
      {"ceres_fit", &detector}, {"edges_only", &edges_detector}};
  for (const auto& [variant, d] : variants) {
    for (std::size_t i = 0; i < 2; ++i) {
      const std::vector<cairn::perception::Staircase> found =
          d->Detect(scenes[i].points_W, scenes[i].p_W_robot);
      if (found.empty()) continue;
      const cairn::perception::Staircase& s = found[0];
      std::printf(
          "FIGURE staircase_accuracy_%s %s rise_err_mm %+.1f run_err_mm %+.1f first_riser_x_err_mm %+.1f "
          "floor_z_err_mm %+.1f yaw_err_deg %+.2f num_steps %d\n",
          scenes[i].name, variant, 1e3 * (s.rise_m - 0.2), 1e3 * (s.run_m - 0.5),
          1e3 * (s.p_W_first_step.x() - 50.0), 1e3 * s.p_W_first_step.z(), s.yaw_rad * 180.0 / kPi,
          s.num_steps);
    }
  }
  const Stats sa = Summarize(add_ms), sac = Summarize(add_cpu_ms);
  std::printf(
      "FIGURE local_cloud_add_scan scans %zu cpu_median_ms %.2f cpu_p90_ms %.2f wall_median_ms %.2f "
      "wall_p90_ms %.2f\n",
      add_ms.size(), sac.median_ms, sac.p90_ms, sa.median_ms, sa.p90_ms);
  return 0;
}
