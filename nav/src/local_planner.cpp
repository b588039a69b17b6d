// Copyright Cairn authors.
#include "cairn/nav/local_planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <utility>

namespace cairn::nav {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kSqrtHalf = 0.70710678118654752440;
constexpr int kMaxSamples = 250;               // Sample indices fit a byte, with room for "none" markers.
constexpr int kMaxNodes = 65535;               // Path tree node ids fit 16 bits.
constexpr int kMaxGridSize = 1000;             // Voxels per grid side.
constexpr std::uint8_t kNone = 255;            // "No blocked sample" (build) / "nothing in the band".
constexpr int kBuckets = 254;                  // Clearance buckets 0..253 over [0, clearance_band_m).
constexpr std::size_t kMessageCapacity = 320;  // Longest LocalPlanResult::message (snprintf truncates).

double WrapAngle(double a) {
  a = std::remainder(a, 2.0 * kPi);  // [-pi, pi]
  return a <= -kPi ? a + 2.0 * kPi : a;
}

// Sizes derived from in-range options, shared by IsValid() (limits), the constructor and the brute force.
struct Geometry {
  int samples = 0;
  double spacing_m = 0.0;
  double block_half_diagonal_m = 0.0;  // Of a blocking voxel.
  double band_half_diagonal_m = 0.0;   // Of a clearance voxel.
  double point_block_m = 0.0;          // collision + spacing / 2
  double voxel_block_m = 0.0;          // point_block + blocking half diagonal
  double band_reach_m = 0.0;  // collision + clearance half diagonal + band: clearance voxel centres within it
  double near_origin_m = 0.0;  // voxel_block + spacing: points nearer the origin are tested exactly
  int block_grid_half = 0;     // Voxels from the origin to an edge of the blocking grid.
  int band_grid_half = 0;      // ... of the clearance grid.
};

Geometry ComputeGeometry(const TrajectoryLibraryOptions& o) {
  Geometry g;
  const double n = std::round(o.path_length_m / o.sample_spacing_m);
  g.samples = static_cast<int>(std::clamp(n, 1.0, 1e6));
  g.spacing_m = o.path_length_m / g.samples;
  g.block_half_diagonal_m = o.voxel_size_m * kSqrtHalf;
  g.band_half_diagonal_m = o.clearance_voxel_size_m * kSqrtHalf;
  g.point_block_m = o.collision_radius_m + 0.5 * g.spacing_m;
  g.voxel_block_m = g.point_block_m + g.block_half_diagonal_m;
  g.band_reach_m = o.collision_radius_m + g.band_half_diagonal_m + o.clearance_band_m;
  g.near_origin_m = g.voxel_block_m + g.spacing_m;
  // Samples lie within path_length_m of the origin (arc length >= chord).
  g.block_grid_half =
      static_cast<int>(std::ceil((o.path_length_m + g.voxel_block_m) / o.voxel_size_m - 1e-9));
  g.band_grid_half =
      static_cast<int>(std::ceil((o.path_length_m + g.band_reach_m) / o.clearance_voxel_size_m - 1e-9));
  return g;
}

int IntSqrt(int v) {
  const int k = static_cast<int>(std::lround(std::sqrt(static_cast<double>(std::max(v, 0)))));
  return k * k == v ? k : -1;
}

// Heading change of choice `i` of `count` evenly spread over [-max, max].
double Turn(int i, int count, double max_turn_rad) {
  return count <= 1 ? 0.0 : max_turn_rad * (2.0 * i / (count - 1) - 1.0);
}

// The same squared distance everywhere (build and brute force), so that their classifications agree bit
// for bit.
inline double SquaredDistance(double ax, double ay, double bx, double by) {
  const double dx = ax - bx;
  const double dy = ay - by;
  return dx * dx + dy * dy;
}

// True when the obstacle point (x, y) lies within `near_m` of the origin: it is tested against the path's
// segments exactly (NearPointBlocks), not through its voxel, whose conservative radius would block the first
// samples of every path, also those leading away from a point the robot stands just inside the collision
// radius of (a door jamb it brushed past): the robot could never leave.
inline bool IsNearOrigin(double x, double y, double near_m) {
  return SquaredDistance(x, y, 0.0, 0.0) < near_m * near_m;
}

// Closer than this to a near point than the robot stands now is closer (metres): range noise of the points.
constexpr double kNearNoCloserM = 1e-3;

// Squared distance a near point (x, y) blocks at: the collision radius, or, for a point the robot already
// stands inside it, the distance it stands at (less kNearNoCloserM): it may move along or away, not closer.
inline double NearBlockSquared(double x, double y, double collision_radius_m) {
  const double r = std::min(collision_radius_m, std::sqrt(SquaredDistance(x, y, 0.0, 0.0)) - kNearNoCloserM);
  return r > 0.0 ? r * r : 0.0;
}

// True when the segment from sample i - 1 (the origin for i = 0) to sample i of `s` passes the near point
// (x, y) closer than sqrt(block2) (exact point-to-segment distance).
inline bool NearPointBlocks(double x, double y, const Eigen::Vector2f* s, int i, double block2) {
  const double ax = i == 0 ? 0.0 : s[i - 1].x(), ay = i == 0 ? 0.0 : s[i - 1].y();
  const double dx = s[i].x() - ax, dy = s[i].y() - ay;
  const double len2 = dx * dx + dy * dy;
  const double t = len2 > 0.0 ? std::clamp(((x - ax) * dx + (y - ay) * dy) / len2, 0.0, 1.0) : 0.0;
  return SquaredDistance(ax + t * dx, ay + t * dy, x, y) < block2;
}

inline std::uint8_t ClearanceBucket(double min_d2, const Geometry& g, const TrajectoryLibraryOptions& o) {
  const double clearance = std::sqrt(min_d2) - g.band_half_diagonal_m - o.collision_radius_m;
  const double b = std::floor(clearance / o.clearance_band_m * kBuckets);
  return static_cast<std::uint8_t>(std::clamp(b, 0.0, static_cast<double>(kBuckets - 1)));
}

inline bool InZBand(const Eigen::Vector3f& p, const TrajectoryLibraryOptions& o) {
  return p.z() >= o.obstacle_min_z_m && p.z() <= o.obstacle_max_z_m;
}

inline bool IsFinite(const Eigen::Vector3f& p) {
  return std::isfinite(p.x()) && std::isfinite(p.y()) && std::isfinite(p.z());
}

// Samples required for a free length (metres), in [0, samples].
int RequiredSamples(double required_m, double spacing_m, int samples) {
  if (!(required_m > 0.0)) return 0;
  const double k = std::ceil(required_m / spacing_m - 1e-6);
  return static_cast<int>(std::clamp(k, 0.0, static_cast<double>(samples)));
}

// Centre of the voxel containing coordinate v of a grid with lower edge min_m (any v, the grid extended).
inline double VoxelCentreCoordinate(float v, double min_m, double voxel_m) {
  const double i = std::floor((static_cast<double>(v) - min_m) * (1.0 / voxel_m));
  return min_m + (i + 0.5) * voxel_m;
}

// Compressed rows (offsets, entries) from per-voxel lists; frees the lists as it goes.
template <typename Entry>
void Compress(std::vector<std::vector<Entry>>* lists, std::vector<std::uint32_t>* offsets,
              std::vector<Entry>* entries) {
  std::size_t total = 0;
  for (const auto& list : *lists) total += list.size();
  entries->reserve(total);
  offsets->reserve(lists->size() + 1);
  offsets->push_back(0);
  for (auto& list : *lists) {
    entries->insert(entries->end(), list.begin(), list.end());
    offsets->push_back(static_cast<std::uint32_t>(entries->size()));
    std::vector<Entry>().swap(list);
  }
}

// The library's paths of heading 0, a tree of three arcs of equal length (path_length_m / 3) each turning by
// one of Turn()'s angles: num_groups first arcs, then sqrt(paths_per_group) second and third arcs each.
// `samples` points per path, `spacing_m` apart along it, frame B.
struct ArcTreePaths {
  std::vector<Eigen::Vector2d> points;  // path p's samples at [p * samples, (p + 1) * samples)
  std::vector<double> turn;             // heading change over the path, rad
  std::vector<double> abs_turn;         // sum of the arcs' absolute turns, rad
  std::vector<int> group;               // first arc
};

// The arc (0, 1, 2) that sample i (0-based, at arc length (i + 1) * spacing_m) lies on.
int ArcOfSample(int i, double spacing_m, double arc_m) {
  return std::min(2, static_cast<int>((i + 1) * spacing_m / arc_m));
}

ArcTreePaths MakeArcTreePaths(const TrajectoryLibraryOptions& options, int samples, double spacing_m) {
  const int k = IntSqrt(options.paths_per_group);
  const std::size_t pph = static_cast<std::size_t>(options.num_groups) * options.paths_per_group;
  const double arc_m = options.path_length_m / 3.0;
  ArcTreePaths out;
  out.points.resize(pph * static_cast<std::size_t>(samples));
  out.turn.resize(pph);
  out.abs_turn.resize(pph);
  out.group.resize(pph);
  std::size_t b = 0;
  for (int g = 0; g < options.num_groups; ++g) {
    for (int i2 = 0; i2 < k; ++i2) {
      for (int i3 = 0; i3 < k; ++i3, ++b) {
        const double turns[3] = {Turn(g, options.num_groups, options.max_segment_turn_rad),
                                 Turn(i2, k, options.max_segment_turn_rad),
                                 Turn(i3, k, options.max_segment_turn_rad)};
        // Start pose (x0, y0, th0) of each arc; point at arc length s along arc j.
        double x0[3] = {0.0, 0.0, 0.0};
        double y0[3] = {0.0, 0.0, 0.0};
        double th0[3] = {0.0, 0.0, 0.0};
        auto arc_point = [&](int j, double s) {
          if (std::abs(turns[j]) < 1e-12) {
            return Eigen::Vector2d(x0[j] + s * std::cos(th0[j]), y0[j] + s * std::sin(th0[j]));
          }
          const double kappa = turns[j] / arc_m;
          return Eigen::Vector2d(x0[j] + (std::sin(th0[j] + kappa * s) - std::sin(th0[j])) / kappa,
                                 y0[j] + (std::cos(th0[j]) - std::cos(th0[j] + kappa * s)) / kappa);
        };
        for (int j = 1; j < 3; ++j) {
          const Eigen::Vector2d end = arc_point(j - 1, arc_m);
          x0[j] = end.x();
          y0[j] = end.y();
          th0[j] = th0[j - 1] + turns[j - 1];
        }
        for (int i = 0; i < samples; ++i) {
          const int j = ArcOfSample(i, spacing_m, arc_m);
          out.points[b * samples + i] = arc_point(j, (i + 1) * spacing_m - j * arc_m);
        }
        out.turn[b] = turns[0] + turns[1] + turns[2];
        out.abs_turn[b] = std::abs(turns[0]) + std::abs(turns[1]) + std::abs(turns[2]);
        out.group[b] = g;
      }
    }
  }
  return out;
}

// The headings (of num_headings around the circle) within heading_range_rad of straight ahead.
std::vector<int> KeptHeadings(const TrajectoryLibraryOptions& options) {
  std::vector<int> kept;
  for (int h = 0; h < options.num_headings; ++h) {
    if (std::abs(WrapAngle(2.0 * kPi * h / options.num_headings)) <= options.heading_range_rad + 1e-9) {
      kept.push_back(h);
    }
  }
  return kept;
}

// The tree nodes of each path (3 per path: levels 0, 1, 2), the paths in heading-major order, each heading's
// paths group-major, then by second arc (k per group) and third arc; level 1 nodes are numbered from
// level1_base and level 2 nodes (one per path) from level2_base.
std::vector<std::uint16_t> PathTreeNodes(int num_paths, int paths_per_heading, int groups, int k,
                                         int level1_base, int level2_base) {
  std::vector<std::uint16_t> node_of_path(static_cast<std::size_t>(num_paths) * 3);
  for (int p = 0; p < num_paths; ++p) {
    const int heading_slot = p / paths_per_heading;
    const int within = p % paths_per_heading;
    const int g = within / (k * k);
    const int a = (within / k) % k;
    std::uint16_t* nodes = node_of_path.data() + static_cast<std::size_t>(p) * 3;
    nodes[0] = static_cast<std::uint16_t>(heading_slot * groups + g);
    nodes[1] = static_cast<std::uint16_t>(level1_base + (heading_slot * groups + g) * k + a);
    nodes[2] = static_cast<std::uint16_t>(level2_base + p);
  }
  return node_of_path;
}

// For one path tree node of a trajectory library at a time, visits every voxel of a grid whose centre lies
// within `reach` of one of the node's samples (taken from its lowest-id path): visit(voxel, sample, squared
// distance, first visit of the voxel for this node), and keeps the voxels visited (touched()).
class NodeVoxelVisitor {
 public:
  explicit NodeVoxelVisitor(const TrajectoryLibrary& library)
      : library_(library), node_samples_(static_cast<std::size_t>(library.num_nodes())) {
    for (int p = library.num_paths() - 1; p >= 0; --p) {
      for (int level = 0; level < 3; ++level) {
        NodeSamples& ns = node_samples_[library.path_nodes(p)[level]];
        ns.path = p;
        ns.i0 = level == 0 ? 0 : library.level_end_sample(level - 1);
        ns.i1 = library.level_end_sample(level);
      }
    }
  }
  // A grid of `num_voxels` voxels, no node visited yet.
  void Reset(std::size_t num_voxels) { stamp_.assign(num_voxels, -1); }
  // Forgets the voxels the last node touched.
  void StartNode() { touched_.clear(); }
  const std::vector<int>& touched() const { return touched_; }

