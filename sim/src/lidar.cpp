// Copyright Cairn authors.
#include "cairn/sim/lidar.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Hit on the face of voxel `index` that a ray along `direction_W` enters through on `axis`: the point is
// put exactly on the face plane and the range recomputed from it (no accumulated rounding).
RayHit FaceHit(const World& world, const Eigen::Vector3d& origin_W, const Eigen::Vector3d& direction_W,
               const Eigen::Vector3i& index, int axis) {
  const double res = world.resolution_m();
  const int face = direction_W[axis] > 0.0 ? index[axis] : index[axis] + 1;
  const double face_W = world.p_W_min()[axis] + face * res;
  RayHit hit;
  hit.range_m = std::max(0.0, (face_W - origin_W[axis]) / direction_W[axis]);
  hit.p_W = origin_W + hit.range_m * direction_W;
  hit.p_W[axis] = face_W;
  hit.axis = axis;
  return hit;
}

// Where a ray from `origin_W` along `direction_W` enters the grid within max_range_m (slab test on the box
// [0, dims] in voxel units; `q0` is the origin in voxel units from the grid's min corner): the range t_enter,
// the axis of the face it enters through (-1: the origin is inside) and the first voxel. nullopt: it misses.
struct GridEntry {
  double t_enter = 0.0;
  int enter_axis = -1;
  Eigen::Vector3i index;
};
std::optional<GridEntry> EnterGrid(const World& world, const Eigen::Vector3d& direction_W,
                                   const Eigen::Vector3d& q0, double max_range_m) {
  const double res = world.resolution_m();
  const Eigen::Vector3i& dims = world.dims();
  GridEntry entry;
  double t_exit = max_range_m;
  for (int k = 0; k < 3; ++k) {
    const double d = direction_W[k];
    if (d == 0.0) {
      if (q0[k] < 0.0 || q0[k] >= dims[k]) return std::nullopt;
      continue;
    }
    double t0 = -q0[k] * res / d;
    double t1 = (dims[k] - q0[k]) * res / d;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > entry.t_enter) {
      entry.t_enter = t0;
      entry.enter_axis = k;
    }
    t_exit = std::min(t_exit, t1);
  }
  if (entry.t_enter > t_exit) return std::nullopt;
  // First voxel: the origin's, or the one where the ray enters the grid.
  const Eigen::Vector3d q = q0 + (entry.t_enter / res) * direction_W;
  for (int k = 0; k < 3; ++k) {
    int i = static_cast<int>(std::floor(q[k]));
    if (k == entry.enter_axis) i = direction_W[k] > 0.0 ? 0 : dims[k] - 1;
    entry.index[k] = std::min(std::max(i, 0), dims[k] - 1);  // Guards rounding at the faces.
  }
  return entry;
}

