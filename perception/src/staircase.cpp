// Copyright Cairn authors.
//
// Staircase detection (PCL voxel filter, 2D projection, step-edge chaining, Ceres model fit), the local cloud
// accumulator and the detection registry. The only translation unit of Cairn that includes PCL and Ceres.
#include "cairn/perception/staircase.h"

#include <ceres/ceres.h>
#include <pcl/filters/voxel_grid.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace cairn::perception {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Wraps an angle to (-pi, pi].
double WrapAngle(double a_rad) {
  double a = std::fmod(a_rad, 2.0 * kPi);
  if (a <= -kPi) a += 2.0 * kPi;
  if (a > kPi) a -= 2.0 * kPi;
  return a;
}

// ---- Option checks ----------------------------------------------------------------------------------------

// Checks `lo <(=) value <(=) hi` for a named field; on failure writes "<Type>::<field> = <value> must be in
// <interval>" to `why` (if not null) and returns false.
bool CheckRange(const char* type, const char* field, double value, double lo, bool lo_open, double hi,
                bool hi_open, std::string* why, const std::string& note = "") {
  const bool ok =
      std::isfinite(value) && (lo_open ? value > lo : value >= lo) && (hi_open ? value < hi : value <= hi);
  if (!ok && why != nullptr) {
    std::ostringstream out;
    out << type << "::" << field << " = " << value << " must be in " << (lo_open ? "(" : "[") << lo << ", "
        << hi << (hi_open ? ")" : "]") << note;
    *why = out.str();
  }
  return ok;
}

// ---- Projection grid --------------------------------------------------------------------------------------

// Summary of the lowest cluster of points in one grid cell (points whose consecutive heights differ by at
// most cluster_gap_m, starting from the lowest point).
struct Cell {
  float top_m = 0.0f;     // Highest point of the cluster, metres, frame W.
  float bottom_m = 0.0f;  // Lowest point of the cluster, metres, frame W.
  float x_m = 0.0f;       // Mean x of the cluster's points, metres, frame W.
  float y_m = 0.0f;       // Mean y.
  int count = 0;          // Points in the cluster (0: empty cell).
};

// A step-edge cell: the nose of a step (upper side of a rise) or a riser seen from below.
struct EdgeCell {
  int cell = 0;    // Index in the grid.
  double x_m = 0;  // Position, metres, frame W.
  double y_m = 0;
  double h_m = 0;  // Height of the nose (cell top), metres, frame W.
  double nx = 0;   // Local edge normal (axial, unit), frame W; zero if unknown.
  double ny = 0;
  double weight = 0;        // Vote weight of the normal (linearity of the neighbourhood), [0, 1].
  bool riser_face = false;  // Found by the vertical extent of its points: it lies on the riser itself.
  bool used = false;        // Belongs to an accepted staircase.
};

// One step edge seen along an axis: a compact blob of edge cells in the side view (s, h).
struct Blob {
  double s_m = 0;        // Median position along the axis, metres.
  double s_front_m = 0;  // Riser position when ascending along +s (see RiserPosition()), metres.
  double s_back_m = 0;   // Riser position when ascending along -s, metres.
  double h_m = 0;        // Height: 90th percentile of the cells' tops, metres, frame W.
  double t_lo_m = 0;     // Lateral extent (across the axis), metres.
  double t_hi_m = 0;
  std::vector<int> edges;  // Indices into the edge-cell list.
};

// A chain of blobs: risers 0..num_risers-1 of a candidate staircase along one axis (ascending along +u).
struct Chain {
  double theta_rad = 0;    // Axis direction; ascending along (cos, sin).
  std::vector<int> blobs;  // Blob indices (into the axis' blob list), one per observed riser.
  std::vector<int> riser;  // Riser index (0-based) of each blob.
  std::vector<std::vector<int>> blob_edges;  // Edge cells of each blob.
  int num_risers = 0;
  int cells = 0;
  std::vector<int> edges;                                      // All member edge cells.
  double s_first_m = 0, h_first_m = 0, rise_m = 0, run_m = 0;  // Linear fit of the blobs.
  double t_lo_m = 0, t_hi_m = 0;                               // Lateral union.
};

// Longest run of sorted values whose consecutive gaps are at most `gap`; returns [lo, hi] and its size.
std::pair<std::pair<double, double>, int> LongestRun(std::vector<double>* values, double gap) {
  std::sort(values->begin(), values->end());
  const std::vector<double>& v = *values;
  if (v.empty()) return {{0.0, 0.0}, 0};
  std::size_t best_begin = 0, best_end = 1, begin = 0;
  for (std::size_t i = 1; i <= v.size(); ++i) {
    if (i == v.size() || v[i] - v[i - 1] > gap) {
      if (i - begin > best_end - best_begin) {
        best_begin = begin;
        best_end = i;
      }
      begin = i;
    }
  }
  return {{v[best_begin], v[best_end - 1]}, static_cast<int>(best_end - best_begin)};
}

// Position of the riser of a step edge along the axis, from the positions `s` of its edge cells and whether
// each lies on the riser face (`on_face`): the median of the face cells if there are 3 or more; else the
// front of the cells (10th percentile when ascending along +s, 90th along -s), since nose cells lie on the
// upper tread, behind the riser.
double RiserPosition(std::vector<double> s, const std::vector<bool>& on_face, int sign) {
  std::vector<double> face;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (on_face[i]) face.push_back(s[i]);
  }
  if (face.size() >= 3) {
    std::nth_element(face.begin(), face.begin() + static_cast<std::ptrdiff_t>(face.size() / 2), face.end());
    return face[face.size() / 2];
  }
  std::sort(s.begin(), s.end());
  return sign > 0 ? s[s.size() / 10] : s[s.size() - 1 - s.size() / 10];
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const std::size_t mid = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(mid), v.end());
  return v[mid];
}

// ---- Staircase model fit (Ceres) ------------------------------------------------------------------------
// Parameters x = [theta (rad), s0 (m), z0 (m), rise (m), run (m)]: ascending direction u = (cos, sin) of
// theta, first riser at distance s0 along u from the reference point, floor height z0. A point at horizontal
// offset (dx, dy) from the reference has s = u . (dx, dy).

constexpr int kNumParams = 5;

// One observation of the fit: a tread point (its height, and its position between the tread's risers) or a
// riser point (its position along the axis). `dx`, `dy` are offsets from the reference point, metres.
struct Observation {
  enum class Kind { kTreadHeight, kTreadExtent, kRiser };
  Kind kind = Kind::kTreadHeight;
  double dx_m = 0, dy_m = 0, z_m = 0;
  int index = 0;  // Tread level (0 = floor before the first riser, .., num_steps) or riser (0-based).
};

// All residuals of the fit in one Ceres block (an N x 5 Jacobian; thousands of one-residual blocks cost more
// in bookkeeping than the solve itself):
//  - tread height, level k:   z - (z0 + k rise);
//  - tread extent, level k:   hinge, zero while s0 + (k-1) run <= s <= s0 + k run (no lower bound for k = 0,
//                             no upper bound for the top tread), else the distance to the violated bound;
//  - riser k (0-based):       s - (s0 + k run).
// Each residual is robustified in place with a Huber function of scale d: r' = r for |r| <= d, else
// sign(r) sqrt(2 d |r| - d^2), whose square is the Huber cost (Huber 1964).
class StaircaseModelCost : public ceres::CostFunction {
 public:
  StaircaseModelCost(const std::vector<Observation>* observations, int num_steps, double huber_m)
      : obs_(observations), num_steps_(num_steps), huber_m_(huber_m) {
    set_num_residuals(static_cast<int>(observations->size()));
    mutable_parameter_block_sizes()->push_back(kNumParams);
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const double* x = parameters[0];
    const double c = std::cos(x[0]);
    const double s = std::sin(x[0]);
    double* jac = (jacobians != nullptr) ? jacobians[0] : nullptr;
    for (std::size_t i = 0; i < obs_->size(); ++i) {
      const Observation& o = (*obs_)[i];
      double r = 0.0;
      double j[kNumParams] = {0, 0, 0, 0, 0};
      const double pos = c * o.dx_m + s * o.dy_m;
      const double dpos = -s * o.dx_m + c * o.dy_m;
      switch (o.kind) {
        case Observation::Kind::kTreadHeight:
          r = o.z_m - (x[2] + o.index * x[3]);
          j[2] = -1.0;
          j[3] = -o.index;
          break;
        case Observation::Kind::kTreadExtent: {
          const double lo = x[1] + (o.index - 1) * x[4];
          const double hi = x[1] + o.index * x[4];
          if (o.index >= 1 && pos < lo) {
            r = pos - lo;
            j[0] = dpos;
            j[1] = -1.0;
            j[4] = -(o.index - 1);
          } else if (o.index < num_steps_ && pos > hi) {
            r = pos - hi;
            j[0] = dpos;
            j[1] = -1.0;
            j[4] = -o.index;
          }
          break;
        }
        case Observation::Kind::kRiser:
          r = pos - x[1] - o.index * x[4];
          j[0] = dpos;
          j[1] = -1.0;
          j[4] = -o.index;
          break;
      }
      double scale = 1.0;
      if (std::abs(r) > huber_m_) {
        const double robust = std::sqrt(2.0 * huber_m_ * std::abs(r) - huber_m_ * huber_m_);
        scale = huber_m_ / robust;
        r = r > 0 ? robust : -robust;
      }
      residuals[i] = r;
      if (jac != nullptr) {
        for (int k = 0; k < kNumParams; ++k) jac[i * kNumParams + static_cast<std::size_t>(k)] = scale * j[k];
      }
    }
    return true;
  }

 private:
  const std::vector<Observation>* obs_;
  int num_steps_;
  double huber_m_;
};

// Staircase model in the frame of the fit.
struct Model {
  double theta = 0, s0 = 0, z0 = 0, rise = 0, run = 0;
  int n = 0;  // Risers.
  double RiserS(int k) const { return s0 + k * run; }
  double TreadZ(int level) const { return z0 + level * rise; }
};

enum class PointClass { kNone, kTread, kRiser };

struct Classified {
  PointClass kind = PointClass::kNone;
  int index = 0;          // Tread level (0..n) or riser (0..n-1).
  bool at_riser = false;  // Tread point within 3 cm of a riser: may be the top or the foot of the riser.
};

// Classifies a point at along-axis s and height z against `m`, with tolerances `z_tol` (treads) and `s_tol`
// (risers). Tread points must lie on their tread (within s_tol of its ends); level 0 is the floor within one
// run before the first riser.
Classified Classify(const Model& m, double s, double z, double z_tol, double s_tol) {
  Classified c;
  const double level_f = (z - m.z0) / m.rise;
  const int level = static_cast<int>(std::lround(level_f));
  if (level >= 0 && level <= m.n && std::abs(z - m.TreadZ(level)) <= z_tol) {
    const double lo = level == 0 ? m.s0 - m.run : m.RiserS(level - 1);
    const double hi = level == m.n ? m.RiserS(m.n - 1) + m.run : m.RiserS(level);
    if (s >= lo - s_tol && s <= hi + s_tol) {
      c.kind = PointClass::kTread;
      c.index = level;
      c.at_riser = (level >= 1 && s < lo + 0.03) || (level < m.n && s > hi - 0.03);
      return c;
    }
  }
  const int riser = static_cast<int>(std::lround((s - m.s0) / m.run));
  if (riser >= 0 && riser < m.n && std::abs(s - m.RiserS(riser)) <= s_tol &&
      z > m.TreadZ(riser) + 0.5 * z_tol && z < m.TreadZ(riser + 1) + z_tol) {
    c.kind = PointClass::kRiser;
    c.index = riser;
  }
  return c;
}

// ---- The detector -----------------------------------------------------------------------------------------

// PCL VoxelGrid: one point (the centroid) per occupied voxel of edge `leaf_m`.
std::vector<Eigen::Vector3f> VoxelFilter(const std::vector<Eigen::Vector3f>& points, double leaf_m) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->reserve(points.size());
  for (const Eigen::Vector3f& p : points) cloud->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
  pcl::PointCloud<pcl::PointXYZ> filtered;
  pcl::VoxelGrid<pcl::PointXYZ> voxel;
  voxel.setInputCloud(cloud);
  const auto leaf = static_cast<float>(leaf_m);
  voxel.setLeafSize(leaf, leaf, leaf);
  voxel.filter(filtered);
  std::vector<Eigen::Vector3f> out;
  out.reserve(filtered.size());
  for (const pcl::PointXYZ& p : filtered) out.emplace_back(p.x, p.y, p.z);
  return out;
}

// Height tolerance on a rise when comparing cells and blobs, metres.
constexpr double kRiseTol = 0.03;
// Tolerance on a run when chaining blobs, metres.
constexpr double kRunTol = 0.07;
// Tolerance on the height of a step edge when chaining blobs, metres (the nose of a riser seen from below is
// sampled by a few beams only, its height is known to a few centimetres before the fit).
constexpr double kChainRiseTol = 0.05;
// A chain may seed across an unobserved riser only when its rise is at least min_rise_m plus this, metres.
constexpr double kSkippedRiserMinExtraRise = 0.05;
// Largest height of the lidar above the detector's reference position (the robot's body), metres.
constexpr double kSensorAboveReferenceMaxM = 0.6;

class DetectorRun {
 public:
  DetectorRun(const StaircaseDetectorOptions& o, const Eigen::Vector3d& p_W_robot, DetectStats* stats)
      : o_(o), p_ref_(p_W_robot), stats_(stats) {}