  template <typename GridT, typename Visit>
  void ForEachNear(const GridT& grid, double reach, int node, Visit&& visit) {
    const double reach2 = reach * reach;
    const NodeSamples& ns = node_samples_[static_cast<std::size_t>(node)];
    const Eigen::Vector2f* samples = library_.samples_B(ns.path);
    for (int i = ns.i0; i < ns.i1; ++i) {
      const double sx = samples[i].x();
      const double sy = samples[i].y();
      const int ix0 = std::max(0, static_cast<int>(std::floor((sx - reach - grid.min_m) * grid.inv_voxel)));
      const int ix1 =
          std::min(grid.size - 1, static_cast<int>(std::floor((sx + reach - grid.min_m) * grid.inv_voxel)));
      const int iy0 = std::max(0, static_cast<int>(std::floor((sy - reach - grid.min_m) * grid.inv_voxel)));
      const int iy1 =
          std::min(grid.size - 1, static_cast<int>(std::floor((sy + reach - grid.min_m) * grid.inv_voxel)));
      for (int iy = iy0; iy <= iy1; ++iy) {
        const double cy = grid.min_m + (iy + 0.5) * grid.voxel_m;
        for (int ix = ix0; ix <= ix1; ++ix) {
          const double d2 = SquaredDistance(grid.min_m + (ix + 0.5) * grid.voxel_m, cy, sx, sy);
          if (d2 > reach2) continue;
          const int v = ix + grid.size * iy;
          const bool first_visit = stamp_[static_cast<std::size_t>(v)] != node;
          if (first_visit) {
            stamp_[static_cast<std::size_t>(v)] = node;
            touched_.push_back(v);
          }
          visit(v, i, d2, first_visit);
        }
      }
    }
  }