// 3D DDA (Amanatides & Woo 1987) from the free voxel `index` to the first occupied one within max_range_m.
std::optional<RayHit> Traverse(const World& world, const Eigen::Vector3d& origin_W,
                               const Eigen::Vector3d& direction_W, const Eigen::Vector3d& q0,
                               const Eigen::Vector3i& index, double max_range_m) {
  const double res = world.resolution_m();
  const Eigen::Vector3i& dims = world.dims();
  // t_max[k] is the range at which the ray crosses the next voxel boundary normal to axis k, t_delta[k] the
  // range between two such boundaries.
  constexpr double kInf = std::numeric_limits<double>::infinity();
  int step[3];
  double t_max[3];
  double t_delta[3];
  for (int k = 0; k < 3; ++k) {
    const double d = direction_W[k];
    if (d > 0.0) {
      step[k] = 1;
      t_max[k] = (index[k] + 1 - q0[k]) * res / d;
      t_delta[k] = res / d;
    } else if (d < 0.0) {
      step[k] = -1;
      t_max[k] = (index[k] - q0[k]) * res / d;
      t_delta[k] = -res / d;
    } else {
      step[k] = 0;
      t_max[k] = kInf;
      t_delta[k] = kInf;
    }
  }
  // The axis to step along is data-dependent and would mispredict about every other step as a branch: keep
  // the state in scalars and select with conditional moves; one well-predicted exit test per step.
  int ix = index.x();
  int iy = index.y();
  int iz = index.z();
  double tx = t_max[0];
  double ty = t_max[1];
  double tz = t_max[2];
  const auto nx = static_cast<unsigned>(dims.x());
  const auto ny = static_cast<unsigned>(dims.y());
  const auto nz = static_cast<unsigned>(dims.z());
  // The voxel's storage index moves with it (z fastest): a step along x, y or z adds this much; the bounds
  // test below runs before it is read.
  const std::int64_t move_x = static_cast<std::int64_t>(step[0]) * dims.y() * dims.z();
  const std::int64_t move_y = static_cast<std::int64_t>(step[1]) * dims.z();
  const std::int64_t move_z = step[2];
  std::int64_t linear = world.LinearIndex(index);
  for (;;) {
    const bool sx = tx < ty && tx < tz;
    const bool sy = !sx && ty < tz;
    const bool sz = !sx && !sy;
    const double t = sx ? tx : (sy ? ty : tz);  // Range at which the ray enters the next voxel.
    ix += sx ? step[0] : 0;
    iy += sy ? step[1] : 0;
    iz += sz ? step[2] : 0;
    linear += sx ? move_x : (sy ? move_y : move_z);
    tx += sx ? t_delta[0] : 0.0;
    ty += sy ? t_delta[1] : 0.0;
    tz += sz ? t_delta[2] : 0.0;
    // Beyond max range, or left the grid (outside is free; unsigned compare also catches -1).
    if ((t > max_range_m) | (static_cast<unsigned>(ix) >= nx) | (static_cast<unsigned>(iy) >= ny) |
        (static_cast<unsigned>(iz) >= nz)) {
      return std::nullopt;
    }
    if (world.IsOccupiedLinear(linear)) {
      return FaceHit(world, origin_W, direction_W, Eigen::Vector3i(ix, iy, iz), sx ? 0 : (sy ? 1 : 2));
    }
  }
}

}  // namespace

std::optional<RayHit> CastRay(const World& world, const Eigen::Vector3d& origin_W,
                              const Eigen::Vector3d& direction_W, double max_range_m) {
  if (!origin_W.allFinite() || !direction_W.allFinite() || !(max_range_m >= 0.0)) return std::nullopt;
  // Origin in voxel units relative to the grid's min corner; ranges t stay in metres along the ray.
  const Eigen::Vector3d q0 = (origin_W - world.p_W_min()) / world.resolution_m();
  const std::optional<GridEntry> entry = EnterGrid(world, direction_W, q0, max_range_m);
  if (!entry) return std::nullopt;
  if (world.IsOccupiedIndex(entry->index)) {
    if (entry->enter_axis >= 0) return FaceHit(world, origin_W, direction_W, entry->index, entry->enter_axis);
    RayHit hit;
    hit.range_m = 0.0;
    hit.p_W = origin_W;
    direction_W.cwiseAbs().maxCoeff(&hit.axis);
    return hit;
  }
  return Traverse(world, origin_W, direction_W, q0, entry->index, max_range_m);
}