  std::vector<Staircase> Run(const std::vector<Eigen::Vector3f>& points_W) {
    const Clock::time_point t0 = Clock::now();
    std::vector<Staircase> out;
    stats_->points_in = static_cast<std::int64_t>(points_W.size());
    Filter(points_W);
    stats_->filter_ms = MsSince(t0);
    if (pts_.empty() || !p_ref_.allFinite()) return out;
    const Clock::time_point t1 = Clock::now();
    Project();
    FindEdges();
    std::vector<Chain> chains;
    for (double theta : AxisHypotheses()) FindChains(theta, &chains);
    std::sort(chains.begin(), chains.end(), [](const Chain& a, const Chain& b) {
      return std::make_tuple(a.blobs.size(), a.cells) > std::make_tuple(b.blobs.size(), b.cells);
    });
    stats_->projection_ms = MsSince(t1);
    const Clock::time_point t2 = Clock::now();
    constexpr int kMaxFits = 8;
    for (const Chain& chain : chains) {
      if (static_cast<int>(out.size()) >= o_.max_detections || stats_->chains_fitted >= kMaxFits) break;
      int used = 0;
      for (int e : chain.edges) used += edges_[static_cast<std::size_t>(e)].used ? 1 : 0;
      if (used * 10 > static_cast<int>(chain.edges.size()) * 3) continue;
      ++stats_->chains_fitted;
      Staircase stairs;
      std::string why;
      if (FitAndCheck(chain, &stairs, &why)) {
        out.push_back(stairs);
      } else {
        ++stats_->chains_rejected;
        stats_->last_rejection = why;
        stats_->rejections.push_back(why);
      }
    }
    MergeContinuations(&out);
    std::sort(out.begin(), out.end(),
              [](const Staircase& a, const Staircase& b) { return a.confidence > b.confidence; });
    stats_->fit_ms = MsSince(t2);
    return out;
  }

  // One flight is one detection: a detection that continues another one up the same flight (a chain broken
  // by two unseen risers, or a far part chained apart) is merged into it. `upper` continues `lower` when
  // their directions differ by at most 10 deg, the upper first riser lies k whole runs (within a third of a
  // run; 1 <= k <= lower's risers + 2) and k rises (within half a rise) from the lower one, and their
  // centres lie within half the narrower width of each other across the flight. The merge keeps the lower
  // first riser, spans both, and averages rise, run and width weighted by support points.
  static void MergeContinuations(std::vector<Staircase>* found) {
    bool merged = true;
    while (merged) {
      merged = false;
      for (std::size_t i = 0; i < found->size() && !merged; ++i) {
        for (std::size_t j = 0; j < found->size() && !merged; ++j) {
          if (i == j) continue;
          Staircase& lower = (*found)[i];
          const Staircase& upper = (*found)[j];
          if (std::abs(WrapAngle(lower.yaw_rad - upper.yaw_rad)) > 10.0 * kPi / 180.0) continue;
          const Eigen::Vector2d u(std::cos(lower.yaw_rad), std::sin(lower.yaw_rad));
          const Eigen::Vector2d d = (upper.p_W_first_step - lower.p_W_first_step).head<2>();
          const double along = u.dot(d);
          const int k = static_cast<int>(std::lround(along / lower.run_m));
          if (k < 1 || k > lower.num_steps + 2 || std::abs(along - k * lower.run_m) > lower.run_m / 3.0)
            continue;
          const double dz = upper.p_W_first_step.z() - lower.p_W_first_step.z();
          if (std::abs(dz - k * lower.rise_m) > 0.5 * lower.rise_m) continue;
          if (std::abs(u.x() * d.y() - u.y() * d.x()) > 0.5 * std::min(lower.width_m, upper.width_m))
            continue;
          const double wl = std::max(1, lower.support_points), wu = std::max(1, upper.support_points);
          const double w = wl + wu;
          lower.rise_m = (wl * lower.rise_m + wu * upper.rise_m) / w;
          lower.run_m = (wl * lower.run_m + wu * upper.run_m) / w;
          lower.width_m = (wl * lower.width_m + wu * upper.width_m) / w;
          lower.num_steps = std::max(lower.num_steps, k + upper.num_steps);
          lower.confidence = std::max(lower.confidence, upper.confidence);
          lower.support_points += upper.support_points;
          found->erase(found->begin() + static_cast<std::ptrdiff_t>(j));
          merged = true;
        }
      }
    }
  }

 private:
  // 1. Drops non-finite points, crops the cylinder, optionally voxel-filters with PCL.
  void Filter(const std::vector<Eigen::Vector3f>& points_W) {
    pts_.reserve(points_W.size());
    const double r2 = o_.crop_radius_m * o_.crop_radius_m;
    const double z_lo = p_ref_.z() - o_.crop_below_m;
    const double z_hi = p_ref_.z() + o_.crop_above_m;
    for (const Eigen::Vector3f& p : points_W) {
      if (!p.allFinite()) {
        ++stats_->points_non_finite;
        continue;
      }
      const double dx = p.x() - p_ref_.x();
      const double dy = p.y() - p_ref_.y();
      if (dx * dx + dy * dy > r2 || p.z() < z_lo || p.z() > z_hi) continue;
      pts_.push_back(p);
    }
    stats_->points_cropped = static_cast<std::int64_t>(pts_.size());
    if (o_.input_voxel_m > 0.0 && !pts_.empty()) pts_ = VoxelFilter(pts_, o_.input_voxel_m);
    stats_->points_filtered = static_cast<std::int64_t>(pts_.size());
  }

  // 2. Projection: per cell of a horizontal grid around the robot, the lowest cluster of points.
  void Project() {
    cell_m_ = o_.cell_size_m;
    nx_ = static_cast<int>(std::ceil(2.0 * o_.crop_radius_m / cell_m_)) + 1;
    ox_ = p_ref_.x() - 0.5 * nx_ * cell_m_;
    oy_ = p_ref_.y() - 0.5 * nx_ * cell_m_;
    const std::size_t num_cells = static_cast<std::size_t>(nx_) * nx_;
    // Counting sort of the points by cell (every cropped point lies in the grid), then each cell by height.
    std::vector<int> cell_of(pts_.size());
    std::vector<int> start(num_cells + 1, 0);
    const double inv = 1.0 / cell_m_;
    for (std::size_t i = 0; i < pts_.size(); ++i) {
      const int ix = std::clamp(static_cast<int>((pts_[i].x() - ox_) * inv), 0, nx_ - 1);
      const int iy = std::clamp(static_cast<int>((pts_[i].y() - oy_) * inv), 0, nx_ - 1);
      cell_of[i] = ix * nx_ + iy;
      ++start[static_cast<std::size_t>(cell_of[i]) + 1];
    }
    std::partial_sum(start.begin(), start.end(), start.begin());
    std::vector<Eigen::Vector3f> sorted(pts_.size());
    {
      std::vector<int> fill(start.begin(), start.end() - 1);
      for (std::size_t i = 0; i < pts_.size(); ++i) {
        sorted[static_cast<std::size_t>(fill[static_cast<std::size_t>(cell_of[i])]++)] = pts_[i];
      }
    }
    pts_.swap(sorted);
    cells_.assign(num_cells, Cell{});
    occupied_.clear();
    const auto gap = static_cast<float>(o_.cluster_gap_m);
    for (std::size_t c = 0; c < num_cells; ++c) {
      if (start[c] == start[c + 1]) continue;
      occupied_.push_back(static_cast<int>(c));
      const auto begin = pts_.begin() + start[c];
      const auto end = pts_.begin() + start[c + 1];
      float z_min = begin->z(), z_max = begin->z();
      for (auto it = begin; it != end; ++it) {
        z_min = std::min(z_min, it->z());
        z_max = std::max(z_max, it->z());
      }
      Cell& cell = cells_[c];
      if (z_max - z_min <= gap) {  // One cluster: no need to sort (most cells).
        float sx = 0, sy = 0;
        for (auto it = begin; it != end; ++it) {
          sx += it->x();
          sy += it->y();
        }
        cell.count = static_cast<int>(end - begin);
        cell.bottom_m = z_min;
        cell.top_m = z_max;
        cell.x_m = sx / cell.count;
        cell.y_m = sy / cell.count;
        ++stats_->cells_occupied;
        continue;
      }
      std::sort(begin, end, [](const Eigen::Vector3f& a, const Eigen::Vector3f& b) { return a.z() < b.z(); });
      float sx = 0, sy = 0;
      float prev = begin->z();
      cell.bottom_m = prev;
      for (auto it = begin; it != end && it->z() - prev <= gap; ++it) {
        prev = it->z();
        sx += it->x();
        sy += it->y();
        ++cell.count;
      }
      cell.top_m = prev;
      cell.x_m = sx / cell.count;
      cell.y_m = sy / cell.count;
      ++stats_->cells_occupied;
    }
  }

  // 3. Step-edge cells, then a local edge normal for each from its edge neighbours (2D PCA).
  void FindEdges() {
    const int r = std::max(1, static_cast<int>(std::lround(o_.edge_search_radius_m / cell_m_)));
    std::vector<std::pair<int, int>> offsets;
    for (int dx = -r; dx <= r; ++dx) {
      for (int dy = -r; dy <= r; ++dy) {
        if ((dx != 0 || dy != 0) && dx * dx + dy * dy <= r * r) offsets.emplace_back(dx, dy);
      }
    }
    const double rise_lo = o_.min_rise_m - kRiseTol;
    const double rise_hi = o_.max_rise_m + kRiseTol;
    // Cell tops on a grid padded by r cells, +inf where empty (so no empty cell passes the rise test).
    const int np = nx_ + 2 * r;
    std::vector<float> tops(static_cast<std::size_t>(np) * np, std::numeric_limits<float>::infinity());
    // Index in `tops` of cell (ix, iy), computed in std::size_t.
    const auto padded = [np, r](int ix, int iy) {
      return static_cast<std::size_t>(ix + r) * static_cast<std::size_t>(np) +
             static_cast<std::size_t>(iy + r);
    };
    for (int c : occupied_) tops[padded(c / nx_, c % nx_)] = cells_[static_cast<std::size_t>(c)].top_m;
    std::vector<std::ptrdiff_t> deltas;
    deltas.reserve(offsets.size());
    for (const auto& [dx, dy] : offsets) deltas.push_back(static_cast<std::ptrdiff_t>(dx) * np + dy);
    const auto lo = static_cast<float>(rise_lo);
    const auto hi = static_cast<float>(rise_hi);
    edge_of_.assign(cells_.size(), -1);
    for (int c : occupied_) {
      const int ix = c / nx_;
      const int iy = c % nx_;
      const Cell& cell = cells_[static_cast<std::size_t>(c)];
      // (a) A riser seen from below: the lowest cluster spans about one rise.
      const double extent = cell.top_m - cell.bottom_m;
      bool edge = extent >= 0.5 * o_.min_rise_m && extent <= rise_hi;
      // (b) The nose above a lower tread nearby.
      const float* centre = tops.data() + padded(ix, iy);
      for (std::size_t k = 0; k < deltas.size() && !edge; ++k) {
        const float drop = cell.top_m - centre[deltas[k]];
        edge = drop >= lo && drop <= hi;
      }
      // (c) The nose seen from above, its lower tread beyond a shadow.
      if (!edge) edge = IsDropOff(ix, iy, rise_lo, rise_hi);
      if (!edge) continue;
      EdgeCell e;
      e.cell = c;
      e.x_m = cell.x_m;
      e.y_m = cell.y_m;
      e.h_m = cell.top_m;
      e.riser_face = extent >= 0.5 * o_.min_rise_m && extent <= rise_hi;
      edge_of_[static_cast<std::size_t>(c)] = static_cast<int>(edges_.size());
      edges_.push_back(e);
    }
    stats_->edge_cells = static_cast<std::int64_t>(edges_.size());
    for (EdgeCell& e : edges_) EstimateNormal(&e);
  }