 private:
  // A node's samples [i0, i1) of path `path`.
  struct NodeSamples {
    int path = 0;
    int i0 = 0;
    int i1 = 0;
  };
  const TrajectoryLibrary& library_;
  std::vector<NodeSamples> node_samples_;
  std::vector<int> stamp_;  // per voxel: the last node that visited it
  std::vector<int> touched_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// TrajectoryLibraryOptions

bool TrajectoryLibraryOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi) {
    if (std::isfinite(value) && value >= lo && value <= hi) return true;
    msg << "TrajectoryLibraryOptions::" << field << " = " << value << " must be finite and in [" << lo << ", "
        << hi << "]";
    return false;
  };
  auto int_range = [&msg](const char* field, int value, int lo, int hi) {
    if (value >= lo && value <= hi) return true;
    msg << "TrajectoryLibraryOptions::" << field << " = " << value << " must be in [" << lo << ", " << hi
        << "]";
    return false;
  };
  bool ok = range("path_length_m", path_length_m, 0.1, 10.0) && int_range("num_groups", num_groups, 1, 63) &&
            int_range("paths_per_group", paths_per_group, 1, 225);
  if (ok && IntSqrt(paths_per_group) < 1) {
    msg << "TrajectoryLibraryOptions::paths_per_group = " << paths_per_group
        << " must be a square k * k (k choices for each of the second and third arcs)";
    ok = false;
  }
  ok = ok && int_range("num_headings", num_headings, 1, 360) &&
       range("heading_range_rad", heading_range_rad, 0.0, kPi) &&
       range("max_segment_turn_rad", max_segment_turn_rad, 0.0, kPi / 2.0) &&
       range("sample_spacing_m", sample_spacing_m, 0.005, 1.0) &&
       range("voxel_size_m", voxel_size_m, 0.02, 1.0) &&
       range("clearance_voxel_size_m", clearance_voxel_size_m, 0.02, 2.0) &&
       range("collision_radius_m", collision_radius_m, 0.0, 5.0) &&
       range("clearance_band_m", clearance_band_m, 0.0, 5.0);
  if (ok && (!std::isfinite(obstacle_min_z_m) || !std::isfinite(obstacle_max_z_m) ||
             !(obstacle_min_z_m < obstacle_max_z_m))) {
    msg << "TrajectoryLibraryOptions::obstacle_min_z_m = " << obstacle_min_z_m
        << " must be finite and < obstacle_max_z_m = " << obstacle_max_z_m << " (finite)";
    ok = false;
  }
  if (ok) {
    const double n = std::round(path_length_m / sample_spacing_m);
    if (n > kMaxSamples) {
      msg << "TrajectoryLibraryOptions::sample_spacing_m = " << sample_spacing_m << " gives " << n
          << " samples on path_length_m = " << path_length_m << "; at most " << kMaxSamples << " allowed";
      ok = false;
    }
  }
  if (ok) {
    int kept = 0;
    for (int k = 0; k < num_headings; ++k) {
      if (std::abs(WrapAngle(2.0 * kPi * k / num_headings)) <= heading_range_rad + 1e-9) ++kept;
    }
    const long long k = IntSqrt(paths_per_group);
    const long long nodes = static_cast<long long>(kept) * num_groups * (1 + k + k * k);
    if (nodes > kMaxNodes) {
      msg << "TrajectoryLibraryOptions::num_headings = " << num_headings << " (" << kept
          << " kept) x num_groups = " << num_groups << " x (1 + k + paths_per_group = " << paths_per_group
          << ") = " << nodes << " path tree nodes; at most " << kMaxNodes << " allowed";
      ok = false;
    }
  }
  if (ok) {
    const Geometry g = ComputeGeometry(*this);
    if (2 * g.block_grid_half > kMaxGridSize) {
      msg << "TrajectoryLibraryOptions::voxel_size_m = " << voxel_size_m << " gives a blocking grid of "
          << 2 * g.block_grid_half << " voxels per side; at most " << kMaxGridSize << " allowed";
      ok = false;
    } else if (2 * g.band_grid_half > kMaxGridSize) {
      msg << "TrajectoryLibraryOptions::clearance_voxel_size_m = " << clearance_voxel_size_m
          << " gives a clearance grid of " << 2 * g.band_grid_half << " voxels per side; at most "
          << kMaxGridSize << " allowed";
      ok = false;
    }
  }
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

// ---------------------------------------------------------------------------------------------------------
// TrajectoryLibrary

TrajectoryLibrary::TrajectoryLibrary(const TrajectoryLibraryOptions& options)
    : TrajectoryLibrary(options, PathsOnly{}) {
  const auto t0 = std::chrono::steady_clock::now();
  Correspondence all = BuildCorrespondence([](int) { return true; });
  blocking_offsets_ = std::move(all.blocking_offsets);
  blocking_ = std::move(all.blocking);
  band_offsets_ = std::move(all.band_offsets);
  band_ = std::move(all.band);
  build_time_s_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TrajectoryLibrary::TrajectoryLibrary(const TrajectoryLibraryOptions& options, PathsOnly) : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto t0 = std::chrono::steady_clock::now();
  const Geometry geo = ComputeGeometry(options);
  samples_per_path_ = geo.samples;
  spacing_m_ = geo.spacing_m;
  point_blocking_radius_m_ = geo.point_block_m;
  voxel_blocking_radius_m_ = geo.voxel_block_m;
  near_origin_radius_m_ = geo.near_origin_m;
  auto make_grid = [](double voxel_m, int half) {
    Grid grid;
    grid.voxel_m = voxel_m;
    grid.inv_voxel = 1.0 / voxel_m;
    grid.min_m = -half * voxel_m;
    grid.size = 2 * half;
    return grid;
  };
  block_grid_ = make_grid(options.voxel_size_m, geo.block_grid_half);
  band_grid_ = make_grid(options.clearance_voxel_size_m, geo.band_grid_half);

  const int k = IntSqrt(options.paths_per_group);
  paths_per_heading_ = options.num_groups * options.paths_per_group;
  const int n = samples_per_path_;
  const double arc_m = options.path_length_m / 3.0;
  const std::size_t pph = static_cast<std::size_t>(paths_per_heading_);
  const ArcTreePaths base = MakeArcTreePaths(options, n, spacing_m_);

  // Rotations to the kept headings.
  const std::vector<int> kept_headings = KeptHeadings(options);
  num_kept_headings_ = static_cast<int>(kept_headings.size());
  info_.reserve(kept_headings.size() * pph);
  samples_B_.reserve(kept_headings.size() * pph * static_cast<std::size_t>(n));
  for (int h : kept_headings) {
    const double angle = WrapAngle(2.0 * kPi * h / options.num_headings);
    const double c = std::cos(angle);
    const double s = std::sin(angle);
    for (std::size_t p = 0; p < pph; ++p) {
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d& q = base.points[p * n + i];
        samples_B_.emplace_back(static_cast<float>(c * q.x() - s * q.y()),
                                static_cast<float>(s * q.x() + c * q.y()));
      }
      TrajectoryInfo info;
      info.group = base.group[p];
      info.heading_index = h;
      info.heading_rad = static_cast<float>(angle);
      info.end_B = samples_B_.back();
      info.end_bearing_rad = std::atan2(info.end_B.y(), info.end_B.x());
      info.end_heading_rad = static_cast<float>(WrapAngle(angle + base.turn[p]));
      info.total_turn_rad = static_cast<float>(base.abs_turn[p]);
      info.length_m = static_cast<float>(options.path_length_m);
      info_.push_back(info);
    }
  }

