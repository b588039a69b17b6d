// Copyright Cairn authors.
#include "cairn/sim/world.h"

#include <sys/stat.h>

#include <bitset>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "cairn/sim/builtin_worlds.h"
#include "world_loaders.h"

namespace cairn::sim {
namespace {

bool EndsWith(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  for (std::size_t i = 0; i < suffix.size(); ++i) {
    const char a =
        static_cast<char>(std::tolower(static_cast<unsigned char>(s[s.size() - suffix.size() + i])));
    if (a != suffix[i]) return false;
  }
  return true;
}

}  // namespace

bool WorldLoadOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (!std::isfinite(pcd_resolution_m) || pcd_resolution_m < 0.02 || pcd_resolution_m > 2.0) {
    msg << "WorldLoadOptions::pcd_resolution_m = " << pcd_resolution_m << " must be in [0.02, 2] m";
  } else if (max_voxels < 1 || max_voxels > 2'000'000'000) {
    msg << "WorldLoadOptions::max_voxels = " << max_voxels << " must be in [1, 2e9]";
  } else if (!std::isfinite(support_radius_m) ||
             (support_radius_m != 0.0 && (support_radius_m < 0.01 || support_radius_m > 1.0))) {
    msg << "WorldLoadOptions::support_radius_m = " << support_radius_m
        << " must be 0 (off) or in [0.01, 1] m";
  } else if (min_support_neighbors < 1 || min_support_neighbors > 100) {
    msg << "WorldLoadOptions::min_support_neighbors = " << min_support_neighbors << " must be in [1, 100]";
  } else if (pcd_min_points_per_voxel < 1 || pcd_min_points_per_voxel > 1000) {
    msg << "WorldLoadOptions::pcd_min_points_per_voxel = " << pcd_min_points_per_voxel
        << " must be in [1, 1000]";
  } else if (!std::isfinite(fill_hole_max_m) ||
             (fill_hole_max_m != 0.0 && (fill_hole_max_m < 0.05 || fill_hole_max_m > 3.0))) {
    msg << "WorldLoadOptions::fill_hole_max_m = " << fill_hole_max_m << " must be 0 (off) or in [0.05, 3] m";
  } else if (!std::isfinite(fill_strip_max_m) ||
             (fill_strip_max_m != 0.0 && (fill_strip_max_m < 0.05 || fill_strip_max_m > 3.0))) {
    msg << "WorldLoadOptions::fill_strip_max_m = " << fill_strip_max_m
        << " must be 0 (off) or in [0.05, 3] m";
  } else if (!std::isfinite(fill_clearance_m) || fill_clearance_m < 0.05 || fill_clearance_m > 5.0) {
    msg << "WorldLoadOptions::fill_clearance_m = " << fill_clearance_m << " must be in [0.05, 5] m";
  } else if (!std::isfinite(fill_gap_depth_m) || fill_gap_depth_m < 0.05 || fill_gap_depth_m > 5.0) {
    msg << "WorldLoadOptions::fill_gap_depth_m = " << fill_gap_depth_m << " must be in [0.05, 5] m";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

std::string WorldLoadReport::Summary() const {
  std::ostringstream out;
  out << kind << ": ";
  if (kind == "builtin") {
    out << "procedural world, no clean-up";
    return out.str();
  }
  if (kind == "pcd") {
    out << points_total << " points (" << points_dropped_non_finite << " non-finite dropped) -> ";
  } else {
    out << leaves_occupied << " occupied leaves -> ";
  }
  out << voxels_read << " voxels; " << voxels_removed_unsupported << " unsupported voxels removed; "
      << voxels_filled_floor << " floor-hole voxels filled (" << voxels_filled_strip << " in strips, "
      << floor_surface_voxels << " floor and " << overhead_surface_voxels << " overhead surface voxels, "
      << holes_seen_through << " holes seen through left open); clean-up "
      << static_cast<int>(std::lround(cleanup_ms)) << " ms";
  return out.str();
}

namespace internal {

void CheckReadableFile(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    throw WorldError("world file '" + path + "' does not exist");
  }
  if (!S_ISREG(st.st_mode)) {
    throw WorldError("world file '" + path + "' is not a regular file");
  }
  if (FILE* f = std::fopen(path.c_str(), "rb")) {
    std::fclose(f);
  } else {
    throw WorldError("world file '" + path + "' cannot be opened for reading");
  }
}

World MakeGridCovering(const std::string& name, const std::string& source, const Eigen::Vector3d& lo,
                       const Eigen::Vector3d& hi, double resolution_m, std::int64_t max_voxels) {
  // Snap to multiples of the resolution (the OctoMap voxel lattice); the small epsilon absorbs rounding of
  // coordinates that already are voxel centres or faces.
  constexpr double kEps = 1e-6;
  Eigen::Vector3d p_min;
  Eigen::Vector3d dims_d;
  for (int k = 0; k < 3; ++k) {
    const double i_lo = std::floor(lo[k] / resolution_m + kEps);
    const double i_hi = std::ceil(hi[k] / resolution_m - kEps);
    p_min[k] = i_lo * resolution_m;
    dims_d[k] = std::max(1.0, i_hi - i_lo);
  }
  const double n = dims_d.prod();
  if (!(n <= static_cast<double>(max_voxels)) || dims_d.maxCoeff() > 2e9) {
    std::ostringstream msg;
    msg << source << ": occupied extent [" << lo.x() << ", " << hi.x() << "] x [" << lo.y() << ", " << hi.y()
        << "] x [" << lo.z() << ", " << hi.z() << "] m at " << resolution_m << " m needs a grid of "
        << dims_d.x() << " x " << dims_d.y() << " x " << dims_d.z() << " = " << n
        << " voxels: too large (limit " << max_voxels << " voxels, WorldLoadOptions::max_voxels)";
    throw WorldError(msg.str());
  }
  return World(name, p_min, resolution_m, dims_d.cast<int>(), max_voxels);
}

}  // namespace internal

World LoadWorld(const std::string& spec, const WorldLoadOptions& options, WorldLoadReport* report) {
  std::string why;
  if (!options.IsValid(&why)) throw WorldError("LoadWorld('" + spec + "'): " + why);
  WorldLoadReport local_report;
  WorldLoadReport* out = report != nullptr ? report : &local_report;
  *out = WorldLoadReport{};

  const std::string kBuiltin = "builtin:";
  if (spec.compare(0, kBuiltin.size(), kBuiltin) == 0) {
    out->kind = "builtin";
    World world = MakeBuiltinWorld(spec.substr(kBuiltin.size()), options.builtin_seed);
    if (world.num_voxels() > options.max_voxels) {
      throw WorldError("world '" + spec + "' has " + std::to_string(world.num_voxels()) +
                       " voxels: too large (limit " + std::to_string(options.max_voxels) +
                       " voxels, WorldLoadOptions::max_voxels)");
    }
    return world;
  }
  if (EndsWith(spec, ".bt")) {
    out->kind = "bt";
    return internal::LoadOctomapFile(spec, /*binary=*/true, options, out);
  }
  if (EndsWith(spec, ".ot")) {
    out->kind = "ot";
    return internal::LoadOctomapFile(spec, /*binary=*/false, options, out);
  }
  if (EndsWith(spec, ".pcd")) {
    out->kind = "pcd";
    return internal::LoadPcdFile(spec, options, out);
  }
  throw WorldError("world spec '" + spec +
                   "' is not understood: expected 'builtin:NAME' or a file ending in .bt, .ot or .pcd");
}

}  // namespace cairn::sim