  // The local normal of edge cell `e` and its weight: PCA of the edge cells at about the same height within
  // ~0.25 m (none with fewer than 4).
  void EstimateNormal(EdgeCell* edge) const {
    EdgeCell& e = *edge;
    const int w = std::max(2, static_cast<int>(std::lround(0.25 / cell_m_)));
    const int ix = e.cell / nx_;
    const int iy = e.cell % nx_;
    double n = 0, mx = 0, my = 0, sxx = 0, sxy = 0, syy = 0;
    for (int jx = std::max(0, ix - w); jx <= std::min(nx_ - 1, ix + w); ++jx) {
      for (int jy = std::max(0, iy - w); jy <= std::min(nx_ - 1, iy + w); ++jy) {
        const int j = edge_of_[static_cast<std::size_t>(jx) * static_cast<std::size_t>(nx_) +
                               static_cast<std::size_t>(jy)];
        if (j < 0) continue;
        const EdgeCell& f = edges_[static_cast<std::size_t>(j)];
        if (std::abs(f.h_m - e.h_m) > kRiseTol) continue;
        const double x = (jx - ix) * cell_m_;
        const double y = (jy - iy) * cell_m_;
        n += 1;
        mx += x;
        my += y;
        sxx += x * x;
        sxy += x * y;
        syy += y * y;
      }
    }
    if (n < 4) return;
    mx /= n;
    my /= n;
    const double cxx = sxx / n - mx * mx;
    const double cxy = sxy / n - mx * my;
    const double cyy = syy / n - my * my;
    const double tr = cxx + cyy;
    const double det = cxx * cyy - cxy * cxy;
    const double disc = std::sqrt(std::max(0.0, 0.25 * tr * tr - det));
    const double l1 = 0.5 * tr + disc;
    const double l2 = 0.5 * tr - disc;
    if (l1 <= 1e-12) return;
    const double line_angle = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);  // Direction of largest spread.
    e.nx = -std::sin(line_angle);
    e.ny = std::cos(line_angle);
    e.weight = (l1 - l2) / l1;
  }

  // A nose seen from above: walking away from the robot from cell (ix, iy), the first occupied cell lies
  // beyond an empty gap (the nose's shadow) and one rise lower. Looks up to max_run_m + 0.1 m away.
  bool IsDropOff(int ix, int iy, double rise_lo, double rise_hi) const {
    const auto dx = static_cast<float>(ix - ((p_ref_.x() - ox_) / cell_m_ - 0.5));
    const auto dy = static_cast<float>(iy - ((p_ref_.y() - oy_) / cell_m_ - 0.5));
    const float norm2 = dx * dx + dy * dy;
    if (norm2 < 1.0f) return false;
    const float inv = 1.0f / std::sqrt(norm2);
    const float ux = dx * inv, uy = dy * inv;
    const float top =
        cells_[static_cast<std::size_t>(ix) * static_cast<std::size_t>(nx_) + static_cast<std::size_t>(iy)]
            .top_m;
    const int steps = static_cast<int>(std::ceil((o_.max_run_m + 0.1) / cell_m_));
    int last = ix * nx_ + iy;
    for (int k = 1; k <= steps; ++k) {
      const auto jx = static_cast<int>(std::floor(static_cast<float>(ix) + k * ux + 0.5f));
      const auto jy = static_cast<int>(std::floor(static_cast<float>(iy) + k * uy + 0.5f));
      if (jx < 0 || jy < 0 || jx >= nx_ || jy >= nx_) return false;
      const int j = jx * nx_ + jy;
      if (j == last) continue;
      last = j;
      const Cell& other = cells_[static_cast<std::size_t>(j)];
      if (other.count == 0) continue;
      const double drop = top - other.top_m;
      return k >= 2 && drop >= rise_lo && drop <= rise_hi;
    }
    return false;
  }

  // 4. Ascending-axis hypotheses: peaks of the histogram of edge normals (axial, 2 deg bins, smoothed with a
  // 1-2-3-2-1 kernel), at most 4, each with the votes of at least 5 well-aligned edge cells.
  std::vector<double> AxisHypotheses() {
    constexpr int kBins = 90;
    constexpr double kMinAxisVotes = 9.0 * 5;  // Kernel sum x 5 cells.
    std::array<double, kBins> hist{};
    for (const EdgeCell& e : edges_) {
      if (e.weight <= 0.5) continue;
      double a = std::atan2(e.ny, e.nx);
      if (a < 0) a += kPi;
      if (a >= kPi) a -= kPi;
      hist[static_cast<std::size_t>(std::min(kBins - 1, static_cast<int>(a / kPi * kBins)))] += e.weight;
    }
    std::array<double, kBins> smooth{};
    for (int b = 0; b < kBins; ++b) {
      for (int d = -2; d <= 2; ++d) {
        smooth[static_cast<std::size_t>(b)] +=
            (3 - std::abs(d)) * hist[static_cast<std::size_t>((b + d + kBins) % kBins)];
      }
    }
    std::vector<std::pair<double, int>> peaks;
    for (int b = 0; b < kBins; ++b) {
      const double v = smooth[static_cast<std::size_t>(b)];
      if (v >= smooth[static_cast<std::size_t>((b + 1) % kBins)] &&
          v > smooth[static_cast<std::size_t>((b + kBins - 1) % kBins)] && v >= kMinAxisVotes) {
        peaks.emplace_back(v, b);
      }
    }
    std::sort(peaks.rbegin(), peaks.rend());
    std::vector<double> axes;
    for (const auto& [v, b] : peaks) {
      if (axes.size() >= 4 || v < 0.1 * peaks.front().first) break;
      // Refine: weighted axial mean (doubled angles) of the normals within +-4 deg of the peak.
      const double centre = (b + 0.5) * kPi / kBins;
      double c2 = 0, s2 = 0;
      for (const EdgeCell& e : edges_) {
        if (e.weight <= 0.5) continue;
        const double a = std::atan2(e.ny, e.nx);
        const double d = WrapAngle(2.0 * (a - centre));
        if (std::abs(d) > 2.0 * 4.0 * kPi / 180.0) continue;
        c2 += e.weight * std::cos(2.0 * a);
        s2 += e.weight * std::sin(2.0 * a);
      }
      axes.push_back(0.5 * std::atan2(s2, c2));
    }
    stats_->axis_hypotheses += static_cast<int>(axes.size());
    return axes;
  }

  // 5. Side view along axis `theta`: blobs of edge cells in (s, h), chained into risers of consistent rise
  // and run. Appends chains with >= min_risers risers (at most one riser unobserved: FitAndCheck() counts the
  // risers the points show).
  void FindChains(double theta, std::vector<Chain>* chains) {
    const double c = std::cos(theta);
    const double s = std::sin(theta);
    constexpr double kSBin = 0.04;
    constexpr double kHBin = 0.03;
    std::unordered_map<std::int64_t, std::vector<int>> bins;
    auto key = [](std::int64_t is, std::int64_t ih) {
      return (is + (1 << 20)) * (1LL << 22) + (ih + (1 << 20));
    };
    std::vector<double> es(edges_.size()), et(edges_.size());
    for (std::size_t i = 0; i < edges_.size(); ++i) {
      const EdgeCell& e = edges_[i];
      const double dx = e.x_m - p_ref_.x();
      const double dy = e.y_m - p_ref_.y();
      es[i] = c * dx + s * dy;
      et[i] = -s * dx + c * dy;
      const auto is = static_cast<std::int64_t>(std::floor(es[i] / kSBin));
      const auto ih = static_cast<std::int64_t>(std::floor(e.h_m / kHBin));
      bins[key(is, ih)].push_back(static_cast<int>(i));
    }
    // Connected components of occupied bins (8-neighbourhood).
    std::unordered_map<std::int64_t, int> seen;
    std::vector<Blob> blobs;
    for (const auto& [k0, members0] : bins) {
      if (seen.count(k0) != 0) continue;
      std::vector<std::int64_t> stack{k0};
      seen[k0] = 1;
      std::vector<int> members;
      while (!stack.empty()) {
        const std::int64_t k = stack.back();
        stack.pop_back();
        const std::vector<int>& m = bins[k];
        members.insert(members.end(), m.begin(), m.end());
        const std::int64_t is = k / (1LL << 22) - (1 << 20);
        const std::int64_t ih = k % (1LL << 22) - (1 << 20);
        for (int a = -1; a <= 1; ++a) {
          for (int b = -1; b <= 1; ++b) {
            const std::int64_t kk = key(is + a, ih + b);
            if ((a == 0 && b == 0) || seen.count(kk) != 0 || bins.count(kk) == 0) continue;
            seen[kk] = 1;
            stack.push_back(kk);
          }
        }
      }
      if (auto blob = MakeBlob(members, es, et)) blobs.push_back(std::move(*blob));
    }
    std::sort(blobs.begin(), blobs.end(), [](const Blob& a, const Blob& b) { return a.h_m < b.h_m; });
    for (int sign : {1, -1}) ChainBlobs(theta, sign, blobs, chains);
  }

  // A blob of edge cells `members` (edges_ indices at positions es, et along and across the direction): its
  // compact core (cells near the median in s and h and inside the longest lateral run), the riser's front and
  // back, and its nose height; nullopt when fewer than 4 cells or a run narrower than 0.25 m support it.
  std::optional<Blob> MakeBlob(const std::vector<int>& members, const std::vector<double>& es,
                               const std::vector<double>& et) const {
    if (members.size() < 4) return std::nullopt;
    std::vector<double> ss, hh, tt;
    for (int i : members) {
      ss.push_back(es[static_cast<std::size_t>(i)]);
      hh.push_back(edges_[static_cast<std::size_t>(i)].h_m);
      tt.push_back(et[static_cast<std::size_t>(i)]);
    }
    const auto [range, count] = LongestRun(&tt, 0.25);
    if (count < 4 || range.second - range.first < 0.25) return std::nullopt;
    Blob blob;
    blob.s_m = Median(ss);
    blob.h_m = Median(hh);  // Refined below on the core.
    blob.t_lo_m = range.first;
    blob.t_hi_m = range.second;
    // Keep the compact core: cells near the median in s and h and inside the lateral run.
    for (int i : members) {
      const std::size_t u = static_cast<std::size_t>(i);
      if (std::abs(es[u] - blob.s_m) <= 0.12 && std::abs(edges_[u].h_m - blob.h_m) <= kRiseTol &&
          et[u] >= range.first && et[u] <= range.second) {
        blob.edges.push_back(i);
      }
    }
    if (blob.edges.size() < 4) return std::nullopt;
    std::vector<double> core, tops;
    std::vector<bool> on_face;
    for (int i : blob.edges) {
      core.push_back(es[static_cast<std::size_t>(i)]);
      tops.push_back(edges_[static_cast<std::size_t>(i)].h_m);
      on_face.push_back(edges_[static_cast<std::size_t>(i)].riser_face);
    }
    std::sort(tops.begin(), tops.end());
    blob.s_front_m = RiserPosition(core, on_face, 1);
    blob.s_back_m = RiserPosition(core, on_face, -1);
    // A riser seen from below is sampled by a few beams: most cell tops fall short of its nose.
    blob.h_m = tops[tops.size() * 9 / 10];
    return blob;
  }

  // A blob's riser seen along one direction: its position s along it, height h, lateral extent [tlo, thi].
  struct ChainStep {
    double s, h, tlo, thi;
  };
  static bool LaterallyOverlap(double alo, double ahi, double blo, double bhi) {
    const double inter = std::min(ahi, bhi) - std::max(alo, blo);
    return inter >= std::max(0.2, 0.5 * std::min(ahi - alo, bhi - blo));
  }
  // The step expected at (s, h) overlapping [tlo, thi], -1 if none.
  static int FindStep(const std::vector<ChainStep>& steps, double s_exp, double h_exp, double tlo,
                      double thi) {
    int best = -1;
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t m = 0; m < steps.size(); ++m) {
      const ChainStep& b = steps[m];
      if (std::abs(b.h - h_exp) > kChainRiseTol || std::abs(b.s - s_exp) > 0.8 * kRunTol) continue;
      if (!LaterallyOverlap(b.tlo, b.thi, tlo, thi)) continue;
      const double d = std::abs(b.s - s_exp) + std::abs(b.h - h_exp);
      if (d < best_d) {
        best_d = d;
        best = static_cast<int>(m);
      }
    }
    return best;
  }

  // Chains `blobs` (sorted by height) into staircases ascending along sign * (cos theta, sin theta), allowing
  // one unobserved riser. In that frame a blob's riser is at its front: the edge cells lie on the upper
  // tread, behind the riser (or on the riser itself).
  void ChainBlobs(double theta, int sign, const std::vector<Blob>& blobs, std::vector<Chain>* chains) const {
    std::vector<ChainStep> steps;
    steps.reserve(blobs.size());
    for (const Blob& b : blobs) {
      steps.push_back(sign > 0 ? ChainStep{b.s_front_m, b.h_m, b.t_lo_m, b.t_hi_m}
                               : ChainStep{-b.s_back_m, b.h_m, -b.t_hi_m, -b.t_lo_m});
    }
    for (std::size_t i = 0; i < steps.size(); ++i) {
      for (std::size_t j = i + 1; j < steps.size(); ++j) {
        const ChainStep& a = steps[i];
        const ChainStep& b = steps[j];
        const int seed_gap = SeedGap(a, b);
        if (seed_gap == 0 || !LaterallyOverlap(a.tlo, a.thi, b.tlo, b.thi)) continue;
        const double tlo = std::max(a.tlo, b.tlo);
        const double thi = std::min(a.thi, b.thi);
        const std::map<int, int> members = GrowChain(steps, i, j, seed_gap, tlo, thi);
        const int num_risers = members.rbegin()->first - members.begin()->first + 1;
        if (num_risers < o_.min_risers) continue;
        if (seed_gap > 1 && Aliased(steps, members, tlo, thi)) continue;
        if (auto chain = FitChain(theta, sign, blobs, steps, members)) chains->push_back(std::move(*chain));
      }
    }
  }

  // A seed pair is two neighbouring risers (1), or two risers with one unobserved between them (2: from a few
  // metres a VLP-16's beams 2 deg apart pass over a riser between two they hit); 0: neither. The latter only
  // for rises well above the smallest: a ramp in a map of 0.1 m voxels reads as 0.1 m steps, and skipping
  // one of those would turn any slope into a staircase.
  int SeedGap(const ChainStep& a, const ChainStep& b) const {
    for (int g = 1; g <= 2; ++g) {
      const double rise = (b.h - a.h) / g;
      const double run = (b.s - a.s) / g;
      const double lo = g == 1 ? o_.min_rise_m - kRiseTol : o_.min_rise_m + kSkippedRiserMinExtraRise;
      if (rise >= lo && rise <= o_.max_rise_m + kRiseTol && run >= o_.min_run_m - kRunTol &&
          run <= o_.max_run_m + kRunTol) {
        return g;
      }
    }
    return 0;
  }

  // Riser index -> step index, grown up and down from the seed pair (i at riser 0, j at riser seed_gap) with
  // the chain's mean rise and run, across one unobserved riser at most.
  static std::map<int, int> GrowChain(const std::vector<ChainStep>& steps, std::size_t i, std::size_t j,
                                      int seed_gap, double tlo, double thi) {
    std::map<int, int> members{{0, static_cast<int>(i)}, {seed_gap, static_cast<int>(j)}};
    int missing = seed_gap - 1;
    double rise_est = (steps[j].h - steps[i].h) / seed_gap, run_est = (steps[j].s - steps[i].s) / seed_gap;
    for (int dir : {1, -1}) {
      int k = dir > 0 ? seed_gap : 0;
      while (true) {
        const ChainStep& last = steps[static_cast<std::size_t>(members[k])];
        int found = -1;
        int gap = 1;
        for (; gap <= (missing == 0 ? 2 : 1); ++gap) {
          found = FindStep(steps, last.s + dir * gap * run_est, last.h + dir * gap * rise_est, tlo, thi);
          if (found >= 0) break;
        }
        // A step already in the chain ends it (a chain never revisits a riser).
        if (found < 0 || std::any_of(members.begin(), members.end(),
                                     [found](const auto& km) { return km.second == found; })) {
          break;
        }
        if (gap == 2) ++missing;
        k += dir * gap;
        members[k] = found;
        // Mean rise and run over the chain so far.
        const ChainStep& lowest = steps[static_cast<std::size_t>(members.begin()->second)];
        const ChainStep& highest = steps[static_cast<std::size_t>(members.rbegin()->second)];
        const int span = members.rbegin()->first - members.begin()->first;
        rise_est = (highest.h - lowest.h) / span;
        run_est = (highest.s - lowest.s) / span;
      }
    }
    return members;
  }

  // A chain seeded across an unobserved riser explains every step edge inside its span: an edge there between
  // two of its risers means the spacing is an alias (three of four risers read as two of three). An edge at
  // one of its risers, lower than its nose, is that riser seen from below.
  static bool Aliased(const std::vector<ChainStep>& steps, const std::map<int, int>& members, double tlo,
                      double thi) {
    const ChainStep& lowest = steps[static_cast<std::size_t>(members.begin()->second)];
    const ChainStep& highest = steps[static_cast<std::size_t>(members.rbegin()->second)];
    const int num_risers = members.rbegin()->first - members.begin()->first + 1;
    const double chain_run = (highest.s - lowest.s) / (num_risers - 1);
    for (const ChainStep& st : steps) {
      if (st.s <= lowest.s + 0.5 * kRunTol || st.s >= highest.s - 0.5 * kRunTol) continue;
      if (st.h <= lowest.h + kRiseTol || st.h >= highest.h - kRiseTol) continue;
      if (!LaterallyOverlap(st.tlo, st.thi, tlo, thi)) continue;
      if (std::abs(std::remainder(st.s - lowest.s, chain_run)) > 0.5 * kRunTol) return true;
    }
    return false;
  }

  // The chain of `members` (riser index -> step index): least squares lines s(k) and h(k) over the riser
  // index k, its edges and lateral extent; nullopt unless every observed riser lies close to the lines.
  static std::optional<Chain> FitChain(double theta, int sign, const std::vector<Blob>& blobs,
                                       const std::vector<ChainStep>& steps,
                                       const std::map<int, int>& members) {
    const int first = members.begin()->first;
    Chain chain;
    chain.theta_rad = sign > 0 ? WrapAngle(theta) : WrapAngle(theta + kPi);
    chain.num_risers = members.rbegin()->first - first + 1;
    chain.t_lo_m = std::numeric_limits<double>::infinity();
    chain.t_hi_m = -std::numeric_limits<double>::infinity();
    double n = 0, sk = 0, skk = 0, ss = 0, sks = 0, sh = 0, skh = 0;
    for (const auto& [k, m] : members) {
      const ChainStep& st = steps[static_cast<std::size_t>(m)];
      const double kk = k - first;
      chain.blobs.push_back(m);
      chain.riser.push_back(k - first);
      const std::vector<int>& e = blobs[static_cast<std::size_t>(m)].edges;
      chain.edges.insert(chain.edges.end(), e.begin(), e.end());
      chain.blob_edges.push_back(e);
      n += 1;
      sk += kk;
      skk += kk * kk;
      ss += st.s;
      sks += kk * st.s;
      sh += st.h;
      skh += kk * st.h;
      chain.t_lo_m = std::min(chain.t_lo_m, st.tlo);
      chain.t_hi_m = std::max(chain.t_hi_m, st.thi);
    }
    chain.cells = static_cast<int>(chain.edges.size());
    const double den = n * skk - sk * sk;
    if (den <= 0) return std::nullopt;
    chain.run_m = (n * sks - sk * ss) / den;
    chain.s_first_m = (ss - chain.run_m * sk) / n;
    chain.rise_m = (n * skh - sk * sh) / den;
    chain.h_first_m = (sh - chain.rise_m * sk) / n;
    for (const auto& [k, m] : members) {
      const ChainStep& st = steps[static_cast<std::size_t>(m)];
      const double kk = k - first;
      if (std::abs(st.s - (chain.s_first_m + kk * chain.run_m)) > 0.8 * kRunTol ||
          std::abs(st.h - (chain.h_first_m + kk * chain.rise_m)) > kChainRiseTol) {
        return std::nullopt;
      }
    }
    return chain;
  }

  // Refines the axis of `chain` from all its step edges at once: they are parallel lines, so the major axis
  // of the pooled scatter of the edge cells about their own edge's centroid is their direction (more precise
  // than the local normals that seeded the axis; it matters when no riser is seen, e.g. from the top). Then
  // recomputes the first riser, the run and the lateral extent in the refined frame.
  void RefineAxis(Chain* chain) const {
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const std::vector<int>& cells : chain->blob_edges) {
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (int e : cells)
        mean +=
            Eigen::Vector2d(edges_[static_cast<std::size_t>(e)].x_m, edges_[static_cast<std::size_t>(e)].y_m);
      mean /= static_cast<double>(cells.size());
      for (int e : cells) {
        const Eigen::Vector2d d = Eigen::Vector2d(edges_[static_cast<std::size_t>(e)].x_m,
                                                  edges_[static_cast<std::size_t>(e)].y_m) -
                                  mean;
        scatter += d * d.transpose();
      }
    }
    // Major axis of the 2 x 2 scatter in closed form.
    const double along_rad = 0.5 * std::atan2(2.0 * scatter(0, 1), scatter(0, 0) - scatter(1, 1));
    Eigen::Vector2d u(-std::sin(along_rad), std::cos(along_rad));
    const Eigen::Vector2d u_old(std::cos(chain->theta_rad), std::sin(chain->theta_rad));
    if (u.dot(u_old) < 0) u = -u;
    if (u.dot(u_old) < std::cos(10.0 * kPi / 180.0)) return;  // Implausible jump: keep the seed.
    chain->theta_rad = std::atan2(u.y(), u.x());
    double n = 0, sk = 0, skk = 0, ss = 0, sks = 0;
    chain->t_lo_m = std::numeric_limits<double>::infinity();
    chain->t_hi_m = -std::numeric_limits<double>::infinity();
    for (std::size_t b = 0; b < chain->blob_edges.size(); ++b) {
      std::vector<double> along_axis;
      std::vector<bool> on_face;
      for (int e : chain->blob_edges[b]) {
        const EdgeCell& cell = edges_[static_cast<std::size_t>(e)];
        const Eigen::Vector2d d(cell.x_m - p_ref_.x(), cell.y_m - p_ref_.y());
        along_axis.push_back(u.dot(d));
        on_face.push_back(cell.riser_face);
        const double t = u.x() * d.y() - u.y() * d.x();
        chain->t_lo_m = std::min(chain->t_lo_m, t);
        chain->t_hi_m = std::max(chain->t_hi_m, t);
      }
      const double front = RiserPosition(along_axis, on_face, 1);
      const double k = chain->riser[b];
      n += 1;
      sk += k;
      skk += k * k;
      ss += front;
      sks += k * front;
    }
    const double den = n * skk - sk * sk;
    if (den <= 0) return;
    chain->run_m = (n * sks - sk * ss) / den;
    chain->s_first_m = (ss - chain->run_m * sk) / n;
  }

  // Lateral bins (kWallBinM wide, across the axis, from chain.t_lo_m) of the fit's neighbourhood that hold a
  // wall or a rail rather than steps: points more than one rise + 0.1 m above the tread of `m` at their
  // position along the axis, at least as many as on the tread. A side wall inside the chain's lateral extent
  // (a walled flight whose step edges reach the wall) otherwise lends the fit points at every tread height
  // and riser position; seen in 5 cm survey copies, where it pulled a 0.25 m run to 0.227 m. The bins next to
  // a wall bin are walls too (the wall's thickness and the voxel filter's spread).
  static constexpr double kWallBinM = 0.05;
  static std::size_t WallBin(const Chain& chain, double t_m) {
    const double b = std::floor((t_m - chain.t_lo_m) / kWallBinM);
    return static_cast<std::size_t>(
        std::clamp(b, 0.0, std::floor((chain.t_hi_m - chain.t_lo_m) / kWallBinM)));
  }
  template <typename LocalPoints>
  static std::vector<bool> WallColumns(const Model& m, const Chain& chain, const LocalPoints& near) {
    const std::size_t bins = WallBin(chain, chain.t_hi_m) + 1;
    std::vector<int> above(bins, 0), on(bins, 0);
    for (const auto& p : near) {
      if (p.t < chain.t_lo_m || p.t > chain.t_hi_m) continue;
      if (p.s < m.s0 - m.run || p.s > m.RiserS(m.n - 1) + m.run) continue;
      const int level = std::clamp(static_cast<int>(std::floor((p.s - m.s0) / m.run)) + 1, 0, m.n);
      const double dz = p.z - m.TreadZ(level);
      if (dz > m.rise + 0.1) ++above[WallBin(chain, p.t)];
      if (std::abs(dz) <= 0.03) ++on[WallBin(chain, p.t)];
    }
    std::vector<bool> wall(bins, false);
    for (std::size_t b = 0; b < bins; ++b) {
      if (above[b] < 4 || above[b] < on[b]) continue;
      for (std::size_t nb = (b == 0 ? 0 : b - 1); nb <= std::min(bins - 1, b + 1); ++nb) wall[nb] = true;
    }
    return wall;
  }

  // A point near a candidate staircase in the frame of its fit: offset (dx, dy) from the reference position,
  // position s along the ascending axis and t across it, height z; metres, frame W.
  struct Local {
    double dx, dy, s, t, z;
  };

  // 6-7. Ceres fit of the staircase model seeded by `chain`, the count of the risers the points show, then
  // the checks. Fills `out` and marks the edge cells inside an accepted staircase as used; otherwise writes
  // the reason to `why`.
  bool FitAndCheck(Chain chain, Staircase* out, std::string* why) {
    RefineAxis(&chain);
    Model m;
    m.theta = chain.theta_rad;
    m.n = chain.num_risers;
    m.rise = chain.rise_m;
    m.run = chain.run_m;
    m.s0 = chain.s_first_m;
    m.z0 = chain.h_first_m - chain.rise_m;
    std::vector<Local> near;
    if (!GatherNear(chain, m, &near, why)) return false;
    if (!FitModel(chain, 0, &m, &near, why)) return false;
    // Risers of the chain below the model's first riser (dropped or left out as unobserved).
    int first_chain_riser = DropPhantomFirstSteps(chain, near, &m);
    if (!KeepObservedRisers(chain, &m, &near, &first_chain_riser, why)) return false;
    return CheckAndDescribe(chain, m, first_chain_riser, near, out, why);
  }

  // Points near the staircase `m` seeded by `chain` (0.3 m beyond its lateral extent, a run and 0.2 m beyond
  // its first and last risers, from 0.2 m below its floor to 1.2 m above its top tread), voxel-filtered (PCL)
  // to even out the lidar's density, in the fit frame. False, with the reason, if fewer than 50 raw points.
  bool GatherNear(const Chain& chain, const Model& m, std::vector<Local>* near, std::string* why) const {
    const double c = std::cos(m.theta), s = std::sin(m.theta);
    const double t_lo = chain.t_lo_m - 0.3, t_hi = chain.t_hi_m + 0.3;
    std::vector<Eigen::Vector3f> raw;
    for (const Eigen::Vector3f& p : pts_) {
      const double dx = p.x() - p_ref_.x();
      const double dy = p.y() - p_ref_.y();
      const double ps = c * dx + s * dy;
      const double pt = -s * dx + c * dy;
      if (pt < t_lo || pt > t_hi || ps < m.s0 - m.run - 0.2 || ps > m.RiserS(m.n - 1) + m.run + 0.2) continue;
      if (p.z() < m.z0 - 0.2 || p.z() > m.TreadZ(m.n) + 1.2) continue;
      raw.push_back(p);
    }
    if (raw.size() < 50) {
      *why = "too few points near the chain (" + std::to_string(raw.size()) + ")";
      return false;
    }
    near->clear();
    for (const Eigen::Vector3f& p : VoxelFilter(raw, o_.fit_voxel_m)) {
      const double dx = p.x() - p_ref_.x();
      const double dy = p.y() - p_ref_.y();
      near->push_back({dx, dy, c * dx + s * dy, -s * dx + c * dy, p.z()});
    }
    return true;
  }

  // Fits `m` to `near` with Ceres, like ICP: classify the points as tread or riser points of the current
  // model, solve, re-express `near` in the new frame; rounds `first_round`..2 with tightening tolerances
  // (tread height, riser position). Without refine_with_ceres, nothing. False, with the reason, if a round
  // finds fewer than 10 tread points.
  bool FitModel(const Chain& chain, int first_round, Model* model, std::vector<Local>* near,
                std::string* why) const {
    Model& m = *model;
    const double tols[][2] = {{0.05, 0.10}, {0.035, 0.06}, {0.03, 0.04}};
    const std::size_t stride = std::max<std::size_t>(1, near->size() / 1500);
    std::vector<Observation> observations;
    const int rounds = o_.refine_with_ceres ? 3 : 0;
    for (int round = first_round; round < rounds; ++round) {
      const double* tol = tols[round];
      observations.clear();
      int treads = 0;
      const std::vector<bool> wall = WallColumns(m, chain, *near);
      for (std::size_t i = 0; i < near->size(); i += stride) {
        const Local& p = (*near)[i];
        // Only the inner part of the width: the ends meet walls and side faces.
        if (p.t < chain.t_lo_m + 0.1 || p.t > chain.t_hi_m - 0.1) continue;
        if (wall[WallBin(chain, p.t)]) continue;
        const Classified cl = Classify(m, p.s, p.z, tol[0], tol[1]);
        Observation ob;
        ob.dx_m = p.dx;
        ob.dy_m = p.dy;
        ob.z_m = p.z;
        ob.index = cl.index;
        if (cl.kind == PointClass::kTread) {
          ob.kind = Observation::Kind::kTreadHeight;
          if (!cl.at_riser) observations.push_back(ob);
          ob.kind = Observation::Kind::kTreadExtent;
          observations.push_back(ob);
          ++treads;
        } else if (cl.kind == PointClass::kRiser) {
          ob.kind = Observation::Kind::kRiser;
          observations.push_back(ob);
        }
      }
      if (treads < 10) {
        *why = "too few tread points (" + std::to_string(treads) + ")";
        return false;
      }
      double x[kNumParams] = {m.theta, m.s0, m.z0, m.rise, m.run};
      ceres::Problem problem;
      problem.AddResidualBlock(new StaircaseModelCost(&observations, m.n, 0.02), nullptr, x);
      problem.SetParameterLowerBound(x, 3, 0.5 * o_.min_rise_m);
      problem.SetParameterUpperBound(x, 3, 2.0 * o_.max_rise_m);
      problem.SetParameterLowerBound(x, 4, 0.5 * o_.min_run_m);
      problem.SetParameterUpperBound(x, 4, 2.0 * o_.max_run_m);
      ceres::Solver::Options sopts;
      sopts.linear_solver_type =
          ceres::DENSE_NORMAL_CHOLESKY;  // N x 5: the 5 x 5 normal equations are cheapest.
      sopts.max_num_iterations = 10;
      sopts.num_threads = 1;
      sopts.logging_type = ceres::SILENT;
      ceres::Solver::Summary summary;
      ceres::Solve(sopts, &problem, &summary);
      m.theta = x[0];
      m.s0 = x[1];
      m.z0 = x[2];
      m.rise = x[3];
      m.run = x[4];
      const double c = std::cos(m.theta), s = std::sin(m.theta);
      for (Local& p : *near) {
        p.s = c * p.dx + s * p.dy;
        p.t = -s * p.dx + c * p.dy;
      }
    }
    return true;
  }

  // A first riser is a step up from the floor in front of it. A fit that slipped a step down the flight (a
  // "first riser" in front of the real one, its floor a rise below the real floor) finds the surface in
  // front of its first riser at its first tread's height, not at its floor's: such phantom lowest steps are
  // dropped from `m`; returns how many. (Seen from the top, the floor in front may be hidden: no point either
  // way, nothing dropped.)
  int DropPhantomFirstSteps(const Chain& chain, const std::vector<Local>& near, Model* model) const {
    Model& m = *model;
    int dropped = 0;
    constexpr int kMinFloorPoints = 5;
    while (m.n >= o_.min_risers) {
      int floor_points = 0, raised_points = 0;
      for (const Local& p : near) {
        if (p.t < chain.t_lo_m + 0.1 || p.t > chain.t_hi_m - 0.1) continue;
        if (p.s < m.s0 - m.run || p.s > m.s0 - 0.05) continue;
        floor_points += std::abs(p.z - m.z0) <= 0.03 ? 1 : 0;
        raised_points += std::abs(p.z - m.z0 - m.rise) <= 0.03 ? 1 : 0;
      }
      if (raised_points < kMinFloorPoints || raised_points <= floor_points) break;
      m.s0 += m.run;
      m.z0 += m.rise;
      --m.n;
      ++dropped;
    }
    return dropped;
  }

  // What the points show of one riser of a fitted model (see ObserveRisers()).
  struct RiserEvidence {
    double rise_m = 0.0;  // Median tread step of the bins that show it as a step, metres; NaN: none does.
    double seen_fraction = 0.0;          // Fraction of the lateral bins (over the inner width) that show it.
    double contradicted_fraction = 0.0;  // Fraction of the bins whose two flat treads differ by another rise.
    bool observed = false;               // Shown over enough of the width, and rarely contradicted.
  };

  // Lateral bins of the riser evidence (across the ascending axis), metres.
  static constexpr double kEvidenceBinM = 0.1;
  // Points within this distance of a riser along the axis lie on its face, metres (the fit's last tolerance).
  static constexpr double kRiserFaceM = 0.04;
  // A tread is flat where this fraction of its points lie within kFlatM of their median height (sensor noise
  // of 2 cm keeps ~85 %; a patchwork of two heights, e.g. a coarse scan's voxels straddling a surface, does
  // not), metres.
  static constexpr double kFlatFraction = 0.7;
  static constexpr double kFlatM = 0.03;
  // Fewest of the lateral bins over the inner width that must show a riser for it to be observed: a riser
  // runs across the flight; a terrace of a coarse scan, a box or a patch of clutter shows in a few bins.
  static constexpr double kMinRiserSeenFraction = 0.25;

  // Heights `z` (non-empty) kFlatFraction of which lie within kFlatM of `median`.
  static bool Flat(const std::vector<double>& z, double median) {
    const auto near_median =
        std::count_if(z.begin(), z.end(), [median](double h) { return std::abs(h - median) <= kFlatM; });
    return !z.empty() && static_cast<double>(near_median) >= kFlatFraction * static_cast<double>(z.size());
  }
  // Most of `z` below (sign -1) or above (sign +1) `mid`; true when empty.
  static bool OnSide(const std::vector<double>& z, double mid, int sign) {
    const auto on = std::count_if(z.begin(), z.end(), [mid, sign](double h) { return sign * (h - mid) > 0; });
    return 2 * on >= static_cast<std::ptrdiff_t>(z.size());
  }

  // The riser-counting step: how the points show each riser of `m`, in lateral bins of kEvidenceBinM over
  // the inner width of `chain` (0.1 m in from each side, wall columns left out). The points on tread k (along
  // the axis from S - run to S, S = RiserS(k) the riser's foot) and on tread k + 1 (S to S + run), at least
  // kRiserFaceM from either riser and within half a rise of the two treads' heights, are its lower and upper
  // side. A bin shows riser k as
  //  - a step between its treads: both sides flat (kFlatFraction within kFlatM of their median), their
  //    median heights differing by the model's rise within riser_rise_tolerance_m; or else
  //  - a vertical face: points within kRiserFaceM of S in the upper three quarters of the riser, the highest
  //    of them at most the rise (plus the tolerance) above the lower side (measured where seen, else the
  //    model's lower tread), none in the 0.3 m above the nose (a wall or a cabinet's front is no riser: its
  //    face goes on up), and no side contradicting it (most of the lower side's points in the lower half of
  //    the riser's height, most of the upper side's in the upper half). From below, a riser may be hit by one
  //    beam between its foot and its nose, and its upper tread is out of sight: a face shows part of a rise.
  // A bin whose two sides are flat but differ by another rise contradicts the riser (a tread running on at
  // one height, a patchwork of terraces). A riser is observed when at least kMinRiserSeenFraction of the bins
  // show it and more bins show it than contradict it: every riser counted is seen, across the flight, with a
  // rise consistent with the others'.
  std::vector<RiserEvidence> ObserveRisers(const Chain& chain, const Model& m,
                                           const std::vector<Local>& near) const {
    const double t_lo = chain.t_lo_m + 0.1, t_hi = chain.t_hi_m - 0.1;
    const int bins = std::max(1, static_cast<int>(std::ceil((t_hi - t_lo) / kEvidenceBinM)));
    const std::vector<bool> wall = WallColumns(m, chain, near);
    struct Bin {
      std::vector<double> lower, upper;  // Heights of the points on the lower and upper side.
      double face_top = -std::numeric_limits<double>::infinity();  // Highest face point.
      bool above_nose = false;                                     // A point over the nose: a wall.
    };
    std::vector<Bin> grid(static_cast<std::size_t>(m.n) * static_cast<std::size_t>(bins));
    auto bin_of = [&](int riser, int b) -> Bin& {
      return grid[static_cast<std::size_t>(riser) * static_cast<std::size_t>(bins) +
                  static_cast<std::size_t>(b)];
    };
    const double half_rise = 0.5 * m.rise;
    for (const Local& p : near) {
      if (p.t < t_lo || p.t > t_hi || wall[WallBin(chain, p.t)]) continue;
      const int b = std::clamp(static_cast<int>(std::floor((p.t - t_lo) / kEvidenceBinM)), 0, bins - 1);
      const double from_first = (p.s - m.s0) / m.run;
      // On a face: the nearest riser.
      const int k = static_cast<int>(std::lround(from_first));
      if (k >= 0 && k < m.n && std::abs(p.s - m.RiserS(k)) <= kRiserFaceM) {
        Bin& bin = bin_of(k, b);
        const double nose = m.TreadZ(k + 1);
        if (p.z > m.TreadZ(k) + 0.25 * m.rise && p.z <= nose + half_rise) {
          bin.face_top = std::max(bin.face_top, p.z);
        } else if (p.z > nose + half_rise && p.z <= nose + half_rise + 0.3) {
          bin.above_nose = true;
        }
        continue;
      }
      // On a tread: the upper side of the riser behind it, the lower side of the riser ahead.
      const int behind = static_cast<int>(std::floor(from_first));
      for (int riser : {behind, behind + 1}) {
        if (riser < 0 || riser >= m.n) continue;
        if (p.z < m.TreadZ(riser) - half_rise || p.z > m.TreadZ(riser + 1) + half_rise) continue;
        Bin& bin = bin_of(riser, b);
        (riser == behind ? bin.upper : bin.lower).push_back(p.z);
      }
    }
    std::vector<RiserEvidence> evidence(static_cast<std::size_t>(m.n));
    const double tol = o_.riser_rise_tolerance_m;
    for (int k = 0; k < m.n; ++k) {
      const double mid = m.TreadZ(k) + half_rise;
      std::vector<double> steps;  // Tread steps of the bins that show the riser as one.
      int shown = 0, contradicted = 0;
      for (int b = 0; b < bins; ++b) {
        const Bin& bin = bin_of(k, b);
        const double lower = bin.lower.empty() ? m.TreadZ(k) : Median(bin.lower);
        const double upper = bin.upper.empty() ? m.TreadZ(k + 1) : Median(bin.upper);
        if (Flat(bin.lower, lower) && Flat(bin.upper, upper)) {
          if (std::abs(upper - lower - m.rise) <= tol) {
            steps.push_back(upper - lower);
            ++shown;
          } else {
            ++contradicted;
          }
        } else if (std::isfinite(bin.face_top) && !bin.above_nose && bin.face_top - lower <= m.rise + tol &&
                   OnSide(bin.lower, mid, -1) && OnSide(bin.upper, mid, 1)) {
          ++shown;
        }
      }
      RiserEvidence& e = evidence[static_cast<std::size_t>(k)];
      e.rise_m = steps.empty() ? std::numeric_limits<double>::quiet_NaN() : Median(steps);
      e.seen_fraction = static_cast<double>(shown) / bins;
      e.contradicted_fraction = static_cast<double>(contradicted) / bins;
      e.observed = e.seen_fraction >= kMinRiserSeenFraction && shown > contradicted;
    }
    return evidence;
  }

  // Restricts `m` to its longest run of consecutive observed risers (ObserveRisers(); the lowest run if
  // tied), refits it when that dropped a riser, and checks the refit model's risers once more (the count
  // must not rest on risers the refit no longer shows); adds the risers left out below to `*first_riser`.
  // False, with the reason, if fewer than min_risers risers remain.
  bool KeepObservedRisers(const Chain& chain, Model* model, std::vector<Local>* near, int* first_riser,
                          std::string* why) const {
    Model& m = *model;
    for (int pass = 0; pass < 2; ++pass) {
      const std::vector<RiserEvidence> evidence = ObserveRisers(chain, m, *near);
      int best_first = 0, best_count = 0;
      for (int k = 0, run = 0; k < m.n; ++k) {
        run = evidence[static_cast<std::size_t>(k)].observed ? run + 1 : 0;
        if (run > best_count) {
          best_count = run;
          best_first = k - run + 1;
        }
      }
      if (best_count < o_.min_risers) {
        std::ostringstream reason;
        reason << best_count << " consecutive risers observed of " << m.n << " fitted (< min_risers "
               << o_.min_risers << "); rise " << m.rise << " m, measured";
        for (const RiserEvidence& e : evidence) {
          reason << " " << (e.observed ? "" : "!") << e.rise_m << " (seen " << e.seen_fraction
                 << ", contradicted " << e.contradicted_fraction << ")";
        }
        *why = reason.str();
        return false;
      }
      if (best_count == m.n) return true;
      m.s0 += best_first * m.run;
      m.z0 += best_first * m.rise;
      m.n = best_count;
      *first_riser += best_first;
      if (pass == 0 && !FitModel(chain, 2, &m, near, why)) return false;
    }
    return true;
  }

  // 7. The checks of a fitted model `m` of `chain` with observed risers (its riser k is the chain's riser
  // first_chain_riser + k): residuals, each step's lateral extent and coverage, free space above the treads,
  // ranges, risers facing the sensor, support of the risers the chain skipped, confidence. Fills `out` and
  // marks the edge cells inside the staircase as used, or writes the reason to `why`.
  bool CheckAndDescribe(const Chain& chain, const Model& m, int first_chain_riser,
                        const std::vector<Local>& near, Staircase* out, std::string* why) {
    const StepEvidence evidence = GatherEvidence(m, near);
    const StepExtents extents = LateralExtents(m, evidence.step_t);
    if (extents.steps < std::max(2, m.n / 2)) {
      std::ostringstream reason;
      reason << "too few steps with lateral support (" << extents.steps << " of " << m.n << ")";
      *why = reason.str();
      return false;
    }
    Verdict v;
    v.rms = evidence.inliers > 0 ? std::sqrt(evidence.squared_residuals / evidence.inliers) : 1.0;
    v.width = extents.width_sum / extents.steps;
    v.coverage = Coverage(m, evidence.step_t, extents);
    v.violation = static_cast<double>(FreeSpaceViolations(m, near, extents)) / std::max(1, evidence.inliers);
    v.confidence = std::clamp(v.coverage, 0.0, 1.0) * std::clamp(1.0 - v.rms / o_.max_fit_rms_m, 0.0, 1.0) *
                   std::min(1.0, static_cast<double>(m.n) / (o_.min_risers + 2));
    v.unsupported_riser = UnsupportedRiser(chain, m, first_chain_riser, evidence.riser_support);
    CountRiserPoints(m, evidence.riser_support, &v.riser_points, &v.unseeable_riser_points);
    if (const std::string reason = Rejection(m, v, evidence.riser_support); !reason.empty()) {
      *why = reason;
      return false;
    }
    const double c = std::cos(m.theta), s = std::sin(m.theta);
    const double centre = extents.centre_sum / extents.steps;
    out->yaw_rad = WrapAngle(m.theta);
    out->p_W_first_step =
        Eigen::Vector3d(p_ref_.x() + c * m.s0 - s * centre, p_ref_.y() + s * m.s0 + c * centre, m.z0);
    out->rise_m = m.rise;
    out->run_m = m.run;
    out->width_m = v.width;
    out->num_steps = m.n;
    out->confidence = v.confidence;
    out->support_points = evidence.inliers;
    MarkEdgesUsed(m, extents.all_lo, extents.all_hi);
    return true;
  }

  // The points of `near` the model explains, step by step.
  struct StepEvidence {
    double squared_residuals = 0.0;           // of the inliers, m^2
    int inliers = 0;                          // points on a tread or a riser
    std::vector<std::vector<double>> step_t;  // lateral coordinates t of each step's points
    std::vector<int> riser_support;           // points on each riser
  };
  static StepEvidence GatherEvidence(const Model& m, const std::vector<Local>& near) {
    StepEvidence e;
    e.step_t.resize(static_cast<std::size_t>(m.n));
    e.riser_support.assign(static_cast<std::size_t>(m.n), 0);
    for (const Local& p : near) {
      const Classified cl = Classify(m, p.s, p.z, 0.03, 0.04);
      if (cl.kind == PointClass::kRiser) ++e.riser_support[static_cast<std::size_t>(cl.index)];
      if (cl.kind == PointClass::kTread) {
        const double r = p.z - m.TreadZ(cl.index);
        e.squared_residuals += r * r;
        ++e.inliers;
        // Tread `level` belongs to step `level` (1-based); the top tread only up to one run past its riser.
        if (cl.index >= 1 && p.s <= m.RiserS(cl.index - 1) + m.run)
          e.step_t[static_cast<std::size_t>(cl.index - 1)].push_back(p.t);
      } else if (cl.kind == PointClass::kRiser) {
        const double r = p.s - m.RiserS(cl.index);
        e.squared_residuals += r * r;
        ++e.inliers;
        if (p.z > m.TreadZ(cl.index) + 0.03) e.step_t[static_cast<std::size_t>(cl.index)].push_back(p.t);
      }
    }
    return e;
  }

  // Each step's lateral extent [t_lo, t_hi] (the longest run of its points without a 0.2 m gap, 1 % trimmed
  // at each end: range noise of the outermost points widens it otherwise), for steps with 8 points or more.
  struct StepExtents {
    std::vector<std::pair<double, double>> extent;
    std::vector<bool> has_extent;
    int steps = 0;  // steps with an extent
    double width_sum = 0.0, centre_sum = 0.0;
    double all_lo = std::numeric_limits<double>::infinity(),
           all_hi = -std::numeric_limits<double>::infinity();
  };
  static StepExtents LateralExtents(const Model& m, const std::vector<std::vector<double>>& step_t) {
    StepExtents x;
    x.extent.assign(static_cast<std::size_t>(m.n), {0.0, 0.0});
    x.has_extent.assign(static_cast<std::size_t>(m.n), false);
    for (int k = 0; k < m.n; ++k) {
      const std::vector<double>& ts = step_t[static_cast<std::size_t>(k)];
      if (ts.size() < 8) continue;
      std::vector<double> sorted = ts;
      const auto [span, count] = LongestRun(&sorted, 0.2);
      if (count < 8) continue;
      const auto first = static_cast<std::size_t>(std::lower_bound(sorted.begin(), sorted.end(), span.first) -
                                                  sorted.begin());
      const auto trim = static_cast<std::size_t>(count / 100);
      const std::pair<double, double> range(sorted[first + trim],
                                            sorted[first + static_cast<std::size_t>(count) - 1 - trim]);
      x.extent[static_cast<std::size_t>(k)] = range;
      x.has_extent[static_cast<std::size_t>(k)] = true;
      x.width_sum += range.second - range.first;
      x.centre_sum += 0.5 * (range.first + range.second);
      ++x.steps;
      x.all_lo = std::min(x.all_lo, range.first);
      x.all_hi = std::max(x.all_hi, range.second);
    }
    return x;
  }

  // Coverage: the mean over the steps of the fraction of 0.1 m lateral bins over the staircase width that
  // hold points of the step.
  static double Coverage(const Model& m, const std::vector<std::vector<double>>& step_t,
                         const StepExtents& x) {
    constexpr double kBin = 0.1;
    const int bins = std::max(1, static_cast<int>(std::ceil((x.all_hi - x.all_lo) / kBin)));
    double coverage_sum = 0;
    for (int k = 0; k < m.n; ++k) {
      std::vector<char> hit(static_cast<std::size_t>(bins), 0);
      for (double t : step_t[static_cast<std::size_t>(k)]) {
        const int b = static_cast<int>(std::floor((t - x.all_lo) / kBin));
        if (b >= 0 && b < bins) hit[static_cast<std::size_t>(b)] = 1;
      }
      coverage_sum += static_cast<double>(std::count(hit.begin(), hit.end(), 1)) / bins;
    }
    return coverage_sum / m.n;
  }

  // Points in the free space above the treads, inside each step's lateral extent shrunk by 0.25 m on each
  // side: side walls (a stairwell; a sparse wall whose gaps let the tread's extent reach into it) are not
  // above the treads, shelves and terraces span the width.
  static int FreeSpaceViolations(const Model& m, const std::vector<Local>& near, const StepExtents& x) {
    int violations = 0;
    for (const Local& p : near) {
      const int k = static_cast<int>(std::floor((p.s - m.s0) / m.run));  // Step index (0-based) at s.
      if (k < 0 || k >= m.n - 1 || !x.has_extent[static_cast<std::size_t>(k)]) continue;
      const double ds = p.s - m.RiserS(k);
      if (ds < 0.05 || ds > m.run - 0.05) continue;
      const auto& e = x.extent[static_cast<std::size_t>(k)];
      if (p.t < e.first + 0.25 || p.t > e.second - 0.25) continue;
      const double above = p.z - m.TreadZ(k + 1);
      if (above > 0.1 && above < 1.0) ++violations;
    }
    return violations;
  }

  // A riser the chain skipped (no edge blob there) must still be in the points: at least a quarter of the
  // median support of the risers with a blob, half when only two have one (then the skipped one is a third
  // of the evidence). Two walls and a box two "steps" apart leave little in between. The first such riser
  // that is not, or -1.
  static int UnsupportedRiser(const Chain& chain, const Model& m, int first_chain_riser,
                              const std::vector<int>& riser_support) {
    std::vector<bool> has_blob(static_cast<std::size_t>(m.n), false);
    for (int k : chain.riser) {
      const int model_k = k - first_chain_riser;
      if (model_k >= 0 && model_k < m.n) has_blob[static_cast<std::size_t>(model_k)] = true;
    }
    std::vector<double> blob_support;
    for (int k = 0; k < m.n; ++k) {
      const auto u = static_cast<std::size_t>(k);
      if (has_blob[u]) blob_support.push_back(riser_support[u]);
    }
    if (blob_support.empty()) return -1;
    const double need = (blob_support.size() <= 2 ? 0.5 : 0.25) * Median(blob_support);
    for (int k = 1; k + 1 < m.n; ++k) {
      if (!has_blob[static_cast<std::size_t>(k)] && riser_support[static_cast<std::size_t>(k)] < need)
        return k;
    }
    return -1;
  }

  // A riser faces down the flight: a sensor beyond it (up the flight) and well below its foot cannot have
  // seen it. Such "risers" are the stepped underside of a flight above (builtin:building's upper flight seen
  // from floor 1). p_ref_ may be the body, not the sensor: 0.6 m allows for the sensor's mount.
  void CountRiserPoints(const Model& m, const std::vector<int>& riser_support, int* riser_points,
                        int* unseeable_riser_points) const {
    for (int k = 0; k < m.n; ++k) {
      const int support = riser_support[static_cast<std::size_t>(k)];
      *riser_points += support;
      const bool behind_and_below =
          m.RiserS(k) < -0.1 && m.TreadZ(k) - p_ref_.z() > kSensorAboveReferenceMaxM;
      if (behind_and_below) *unseeable_riser_points += support;
    }
  }

  // What the checks found of a model.
  struct Verdict {
    double rms = 1.0, width = 0.0, coverage = 0.0, violation = 0.0, confidence = 0.0;
    int unsupported_riser = -1;
    int riser_points = 0, unseeable_riser_points = 0;
  };
  // Why the model is no staircase (the first check it fails), or "".
  std::string Rejection(const Model& m, const Verdict& v, const std::vector<int>& riser_support) const {
    std::ostringstream reason;
    if (m.rise < o_.min_rise_m - 0.01 || m.rise > o_.max_rise_m + 0.01) {
      reason << "rise " << m.rise << " m out of range";
    } else if (m.run < o_.min_run_m - 0.01 || m.run > o_.max_run_m + 0.01) {
      reason << "run " << m.run << " m out of range";
    } else if (v.width < o_.min_width_m) {
      reason << "width " << v.width << " m < " << o_.min_width_m;
    } else if (v.rms > o_.max_fit_rms_m) {
      reason << "fit rms " << v.rms << " m > " << o_.max_fit_rms_m;
    } else if (v.coverage < o_.min_step_coverage) {
      reason << "step coverage " << v.coverage << " < " << o_.min_step_coverage;
    } else if (v.violation > o_.max_free_space_violation) {
      reason << "points above the treads: " << v.violation << " > " << o_.max_free_space_violation;
    } else if (2 * v.unseeable_riser_points > v.riser_points) {
      reason << "risers face away from the sensor (" << v.unseeable_riser_points << " of " << v.riser_points
             << " riser points behind and above it: the underside of a flight)";
    } else if (v.unsupported_riser >= 0) {
      reason << "riser " << v.unsupported_riser << " unseen by the chain and unsupported ("
             << riser_support[static_cast<std::size_t>(v.unsupported_riser)] << " points)";
    } else if (v.confidence < o_.min_confidence) {
      reason << "confidence " << v.confidence << " < " << o_.min_confidence;
    }
    return reason.str();
  }

  // Marks the edge cells of the staircase `m` (lateral extent [all_lo, all_hi]) as used.
  void MarkEdgesUsed(const Model& m, double all_lo, double all_hi) {
    const double c = std::cos(m.theta), s = std::sin(m.theta);
    for (EdgeCell& e : edges_) {
      const double dx = e.x_m - p_ref_.x();
      const double dy = e.y_m - p_ref_.y();
      const double es = c * dx + s * dy;
      const double et = -s * dx + c * dy;
      if (es > m.s0 - 0.3 && es < m.RiserS(m.n - 1) + 0.3 && et > all_lo - 0.3 && et < all_hi + 0.3)
        e.used = true;
    }
  }

  const StaircaseDetectorOptions& o_;
  Eigen::Vector3d p_ref_;
  DetectStats* stats_;
  std::vector<Eigen::Vector3f> pts_;
  double cell_m_ = 0.05, ox_ = 0, oy_ = 0;
  int nx_ = 0;
  std::vector<Cell> cells_;
  std::vector<int> occupied_;  // Indices of the occupied cells, increasing.
  std::vector<int> edge_of_;
  std::vector<EdgeCell> edges_;
};

}  // namespace

