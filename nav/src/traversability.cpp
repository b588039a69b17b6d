// Copyright Cairn authors.
#include "cairn/nav/traversability.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

namespace cairn::nav {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps_m = 1e-6;

// Stands for "no lethal cell" in the distance transform; finite so that the parabola arithmetic stays exact
// where it matters (the standard trick of the reference implementation).
constexpr double kFar = 1e20;

// One-dimensional squared Euclidean distance transform of `f` (length n >= 1) into `d`: the lower envelope
// of parabolas, algorithm DT(f) of Felzenszwalb & Huttenlocher (2012). v, z are scratch.
void DistanceTransform1D(const double* f, int n, double* d, std::vector<int>* v, std::vector<double>* z) {
  v->assign(static_cast<std::size_t>(n), 0);
  z->assign(static_cast<std::size_t>(n) + 1, 0.0);
  int k = 0;
  (*v)[0] = 0;
  (*z)[0] = -kInf;
  (*z)[1] = kInf;
  for (int q = 1; q < n; ++q) {
    double s = 0.0;
    while (true) {
      const int p = (*v)[static_cast<std::size_t>(k)];
      s = ((f[q] + static_cast<double>(q) * q) - (f[p] + static_cast<double>(p) * p)) / (2.0 * (q - p));
      if (s <= (*z)[static_cast<std::size_t>(k)] && k > 0) {
        --k;
      } else {
        break;
      }
    }
    ++k;
    (*v)[static_cast<std::size_t>(k)] = q;
    (*z)[static_cast<std::size_t>(k)] = s;
    (*z)[static_cast<std::size_t>(k) + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while ((*z)[static_cast<std::size_t>(k) + 1] < q) ++k;
    const int p = (*v)[static_cast<std::size_t>(k)];
    d[q] = static_cast<double>(q - p) * (q - p) + f[p];
  }
}

}  // namespace

const char* ToString(CellState state) {
  switch (state) {
    case CellState::kUnknown:
      return "unknown";
    case CellState::kObstacle:
      return "obstacle";
    case CellState::kFree:
      return "free";
  }
  return "?";
}

bool TraversabilityOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi) {
    if (std::isfinite(value) && value >= lo && value <= hi) return true;
    msg << "TraversabilityOptions::" << field << " = " << value << " must be finite and in [" << lo << ", "
        << hi << "]";
    return false;
  };
  bool ok = range("cell_size_m", cell_size_m, 0.0, 100.0) &&
            range("robot_radius_m", robot_radius_m, 0.0, 5.0) && range("max_step_m", max_step_m, 0.0, 5.0);
  if (ok && (!std::isfinite(robot_height_m) || robot_height_m <= 0.0 || robot_height_m > 10.0)) {
    msg << "TraversabilityOptions::robot_height_m = " << robot_height_m << " must be finite and in (0, 10]";
    ok = false;
  }
  if (ok && (std::isnan(ground_search_min_z_m) || std::isnan(ground_search_max_z_m) ||
             !(ground_search_min_z_m < ground_search_max_z_m))) {
    msg << "TraversabilityOptions::ground_search_min_z_m = " << ground_search_min_z_m
        << " must be < ground_search_max_z_m = " << ground_search_max_z_m << " (neither NaN)";
    ok = false;
  }
  if (ok && std::isinf(reference_height_m)) {
    msg << "TraversabilityOptions::reference_height_m = " << reference_height_m
        << " must be finite or NaN (auto)";
    ok = false;
  }
  if (ok && (fill_passes < 0 || fill_passes > 20)) {
    msg << "TraversabilityOptions::fill_passes = " << fill_passes << " must be in [0, 20]";
    ok = false;
  }
  if (ok && (fill_min_neighbors < 1 || fill_min_neighbors > 8)) {
    msg << "TraversabilityOptions::fill_min_neighbors = " << fill_min_neighbors << " must be in [1, 8]";
    ok = false;
  }
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

