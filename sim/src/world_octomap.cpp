// Copyright Cairn authors.
//
// OctoMap (.bt, .ot) reading and writing. The only translation unit that includes OctoMap headers.
#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "cairn/core/octomap_bt.h"
#include "world_loaders.h"

namespace cairn::sim {
namespace internal {
namespace {

// The voxel edges a world file may have, metres: a survey map's finest to a coarse site map's. A .bt's keys
// span 65536 voxels per axis, so the largest gives a 330 km map.
constexpr double kMinResolutionM = 0.005;
constexpr double kMaxResolutionM = 5.0;

World WorldFromTree(const octomap::OcTree& tree, const std::string& path, const WorldLoadOptions& options,
                    WorldLoadReport* report) {
  const double res = tree.getResolution();
  if (!std::isfinite(res) || res < kMinResolutionM || res > kMaxResolutionM) {
    // A resolution of 1e30 loaded and put the robot at (1.2e32, ...).
    std::ostringstream msg;
    msg << "OctoMap file '" << path << "' has resolution " << res << " m, outside [" << kMinResolutionM
        << ", " << kMaxResolutionM << "] m (corrupt file?)";
    throw WorldError(msg.str());
  }
  // Bounds of the occupied leaves only (free space may reach far beyond the structure).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  std::int64_t leaves = 0;
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    ++leaves;
    const double half = 0.5 * it.getSize();
    const octomap::point3d c = it.getCoordinate();
    const Eigen::Vector3d center(c.x(), c.y(), c.z());
    lo = lo.cwiseMin(center - Eigen::Vector3d::Constant(half));
    hi = hi.cwiseMax(center + Eigen::Vector3d::Constant(half));
  }
  report->leaves_occupied = leaves;
  if (leaves == 0) {
    throw WorldError("OctoMap file '" + path + "' is an empty map: it has no occupied voxel");
  }
  World world = MakeGridCovering(path, "OctoMap file '" + path + "'", lo, hi, res, options.max_voxels);
  for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
    if (!tree.isNodeOccupied(*it)) continue;
    const double size = it.getSize();
    const int n = std::max(1, static_cast<int>(std::lround(size / res)));  // Voxels per edge of this leaf.
    const octomap::point3d c = it.getCoordinate();
    const Eigen::Vector3d corner =
        Eigen::Vector3d(c.x(), c.y(), c.z()) - Eigen::Vector3d::Constant(0.5 * size);
    for (int a = 0; a < n; ++a) {
      for (int b = 0; b < n; ++b) {
        for (int d = 0; d < n; ++d) {
          const Eigen::Vector3d p = corner + (Eigen::Vector3d(a, b, d).array() + 0.5).matrix() * res;
          world.SetOccupiedAt(p);
        }
      }
    }
  }
  CleanUpScannedWorld(&world, options, /*counts=*/nullptr, report);
  return world;
}

}  // namespace

World LoadOctomapFile(const std::string& path, bool binary, const WorldLoadOptions& options,
                      WorldLoadReport* report) {
  CheckReadableFile(path);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw WorldError("world file '" + path + "' cannot be opened for reading");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  // Checked before OctoMap sees it: its readers recurse once per node and trust the header (a fuzzed .bt of
  // nested inner nodes overflowed the stack), and its .ot reader reads on past the end of the data.
  const std::string where = "world file '" + path + "'";
  core::BtFile file;
  try {
    file = binary ? core::ParseBtFile(bytes, where) : core::ParseOtFile(bytes, where);
  } catch (const std::invalid_argument& e) {
    throw WorldError(e.what());
  }
  const auto num_nodes = static_cast<std::size_t>(file.num_nodes);
  std::istringstream stream((binary ? core::BtFileHeader(num_nodes, file.resolution_m)
                                    : core::OtFileHeader(num_nodes, file.resolution_m)) +
                            file.data);
  if (binary) {
    octomap::OcTree tree(0.1);
    if (!tree.readBinary(stream)) {
      throw WorldError(
          where + " is not a valid OctoMap binary (.bt) file (bad header, or corrupt or truncated data)");
    }
    return WorldFromTree(tree, path, options, report);
  }
  std::unique_ptr<octomap::AbstractOcTree> abstract(octomap::AbstractOcTree::read(stream));
  if (!abstract) throw WorldError(where + " is not a valid OctoMap (.ot) file (bad header or corrupt data)");
  const auto* tree = dynamic_cast<const octomap::OcTree*>(abstract.get());
  if (tree == nullptr) {
    throw WorldError(where + " holds an OctoMap tree of type '" + abstract->getTreeType() +
                     "'; only OcTree is supported");
  }
  return WorldFromTree(*tree, path, options, report);
}

}  // namespace internal

void SaveWorldAsBt(const World& world, const std::string& path) {
  octomap::OcTree tree(world.resolution_m());
  const Eigen::Vector3i& dims = world.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3i index(ix, iy, iz);
        if (!world.IsOccupiedIndex(index)) continue;
        const Eigen::Vector3d p = world.CenterOf(index);
        tree.updateNode(
            octomap::point3d(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())),
            true, /*lazy_eval=*/true);
      }
    }
  }
  tree.updateInnerOccupancy();
  std::ofstream out(path, std::ios::binary);
  if (!out || !tree.writeBinary(out) || !out.flush()) {
    throw WorldError("cannot write OctoMap file '" + path + "'");
  }
}

}  // namespace cairn::sim