// ---- StaircaseDetectorOptions -----------------------------------------------------------------------------

bool StaircaseDetectorOptions::IsValid(std::string* why) const {
  constexpr const char* kType = "StaircaseDetectorOptions";
  return CheckRange(kType, "crop_radius_m", crop_radius_m, 1.0, false, 30.0, false, why) &&
         CheckRange(kType, "crop_below_m", crop_below_m, 0.0, true, 10.0, false, why) &&
         CheckRange(kType, "crop_above_m", crop_above_m, 0.0, true, 10.0, false, why) &&
         CheckRange(kType, "cell_size_m", cell_size_m, 0.02, false, 0.1, false, why) &&
         (input_voxel_m == 0.0 ||
          CheckRange(kType, "input_voxel_m", input_voxel_m, 0.01, false, 0.1, false, why, " (or 0: off)")) &&
         CheckRange(kType, "fit_voxel_m", fit_voxel_m, 0.01, false, 0.1, false, why) &&
         CheckRange(kType, "max_rise_m", max_rise_m, 0.0, true, 0.5, false, why) &&
         CheckRange(kType, "min_rise_m", min_rise_m, 0.0, true, max_rise_m, true, why,
                    " (below max_rise_m)") &&
         CheckRange(kType, "cluster_gap_m", cluster_gap_m, max_rise_m, true, 2.0, false, why,
                    " (above max_rise_m)") &&
         CheckRange(kType, "edge_search_radius_m", edge_search_radius_m, cell_size_m, false, 0.5, false, why,
                    " (from cell_size_m)") &&
         CheckRange(kType, "max_run_m", max_run_m, 0.0, true, 1.0, false, why) &&
         CheckRange(kType, "min_run_m", min_run_m, 0.0, true, max_run_m, true, why, " (below max_run_m)") &&
         CheckRange(kType, "min_risers", min_risers, 3, false, 50, false, why) &&
         CheckRange(kType, "riser_rise_tolerance_m", riser_rise_tolerance_m, 0.01, false, 0.1, false, why) &&
         CheckRange(kType, "min_width_m", min_width_m, 0.2, false, 10.0, false, why) &&
         CheckRange(kType, "max_fit_rms_m", max_fit_rms_m, 0.0, true, 0.1, false, why) &&
         CheckRange(kType, "min_step_coverage", min_step_coverage, 0.0, false, 1.0, false, why) &&
         CheckRange(kType, "max_free_space_violation", max_free_space_violation, 0.0, false, 1.0, false,
                    why) &&
         CheckRange(kType, "min_confidence", min_confidence, 0.0, false, 1.0, false, why) &&
         CheckRange(kType, "max_detections", max_detections, 1, false, 20, false, why);
}

