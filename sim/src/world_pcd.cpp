// Copyright Cairn authors.
//
// PCD point cloud loading. The only translation unit of Cairn that includes PCL headers (they are slow to
// compile); keep it that way.
#include <pcl/io/pcd_io.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <exception>
#include <fstream>
#include <algorithm>
#include <limits>
#include <set>
#include <sstream>
#include <vector>

#include "world_loaders.h"

namespace cairn::sim::internal {
namespace {

// Checks the PCD header (format: https://pointclouds.org/documentation/tutorials/pcd_file_format.html)
// before PCL reads the file: PCL 1.13's PCDReader dereferences missing fields of a file without a header and
// crashes, so files that are not PCD at all must not reach it. Throws WorldError naming what is missing.
void CheckPcdHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  bool has_xyz = false;
  bool has_fields = false;
  for (int n = 0; n < 64 && std::getline(in, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream tokens(line);
    std::string key;
    tokens >> key;
    if (key == "FIELDS") {
      has_fields = true;
      std::set<std::string> names;
      for (std::string name; tokens >> name;) names.insert(name);
      has_xyz = names.count("x") && names.count("y") && names.count("z");
    } else if (key == "DATA") {
      std::string kind;
      tokens >> kind;
      if (kind != "ascii" && kind != "binary" && kind != "binary_compressed") {
        throw WorldError("world file '" + path + "' is not a valid PCD file (DATA '" + kind +
                         "' is not ascii, binary or binary_compressed)");
      }
      if (!has_fields || !has_xyz) {
        throw WorldError("world file '" + path + "' is not a valid PCD file (" +
                         (has_fields ? "FIELDS lacks x, y or z" : "no FIELDS line") + ")");
      }
      return;
    } else if (key != "VERSION" && key != "SIZE" && key != "TYPE" && key != "COUNT" && key != "WIDTH" &&
               key != "HEIGHT" && key != "VIEWPOINT" && key != "POINTS") {
      throw WorldError("world file '" + path + "' is not a valid PCD file (unexpected header line '" +
                       line.substr(0, 40) + "')");
    }
  }
  throw WorldError("world file '" + path + "' is not a valid PCD file (no DATA line in the header)");
}

}  // namespace

World LoadPcdFile(const std::string& path, const WorldLoadOptions& options, WorldLoadReport* report) {
  CheckReadableFile(path);
  CheckPcdHeader(path);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  int rc = -1;
  try {
    pcl::PCDReader reader;
    rc = reader.read(path, cloud);
  } catch (const std::exception& e) {
    throw WorldError("world file '" + path + "' is not a valid PCD file: " + e.what());
  }
  if (rc < 0) {
    throw WorldError("world file '" + path +
                     "' is not a valid PCD file (bad header, or corrupt or truncated data)");
  }
  report->points_total = static_cast<std::int64_t>(cloud.size());
  std::vector<Eigen::Vector3d> points;
  points.reserve(cloud.size());
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const pcl::PointXYZ& q : cloud.points) {
    const Eigen::Vector3d p(q.x, q.y, q.z);
    if (!p.allFinite()) {
      ++report->points_dropped_non_finite;
      continue;
    }
    points.push_back(p);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  if (points.empty()) {
    std::ostringstream msg;
    msg << "world file '" << path << "' is an empty map: no finite point (" << report->points_total
        << " points, " << report->points_dropped_non_finite << " dropped as NaN/inf)";
    throw WorldError(msg.str());
  }
  const double res = options.pcd_resolution_m;
  // A point on a voxel face belongs to the voxel above it, so the grid must reach past `hi`.
  World world = MakeGridCovering(path, "PCD file '" + path + "'", lo,
                                 hi + Eigen::Vector3d::Constant(0.5 * res), res, options.max_voxels);
  PointCounts counts;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d q = (p - world.p_W_min()) / res;
    Eigen::Vector3i index(static_cast<int>(std::floor(q.x())), static_cast<int>(std::floor(q.y())),
                          static_cast<int>(std::floor(q.z())));
    index = index.cwiseMax(0).cwiseMin(world.dims() - Eigen::Vector3i::Ones());  // Rounding at the faces.
    world.SetOccupied(index);
    int& n = counts[world.LinearIndex(index)];
    n = std::min(n + 1, 1 << 20);
  }
  CleanUpScannedWorld(&world, options, &counts, report);
  return world;
}

}  // namespace cairn::sim::internal
