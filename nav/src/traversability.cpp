// Copyright Cairn authors.
#include "cairn/nav/traversability.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <sstream>
#include <stdexcept>

#include "path_internal.h"

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
  if (ok &&
      (!std::isfinite(clearance_exact_m) || clearance_exact_m < robot_radius_m || clearance_exact_m > 20.0)) {
    msg << "TraversabilityOptions::clearance_exact_m = " << clearance_exact_m
        << " must be in [robot_radius_m = " << robot_radius_m << ", 20]";
    ok = false;
  }
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

namespace {

// Clears the grid's seen-free pointer (valid only while a caller's grid is in reach) when leaving a scope.
struct SeenFreeScope {
  const core::VoxelGrid** pointer;
  ~SeenFreeScope() { *pointer = nullptr; }
};

// Inclusive cell window clamped to the grid; empty when x1 < x0 or y1 < y0.
struct Window {
  int x0, y0, x1, y1;
  Window Grown(int by, int nx, int ny) const {
    return Window{std::max(0, x0 - by), std::max(0, y0 - by), std::min(nx - 1, x1 + by),
                  std::min(ny - 1, y1 + by)};
  }
  bool Empty() const { return x1 < x0 || y1 < y0; }
};

}  // namespace

TraversabilityGrid::TraversabilityGrid(const core::VoxelGrid& world, const TraversabilityOptions& options,
                                       const core::VoxelGrid* seen_free, double sensor_max_z_m)
    : options_(options), sensor_max_z_m_(sensor_max_z_m) {
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
  k_ = k;
  cell_m_ = k * res;
  options_.cell_size_m = cell_m_;
  world_dims_ = world.dims();
  world_p_min_ = world.p_W_min();
  world_res_m_ = res;
  nx_ = (world_dims_.x() + k - 1) / k;
  ny_ = (world_dims_.y() + k - 1) / k;
  p_W_min_ = world.p_W_min().head<2>();
  need_voxels_ = std::max(1, static_cast<int>(std::ceil(options.robot_height_m / res - kEps_m)));
  if (seen_free != nullptr) CheckGeometry(*seen_free, "seen_free");
  seen_free_ = seen_free;
  const SeenFreeScope scope{&seen_free_};

  double reference = options.reference_height_m;
  if (std::isnan(reference)) {
    // Automatic: the most common lowest ground (the main floor); ties go to the lower height.
    std::map<int, std::int64_t> histogram;
    for (int ix = 0; ix < world_dims_.x(); ++ix) {
      for (int iy = 0; iy < world_dims_.y(); ++iy) {
        int lowest = -1;
        ScanColumn(world, ix, iy, [&](int iz) { lowest = iz; });
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
    reference = best >= 0 ? TopOf(best) : world_p_min_.z();
  }
  summary_.reference_height_m = reference;

  const std::size_t n_cells = static_cast<std::size_t>(nx_) * ny_;
  state_.assign(n_cells, CellState::kUnknown);
  ground_.assign(n_cells, std::nan(""));
  inferred_.assign(n_cells, 0);
  lethal_.assign(n_cells, 0);
  internal_step_.assign(n_cells, 0);
  clearance_m_.assign(n_cells, 0.0);
  Recompute(world, {{0, 0, nx_ - 1, ny_ - 1}}, /*whole=*/true);
}

void TraversabilityGrid::CheckGeometry(const core::VoxelGrid& grid, const char* what) const {
  if (grid.dims() != world_dims_ || grid.resolution_m() != world_res_m_ || grid.p_W_min() != world_p_min_) {
    throw std::invalid_argument(std::string("TraversabilityGrid: the geometry of ") + what +
                                " differs from the one the grid was built on");
  }
}

double TraversabilityGrid::TopOf(int iz) const { return world_p_min_.z() + (iz + 1) * world_res_m_; }

template <class Visit>
bool TraversabilityGrid::ScanColumn(const core::VoxelGrid& world, int ix, int iy, Visit&& visit) const {
  const internal::FloorColumnScan scan{world,
                                       seen_free_,
                                       sensor_max_z_m_,
                                       options_.ground_search_min_z_m - kEps_m,
                                       options_.ground_search_max_z_m + kEps_m,
                                       need_voxels_,
                                       options_.free_above_map};
  return scan(ix, iy, visit);
}

void TraversabilityGrid::Update(const core::VoxelGrid& world, const Eigen::AlignedBox2d& region_W) {
  Update(world, std::vector<Eigen::AlignedBox2d>{region_W});
}

void TraversabilityGrid::Update(const core::VoxelGrid& world,
                                const std::vector<Eigen::AlignedBox2d>& regions_W) {
  Update(world, nullptr, regions_W);
}

void TraversabilityGrid::Update(const core::VoxelGrid& world, const core::VoxelGrid* seen_free,
                                const std::vector<Eigen::AlignedBox2d>& regions_W) {
  CheckGeometry(world, "the world");
  if (seen_free != nullptr) CheckGeometry(*seen_free, "seen_free");
  seen_free_ = seen_free;
  const SeenFreeScope scope{&seen_free_};
  std::vector<std::array<int, 4>> windows;
  const auto cell = [&](double v, double lo) { return static_cast<int>(std::floor((v - lo) / cell_m_)); };
  for (const Eigen::AlignedBox2d& region_W : regions_W) {
    if (region_W.isEmpty() || !region_W.min().allFinite() || !region_W.max().allFinite()) continue;
    const int x0 = std::max(0, cell(region_W.min().x(), p_W_min_.x()));
    const int y0 = std::max(0, cell(region_W.min().y(), p_W_min_.y()));
    const int x1 = std::min(nx_ - 1, cell(region_W.max().x(), p_W_min_.x()));
    const int y1 = std::min(ny_ - 1, cell(region_W.max().y(), p_W_min_.y()));
    if (x1 >= x0 && y1 >= y0) windows.push_back({x0, y0, x1, y1});
  }
  if (!windows.empty()) Recompute(world, windows, /*whole=*/false);
}

void TraversabilityGrid::Recompute(const core::VoxelGrid& world,
                                   const std::vector<std::array<int, 4>>& changed_cells, bool whole) {
  Window changed{nx_, ny_, -1, -1};  // the union of the changed windows
  for (const auto& w : changed_cells) {
    changed = Window{std::min(changed.x0, w[0]), std::min(changed.y0, w[1]), std::max(changed.x1, w[2]),
                     std::max(changed.y1, w[3])};
  }
  if (changed.Empty()) return;
  // Hole filling reads up to fill_passes cells around a changed cell; lethal one more; clearance reads lethal
  // cells within clearance_exact_m.
  const Window filled = changed.Grown(options_.fill_passes, nx_, ny_);
  const Window lethal = filled.Grown(options_.unknown_is_lethal ? 1 : 3, nx_, ny_);
  const int reach_cells = static_cast<int>(std::ceil(options_.clearance_exact_m / cell_m_)) + 1;
  const Window written = whole ? lethal : lethal.Grown(reach_cells, nx_, ny_);
  const Window window = whole ? lethal : written.Grown(reach_cells, nx_, ny_);

  ClassifyCells(world, changed_cells);
  FillHoles(world, {filled.x0, filled.y0, filled.x1, filled.y1});
  MarkLethal({lethal.x0, lethal.y0, lethal.x1, lethal.y1});
  ComputeClearance({window.x0, window.y0, window.x1, window.y1},
                   {written.x0, written.y0, written.x1, written.y1});
  Summarize();
}

// Steps 1-2: the ground per world column, aggregated k x k into the changed cells (free, obstacle or
// unknown).
void TraversabilityGrid::ClassifyCells(const core::VoxelGrid& world,
                                       const std::vector<std::array<int, 4>>& changed_cells) {
  const int k = k_;
  const int nxw = world_dims_.x();
  const int nyw = world_dims_.y();
  const double reference = summary_.reference_height_m;
  for (const auto& w : changed_cells)
    for (int cx = w[0]; cx <= w[2]; ++cx) {
      for (int cy = w[1]; cy <= w[3]; ++cy) {
        bool any_obstacle = false;
        double lo = kInf;
        double hi = -kInf;
        for (int ix = cx * k; ix < std::min(nxw, (cx + 1) * k); ++ix) {
          for (int iy = cy * k; iy < std::min(nyw, (cy + 1) * k); ++iy) {
            int chosen = -1;
            const bool band_occupied = ScanColumn(world, ix, iy, [&](int iz) {
              if (chosen < 0 || std::abs(TopOf(iz) - reference) <= std::abs(TopOf(chosen) - reference))
                chosen = iz;
            });
            if (chosen >= 0) {
              lo = std::min(lo, TopOf(chosen));
              hi = std::max(hi, TopOf(chosen));
            } else if (band_occupied) {
              any_obstacle = true;
            }
          }
        }
        const std::size_t i = Index(cx, cy);
        inferred_[i] = 0;
        internal_step_[i] = 0;
        ground_[i] = std::nan("");
        if (any_obstacle) {
          state_[i] = CellState::kObstacle;
        } else if (hi > -kInf) {
          state_[i] = CellState::kFree;
          ground_[i] = hi;
          internal_step_[i] = (hi - lo) > options_.max_step_m + kEps_m;
        } else {
          state_[i] = CellState::kUnknown;
        }
      }
    }
}

// Step 3: hole filling for sparse scans in `filled_box` (cells near a change: their inferred ground is
// redone).
void TraversabilityGrid::FillHoles(const core::VoxelGrid& world, const std::array<int, 4>& filled_box) {
  const int k = k_;
  const int nxw = world_dims_.x();
  const int nyw = world_dims_.y();
  const int nzw = world_dims_.z();
  const Window filled{filled_box[0], filled_box[1], filled_box[2], filled_box[3]};
  for (int cx = filled.x0; cx <= filled.x1; ++cx) {
    for (int cy = filled.y0; cy <= filled.y1; ++cy) {
      const std::size_t i = Index(cx, cy);
      if (inferred_[i]) {
        inferred_[i] = 0;
        state_[i] = CellState::kUnknown;
        ground_[i] = std::nan("");
      }
    }
  }
  // Body space check for an inferred ground g: no occupied voxel of the cell's columns in (g, g + height].
  const double z0 = world_p_min_.z();
  const double res = world_res_m_;
  auto body_space_free = [&](int cx, int cy, double g) {
    for (int ix = cx * k; ix < std::min(nxw, (cx + 1) * k); ++ix) {
      for (int iy = cy * k; iy < std::min(nyw, (cy + 1) * k); ++iy) {
        for (int iz = 0; iz < nzw; ++iz) {
          const double zc = z0 + (iz + 0.5) * res;
          if (zc > g && zc <= g + options_.robot_height_m && world.IsOccupiedIndex({ix, iy, iz}))
            return false;
        }
      }
    }
    return true;
  };
  for (int pass = 0; pass < options_.fill_passes; ++pass) {
    std::vector<std::pair<std::size_t, double>> fills;
    for (int cx = filled.x0; cx <= filled.x1; ++cx) {
      for (int cy = filled.y0; cy <= filled.y1; ++cy) {
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
        if (count < options_.fill_min_neighbors || hi - lo > options_.max_step_m + kEps_m) continue;
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
}

// Step 4: the lethal layer in `lethal_box`: non-free cells (unknown ones only if unknown_is_lethal) and the
// high side of too high steps.
void TraversabilityGrid::MarkLethal(const std::array<int, 4>& lethal_box) {
  const Window lethal{lethal_box[0], lethal_box[1], lethal_box[2], lethal_box[3]};
  for (int cx = lethal.x0; cx <= lethal.x1; ++cx) {
    for (int cy = lethal.y0; cy <= lethal.y1; ++cy) {
      const std::size_t i = Index(cx, cy);
      lethal_[i] = 0;
      if (state_[i] == CellState::kObstacle || internal_step_[i] ||
          (state_[i] == CellState::kUnknown && options_.unknown_is_lethal)) {
        lethal_[i] = 1;
        continue;
      }
      if (state_[i] != CellState::kFree) continue;
      for (int dx = -1; dx <= 1 && !lethal_[i]; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          if ((dx == 0 && dy == 0) || !InGrid(cx + dx, cy + dy)) continue;
          const std::size_t j = Index(cx + dx, cy + dy);
          if (state_[j] == CellState::kFree && ground_[i] - ground_[j] > options_.max_step_m + kEps_m) {
            lethal_[i] = 1;
            break;
          }
        }
      }
      if (!lethal_[i] && !options_.unknown_is_lethal) {
        // Optimistic reading: a step seen across unseen cells (a wall face whose foot is hidden) must not be
        // bridged by planning through the gap. Free cells 2 or 3 cells away along the 8 directions, with only
        // unknown cells between, count as neighbours, allowing a slope of kGapSlope over the gap.
        constexpr double kGapSlope = 0.5;
        for (int dir = 0; dir < 8 && !lethal_[i]; ++dir) {
          static const int kDx[8] = {1, 1, 0, -1, -1, -1, 0, 1};
          static const int kDy[8] = {0, 1, 1, 1, 0, -1, -1, -1};
          for (int d = 2; d <= 3; ++d) {
            const int mx = cx + d * kDx[dir];
            const int my = cy + d * kDy[dir];
            const int px = cx + (d - 1) * kDx[dir];
            const int py = cy + (d - 1) * kDy[dir];
            if (!InGrid(mx, my) || state_[Index(px, py)] != CellState::kUnknown) break;
            const std::size_t j = Index(mx, my);
            if (state_[j] != CellState::kFree) continue;
            const double run_m = (d - 1) * cell_m_ * std::hypot(kDx[dir], kDy[dir]);
            if (ground_[i] - ground_[j] > options_.max_step_m + kGapSlope * run_m + kEps_m) lethal_[i] = 1;
            break;
          }
        }
      }
    }
  }
}

// Step 5: clearance, the exact Euclidean distance to the nearest lethal cell and to the outside, computed on
// `window_box` and written for `written_box` (exact up to clearance_exact_m there, see ClearanceM()).
void TraversabilityGrid::ComputeClearance(const std::array<int, 4>& window_box,
                                          const std::array<int, 4>& written_box) {
  const Window window{window_box[0], window_box[1], window_box[2], window_box[3]};
  const Window written{written_box[0], written_box[1], written_box[2], written_box[3]};
  const int wx = window.x1 - window.x0 + 1;
  const int wy = window.y1 - window.y0 + 1;
  std::vector<double> d2(static_cast<std::size_t>(wx) * wy);
  auto w_index = [&](int cx, int cy) {
    return static_cast<std::size_t>(cx - window.x0) + static_cast<std::size_t>(wx) * (cy - window.y0);
  };
  for (int cy = window.y0; cy <= window.y1; ++cy) {
    for (int cx = window.x0; cx <= window.x1; ++cx) d2[w_index(cx, cy)] = lethal_[Index(cx, cy)] ? 0.0 : kFar;
  }
  std::vector<int> v;
  std::vector<double> z;
  std::vector<double> line_in(static_cast<std::size_t>(std::max(wx, wy)));
  std::vector<double> line_out(line_in.size());
  for (int cy = window.y0; cy <= window.y1; ++cy) {  // Along x.
    for (int cx = window.x0; cx <= window.x1; ++cx)
      line_in[static_cast<std::size_t>(cx - window.x0)] = d2[w_index(cx, cy)];
    DistanceTransform1D(line_in.data(), wx, line_out.data(), &v, &z);
    for (int cx = window.x0; cx <= window.x1; ++cx)
      d2[w_index(cx, cy)] = line_out[static_cast<std::size_t>(cx - window.x0)];
  }
  for (int cx = window.x0; cx <= window.x1; ++cx) {  // Along y.
    for (int cy = window.y0; cy <= window.y1; ++cy)
      line_in[static_cast<std::size_t>(cy - window.y0)] = d2[w_index(cx, cy)];
    DistanceTransform1D(line_in.data(), wy, line_out.data(), &v, &z);
    for (int cy = window.y0; cy <= window.y1; ++cy)
      d2[w_index(cx, cy)] = line_out[static_cast<std::size_t>(cy - window.y0)];
  }
  for (int cx = written.x0; cx <= written.x1; ++cx) {
    for (int cy = written.y0; cy <= written.y1; ++cy) {
      const double border_cells = std::min({cx + 1, nx_ - cx, cy + 1, ny_ - cy});
      const double d = d2[w_index(cx, cy)] >= 0.5 * kFar ? kInf : std::sqrt(d2[w_index(cx, cy)]);
      clearance_m_[Index(cx, cy)] = std::min(d, static_cast<double>(border_cells)) * cell_m_;
    }
  }
}

// Step 6: the summary's counts.
void TraversabilityGrid::Summarize() {
  const double reference_height_m = summary_.reference_height_m;
  summary_ = TraversabilitySummary{};
  summary_.reference_height_m = reference_height_m;
  summary_.cells_total = static_cast<std::int64_t>(state_.size());
  for (std::size_t i = 0; i < state_.size(); ++i) {
    summary_.cells_unknown += state_[i] == CellState::kUnknown;
    summary_.cells_obstacle += state_[i] == CellState::kObstacle;
    summary_.cells_free += state_[i] == CellState::kFree;
    summary_.cells_inferred += inferred_[i];
    summary_.cells_lethal += lethal_[i];
    summary_.cells_traversable += clearance_m_[i] > options_.robot_radius_m + 1e-9;
  }
}

std::size_t TraversabilityGrid::MemoryBytes() const {
  return internal_step_.capacity() + state_.capacity() * sizeof(CellState) +
         ground_.capacity() * sizeof(double) + inferred_.capacity() + lethal_.capacity() +
         clearance_m_.capacity() * sizeof(double);
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

bool TraversabilityGrid::OnLevel(double x_m, double y_m, double z_m) const {
  if (const std::optional<double> ground = GroundHeight(x_m, y_m)) {
    return std::abs(*ground - z_m) <= options_.max_step_m + 0.05;
  }
  return z_m >= options_.ground_search_min_z_m && z_m <= options_.ground_search_max_z_m;
}

}  // namespace cairn::nav