// ---- StaircaseDetector ------------------------------------------------------------------------------------

StaircaseDetector::StaircaseDetector(const StaircaseDetectorOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

std::vector<Staircase> StaircaseDetector::Detect(const std::vector<Eigen::Vector3f>& points_W,
                                                 const Eigen::Vector3d& p_W_robot, DetectStats* stats) const {
  const Clock::time_point t0 = Clock::now();
  DetectStats local;
  DetectStats* st = stats != nullptr ? stats : &local;
  *st = DetectStats{};
  DetectorRun run(options_, p_W_robot, st);
  std::vector<Staircase> out = run.Run(points_W);
  st->total_ms = MsSince(t0);
  return out;
}

// ---- LocalCloud -------------------------------------------------------------------------------------------

bool LocalCloudOptions::IsValid(std::string* why) const {
  constexpr const char* kType = "LocalCloudOptions";
  return CheckRange(kType, "voxel_size_m", voxel_size_m, 0.005, false, 0.5, false, why) &&
         CheckRange(kType, "radius_m", radius_m, 1.0, false, 100.0, false, why) &&
         CheckRange(kType, "window_s", window_s, 0.0, true, 600.0, false, why) &&
         CheckRange(kType, "max_points", static_cast<double>(max_points), 1000.0, false, 1e7, false, why) &&
         (std::isnan(blind_below_elevation_rad) ||
          CheckRange(kType, "blind_below_elevation_rad", blind_below_elevation_rad, -kPi / 2, false, kPi / 2,
                     false, why)) &&
         CheckRange(kType, "blind_window_s", blind_window_s, window_s, false, 600.0, false, why);
}

struct LocalCloud::Impl {
  // One voxel: running mean of its points (the last kMaxWeight points dominate, so slow SLAM drift is
  // followed) and the stamp it was last seen.
  struct Slot {
    std::int64_t key;
    Eigen::Vector3f mean_W;
    float weight;
    double stamp_s;
  };
  static constexpr float kMaxWeight = 8.0f;
  static constexpr std::int64_t kOffset = 1 << 20;  // Voxel indices in [-2^20, 2^20) per axis.
  static constexpr std::int64_t kEmpty = -1;
  static constexpr int kPrunePeriod = 4;  // Scans between two reclaims of forgotten voxels.

  LocalCloudOptions options;
  std::vector<Slot> slots;
  // Open-addressing hash table (linear probing) from voxel key to slot index; rebuilt when slots are removed.
  std::vector<std::int64_t> table_keys;
  std::vector<std::int32_t> table_slots;
  std::size_t mask = 0;
  double newest_stamp_s = -std::numeric_limits<double>::infinity();
  Eigen::Vector3d p_W_sensor = Eigen::Vector3d::Zero();
  Eigen::Matrix3f R_SW = Eigen::Matrix3f::Identity();  // latest sensor orientation, W to S
  int scans_since_prune = 0;
  // A point this close below the lowest beam may still be hit by it: not counted as blind.
  static constexpr double kBlindMarginRad = 0.02;

  // True if a point at `p_W` lies below the sensor's lowest beam as seen from the latest scan's pose.
  bool InBlindZone(const Eigen::Vector3f& p_W) const {
    if (std::isnan(options.blind_below_elevation_rad)) return false;
    const Eigen::Vector3f v_S = R_SW * (p_W - p_W_sensor.cast<float>());
    return std::atan2(v_S.z(), v_S.head<2>().norm()) < options.blind_below_elevation_rad - kBlindMarginRad;
  }
  // True if `slot` is within the radius, and within the window (the blind window in the blind zone).
  bool IsLive(const Slot& slot) const {
    const auto r2 = static_cast<float>(options.radius_m * options.radius_m);
    if ((slot.mean_W - p_W_sensor.cast<float>()).squaredNorm() > r2) return false;
    if (slot.stamp_s >= newest_stamp_s - options.window_s) return true;
    return slot.stamp_s >= newest_stamp_s - options.blind_window_s && InBlindZone(slot.mean_W);
  }

  // Locality-preserving hash: the 4 x 4 x 4 voxels of a block share 64 consecutive places, so the points of a
  // scan, which arrive along beams, mostly hit cache lines used a moment before.
  static std::size_t Hash(std::int64_t key) {
    const auto k = static_cast<std::uint64_t>(key);
    const std::uint64_t ix = k >> 42, iy = (k >> 21) & 0x1FFFFF, iz = k & 0x1FFFFF;
    const std::uint64_t block =
        (ix >> 2) * 0x9E3779B1ull ^ (iy >> 2) * 0x85EBCA77ull ^ (iz >> 2) * 0xC2B2AE3Dull;
    return static_cast<std::size_t>((block << 6) | ((ix & 3) << 4) | ((iy & 3) << 2) | (iz & 3));
  }
  // Grows (and rebuilds) the table so it stays at most half full with `expected` slots.
  void Reserve(std::size_t expected) {
    if (!table_keys.empty() && expected * 2 <= table_keys.size()) return;
    std::size_t capacity = 1024;
    while (capacity < expected * 2) capacity *= 2;
    table_keys.assign(capacity, kEmpty);
    table_slots.assign(capacity, 0);
    mask = capacity - 1;
    for (std::size_t i = 0; i < slots.size(); ++i) Insert(slots[i].key, static_cast<std::int32_t>(i));
  }
  // Position of `key` in the table: where it is, or the empty place where it would go.
  std::size_t Find(std::int64_t key) const {
    std::size_t h = Hash(key) & mask;
    while (table_keys[h] != kEmpty && table_keys[h] != key) h = (h + 1) & mask;
    return h;
  }
  void Insert(std::int64_t key, std::int32_t slot) {
    const std::size_t h = Find(key);
    table_keys[h] = key;
    table_slots[h] = slot;
  }
  // Removes the slots for which `forget(slot)` is true, keeping the others in order, and rebuilds the table
  // by walking the old one in order: with the locality-preserving hash the new places are near the old ones,
  // so the rebuild streams through memory instead of jumping.
  // The scratch buffers are kept between calls: allocating them anew (megabytes at scan rate) cost more in
  // page faults than the rebuild itself.
  template <typename Forget>
  void RemoveIf(const Forget& forget) {
    remap.assign(slots.size(), -1);
    std::size_t kept = 0;
    for (std::size_t i = 0; i < slots.size(); ++i) {
      if (forget(slots[i])) continue;
      remap[i] = static_cast<std::int32_t>(kept);
      slots[kept++] = slots[i];
    }
    if (kept == slots.size()) return;
    slots.resize(kept);
    old_keys.swap(table_keys);
    old_slots.swap(table_slots);
    table_keys.assign(old_keys.size(), kEmpty);
    table_slots.assign(old_slots.size(), 0);
    for (std::size_t h = 0; h < old_keys.size(); ++h) {
      if (old_keys[h] == kEmpty) continue;
      const std::int32_t to = remap[static_cast<std::size_t>(old_slots[h])];
      if (to >= 0) Insert(old_keys[h], to);
    }
  }
  std::vector<std::int32_t> remap;
  std::vector<std::int64_t> old_keys;
  std::vector<std::int32_t> old_slots;
  // AddScan's points to add, with their voxel keys (kept between calls, as the buffers above).
  struct Keyed {
    std::int64_t key;
    Eigen::Vector3f p_W;
  };
  std::vector<Keyed> batch;
};

LocalCloud::LocalCloud(const LocalCloudOptions& options) : impl_(std::make_unique<Impl>()) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  impl_->options = options;
}