  // Path tree nodes: the paths of a group share their first arc (level 0 node), those that also share the
  // second arc share a level 1 node, and each path owns its third arc (level 2 node). Samples of arc j depend
  // only on the turns of arcs 0..j (computed by the same operations), so they are bitwise equal for all paths
  // under a node.
  const int num_paths = static_cast<int>(info_.size());
  const int groups = options.num_groups;
  const int level1_base = num_kept_headings_ * groups;
  const int level2_base = level1_base + num_kept_headings_ * groups * k;
  num_nodes_ = level2_base + num_paths;
  for (int i = 0; i < n; ++i) level_end_sample_[ArcOfSample(i, spacing_m_, arc_m)] = i + 1;
  level_end_sample_[1] = std::max(level_end_sample_[1], level_end_sample_[0]);
  level_end_sample_[2] = n;
  node_of_path_ = PathTreeNodes(num_paths, paths_per_heading_, groups, k, level1_base, level2_base);
  build_time_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TrajectoryLibrary::Correspondence TrajectoryLibrary::BuildCorrespondence(
    const std::function<bool(int node)>& keep) const {
  const TrajectoryLibraryOptions& options = options_;
  const Geometry geo = ComputeGeometry(options);
  Correspondence out;
  NodeVoxelVisitor near(*this);
  {  // Blocking: first sample whose distance is within voxel_block_m.
    const std::size_t nv = static_cast<std::size_t>(num_voxels());
    std::vector<std::vector<BlockingEntry>> lists(nv);
    std::vector<std::uint8_t> first(nv);
    near.Reset(nv);
    for (int node = 0; node < num_nodes_; ++node) {
      if (!keep(node)) continue;
      near.StartNode();
      // Samples come in increasing order, so the first visit of a voxel is its first blocked sample.
      near.ForEachNear(block_grid_, geo.voxel_block_m, node, [&](int v, int i, double, bool first_visit) {
        if (first_visit) first[static_cast<std::size_t>(v)] = static_cast<std::uint8_t>(i);
      });
      for (int v : near.touched()) {
        BlockingEntry e;
        e.node = static_cast<std::uint16_t>(node);
        e.first_sample = first[static_cast<std::size_t>(v)];
        lists[static_cast<std::size_t>(v)].push_back(e);
      }
    }
    Compress(&lists, &out.blocking_offsets, &out.blocking);
  }
  {  // Clearance band: nearest sample (first if tied) and the clearance bucket.
    const std::size_t nv = static_cast<std::size_t>(num_clearance_voxels());
    std::vector<std::vector<BandEntry>> lists(nv);
    std::vector<double> min_d2(nv);
    std::vector<std::uint8_t> closest(nv);
    near.Reset(nv);
    for (int node = 0; node < num_nodes_ && options.clearance_band_m > 0.0; ++node) {
      if (!keep(node)) continue;
      near.StartNode();
      near.ForEachNear(band_grid_, geo.band_reach_m, node, [&](int v, int i, double d2, bool first_visit) {
        const std::size_t vi = static_cast<std::size_t>(v);
        if (first_visit || d2 < min_d2[vi]) {
          min_d2[vi] = d2;
          closest[vi] = static_cast<std::uint8_t>(i);
        }
      });
      for (int v : near.touched()) {
        const std::size_t vi = static_cast<std::size_t>(v);
        if (!(min_d2[vi] < geo.band_reach_m * geo.band_reach_m)) continue;  // Clearance must be < band.
        BandEntry e;
        e.node = static_cast<std::uint16_t>(node);
        e.closest_sample = closest[vi];
        e.clearance_bucket = ClearanceBucket(min_d2[vi], geo, options);
        lists[vi].push_back(e);
      }
    }
    Compress(&lists, &out.band_offsets, &out.band);
  }
  return out;
}

double TrajectoryLibrary::BucketClearanceM(std::uint8_t bucket) const {
  if (bucket == kNone) return options_.clearance_band_m;
  return bucket * options_.clearance_band_m / kBuckets;
}

ConstSpan<BlockingEntry> TrajectoryLibrary::blocking_entries(int index) const {
  const std::size_t v = static_cast<std::size_t>(index);
  return {blocking_.data() + blocking_offsets_[v], blocking_.data() + blocking_offsets_[v + 1]};
}

ConstSpan<BandEntry> TrajectoryLibrary::band_entries(int index) const {
  const std::size_t v = static_cast<std::size_t>(index);
  return {band_.data() + band_offsets_[v], band_.data() + band_offsets_[v + 1]};
}

std::size_t TrajectoryLibrary::memory_bytes() const {
  return sizeof(*this) + info_.capacity() * sizeof(TrajectoryInfo) +
         samples_B_.capacity() * sizeof(Eigen::Vector2f) + node_of_path_.capacity() * sizeof(std::uint16_t) +
         blocking_offsets_.capacity() * sizeof(std::uint32_t) + blocking_.capacity() * sizeof(BlockingEntry) +
         band_offsets_.capacity() * sizeof(std::uint32_t) + band_.capacity() * sizeof(BandEntry);
}

// ---------------------------------------------------------------------------------------------------------
// TrajectoryLibrary serialization

namespace {

constexpr char kLibraryMagic[8] = {'C', 'A', 'I', 'R', 'N', 'T', 'L', '\0'};
constexpr std::uint32_t kByteOrderMark = 0x01020304u;
static_assert(sizeof(BlockingEntry) == 4 && std::is_trivially_copyable_v<BlockingEntry>);
static_assert(sizeof(BandEntry) == 4 && std::is_trivially_copyable_v<BandEntry>);

// The options in the order they are stored, with their names (for a mismatch message).
std::vector<std::pair<const char*, double>> StoredOptions(const TrajectoryLibraryOptions& o) {
  return {{"path_length_m", o.path_length_m},
          {"num_groups", o.num_groups},
          {"paths_per_group", o.paths_per_group},
          {"num_headings", o.num_headings},
          {"heading_range_rad", o.heading_range_rad},
          {"max_segment_turn_rad", o.max_segment_turn_rad},
          {"sample_spacing_m", o.sample_spacing_m},
          {"voxel_size_m", o.voxel_size_m},
          {"clearance_voxel_size_m", o.clearance_voxel_size_m},
          {"collision_radius_m", o.collision_radius_m},
          {"clearance_band_m", o.clearance_band_m},
          {"obstacle_min_z_m", o.obstacle_min_z_m},
          {"obstacle_max_z_m", o.obstacle_max_z_m}};
}

void Append(std::string* out, const void* data, std::size_t bytes) {
  out->append(static_cast<const char*>(data), bytes);
}

template <typename T>
void AppendArray(std::string* out, const std::vector<T>& v) {
  const std::uint64_t count = v.size();
  Append(out, &count, sizeof(count));
  Append(out, v.data(), v.size() * sizeof(T));
}

// Reads from `bytes` at `*at`, never past the end.
class ByteReader {
 public:
  explicit ByteReader(const std::string& bytes) : bytes_(bytes) {}
  bool Read(void* data, std::size_t n) {
    if (n > bytes_.size() - at_) return false;
    std::memcpy(data, bytes_.data() + at_, n);
    at_ += n;
    return true;
  }
  template <typename T>
  bool ReadArray(std::vector<T>* v) {
    std::uint64_t count = 0;
    if (!Read(&count, sizeof(count)) || count > (bytes_.size() - at_) / sizeof(T)) return false;
    v->resize(static_cast<std::size_t>(count));
    return Read(v->data(), v->size() * sizeof(T));
  }
  bool AtEnd() const { return at_ == bytes_.size(); }

 private:
  const std::string& bytes_;
  std::size_t at_ = 0;
};

// Compressed rows: offsets start at 0, never decrease, end at the entry count, one row per voxel; node ids
// ascend within a row and stay below `num_nodes`; `sample_of(entry)` stays below `samples`.
template <typename Entry, typename SampleOf>
bool RowsValid(const std::vector<std::uint32_t>& offsets, const std::vector<Entry>& entries, int voxels,
               int num_nodes, int samples, SampleOf sample_of) {
  if (offsets.size() != static_cast<std::size_t>(voxels) + 1 || offsets.front() != 0 ||
      offsets.back() != entries.size()) {
    return false;
  }
  for (std::size_t v = 0; v + 1 < offsets.size(); ++v) {
    if (offsets[v] > offsets[v + 1]) return false;
    for (std::uint32_t e = offsets[v]; e < offsets[v + 1]; ++e) {
      const Entry& entry = entries[e];
      if (entry.node >= num_nodes || sample_of(entry) >= samples) return false;
      if (e > offsets[v] && entries[e - 1].node >= entry.node) return false;
    }
  }
  return true;
}

// The rows restricted to the entries of the nodes marked in `keep` (one flag per node).
template <typename Entry>
void KeepRows(const std::vector<std::uint32_t>& offsets, const std::vector<Entry>& entries,
              const std::vector<char>& keep, std::vector<std::uint32_t>* kept_offsets,
              std::vector<Entry>* kept) {
  kept_offsets->assign(1, 0);
  kept->clear();
  for (std::size_t v = 0; v + 1 < offsets.size(); ++v) {
    for (std::uint32_t e = offsets[v]; e < offsets[v + 1]; ++e) {
      if (keep[entries[e].node]) kept->push_back(entries[e]);
    }
    kept_offsets->push_back(static_cast<std::uint32_t>(kept->size()));
  }
}

template <typename Entry>
bool SameEntries(const std::vector<Entry>& a, const std::vector<Entry>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(Entry)) == 0);
}

}  // namespace