bool LidarOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  const double half_pi = kPi / 2.0;
  if (num_beams < 1 || num_beams > 1024) {
    msg << "LidarOptions::num_beams = " << num_beams << " must be in [1, 1024]";
  } else if (!std::isfinite(min_elevation_rad) || min_elevation_rad < -half_pi ||
             min_elevation_rad > half_pi) {
    msg << "LidarOptions::min_elevation_rad = " << min_elevation_rad
        << " must be finite and in [-pi/2, pi/2]";
  } else if (!std::isfinite(max_elevation_rad) || max_elevation_rad < min_elevation_rad ||
             max_elevation_rad > half_pi) {
    msg << "LidarOptions::max_elevation_rad = " << max_elevation_rad
        << " must be finite and in [min_elevation_rad = " << min_elevation_rad << ", pi/2]";
  } else if (num_beams > 1 && max_elevation_rad == min_elevation_rad) {
    msg << "LidarOptions::max_elevation_rad = " << max_elevation_rad << " must be > min_elevation_rad with "
        << num_beams << " beams";
  } else if (points_per_beam < 1 || points_per_beam > 100000) {
    msg << "LidarOptions::points_per_beam = " << points_per_beam << " must be in [1, 100000]";
  } else if (!std::isfinite(max_range_m) || max_range_m <= 0.0 || max_range_m > 1000.0) {
    msg << "LidarOptions::max_range_m = " << max_range_m << " must be finite and in (0, 1000] m";
  } else if (!std::isfinite(min_range_m) || min_range_m < 0.0 || min_range_m >= max_range_m) {
    msg << "LidarOptions::min_range_m = " << min_range_m
        << " must be finite and in [0, max_range_m = " << max_range_m << ") m";
  } else if (!std::isfinite(range_noise_stddev_m) || range_noise_stddev_m < 0.0 ||
             range_noise_stddev_m > 1.0) {
    msg << "LidarOptions::range_noise_stddev_m = " << range_noise_stddev_m
        << " must be finite and in [0, 1] m";
  } else if (!std::isfinite(rate_hz) || rate_hz <= 0.0 || rate_hz > 1000.0) {
    msg << "LidarOptions::rate_hz = " << rate_hz << " must be finite and in (0, 1000] Hz";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

SimulatedLidar::SimulatedLidar(const LidarOptions& options, std::uint32_t seed)
    : options_(options), rng_(seed), noise_(0.0, 1.0) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument("SimulatedLidar: " + why);
  const int beams = options_.num_beams;
  const int columns = options_.points_per_beam;
  std::vector<double> sin_el(beams);
  std::vector<double> cos_el(beams);
  for (int b = 0; b < beams; ++b) {
    const double el = beams == 1
                          ? 0.5 * (options_.min_elevation_rad + options_.max_elevation_rad)
                          : options_.min_elevation_rad +
                                b * (options_.max_elevation_rad - options_.min_elevation_rad) / (beams - 1);
    sin_el[b] = std::sin(el);
    cos_el[b] = std::cos(el);
  }
  directions_S_.reserve(static_cast<std::size_t>(options_.RaysPerScan()));
  for (int c = 0; c < columns; ++c) {
    const double az = 2.0 * kPi * c / columns;
    const double cos_az = std::cos(az);
    const double sin_az = std::sin(az);
    for (int b = 0; b < beams; ++b) {
      directions_S_.emplace_back(cos_el[b] * cos_az, cos_el[b] * sin_az, sin_el[b]);
    }
  }
}

void SimulatedLidar::Scan(const World& world, const Eigen::Isometry3d& T_W_S, LidarScan* scan) {
  if (scan == nullptr) throw std::invalid_argument("SimulatedLidar::Scan: scan must not be null");
  ranges_world_.reset();  // the world may change before the next call: no reuse
  CastRays(world, T_W_S);
  Measure(scan);
}

void SimulatedLidar::Scan(const std::shared_ptr<const World>& world, const Eigen::Isometry3d& T_W_S,
                          LidarScan* scan) {
  if (scan == nullptr) throw std::invalid_argument("SimulatedLidar::Scan: scan must not be null");
  if (world == nullptr) throw std::invalid_argument("SimulatedLidar::Scan: world must not be null");
  // Holding the pointer keeps the world alive, so a new world can never reuse its address.
  if (world == ranges_world_ && T_W_S.matrix() == ranges_T_W_S_.matrix()) {
    ++reused_scans_;
  } else {
    CastRays(*world, T_W_S);
    ranges_world_ = world;
    ranges_T_W_S_ = T_W_S;
  }
  Measure(scan);
}

void SimulatedLidar::CastRays(const World& world, const Eigen::Isometry3d& T_W_S) {
  const Eigen::Matrix3d R_W_S = T_W_S.linear();
  const Eigen::Vector3d p_W_S = T_W_S.translation();
  true_ranges_m_.resize(directions_S_.size());
  for (std::size_t i = 0; i < directions_S_.size(); ++i) {
    const std::optional<RayHit> hit = CastRay(world, p_W_S, R_W_S * directions_S_[i], options_.max_range_m);
    true_ranges_m_[i] = hit ? hit->range_m : kNoHit;
  }
}

void SimulatedLidar::Measure(LidarScan* scan) {
  scan->points_S.clear();
  const double sigma_m = options_.range_noise_stddev_m;
  for (std::size_t i = 0; i < directions_S_.size(); ++i) {
    double range_m = true_ranges_m_[i];
    if (range_m == kNoHit) continue;
    if (sigma_m > 0.0) range_m += sigma_m * noise_(rng_);
    if (range_m < options_.min_range_m) continue;
    scan->points_S.emplace_back((range_m * directions_S_[i]).cast<float>());
  }
  scan->rays_cast = static_cast<std::int64_t>(directions_S_.size());
  scan->returns = static_cast<std::int64_t>(scan->points_S.size());
}

}  // namespace cairn::sim