LocalCloud::~LocalCloud() = default;
LocalCloud::LocalCloud(LocalCloud&&) noexcept = default;
LocalCloud& LocalCloud::operator=(LocalCloud&&) noexcept = default;

void LocalCloud::AddScan(const std::vector<Eigen::Vector3f>& points_S, const Eigen::Isometry3d& T_W_S,
                         double stamp_s) {
  Impl& im = *impl_;
  if (!T_W_S.matrix().allFinite() || !std::isfinite(stamp_s)) return;
  const Eigen::Matrix3f R_WS = T_W_S.linear().cast<float>();
  const Eigen::Vector3f p_WS = T_W_S.translation().cast<float>();
  const auto inv = static_cast<float>(1.0 / im.options.voxel_size_m);
  const auto max_points = static_cast<std::size_t>(im.options.max_points);
  // A point farther from the sensor than the radius plus a voxel's diagonal lands in a voxel whose mean is
  // beyond the radius: forgotten at once (IsLive), so it is not hashed at all. Most of a scan in a long
  // tunnel or hall is such far points.
  const auto far_m = static_cast<float>(im.options.radius_m + std::sqrt(3.0) * im.options.voxel_size_m);
  const float far2 = far_m * far_m;
  im.Reserve(std::min(max_points, im.slots.size() + points_S.size()));
  // Keys first, then the table in the points' order: the table place of the point kAhead on is fetched
  // while this one is added, and its slot once that place has arrived (half-way), so the two cache misses of
  // a point (its table place, its slot) overlap the work on the points before it instead of stalling it.
  im.batch.clear();
  for (const Eigen::Vector3f& p_S : points_S) {
    if (!p_S.allFinite() || p_S.squaredNorm() > far2) continue;
    const Eigen::Vector3f p_W = R_WS * p_S + p_WS;
    std::int64_t key = 0;
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const auto i = static_cast<std::int64_t>(std::floor(p_W[a] * inv));
      inside = inside && i >= -Impl::kOffset && i < Impl::kOffset;
      key = (key << 21) | ((i + Impl::kOffset) & ((1 << 21) - 1));
    }
    if (inside) im.batch.push_back({key, p_W});
  }
  constexpr std::size_t kAhead = 16;
  const std::size_t n = im.batch.size();
  for (std::size_t b = 0; b < n; ++b) {
    if (b + kAhead < n) {
      const std::size_t ahead = Impl::Hash(im.batch[b + kAhead].key) & im.mask;
      __builtin_prefetch(&im.table_keys[ahead]);
      __builtin_prefetch(&im.table_slots[ahead]);
    }
    if (b + kAhead / 2 < n) {
      const std::int64_t half_key = im.batch[b + kAhead / 2].key;
      const std::size_t half = Impl::Hash(half_key) & im.mask;
      if (im.table_keys[half] == half_key) {
        __builtin_prefetch(&im.slots[static_cast<std::size_t>(im.table_slots[half])]);
      }
    }
    const std::int64_t key = im.batch[b].key;
    const Eigen::Vector3f& p_W = im.batch[b].p_W;
    const std::size_t h = im.Find(key);
    if (im.table_keys[h] == Impl::kEmpty) {
      if (im.slots.size() >= max_points) continue;
      im.table_keys[h] = key;
      im.table_slots[h] = static_cast<std::int32_t>(im.slots.size());
      im.slots.push_back({key, p_W, 1.0f, stamp_s});
      continue;
    }
    Impl::Slot& slot = im.slots[static_cast<std::size_t>(im.table_slots[h])];
    slot.weight = std::min(slot.weight + 1.0f, Impl::kMaxWeight);
    slot.mean_W += (p_W - slot.mean_W) / slot.weight;
    slot.stamp_s = std::max(slot.stamp_s, stamp_s);
  }
  im.newest_stamp_s = std::max(im.newest_stamp_s, stamp_s);
  im.p_W_sensor = T_W_S.translation();
  im.R_SW = R_WS.transpose();
  // Reclaim old and far voxels every few scans (or when full); Points() skips them in between.
  if (++im.scans_since_prune >= Impl::kPrunePeriod || im.slots.size() >= max_points) {
    im.scans_since_prune = 0;
    im.RemoveIf([&im](const Impl::Slot& slot) { return !im.IsLive(slot); });
  }
}