int TrajectoryLibrary::HeadingSlotOfNode(int node) const {
  const int groups = options_.num_groups;
  const int k = IntSqrt(options_.paths_per_group);
  const int level1_base = num_kept_headings_ * groups;
  const int level2_base = level1_base + num_kept_headings_ * groups * k;
  if (node < level1_base) return node / groups;
  if (node < level2_base) return (node - level1_base) / (groups * k);
  return (node - level2_base) / paths_per_heading_;
}

std::uint64_t TrajectoryLibrary::Fingerprint(const TrajectoryLibraryOptions& options) {
  std::string bytes;
  Append(&bytes, &kFormatVersion, sizeof(kFormatVersion));
  for (const auto& [name, value] : StoredOptions(options)) Append(&bytes, &value, sizeof(value));
  std::uint64_t hash = 14695981039346656037ull;  // FNV-1a, 64 bits
  for (const char c : bytes) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ull;
  }
  return hash;
}

std::string TrajectoryLibrary::Serialize() const {
  std::string out;
  out.reserve(64 + 8 * 13 + 32 + (blocking_offsets_.size() + band_offsets_.size()) * 4 +
              (blocking_.size() + band_.size()) * 4);
  Append(&out, kLibraryMagic, sizeof(kLibraryMagic));
  Append(&out, &kFormatVersion, sizeof(kFormatVersion));
  Append(&out, &kByteOrderMark, sizeof(kByteOrderMark));
  for (const auto& [name, value] : StoredOptions(options_)) Append(&out, &value, sizeof(value));
  AppendArray(&out, blocking_offsets_);
  AppendArray(&out, blocking_);
  AppendArray(&out, band_offsets_);
  AppendArray(&out, band_);
  return out;
}

std::unique_ptr<TrajectoryLibrary> TrajectoryLibrary::Deserialize(const std::string& bytes,
                                                                  const TrajectoryLibraryOptions& options,
                                                                  std::string* why) {
  std::string invalid;
  if (!options.IsValid(&invalid)) throw std::invalid_argument(invalid);
  const auto t0 = std::chrono::steady_clock::now();
  auto refuse = [why](const std::string& reason) {
    *why = reason;
    return nullptr;
  };
  ByteReader in(bytes);
  char magic[sizeof(kLibraryMagic)] = {};
  std::uint32_t version = 0;
  std::uint32_t byte_order = 0;
  if (!in.Read(magic, sizeof(magic)) || std::memcmp(magic, kLibraryMagic, sizeof(magic)) != 0) {
    return refuse("not a Cairn trajectory library (magic)");
  }
  if (!in.Read(&version, sizeof(version)) || version != kFormatVersion) {
    return refuse("format version " + std::to_string(version) + ", this build reads " +
                  std::to_string(kFormatVersion));
  }
  if (!in.Read(&byte_order, sizeof(byte_order)) || byte_order != kByteOrderMark) {
    return refuse("written on a machine of another byte order");
  }
  for (const auto& [name, value] : StoredOptions(options)) {
    double stored = 0.0;
    if (!in.Read(&stored, sizeof(stored))) return refuse("truncated in its options");
    if (!(stored == value)) {
      std::ostringstream msg;
      msg.precision(17);
      msg << "built with " << name << " = " << stored << ", wanted " << value;
      return refuse(msg.str());
    }
  }
  std::unique_ptr<TrajectoryLibrary> library(new TrajectoryLibrary(options, PathsOnly{}));
  TrajectoryLibrary& lib = *library;
  if (!in.ReadArray(&lib.blocking_offsets_) || !in.ReadArray(&lib.blocking_) ||
      !in.ReadArray(&lib.band_offsets_) || !in.ReadArray(&lib.band_)) {
    return refuse("truncated in its correspondence");
  }
  if (!in.AtEnd()) return refuse("longer than its contents");
  const int n = lib.samples_per_path_;
  if (!RowsValid(lib.blocking_offsets_, lib.blocking_, lib.num_voxels(), lib.num_nodes_, n,
                 [](const BlockingEntry& e) { return e.first_sample; })) {
    return refuse("blocking rows out of range (sizes, offsets, node ids or samples)");
  }
  if (!RowsValid(lib.band_offsets_, lib.band_, lib.num_clearance_voxels(), lib.num_nodes_, n,
                 [](const BandEntry& e) { return e.closest_sample; })) {
    return refuse("band rows out of range (sizes, offsets, node ids or samples)");
  }
  // Spot check: one heading's correspondence built again.
  const int slot = lib.num_kept_headings_ / 2;
  std::vector<char> in_slot(static_cast<std::size_t>(lib.num_nodes_));
  for (int node = 0; node < lib.num_nodes_; ++node)
    in_slot[static_cast<std::size_t>(node)] = lib.HeadingSlotOfNode(node) == slot;
  const Correspondence fresh =
      lib.BuildCorrespondence([&in_slot](int node) { return in_slot[static_cast<std::size_t>(node)] != 0; });
  Correspondence stored;
  KeepRows(lib.blocking_offsets_, lib.blocking_, in_slot, &stored.blocking_offsets, &stored.blocking);
  KeepRows(lib.band_offsets_, lib.band_, in_slot, &stored.band_offsets, &stored.band);
  if (fresh.blocking_offsets != stored.blocking_offsets || !SameEntries(fresh.blocking, stored.blocking) ||
      fresh.band_offsets != stored.band_offsets || !SameEntries(fresh.band, stored.band)) {
    return refuse("the correspondence of heading slot " + std::to_string(slot) +
                  " differs from one built now (a file from another build, or damaged)");
  }
  lib.build_time_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return library;
}

// ---------------------------------------------------------------------------------------------------------
// LocalPlannerOptions, names

bool LocalPlannerOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi) {
    if (std::isfinite(value) && value >= lo && value <= hi) return true;
    msg << "LocalPlannerOptions::" << field << " = " << value << " must be finite and in [" << lo << ", "
        << hi << "]";
    return false;
  };
  const bool ok = range("goal_direction_weight", goal_direction_weight, 0.0, 100.0) &&
                  range("heading_change_weight", heading_change_weight, 0.0, 100.0) &&
                  range("turning_weight", turning_weight, 0.0, 100.0) &&
                  range("clearance_weight", clearance_weight, 0.0, 100.0) &&
                  range("hysteresis_weight", hysteresis_weight, 0.0, 100.0) &&
                  range("min_free_length_m", min_free_length_m, 0.0, 100.0) &&
                  range("max_joystick_deviation_rad", max_joystick_deviation_rad, 0.0, kPi);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

const char* ToString(LocalPlanMode mode) {
  switch (mode) {
    case LocalPlanMode::kGoal:
      return "kGoal";
    case LocalPlanMode::kJoystick:
      return "kJoystick";
  }
  return "?";
}

const char* ToString(LocalPlanResult::Status status) {
  switch (status) {
    case LocalPlanResult::Status::kPathFound:
      return "kPathFound";
    case LocalPlanResult::Status::kBoxedIn:
      return "kBoxedIn";
    case LocalPlanResult::Status::kInvalidInput:
      return "kInvalidInput";
  }
  return "?";
}

bool LocalPlanResult::IsFree(int path_id) const {
  if (path_id < 0 || static_cast<std::size_t>(path_id) / 64 >= free_mask.size()) return false;
  return (free_mask[static_cast<std::size_t>(path_id) / 64] >> (path_id % 64)) & 1u;
}

// ---------------------------------------------------------------------------------------------------------
// LocalPlanner