TraversabilityGrid::TraversabilityGrid(const sim::World& world, const TraversabilityOptions& options)
    : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const double res = world.resolution_m();
  int k = 1;  // World columns per cell edge.
  if (options.cell_size_m > 0.0) {
    k = static_cast<int>(std::lround(options.cell_size_m / res));
    if (k < 1 || k > 20 || std::abs(k * res - options.cell_size_m) > kEps_m) {
      std::ostringstream msg;
      msg << "TraversabilityOptions::cell_size_m = " << options.cell_size_m
          << " must be 0 or an integer multiple (1..20) of the world resolution " << res << " m";
      throw std::invalid_argument(msg.str());
    }
  }
  cell_m_ = k * res;
  options_.cell_size_m = cell_m_;
  const Eigen::Vector3i& dims = world.dims();
  const int nxw = dims.x();
  const int nyw = dims.y();
  const int nzw = dims.z();
  nx_ = (nxw + k - 1) / k;
  ny_ = (nyw + k - 1) / k;
  p_W_min_ = world.p_W_min().head<2>();
  const double z0 = world.p_W_min().z();

  // ---- 1. Ground candidates per world column. ----
  // Voxel iz has its top at z0 + (iz + 1) * res; it is a candidate if that top is in the band and the
  // `need` voxels above it are free.
  const int need = std::max(1, static_cast<int>(std::ceil(options.robot_height_m / res - kEps_m)));
  const double band_lo = options.ground_search_min_z_m - kEps_m;
  const double band_hi = options.ground_search_max_z_m + kEps_m;
  auto top_of = [&](int iz) { return z0 + (iz + 1) * res; };
  auto in_band = [&](int iz) { return top_of(iz) >= band_lo && top_of(iz) <= band_hi; };
  // Calls visit(iz) for each candidate of column (ix, iy), from the top down; returns whether the band
  // holds an occupied voxel.
  auto scan_column = [&](int ix, int iy, auto&& visit) {
    bool band_occupied = false;
    int free_run = options.free_above_map ? need : 0;  // Free voxels directly above the current one.
    for (int iz = nzw - 1; iz >= 0; --iz) {
      if (!world.IsOccupiedIndex({ix, iy, iz})) {
        ++free_run;
        continue;
      }
      if (in_band(iz)) {
        band_occupied = true;
        if (free_run >= need) visit(iz);
      }
      free_run = 0;
    }
    return band_occupied;
  };

  double reference = options.reference_height_m;
  if (std::isnan(reference)) {
    // Automatic: the most common lowest ground (the main floor); ties go to the lower height.
    std::map<int, std::int64_t> histogram;
    for (int ix = 0; ix < nxw; ++ix) {
      for (int iy = 0; iy < nyw; ++iy) {
        int lowest = -1;
        scan_column(ix, iy, [&](int iz) { lowest = iz; });
        if (lowest >= 0) ++histogram[lowest];
      }
    }
    int best = -1;
    std::int64_t best_count = 0;
    for (const auto& [iz, count] : histogram) {
      if (count > best_count) {
        best = iz;
        best_count = count;
      }
    }
    reference = best >= 0 ? top_of(best) : z0;
  }
  summary_.reference_height_m = reference;

  // Column results at world resolution.
  std::vector<CellState> column_state(static_cast<std::size_t>(nxw) * nyw, CellState::kUnknown);
  std::vector<double> column_ground(column_state.size(), std::nan(""));
  for (int ix = 0; ix < nxw; ++ix) {
    for (int iy = 0; iy < nyw; ++iy) {
      int chosen = -1;
      const bool band_occupied = scan_column(ix, iy, [&](int iz) {
        if (chosen < 0 || std::abs(top_of(iz) - reference) <= std::abs(top_of(chosen) - reference))
          chosen = iz;
      });
      const std::size_t c = static_cast<std::size_t>(ix) * nyw + iy;
      if (chosen >= 0) {
        column_state[c] = CellState::kFree;
        column_ground[c] = top_of(chosen);
      } else if (band_occupied) {
        column_state[c] = CellState::kObstacle;
      }
    }
  }

  // ---- 2. Aggregate k x k columns into cells. ----
  const std::size_t n_cells = static_cast<std::size_t>(nx_) * ny_;
  state_.assign(n_cells, CellState::kUnknown);
  ground_.assign(n_cells, std::nan(""));
  inferred_.assign(n_cells, 0);
  lethal_.assign(n_cells, 0);
  std::vector<std::uint8_t> internal_step(n_cells, 0);
  for (int cx = 0; cx < nx_; ++cx) {
    for (int cy = 0; cy < ny_; ++cy) {
      bool any_obstacle = false;
      double lo = kInf;
      double hi = -kInf;
      for (int ix = cx * k; ix < std::min(nxw, (cx + 1) * k); ++ix) {
        for (int iy = cy * k; iy < std::min(nyw, (cy + 1) * k); ++iy) {
          const std::size_t c = static_cast<std::size_t>(ix) * nyw + iy;
          if (column_state[c] == CellState::kObstacle) any_obstacle = true;
          if (column_state[c] == CellState::kFree) {
            lo = std::min(lo, column_ground[c]);
            hi = std::max(hi, column_ground[c]);
          }
        }
      }
      const std::size_t i = Index(cx, cy);
      if (any_obstacle) {
        state_[i] = CellState::kObstacle;
      } else if (hi > -kInf) {
        state_[i] = CellState::kFree;
        ground_[i] = hi;
        internal_step[i] = (hi - lo) > options.max_step_m + kEps_m;
      }
    }
  }

  // ---- 3. Hole filling for sparse scans. ----
  // Body space check for an inferred ground g: no occupied voxel of the cell's columns in (g, g + height].
  auto body_space_free = [&](int cx, int cy, double g) {
    for (int ix = cx * k; ix < std::min(nxw, (cx + 1) * k); ++ix) {
      for (int iy = cy * k; iy < std::min(nyw, (cy + 1) * k); ++iy) {
        for (int iz = 0; iz < nzw; ++iz) {
          const double zc = z0 + (iz + 0.5) * res;
          if (zc > g && zc <= g + options.robot_height_m && world.IsOccupiedIndex({ix, iy, iz})) return false;
        }
      }
    }
    return true;
  };
  for (int pass = 0; pass < options.fill_passes; ++pass) {
    std::vector<std::pair<std::size_t, double>> fills;
    for (int cx = 0; cx < nx_; ++cx) {
      for (int cy = 0; cy < ny_; ++cy) {
        if (state_[Index(cx, cy)] != CellState::kUnknown) continue;
        int count = 0;
        double sum = 0.0;
        double lo = kInf;
        double hi = -kInf;
        for (int dx = -1; dx <= 1; ++dx) {
          for (int dy = -1; dy <= 1; ++dy) {
            if ((dx == 0 && dy == 0) || !InGrid(cx + dx, cy + dy)) continue;
            const std::size_t j = Index(cx + dx, cy + dy);
            if (state_[j] != CellState::kFree) continue;
            ++count;
            sum += ground_[j];
            lo = std::min(lo, ground_[j]);
            hi = std::max(hi, ground_[j]);
          }
        }
        if (count < options.fill_min_neighbors || hi - lo > options.max_step_m + kEps_m) continue;
        const double g = sum / count;
        if (body_space_free(cx, cy, g)) fills.emplace_back(Index(cx, cy), g);
      }
    }
    if (fills.empty()) break;
    for (const auto& [i, g] : fills) {
      state_[i] = CellState::kFree;
      ground_[i] = g;
      inferred_[i] = 1;
    }
  }

  // ---- 4. Lethal layer: non-free cells and the high side of too high steps. ----
  for (int cx = 0; cx < nx_; ++cx) {
    for (int cy = 0; cy < ny_; ++cy) {
      const std::size_t i = Index(cx, cy);
      if (state_[i] != CellState::kFree || internal_step[i]) {
        lethal_[i] = 1;
        continue;
      }
      for (int dx = -1; dx <= 1 && !lethal_[i]; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          if ((dx == 0 && dy == 0) || !InGrid(cx + dx, cy + dy)) continue;
          const std::size_t j = Index(cx + dx, cy + dy);
          if (state_[j] == CellState::kFree && ground_[i] - ground_[j] > options.max_step_m + kEps_m) {
            lethal_[i] = 1;
            break;
          }
        }
      }
    }
  }

  // ---- 5. Clearance: exact Euclidean distance to the nearest lethal cell, and to the outside. ----
  std::vector<double> d2(n_cells);
  for (std::size_t i = 0; i < n_cells; ++i) d2[i] = lethal_[i] ? 0.0 : kFar;
  std::vector<int> v;
  std::vector<double> z;
  std::vector<double> line_in(static_cast<std::size_t>(std::max(nx_, ny_)));
  std::vector<double> line_out(line_in.size());
  for (int cy = 0; cy < ny_; ++cy) {  // Along x.
    for (int cx = 0; cx < nx_; ++cx) line_in[static_cast<std::size_t>(cx)] = d2[Index(cx, cy)];
    DistanceTransform1D(line_in.data(), nx_, line_out.data(), &v, &z);
    for (int cx = 0; cx < nx_; ++cx) d2[Index(cx, cy)] = line_out[static_cast<std::size_t>(cx)];
  }
  for (int cx = 0; cx < nx_; ++cx) {  // Along y.
    for (int cy = 0; cy < ny_; ++cy) line_in[static_cast<std::size_t>(cy)] = d2[Index(cx, cy)];
    DistanceTransform1D(line_in.data(), ny_, line_out.data(), &v, &z);
    for (int cy = 0; cy < ny_; ++cy) d2[Index(cx, cy)] = line_out[static_cast<std::size_t>(cy)];
  }
  clearance_m_.assign(n_cells, 0.0);
  for (int cx = 0; cx < nx_; ++cx) {
    for (int cy = 0; cy < ny_; ++cy) {
      const double border_cells = std::min({cx + 1, nx_ - cx, cy + 1, ny_ - cy});
      const double d = d2[Index(cx, cy)] >= 0.5 * kFar ? kInf : std::sqrt(d2[Index(cx, cy)]);
      clearance_m_[Index(cx, cy)] = std::min(d, border_cells) * cell_m_;
    }
  }

  // ---- 6. Summary. ----
  summary_.cells_total = static_cast<std::int64_t>(n_cells);
  for (std::size_t i = 0; i < n_cells; ++i) {
    summary_.cells_unknown += state_[i] == CellState::kUnknown;
    summary_.cells_obstacle += state_[i] == CellState::kObstacle;
    summary_.cells_free += state_[i] == CellState::kFree;
    summary_.cells_inferred += inferred_[i];
    summary_.cells_lethal += lethal_[i];
    summary_.cells_traversable += clearance_m_[i] > options_.robot_radius_m + 1e-9;
  }
}