std::vector<Eigen::Vector3f> LocalCloud::Points() const {
  std::vector<Eigen::Vector3f> out;
  out.reserve(impl_->slots.size());
  for (const Impl::Slot& slot : impl_->slots) {
    if (impl_->IsLive(slot)) out.push_back(slot.mean_W);
  }
  return out;
}

std::size_t LocalCloud::size() const {
  return static_cast<std::size_t>(
      std::count_if(impl_->slots.begin(), impl_->slots.end(),
                    [this](const Impl::Slot& slot) { return impl_->IsLive(slot); }));
}

Eigen::Vector3d LocalCloud::p_W_latest_sensor() const { return impl_->p_W_sensor; }

void LocalCloud::Clear() {
  impl_->slots.clear();
  std::fill(impl_->table_keys.begin(), impl_->table_keys.end(), Impl::kEmpty);
  impl_->newest_stamp_s = -std::numeric_limits<double>::infinity();
  impl_->p_W_sensor.setZero();
  impl_->R_SW.setIdentity();
}

void LocalCloud::ForgetVisible() {
  Impl& im = *impl_;
  im.RemoveIf([&im](const Impl::Slot& slot) { return !im.IsLive(slot) || !im.InBlindZone(slot.mean_W); });
}

// ---- StaircaseRegistry ------------------------------------------------------------------------------------