LocalPlanner::LocalPlanner(std::shared_ptr<const TrajectoryLibrary> library,
                           const LocalPlannerOptions& options)
    : library_(std::move(library)), options_(options) {
  if (library_ == nullptr) throw std::invalid_argument("LocalPlanner: library must not be null");
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const std::size_t num_paths = static_cast<std::size_t>(library_->num_paths());
  voxel_stamp_.assign(static_cast<std::size_t>(library_->num_voxels()), 0);
  occupied_.reserve(static_cast<std::size_t>(library_->num_voxels()));
  band_stamp_.assign(static_cast<std::size_t>(library_->num_clearance_voxels()), 0);
  occupied_band_.reserve(static_cast<std::size_t>(library_->num_clearance_voxels()));
  first_blocked_.assign(num_paths, static_cast<std::uint8_t>(library_->samples_per_path()));
  clearance_bucket_.assign(num_paths, kNone);
  node_first_blocked_.assign(static_cast<std::size_t>(library_->num_nodes()), 0);
  node_bucket_.assign(static_cast<std::size_t>(library_->num_nodes()), kNone);
  heading_rad_.resize(num_paths);
  end_bearing_rad_.resize(num_paths);
  static_score_.resize(num_paths);
  const double max_total_turn = 3.0 * library_->options().max_segment_turn_rad;
  for (std::size_t p = 0; p < num_paths; ++p) {
    const TrajectoryInfo& info = library_->info(static_cast<int>(p));
    heading_rad_[p] = info.heading_rad;
    end_bearing_rad_[p] = info.end_bearing_rad;
    const double straightness = max_total_turn > 0.0 ? 1.0 - info.total_turn_rad / max_total_turn : 1.0;
    static_score_[p] =
        static_cast<float>(options_.heading_change_weight * (1.0 - std::abs(info.heading_rad) / kPi) +
                           options_.turning_weight * straightness);
  }
  // Near points: a few dozen lethal cells around the robot in practice; beyond the capacity the rest go
  // through their voxels (conservative, no allocation in a cycle). They are tested per path tree node (the
  // first arc of a group holds every sample within reach of them with the defaults: 252 nodes, not 12,348
  // paths).
  near_points_.reserve(4096);
  const double reach = library_->near_origin_radius_m() + library_->options().collision_radius_m +
                       library_->sample_spacing_m();
  std::vector<char> seen(static_cast<std::size_t>(library_->num_nodes()), 0);
  for (int p = 0; p < library_->num_paths(); ++p) {
    const Eigen::Vector2f* samples = library_->samples_B(p);
    const std::uint16_t* nodes = library_->path_nodes(p);
    for (int level = 0; level < 3; ++level) {
      if (seen[nodes[level]]) continue;
      seen[nodes[level]] = 1;
      const int first = level == 0 ? 0 : library_->level_end_sample(level - 1);
      int end = first;
      for (int i = first; i < library_->level_end_sample(level); ++i) {
        if (samples[i].cast<double>().norm() <= reach + 1e-6) end = i + 1;
      }
      if (end > first) near_nodes_.push_back({nodes[level], p, first, end});
    }
  }
}

double LocalPlanner::free_length_m(int path_id) const {
  return first_blocked_[static_cast<std::size_t>(path_id)] * library_->sample_spacing_m();
}

double LocalPlanner::clearance_m(int path_id) const {
  return library_->BucketClearanceM(clearance_bucket_[static_cast<std::size_t>(path_id)]);
}

namespace {

// Empties `r` for a new cycle, keeping (and growing once to their largest size) its buffers, so that later
// cycles do not allocate.
void ResetResult(int num_paths, int samples_per_path, LocalPlanResult* result) {
  LocalPlanResult& r = *result;
  r.status = LocalPlanResult::Status::kInvalidInput;
  r.path_id = -1;
  r.path_B.clear();
  r.free_length_m = 0.0;
  r.required_free_length_m = 0.0;
  r.score = 0.0;
  r.clearance_m = 0.0;
  r.num_free_paths = 0;
  r.num_candidate_paths = 0;
  r.free_mask.assign((static_cast<std::size_t>(num_paths) + 63) / 64, 0);
  r.path_B.reserve(static_cast<std::size_t>(samples_per_path) + 1);
  r.message.reserve(kMessageCapacity);
  r.num_points_used = 0;
  r.num_points_outside_grid = 0;
  r.num_points_outside_z_band = 0;
  r.num_points_non_finite = 0;
  r.num_occupied_voxels = 0;
  r.num_occupied_clearance_voxels = 0;
  r.nearest_obstacle_m = std::numeric_limits<double>::infinity();
}

// False (and why, in buf) when `request` is not one the planner can answer with a library of `num_paths`.
bool CheckRequest(const LocalPlanRequest& request, int num_paths, char (&buf)[kMessageCapacity]) {
  const Eigen::Vector2d& goal = request.goal_B;
  if (!std::isfinite(goal.x()) || !std::isfinite(goal.y())) {
    std::snprintf(buf, sizeof(buf), "LocalPlanRequest::goal_B (%g, %g) must be finite", goal.x(), goal.y());
    return false;
  }
  const double goal_distance_m = goal.norm();
  if (!(goal_distance_m > 1e-6)) {
    std::snprintf(buf, sizeof(buf),
                  "LocalPlanRequest::goal_B (%g, %g) must be longer than 1e-6 m (it sets the %s)", goal.x(),
                  goal.y(), request.mode == LocalPlanMode::kGoal ? "goal direction" : "joystick direction");
    return false;
  }
  if (!(request.max_required_free_length_m > 0.0)) {
    std::snprintf(buf, sizeof(buf), "LocalPlanRequest::max_required_free_length_m = %g must be > 0",
                  request.max_required_free_length_m);
    return false;
  }
  if (request.previous_path_id < -1 || request.previous_path_id >= num_paths) {
    std::snprintf(buf, sizeof(buf), "LocalPlanRequest::previous_path_id = %d must be -1 or in [0, %d]",
                  request.previous_path_id, num_paths - 1);
    return false;
  }
  if (request.mode != LocalPlanMode::kGoal && request.mode != LocalPlanMode::kJoystick) {
    std::snprintf(buf, sizeof(buf), "LocalPlanRequest::mode = %d is not kGoal or kJoystick",
                  static_cast<int>(request.mode));
    return false;
  }
  return true;
}

}  // namespace

LocalPlanResult LocalPlanner::Plan(const std::vector<Eigen::Vector3f>& obstacles_B,
                                   const LocalPlanRequest& request) {
  LocalPlanResult result;
  Plan(obstacles_B, request, &result);
  return result;
}