bool TraversabilityGrid::CellOf(double x_m, double y_m, int* ix, int* iy) const {
  if (!std::isfinite(x_m) || !std::isfinite(y_m)) return false;
  const double u = std::floor((x_m - p_W_min_.x()) / cell_m_);
  const double w = std::floor((y_m - p_W_min_.y()) / cell_m_);
  if (u < 0 || w < 0 || u >= nx_ || w >= ny_) return false;
  *ix = static_cast<int>(u);
  *iy = static_cast<int>(w);
  return true;
}

bool TraversabilityGrid::IsTraversableAt(double x_m, double y_m) const {
  int ix = 0;
  int iy = 0;
  return CellOf(x_m, y_m, &ix, &iy) && IsTraversable(ix, iy);
}

bool TraversabilityGrid::IsFootprintFree(double x_m, double y_m, double radius_m) const {
  int ix = 0;
  int iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy) || IsLethal(ix, iy)) return false;
  if (!(radius_m >= 0.0)) return false;
  const int x_lo = static_cast<int>(std::floor((x_m - radius_m - p_W_min_.x()) / cell_m_));
  const int x_hi = static_cast<int>(std::floor((x_m + radius_m - p_W_min_.x()) / cell_m_));
  const int y_lo = static_cast<int>(std::floor((y_m - radius_m - p_W_min_.y()) / cell_m_));
  const int y_hi = static_cast<int>(std::floor((y_m + radius_m - p_W_min_.y()) / cell_m_));
  const double r2 = radius_m * radius_m;
  for (int cx = x_lo; cx <= x_hi; ++cx) {
    for (int cy = y_lo; cy <= y_hi; ++cy) {
      const Eigen::Vector2d c = CellCenter(cx, cy);
      if ((c - Eigen::Vector2d(x_m, y_m)).squaredNorm() > r2) continue;
      if (!InGrid(cx, cy) || IsLethal(cx, cy)) return false;
    }
  }
  return true;
}

std::optional<double> TraversabilityGrid::GroundHeight(double x_m, double y_m) const {
  int ix = 0;
  int iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy) || State(ix, iy) != CellState::kFree) return std::nullopt;
  return Ground(ix, iy);
}

}  // namespace cairn::nav