namespace {

using Polygon = std::vector<Eigen::Vector2d>;

// Footprint of a staircase seen from above: num_steps * run along the ascending direction from the foot of
// the first riser, width across it (counter-clockwise corners).
Polygon Footprint(const Staircase& st) {
  const Eigen::Vector2d u(std::cos(st.yaw_rad), std::sin(st.yaw_rad));
  const Eigen::Vector2d v(-u.y(), u.x());
  const Eigen::Vector2d p = st.p_W_first_step.head<2>();
  const double len = st.num_steps * st.run_m;
  const double hw = 0.5 * st.width_m;
  return {p - hw * v, p + len * u - hw * v, p + len * u + hw * v, p + hw * v};
}

double Area(const Polygon& poly) {
  double a = 0;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % poly.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * std::abs(a);
}

// Intersection of two convex counter-clockwise polygons (Sutherland-Hodgman clipping).
Polygon Intersect(const Polygon& subject, const Polygon& clip) {
  Polygon out = subject;
  for (std::size_t i = 0; i < clip.size() && !out.empty(); ++i) {
    const Eigen::Vector2d a = clip[i];
    const Eigen::Vector2d b = clip[(i + 1) % clip.size()];
    auto side = [&](const Eigen::Vector2d& p) {
      return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
    };
    Polygon in = std::move(out);
    out.clear();
    for (std::size_t j = 0; j < in.size(); ++j) {
      const Eigen::Vector2d& p = in[j];
      const Eigen::Vector2d& q = in[(j + 1) % in.size()];
      const double sp = side(p), sq = side(q);
      if (sp >= 0) out.push_back(p);
      if ((sp >= 0) != (sq >= 0)) out.push_back(p + (q - p) * (sp / (sp - sq)));
    }
  }
  return out;
}

bool IsUsableDetection(const Staircase& s) {
  return s.p_W_first_step.allFinite() && std::isfinite(s.yaw_rad) && std::isfinite(s.rise_m) &&
         std::isfinite(s.run_m) && std::isfinite(s.width_m) && std::isfinite(s.confidence) &&
         s.num_steps >= 1 && s.rise_m > 0 && s.run_m > 0 && s.width_m > 0;
}

}  // namespace

// The same staircase described from `k` steps further up its flight (k < 0: down): the first riser moves k
// runs along the ascending direction and k rises up; num_steps drops by k.
Staircase ShiftSteps(const Staircase& s, int k) {
  Staircase out = s;
  out.p_W_first_step +=
      k * Eigen::Vector3d(s.run_m * std::cos(s.yaw_rad), s.run_m * std::sin(s.yaw_rad), s.rise_m);
  out.num_steps -= k;
  return out;
}

namespace {

// Weighted sums of views of one staircase, all described from one first riser (the entry's estimate is
// Estimate()); each view weighs confidence x support_points.
struct ViewSums {
  double weight = 0;
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
  double cos_yaw = 0, sin_yaw = 0, rise = 0, run = 0, width = 0;
  std::map<int, double> step_votes;
  double confidence = 0;
  std::int64_t support = 0;

  void Add(const Staircase& s) {
    const double w = std::max(1e-3, s.confidence) * std::max(1, s.support_points);
    weight += w;
    p_W += w * s.p_W_first_step;
    cos_yaw += w * std::cos(s.yaw_rad);
    sin_yaw += w * std::sin(s.yaw_rad);
    rise += w * s.rise_m;
    run += w * s.run_m;
    width += w * s.width_m;
    step_votes[s.num_steps] += w;
    confidence = std::max(confidence, std::clamp(s.confidence, 0.0, 1.0));
    support += std::max(0, s.support_points);
  }

  // Re-indexes everything merged so far `k` steps up the flight (see ShiftSteps()).
  void Shift(int k) {
    const Staircase now = Estimate();
    p_W += weight * (ShiftSteps(now, k).p_W_first_step - now.p_W_first_step);
    std::map<int, double> shifted;
    for (const auto& [steps, w] : step_votes) shifted[steps - k] += w;
    step_votes.swap(shifted);
  }

  Staircase Estimate() const {
    Staircase s;
    s.p_W_first_step = p_W / weight;
    s.yaw_rad = WrapAngle(std::atan2(sin_yaw, cos_yaw));
    s.rise_m = rise / weight;
    s.run_m = run / weight;
    s.width_m = width / weight;
    // The largest num_steps with at least a quarter of the strongest vote: partial views undercount, so the
    // more complete views win unless they are a weak minority.
    double strongest = 0;
    for (const auto& [steps, w] : step_votes) strongest = std::max(strongest, w);
    for (const auto& [steps, w] : step_votes) {
      if (w >= 0.25 * strongest) s.num_steps = steps;  // Ascending keys: the last one kept is the largest.
    }
    s.confidence = confidence;
    s.support_points = static_cast<int>(std::min<std::int64_t>(support, std::numeric_limits<int>::max()));
    return s;
  }

  // Adds `view`, `shift` whole steps up the flight from the first riser of what was merged so far (see
  // StaircaseMatch::shift_steps): a view that starts lower re-indexes everything merged so far down to it.
  void AddShifted(const Staircase& view, int shift) {
    if (shift >= 0) {
      Add(ShiftSteps(view, -shift));  // Described from the first riser merged so far.
    } else {
      Shift(shift);
      Add(view);
    }
  }
};

}  // namespace

struct StaircaseRegistry::Accumulator : ViewSums {};

StaircaseMatch MatchStaircases(const Staircase& a, const Staircase& b,
                               const StaircaseRegistryOptions& options) {
  StaircaseMatch match;
  if (!IsUsableDetection(a) || !IsUsableDetection(b)) return match;
  // Whole steps between the two first risers (a view of the upper part only starts higher), counted along
  // the flight: the riser positions are measured on many points, the floor of a partial view is not.
  const Eigen::Vector2d u(std::cos(a.yaw_rad), std::sin(a.yaw_rad));
  const double ds = u.dot((b.p_W_first_step - a.p_W_first_step).head<2>());
  const double steps = std::clamp(ds / a.run_m, -1e6, 1e6);  // Far apart: no int overflow.
  const int k = static_cast<int>(std::lround(steps));
  match.shift_steps = k;
  if (std::abs(WrapAngle(a.yaw_rad - b.yaw_rad)) > options.max_yaw_difference_rad) return match;
  if (std::abs(k) > std::max(a.num_steps, b.num_steps) - 1) return match;
  if (std::abs(ds - k * a.run_m) > 0.5 * a.run_m) return match;
  // Heights k rises apart. Two views of the same first riser (k = 0) must agree on the floor; the floor of
  // a view that starts k steps up is the tread the viewer stands on or looks over (few points, partly
  // hidden): within half a rise (a robot on the stairs saw 3 steps from the 2nd riser, its floor 8 cm low).
  const double dz = b.p_W_first_step.z() - a.p_W_first_step.z();
  const double height_tolerance =
      k == 0 ? options.max_floor_difference_m : std::max(options.max_floor_difference_m, 0.5 * a.rise_m);
  // Two whole views (k = 0) whose floors disagree but whose flights end at the same height are one flight
  // whose floor one view misjudged (a legged robot at the foot saw the floor 8 cm low and the rise 14 mm
  // high): the floors within half a rise, the tops within the floor tolerance.
  const double dtop =
      (b.p_W_first_step.z() + b.num_steps * b.rise_m) - (a.p_W_first_step.z() + a.num_steps * a.rise_m);
  const bool same_top = k == 0 && b.num_steps == a.num_steps && std::abs(dz) <= 0.5 * a.rise_m &&
                        std::abs(dtop) <= options.max_floor_difference_m;
  if (std::abs(dz - k * a.rise_m) > height_tolerance && !same_top) return match;
  const Polygon fa = Footprint(a);
  const Polygon fb = Footprint(b);
  const double smaller = std::min(Area(fa), Area(fb));
  if (smaller <= 0) return match;
  match.overlap = Area(Intersect(fb, fa)) / smaller;
  match.same = match.overlap >= options.min_overlap_fraction;
  return match;
}

Staircase MergeStaircaseViews(const std::vector<Staircase>& views, const StaircaseRegistryOptions& options) {
  ViewSums sums;
  for (const Staircase& view : views) {
    if (!IsUsableDetection(view)) continue;
    if (sums.weight <= 0) {
      sums.Add(view);
      continue;
    }
    // Views of one staircase are at most the longer flight apart; a view beyond that (an estimate that
    // drifted) must not stretch the merged flight to it.
    const Staircase so_far = sums.Estimate();
    const int reach = std::max(so_far.num_steps, view.num_steps) - 1;
    sums.AddShifted(view, std::clamp(MatchStaircases(so_far, view, options).shift_steps, -reach, reach));
  }
  if (sums.weight <= 0) return Staircase{};
  return sums.Estimate();
}

bool StaircaseRegistryOptions::IsValid(std::string* why) const {
  constexpr const char* kType = "StaircaseRegistryOptions";
  return CheckRange(kType, "max_yaw_difference_rad", max_yaw_difference_rad, 0.0, true, 0.5 * kPi, false,
                    why) &&
         CheckRange(kType, "min_overlap_fraction", min_overlap_fraction, 0.0, true, 1.0, false, why) &&
         CheckRange(kType, "max_floor_difference_m", max_floor_difference_m, 0.0, true, 1.0, false, why);
}

StaircaseRegistry::StaircaseRegistry(const StaircaseRegistryOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

StaircaseRegistry::MergeResult StaircaseRegistry::Add(const Staircase& staircase, const std::string& source) {
  MergeResult result;
  if (!IsUsableDetection(staircase)) return result;
  std::lock_guard<std::mutex> lock(mutex_);
  int best = -1;
  int best_shift = 0;
  double best_overlap = 0;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const StaircaseMatch match = MatchStaircases(entries_[i].staircase, staircase, options_);
    if (match.same && match.overlap > best_overlap) {
      best_overlap = match.overlap;
      best = static_cast<int>(i);
      best_shift = match.shift_steps;
    }
  }
  if (best < 0) {
    auto acc = std::make_shared<Accumulator>();
    acc->Add(staircase);
    Entry entry;
    entry.id = next_id_++;
    entry.staircase = acc->Estimate();
    entry.sources.push_back(source);
    entry.detections = 1;
    entries_.push_back(entry);
    accumulators_.push_back(acc);
    result.id = entry.id;
    result.is_new = true;
    result.changed = true;
    return result;
  }
  Entry& entry = entries_[static_cast<std::size_t>(best)];
  Accumulator& acc = *accumulators_[static_cast<std::size_t>(best)];
  acc.AddShifted(staircase, best_shift);
  const Staircase before = entry.staircase;
  entry.staircase = acc.Estimate();
  ++entry.detections;
  bool changed = false;
  if (std::find(entry.sources.begin(), entry.sources.end(), source) == entry.sources.end()) {
    entry.sources.push_back(source);
    changed = true;
  }
  const Staircase& now = entry.staircase;
  changed = changed || (now.p_W_first_step - before.p_W_first_step).norm() >= 0.01 ||
            std::abs(now.width_m - before.width_m) >= 0.01 ||
            std::abs(WrapAngle(now.yaw_rad - before.yaw_rad)) >= 0.5 * kPi / 180.0 ||
            std::abs(now.rise_m - before.rise_m) >= 0.002 || std::abs(now.run_m - before.run_m) >= 0.002 ||
            now.num_steps != before.num_steps || std::abs(now.confidence - before.confidence) >= 0.01;
  result.id = entry.id;
  result.is_new = false;
  result.changed = changed;
  return result;
}

std::vector<StaircaseRegistry::Entry> StaircaseRegistry::Entries() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_;
}

std::size_t StaircaseRegistry::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

}  // namespace cairn::perception