void LocalPlanner::Plan(const std::vector<Eigen::Vector3f>& obstacles_B, const LocalPlanRequest& request,
                        LocalPlanResult* result) {
  const auto t0 = std::chrono::steady_clock::now();
  const TrajectoryLibrary& lib = *library_;
  const int num_paths = lib.num_paths();
  const int n = lib.samples_per_path();
  LocalPlanResult& r = *result;
  using Status = LocalPlanResult::Status;
  ResetResult(num_paths, n, result);
  char buf[kMessageCapacity];
  auto finish = [&](Status status) {
    r.status = status;
    r.message.assign(buf);
    r.planning_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  };
  if (!CheckRequest(request, num_paths, buf)) return finish(Status::kInvalidInput);
  const Eigen::Vector2d& goal = request.goal_B;
  const bool joystick = request.mode == LocalPlanMode::kJoystick;
  double required_m = request.max_required_free_length_m;
  if (!joystick) required_m = std::min(required_m, goal.norm());
  required_m = std::min(std::max(required_m, options_.min_free_length_m), lib.options().path_length_m);
  const int required_samples = RequiredSamples(required_m, lib.sample_spacing_m(), n);
  r.required_free_length_m = required_m;
  MarkOccupiedVoxels(obstacles_B, &r);
  BlockPaths(required_samples);
  float best_score = 0.0f;
  const int best = ChoosePath(request, required_samples, &r, &best_score);

  char nearest[48];
  if (std::isfinite(r.nearest_obstacle_m)) {
    std::snprintf(nearest, sizeof(nearest), "nearest obstacle %.2f m", r.nearest_obstacle_m);
  } else {
    std::snprintf(nearest, sizeof(nearest), "no obstacles");
  }
  if (best < 0) {
    if (joystick) {
      std::snprintf(
          buf, sizeof(buf),
          "boxed in: 0 of %d paths free for %.2f m within %.0f deg of the joystick direction %.0f deg "
          "(%d free elsewhere), %s",
          num_paths, required_m, options_.max_joystick_deviation_rad * 180.0 / kPi,
          std::atan2(goal.y(), goal.x()) * 180.0 / kPi, r.num_free_paths, nearest);
    } else {
      std::snprintf(buf, sizeof(buf), "boxed in: 0 of %d paths free for %.2f m, %s", num_paths, required_m,
                    nearest);
    }
    return finish(Status::kBoxedIn);
  }
  const std::size_t bi = static_cast<std::size_t>(best);
  r.path_id = best;
  r.score = best_score;
  r.free_length_m = first_blocked_[bi] * lib.sample_spacing_m();
  r.clearance_m = lib.BucketClearanceM(clearance_bucket_[bi]);
  const Eigen::Vector2f* samples = lib.samples_B(best);
  r.path_B.emplace_back(0.0f, 0.0f, 0.0f);
  for (int i = 0; i < first_blocked_[bi]; ++i) r.path_B.emplace_back(samples[i].x(), samples[i].y(), 0.0f);
  const TrajectoryInfo& info = lib.info(best);
  std::snprintf(buf, sizeof(buf),
                "path %d (heading %.0f deg, group %d, end bearing %.0f deg): free %.2f m (%.2f m required), "
                "clearance %.2f m, %d of %d paths free, %s",
                best, info.heading_rad * 180.0 / kPi, info.group, info.end_bearing_rad * 180.0 / kPi,
                r.free_length_m, required_m, r.clearance_m, r.num_free_paths, num_paths, nearest);
  finish(Status::kPathFound);
}

// Points -> the distinct occupied voxels of both grids, and the points near the origin (no allocation: stamps
// and lists are preallocated); counts into `r`.
void LocalPlanner::MarkOccupiedVoxels(const std::vector<Eigen::Vector3f>& obstacles_B,
                                      LocalPlanResult* result) {
  const TrajectoryLibrary& lib = *library_;
  const TrajectoryLibraryOptions& lo = lib.options();
  LocalPlanResult& r = *result;
  if (++cycle_ == 0) {
    std::fill(voxel_stamp_.begin(), voxel_stamp_.end(), 0u);
    std::fill(band_stamp_.begin(), band_stamp_.end(), 0u);
    cycle_ = 1;
  }
  occupied_.clear();
  occupied_band_.clear();
  near_points_.clear();
  const double near_m = lib.near_origin_radius_m();
  float nearest2 = std::numeric_limits<float>::infinity();
  for (const Eigen::Vector3f& p : obstacles_B) {
    if (!IsFinite(p)) {
      ++r.num_points_non_finite;
      continue;
    }
    if (!InZBand(p, lo)) {
      ++r.num_points_outside_z_band;
      continue;
    }
    nearest2 = std::min(nearest2, p.x() * p.x() + p.y() * p.y());
    const bool near = IsNearOrigin(p.x(), p.y(), near_m) && near_points_.size() < near_points_.capacity();
    if (near) near_points_.push_back({p.x(), p.y(), NearBlockSquared(p.x(), p.y(), lo.collision_radius_m)});
    const int v = near ? -1 : lib.VoxelIndex(p.x(), p.y());
    const int w = lib.ClearanceVoxelIndex(p.x(), p.y());
    if (v < 0 && w < 0 && !near) {
      ++r.num_points_outside_grid;
      continue;
    }
    ++r.num_points_used;
    if (v >= 0 && voxel_stamp_[static_cast<std::size_t>(v)] != cycle_) {
      voxel_stamp_[static_cast<std::size_t>(v)] = cycle_;
      occupied_.push_back(v);
    }
    if (w >= 0 && band_stamp_[static_cast<std::size_t>(w)] != cycle_) {
      band_stamp_[static_cast<std::size_t>(w)] = cycle_;
      occupied_band_.push_back(w);
    }
  }
  r.num_occupied_voxels = static_cast<int>(occupied_.size());
  r.num_occupied_clearance_voxels = static_cast<int>(occupied_band_.size());
  r.nearest_obstacle_m = std::sqrt(static_cast<double>(nearest2));
}

// Voxels -> path tree nodes -> paths: each path's first blocked sample and least clearance bucket (counted
// within `required_samples`).
void LocalPlanner::BlockPaths(int required_samples) {
  const TrajectoryLibrary& lib = *library_;
  const int num_paths = lib.num_paths();
  const int n = lib.samples_per_path();
  std::fill(node_first_blocked_.begin(), node_first_blocked_.end(), static_cast<std::uint8_t>(n));
  std::fill(node_bucket_.begin(), node_bucket_.end(), kNone);
  std::uint8_t* const node_first = node_first_blocked_.data();
  std::uint8_t* const node_bucket = node_bucket_.data();
  const int req = required_samples;
  for (int v : occupied_) {
    for (const BlockingEntry& e : lib.blocking_entries(v)) {
      std::uint8_t& f = node_first[e.node];
      f = std::min(f, e.first_sample);
    }
  }
  for (int w : occupied_band_) {
    for (const BandEntry& e : lib.band_entries(w)) {
      const std::uint8_t value = e.closest_sample < req ? e.clearance_bucket : kNone;
      std::uint8_t& c = node_bucket[e.node];
      c = std::min(c, value);
    }
  }
  // Points near the origin, exactly, per path tree node (see TrajectoryLibrary).
  if (!near_points_.empty()) {
    for (const NearNode& nn : near_nodes_) {
      const Eigen::Vector2f* s = lib.samples_B(nn.path);
      std::uint8_t& f = node_first[nn.node];
      const int end = std::min<int>(f, nn.end);
      for (int i = nn.first; i < end; ++i) {
        bool blocked = false;
        for (const NearPoint& q : near_points_) {
          if (NearPointBlocks(q.x, q.y, s, i, q.block2)) {
            blocked = true;
            break;
          }
        }
        if (blocked) {
          f = static_cast<std::uint8_t>(i);
          break;
        }
      }
    }
  }
  std::uint8_t* const first_blocked = first_blocked_.data();
  std::uint8_t* const bucket = clearance_bucket_.data();
  const std::uint16_t* nodes = lib.path_nodes(0);
  for (int p = 0; p < num_paths; ++p, nodes += 3) {
    first_blocked[p] = std::min({node_first[nodes[0]], node_first[nodes[1]], node_first[nodes[2]]});
    bucket[p] = std::min({node_bucket[nodes[0]], node_bucket[nodes[1]], node_bucket[nodes[2]]});
  }
}

// The free path (for `required_samples`) of the best score (see LocalPlannerOptions), -1 if none; the free
// and candidate counts and the free mask into `r`.
int LocalPlanner::ChoosePath(const LocalPlanRequest& request, int required_samples, LocalPlanResult* result,
                             float* best_score_out) const {
  const TrajectoryLibraryOptions& lo = library_->options();
  const int num_paths = library_->num_paths();
  const int req = required_samples;
  const bool joystick = request.mode == LocalPlanMode::kJoystick;
  const Eigen::Vector2d& goal = request.goal_B;
  LocalPlanResult& r = *result;
  const std::uint8_t* const first_blocked = first_blocked_.data();
  const std::uint8_t* const bucket = clearance_bucket_.data();
  const float pi_f = static_cast<float>(kPi);
  // |a - b| wrapped to [0, pi], for a, b in [-pi, pi].
  auto angle_between = [pi_f](float a, float b) {
    const float d = std::abs(a - b);
    return d > pi_f ? 2.0f * pi_f - d : d;
  };
  const float target = static_cast<float>(std::atan2(goal.y(), goal.x()));
  const float limit = static_cast<float>(options_.max_joystick_deviation_rad) + 1e-6f;
  const bool has_previous = request.previous_path_id >= 0;
  const float previous_bearing =
      has_previous ? end_bearing_rad_[static_cast<std::size_t>(request.previous_path_id)] : 0.0f;
  const float band = static_cast<float>(lo.clearance_band_m);
  const float bucket_to_term = 1.0f / kBuckets;  // bucket -> clearance / band
  const float wg = static_cast<float>(options_.goal_direction_weight);
  const float wc = static_cast<float>(options_.clearance_weight);
  const float wp = has_previous ? static_cast<float>(options_.hysteresis_weight) : 0.0f;
  int best = -1;
  float best_score = -std::numeric_limits<float>::infinity();
  for (int p = 0; p < num_paths; ++p) {
    const std::size_t pi = static_cast<std::size_t>(p);
    if (first_blocked[pi] < req) continue;
    ++r.num_free_paths;
    r.free_mask[pi / 64] |= std::uint64_t{1} << (pi % 64);
    const float goal_off = angle_between(end_bearing_rad_[pi], target);
    if (joystick && (goal_off > limit || angle_between(heading_rad_[pi], target) > limit)) continue;
    ++r.num_candidate_paths;
    const float clearance_term = (band <= 0.0f || bucket[pi] == kNone) ? 1.0f : bucket[pi] * bucket_to_term;
    float score = static_score_[pi] + wg * (1.0f - goal_off / pi_f) + wc * clearance_term;
    if (has_previous) score += wp * (1.0f - angle_between(end_bearing_rad_[pi], previous_bearing) / pi_f);
    if (score > best_score) {
      best_score = score;
      best = p;
    }
  }

  *best_score_out = best_score;
  return best;
}

// ---------------------------------------------------------------------------------------------------------
// Brute force

namespace {

// The obstacle points as the brute force tests them: blocking and clearance voxel centres (the grids extended
// beyond their edges), sorted by x so that each arc only scans the points in the x range of its bounding box,
// and the points near the origin, tested exactly (IsNearOrigin): (x, y, squared blocking distance).
struct BruteForceObstacles {
  std::vector<Eigen::Vector2d> block_centres;
  std::vector<Eigen::Vector2d> band_centres;
  std::vector<Eigen::Vector3d> near_points;
};

BruteForceObstacles SortObstacles(const TrajectoryLibrary& library,
                                  const std::vector<Eigen::Vector3f>& obstacles_B, const Geometry& geo) {
  const TrajectoryLibraryOptions& o = library.options();
  BruteForceObstacles out;
  out.block_centres.reserve(obstacles_B.size());
  out.band_centres.reserve(obstacles_B.size());
  for (const Eigen::Vector3f& p : obstacles_B) {
    if (!IsFinite(p) || !InZBand(p, o)) continue;
    out.band_centres.emplace_back(
        VoxelCentreCoordinate(p.x(), library.clearance_grid_min_m(), o.clearance_voxel_size_m),
        VoxelCentreCoordinate(p.y(), library.clearance_grid_min_m(), o.clearance_voxel_size_m));
    if (IsNearOrigin(p.x(), p.y(), geo.near_origin_m)) {
      out.near_points.emplace_back(p.x(), p.y(), NearBlockSquared(p.x(), p.y(), o.collision_radius_m));
      continue;
    }
    out.block_centres.emplace_back(VoxelCentreCoordinate(p.x(), library.grid_min_m(), o.voxel_size_m),
                                   VoxelCentreCoordinate(p.y(), library.grid_min_m(), o.voxel_size_m));
  }
  auto by_x = [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() < b.x(); };
  std::sort(out.block_centres.begin(), out.block_centres.end(), by_x);
  std::sort(out.band_centres.begin(), out.band_centres.end(), by_x);
  return out;
}

// Calls visit(centre) for the centres (sorted by x) within the bounding box of samples [i0, i1) grown by
// `reach` (a cull only: the distance tests decide).
template <typename Visit>
void ForEachNearBox(const std::vector<Eigen::Vector2d>& centres, const Eigen::Vector2f* s, int i0, int i1,
                    double reach, Visit&& visit) {
  if (i0 >= i1) return;
  double x_lo = std::numeric_limits<double>::infinity();
  double x_hi = -x_lo;
  double y_lo = x_lo;
  double y_hi = -x_lo;
  for (int i = i0; i < i1; ++i) {
    x_lo = std::min(x_lo, static_cast<double>(s[i].x()));
    x_hi = std::max(x_hi, static_cast<double>(s[i].x()));
    y_lo = std::min(y_lo, static_cast<double>(s[i].y()));
    y_hi = std::max(y_hi, static_cast<double>(s[i].y()));
  }
  const double grow = reach + 1e-6;
  auto it = std::lower_bound(centres.begin(), centres.end(), x_lo - grow,
                             [](const Eigen::Vector2d& c, double x) { return c.x() < x; });
  for (; it != centres.end() && it->x() <= x_hi + grow; ++it) {
    if (it->y() >= y_lo - grow && it->y() <= y_hi + grow) visit(*it);
  }
}

}  // namespace

std::vector<double> BruteForceFreeLengths(const TrajectoryLibrary& library,
                                          const std::vector<Eigen::Vector3f>& obstacles_B,
                                          double required_free_length_m, std::vector<double>* clearance_m) {
  const TrajectoryLibraryOptions& o = library.options();
  const Geometry geo = ComputeGeometry(o);
  const int n = library.samples_per_path();
  const double block2 = geo.voxel_block_m * geo.voxel_block_m;
  const double band2 = geo.band_reach_m * geo.band_reach_m;
  const bool with_band = o.clearance_band_m > 0.0;
  const int req = RequiredSamples(std::isnan(required_free_length_m) ? 0.0 : required_free_length_m,
                                  library.sample_spacing_m(), n);
  const BruteForceObstacles obstacles = SortObstacles(library, obstacles_B, geo);
  const int num_paths = library.num_paths();
  std::vector<double> free_m(static_cast<std::size_t>(num_paths));
  if (clearance_m != nullptr) clearance_m->assign(static_cast<std::size_t>(num_paths), 0.0);
  for (int p = 0; p < num_paths; ++p) {
    const Eigen::Vector2f* s = library.samples_B(p);
    int first_blocked = n;
    int bucket = kNone;
    // Each arc on its own, as the correspondence (the clearance is defined per arc).
    for (int level = 0; level < 3; ++level) {
      const int i0 = level == 0 ? 0 : library.level_end_sample(level - 1);
      const int i1 = library.level_end_sample(level);
      ForEachNearBox(obstacles.block_centres, s, i0, i1, geo.voxel_block_m, [&](const Eigen::Vector2d& c) {
        for (int i = i0; i < i1 && i < first_blocked; ++i) {
          if (SquaredDistance(c.x(), c.y(), s[i].x(), s[i].y()) <= block2) {
            first_blocked = i;
            break;
          }
        }
      });
      if (!with_band || clearance_m == nullptr) continue;
      ForEachNearBox(obstacles.band_centres, s, i0, i1, geo.band_reach_m, [&](const Eigen::Vector2d& c) {
        int closest = 0;
        double min_d2 = std::numeric_limits<double>::infinity();
        for (int i = i0; i < i1; ++i) {
          const double d2 = SquaredDistance(c.x(), c.y(), s[i].x(), s[i].y());
          if (d2 < min_d2) {
            min_d2 = d2;
            closest = i;
          }
        }
        if (min_d2 < band2 && closest < req) bucket = std::min<int>(bucket, ClearanceBucket(min_d2, geo, o));
      });
    }
    for (int i = 0; i < first_blocked; ++i) {
      const bool blocked =
          std::any_of(obstacles.near_points.begin(), obstacles.near_points.end(),
                      [&](const Eigen::Vector3d& q) { return NearPointBlocks(q.x(), q.y(), s, i, q.z()); });
      if (blocked) first_blocked = i;
    }
    free_m[static_cast<std::size_t>(p)] = first_blocked * library.sample_spacing_m();
    if (clearance_m != nullptr) {
      (*clearance_m)[static_cast<std::size_t>(p)] =
          library.BucketClearanceM(static_cast<std::uint8_t>(bucket));
    }
  }
  return free_m;
}

}  // namespace cairn::nav
