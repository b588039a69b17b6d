// Copyright Cairn authors.
#include "cairn/nav/multilevel.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "cairn/core/range_check.h"
#include "multilevel_search.h"
#include "path_internal.h"
#include "search_scratch.h"

namespace cairn::nav {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps_m = 1e-6;
constexpr double kSqrt2 = 1.41421356237309504880;
constexpr int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
constexpr int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
// A goal or start names a level within this height of a surface, metres.
constexpr double kLevelMatch_m = 1.0;
// Unknown space is entered at the height of the surface left and never climbed, so at a height off the goal's
// level it can only bridge an unseen gap between known surfaces (a tread the lidar missed): a search follows
// it at most this far there. Without the bound a search toward an unconnected floor fills every unknown cell
// within its expansion limit at every height it reached.
constexpr double kMaxUnknownBridgeOffLevelM = 2.0;
// Expansions of a search that may end partial (see AStarOptions::allow_partial).
constexpr int kPartialMaxExpansions = 80000;

std::string Point2(const Eigen::Vector2d& p) {
  char buf[96];
  std::snprintf(buf, sizeof(buf), "(%.2f, %.2f)", p.x(), p.y());
  return buf;
}

}  // namespace

MultiLevelGrid::MultiLevelGrid(std::shared_ptr<const core::VoxelGrid> world,
                               const TraversabilityOptions& options,
                               std::shared_ptr<const core::VoxelGrid> seen_free, double sensor_max_z_m)
    : options_(options),
      world_(std::move(world)),
      seen_free_(std::move(seen_free)),
      sensor_max_z_m_(sensor_max_z_m) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  if (!world_) throw std::invalid_argument("MultiLevelGrid: world is null");
  res_m_ = world_->resolution_m();
  if (options.cell_size_m != 0.0 && std::abs(options.cell_size_m - res_m_) > kEps_m) {
    throw std::invalid_argument(
        "TraversabilityOptions::cell_size_m = " + std::to_string(options.cell_size_m) +
        " must be 0 or the map resolution " + std::to_string(res_m_) + " m for a multi-level grid");
  }
  options_.cell_size_m = res_m_;
  cell_m_ = res_m_;
  world_dims_ = world_->dims();
  world_p_min_ = world_->p_W_min();
  nx_ = world_dims_.x();
  ny_ = world_dims_.y();
  p_W_min_ = world_p_min_.head<2>();
  need_voxels_ = std::max(1, static_cast<int>(std::ceil(options.robot_height_m / res_m_ - kEps_m)));
  if (seen_free_) CheckGeometry(*seen_free_, "seen_free");
  first_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
  observed_.assign(static_cast<std::size_t>(nx_) * ny_, 0);
  observed_near_.assign(static_cast<std::size_t>(nx_) * ny_, 0);
  Recompute({}, /*whole=*/true);
}

void MultiLevelGrid::CheckGeometry(const core::VoxelGrid& grid, const char* what) const {
  if (grid.dims() != world_dims_ || grid.resolution_m() != res_m_ || grid.p_W_min() != world_p_min_) {
    throw std::invalid_argument(std::string("MultiLevelGrid: the geometry of ") + what +
                                " differs from the one the grid was built on");
  }
}

std::size_t MultiLevelGrid::MemoryBytes() const {
  return first_.capacity() * sizeof(int) + z_m_.capacity() * sizeof(float) +
         clearance_m_.capacity() * sizeof(float) + column_of_.capacity() * sizeof(int) +
         observed_.capacity() + observed_near_.capacity();
}

bool MultiLevelGrid::CellOf(double x_m, double y_m, int* ix, int* iy) const {
  if (!std::isfinite(x_m) || !std::isfinite(y_m)) return false;
  const double u = std::floor((x_m - p_W_min_.x()) / cell_m_);
  const double w = std::floor((y_m - p_W_min_.y()) / cell_m_);
  if (u < 0 || w < 0 || u >= nx_ || w >= ny_) return false;
  *ix = static_cast<int>(u);
  *iy = static_cast<int>(w);
  return true;
}

template <class Visit>
void MultiLevelGrid::ScanColumn(int ix, int iy, Visit&& visit) const {
  const internal::FloorColumnScan scan{*world_,
                                       seen_free_.get(),
                                       sensor_max_z_m_,
                                       options_.ground_search_min_z_m - kEps_m,
                                       options_.ground_search_max_z_m + kEps_m,
                                       need_voxels_,
                                       options_.free_above_map};
  scan(ix, iy, visit);
}

int MultiLevelGrid::NodeNear(int ix, int iy, double z_m, double max_dz_m) const {
  if (!InGrid(ix, iy) || !std::isfinite(z_m)) return -1;
  const int column = Column(ix, iy);
  int best = -1;
  double best_dz = max_dz_m + kEps_m;
  for (int n = first_[static_cast<std::size_t>(column)]; n < first_[static_cast<std::size_t>(column) + 1];
       ++n) {
    const double dz = std::abs(z_m_[static_cast<std::size_t>(n)] - z_m);
    if (dz <= best_dz) {
      best = n;
      best_dz = dz;
    }
  }
  return best;
}

bool MultiLevelGrid::IsUnknownAt(int ix, int iy, double z_m) const {
  if (options_.unknown_is_lethal || !InGrid(ix, iy) || !std::isfinite(z_m)) return false;
  if (!observed_[static_cast<std::size_t>(Column(ix, iy))]) return true;  // nothing seen in the whole column
  // The voxel a floor at z_m would be, or the one below it (a floor on a voxel boundary reads a voxel high in
  // one column and low in the next): both seen free means a ray went through, no floor there. Then the body
  // space above (anything occupied: a wall or a step). Body space seen free says nothing about the floor
  // below it (a lidar does not see the floor right around itself).
  const int iz0 = static_cast<int>(std::lround((z_m - world_p_min_.z()) / res_m_));
  if (seen_free_ && seen_free_->IsOccupiedIndex({ix, iy, iz0 - 1}) &&
      seen_free_->IsOccupiedIndex({ix, iy, iz0 - 2})) {
    return false;
  }
  for (int iz = iz0; iz < iz0 + need_voxels_; ++iz) {
    if (world_->IsOccupiedIndex({ix, iy, iz})) return false;
  }
  return true;
}

bool MultiLevelGrid::IsSightClear(const Eigen::Vector3d& from_W, const Eigen::Vector3d& to_W) const {
  const std::optional<Eigen::Vector3i> first = world_->IndexOf(from_W);
  const std::optional<Eigen::Vector3i> last = world_->IndexOf(to_W);
  if (!first || !last) return false;
  const int samples = static_cast<int>(std::ceil((to_W - from_W).norm() / (0.25 * res_m_)));
  for (int k = 1; k < samples; ++k) {
    const std::optional<Eigen::Vector3i> at =
        world_->IndexOf(from_W + (to_W - from_W) * (static_cast<double>(k) / samples));
    if (at && *at != *first && *at != *last && world_->IsOccupiedIndex(*at)) return false;
  }
  return true;
}

bool MultiLevelGrid::IsUnseenStepAt(int ix, int iy, double z_m) const {
  if (options_.unknown_is_lethal || !seen_free_ || !InGrid(ix, iy) || !std::isfinite(z_m)) return false;
  // Voxel iz has its top at TopOf(iz); the steps: tops in (z_m, z_m + max_step_m].
  const int iz_first = static_cast<int>(std::lround((z_m - world_p_min_.z()) / res_m_));  // top at z_m + res
  const int iz_last =
      static_cast<int>(std::floor((z_m + options_.max_step_m + kEps_m - world_p_min_.z()) / res_m_)) - 1;
  for (int iz = std::max(0, iz_first); iz <= iz_last && iz < world_dims_.z(); ++iz) {
    if (!world_->IsOccupiedIndex({ix, iy, iz})) continue;
    bool unseen = false;
    for (int k = iz + 1; k <= iz + need_voxels_; ++k) {
      if (k >= world_dims_.z()) {
        unseen = true;  // above the map: not seen
        break;
      }
      if (world_->IsOccupiedIndex({ix, iy, k})) return false;  // a wall, or the step's own riser goes on
      if (!seen_free_->IsOccupiedIndex({ix, iy, k})) unseen = true;
    }
    return unseen;
  }
  return false;
}

int MultiLevelGrid::Connected(int jx, int jy, double z, bool* unknown) const {
  *unknown = false;
  const int node = NodeNear(jx, jy, z, options_.max_step_m);
  if (node >= 0) return node;
  *unknown = IsUnknownAt(jx, jy, z);
  return -1;
}

void MultiLevelGrid::Update(std::shared_ptr<const core::VoxelGrid> world,
                            std::shared_ptr<const core::VoxelGrid> seen_free,
                            const std::vector<Eigen::AlignedBox2d>& regions_W, double sensor_max_z_m) {
  if (!world) throw std::invalid_argument("MultiLevelGrid::Update: world is null");
  CheckGeometry(*world, "the world");
  if (seen_free) CheckGeometry(*seen_free, "seen_free");
  world_ = std::move(world);
  seen_free_ = std::move(seen_free);
  sensor_max_z_m_ = sensor_max_z_m;
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
  if (!windows.empty()) Recompute(windows, /*whole=*/false);
}

void MultiLevelGrid::Recompute(const std::vector<std::array<int, 4>>& windows, bool whole) {
  const std::array<int, 4> changed = RebuildSurfaces(windows, whole);
  UpdateObservedNear(changed);
  RecomputeClearance(changed, whole);
}

std::array<int, 4> MultiLevelGrid::RebuildSurfaces(const std::vector<std::array<int, 4>>& windows,
                                                   bool whole) {
  const std::size_t n_columns = static_cast<std::size_t>(nx_) * ny_;
  std::array<int, 4> changed{nx_, ny_, -1, -1};
  std::vector<std::uint8_t> is_changed;
  if (whole) {
    changed = {0, 0, nx_ - 1, ny_ - 1};
  } else {
    is_changed.assign(n_columns, 0);
    for (const auto& w : windows) {
      changed = {std::min(changed[0], w[0]), std::min(changed[1], w[1]), std::max(changed[2], w[2]),
                 std::max(changed[3], w[3])};
      for (int iy = w[1]; iy <= w[3]; ++iy) {
        for (int ix = w[0]; ix <= w[2]; ++ix) is_changed[static_cast<std::size_t>(Column(ix, iy))] = 1;
      }
    }
  }
  std::vector<int> first(n_columns + 1, 0);
  std::vector<float> z_m;
  std::vector<float> clearance_m;
  std::vector<int> column_of;
  z_m.reserve(z_m_.size() + 1024);
  clearance_m.reserve(z_m_.size() + 1024);
  column_of.reserve(z_m_.size() + 1024);
  std::vector<int> found;
  max_levels_ = 0;
  for (int iy = 0; iy < ny_; ++iy) {
    for (int ix = 0; ix < nx_; ++ix) {
      const std::size_t column = static_cast<std::size_t>(Column(ix, iy));
      first[column] = static_cast<int>(z_m.size());
      if (whole || is_changed[column]) {
        const int top_z = world_dims_.z() - 1;
        observed_[column] = world_->HighestOccupiedInColumn(ix, iy, top_z) >= 0 ||
                            (seen_free_ && seen_free_->HighestOccupiedInColumn(ix, iy, top_z) >= 0);
        found.clear();
        ScanColumn(ix, iy, [&found](int iz) { found.push_back(iz); });
        for (auto it = found.rbegin(); it != found.rend(); ++it) {  // lowest first
          z_m.push_back(static_cast<float>(TopOf(*it)));
          clearance_m.push_back(0.0f);
          column_of.push_back(static_cast<int>(column));
        }
      } else {
        for (int n = first_[column]; n < first_[column + 1]; ++n) {
          z_m.push_back(z_m_[static_cast<std::size_t>(n)]);
          clearance_m.push_back(clearance_m_[static_cast<std::size_t>(n)]);
          column_of.push_back(static_cast<int>(column));
        }
      }
      max_levels_ = std::max(max_levels_, static_cast<int>(z_m.size()) - first[column]);
    }
  }
  first[n_columns] = static_cast<int>(z_m.size());
  first_ = std::move(first);
  z_m_ = std::move(z_m);
  clearance_m_ = std::move(clearance_m);
  column_of_ = std::move(column_of);
  return changed;
}

void MultiLevelGrid::UpdateObservedNear(const std::array<int, 4>& changed) {
  // A separable square dilation of the observed columns.
  const int r = static_cast<int>(std::ceil(options_.robot_radius_m / cell_m_));
  const int x0 = std::max(0, changed[0] - r), x1 = std::min(nx_ - 1, changed[2] + r);
  const int y0 = std::max(0, changed[1] - r), y1 = std::min(ny_ - 1, changed[3] + r);
  const int wx = x1 - x0 + 1;
  std::vector<std::uint8_t> rows(static_cast<std::size_t>(wx) * (y1 - y0 + 1 + 2 * r), 0);
  // rows[(y - (y0 - r)) * wx + (x - x0)]: any observed column in [x - r, x + r] of row y.
  for (int y = y0 - r; y <= y1 + r; ++y) {
    if (y < 0 || y >= ny_) continue;
    for (int x = x0; x <= x1; ++x) {
      std::uint8_t any = 0;
      for (int d = -r; d <= r && !any; ++d) {
        if (x + d >= 0 && x + d < nx_) any = observed_[static_cast<std::size_t>(Column(x + d, y))];
      }
      rows[static_cast<std::size_t>(y - (y0 - r)) * wx + (x - x0)] = any;
    }
  }
  for (int y = y0; y <= y1; ++y) {
    for (int x = x0; x <= x1; ++x) {
      std::uint8_t any = 0;
      for (int d = -r; d <= r && !any; ++d)
        any = rows[static_cast<std::size_t>(y + d - (y0 - r)) * wx + (x - x0)];
      observed_near_[static_cast<std::size_t>(Column(x, y))] = any;
    }
  }
}

void MultiLevelGrid::RecomputeClearance(const std::array<int, 4>& changed, bool whole) {
  // Computed on `window` and written on `written` (a change alters the blocked points of its neighbours,
  // which reach clearance_exact_m further).
  const int reach = static_cast<int>(std::ceil(options_.clearance_exact_m / cell_m_)) + 2;
  auto grown = [&](const std::array<int, 4>& w, int by) {
    return std::array<int, 4>{std::max(0, w[0] - by), std::max(0, w[1] - by), std::min(nx_ - 1, w[2] + by),
                              std::min(ny_ - 1, w[3] + by)};
  };
  const std::array<int, 4> written = whole ? changed : grown(changed, 1 + reach);
  const std::array<int, 4> window = whole ? changed : grown(written, reach);
  const std::size_t n_nodes = z_m_.size();
  std::vector<float> dist(n_nodes, static_cast<float>(kInf));
  std::vector<std::int32_t> seed_x(n_nodes, 0), seed_y(n_nodes, 0);  // the blocked cell nearest each surface
  using Entry = std::pair<float, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  auto in_window = [&window](int ix, int iy) {
    return ix >= window[0] && ix <= window[2] && iy >= window[1] && iy <= window[3];
  };
  for (int iy = window[1]; iy <= window[3]; ++iy) {
    for (int ix = window[0]; ix <= window[2]; ++ix) {
      const int column = Column(ix, iy);
      for (int n = first_[static_cast<std::size_t>(column)]; n < first_[static_cast<std::size_t>(column) + 1];
           ++n) {
        const double z = z_m_[static_cast<std::size_t>(n)];
        for (int k = 0; k < 8; ++k) {
          const int jx = ix + kDx[k];
          const int jy = iy + kDy[k];
          bool unknown = false;
          if (InGrid(jx, jy) && (Connected(jx, jy, z, &unknown) >= 0 || unknown)) continue;
          const float d = static_cast<float>(((kDx[k] != 0 && kDy[k] != 0) ? kSqrt2 : 1.0) * cell_m_);
          if (d < dist[static_cast<std::size_t>(n)]) {
            dist[static_cast<std::size_t>(n)] = d;
            seed_x[static_cast<std::size_t>(n)] = jx;
            seed_y[static_cast<std::size_t>(n)] = jy;
          }
        }
        if (std::isfinite(dist[static_cast<std::size_t>(n)]))
          open.emplace(dist[static_cast<std::size_t>(n)], n);
      }
    }
  }
  const double limit_m = options_.clearance_exact_m + 2.0 * cell_m_;
  while (!open.empty()) {
    const auto [d, n] = open.top();
    open.pop();
    const auto un = static_cast<std::size_t>(n);
    if (d > dist[un]) continue;
    const int column = column_of_[un];
    const int ix = column % nx_;
    const int iy = column / nx_;
    const Eigen::Vector2d seed = CellCenter(seed_x[un], seed_y[un]);
    for (int k = 0; k < 8; ++k) {
      const int jx = ix + kDx[k];
      const int jy = iy + kDy[k];
      if (!in_window(jx, jy)) continue;
      bool unknown = false;
      const int m = Connected(jx, jy, z_m_[un], &unknown);
      if (m < 0) continue;
      const auto um = static_cast<std::size_t>(m);
      const float dm = static_cast<float>((CellCenter(jx, jy) - seed).norm());
      if (dm + 1e-6f < dist[um] && dm <= limit_m) {
        dist[um] = dm;
        seed_x[um] = seed_x[un];
        seed_y[um] = seed_y[un];
        open.emplace(dm, m);
      }
    }
  }
  for (int iy = written[1]; iy <= written[3]; ++iy) {
    for (int ix = written[0]; ix <= written[2]; ++ix) {
      const int column = Column(ix, iy);
      const double border_m = std::min({ix + 1, nx_ - ix, iy + 1, ny_ - iy}) * cell_m_;
      for (int n = first_[static_cast<std::size_t>(column)]; n < first_[static_cast<std::size_t>(column) + 1];
           ++n) {
        clearance_m_[static_cast<std::size_t>(n)] =
            static_cast<float>(std::min(static_cast<double>(dist[static_cast<std::size_t>(n)]), border_m));
      }
    }
  }
}

bool MultiLevelGrid::IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const {
  int ix = 0;
  int iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy) || !(radius_m >= 0.0)) return false;
  const int start = NodeNear(ix, iy, z_m, options_.max_step_m);
  if (start < 0) return false;
  const Eigen::Vector2d p(x_m, y_m);
  const double reach_m = radius_m + 1.5 * cell_m_;
  // Walk the connected surfaces around the body; any blocked neighbour point within the radius is contact.
  std::vector<int> stack = {start};
  std::vector<int> seen = {start};
  while (!stack.empty()) {
    const int n = stack.back();
    stack.pop_back();
    const int column = column_of_[static_cast<std::size_t>(n)];
    const int cx = column % nx_;
    const int cy = column / nx_;
    for (int k = 0; k < 8; ++k) {
      const int jx = cx + kDx[k];
      const int jy = cy + kDy[k];
      const Eigen::Vector2d c = CellCenter(jx, jy);
      bool unknown = false;
      const int m = InGrid(jx, jy) ? Connected(jx, jy, z_m_[static_cast<std::size_t>(n)], &unknown) : -1;
      if (m < 0) {
        if (!unknown && (c - p).norm() <= radius_m) return false;
        continue;
      }
      if ((c - p).norm() > reach_m || std::find(seen.begin(), seen.end(), m) != seen.end()) continue;
      seen.push_back(m);
      stack.push_back(m);
    }
  }
  return true;
}

std::optional<double> MultiLevelGrid::GroundHeightNear(double x_m, double y_m, double z_m) const {
  int ix = 0;
  int iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy)) return std::nullopt;
  const int node = NodeNear(ix, iy, z_m, options_.max_step_m);
  if (node < 0) return std::nullopt;
  return NodeZ(node);
}

std::optional<double> MultiLevelGrid::GroundHeight(double x_m, double y_m) const {
  int ix = 0;
  int iy = 0;
  if (!CellOf(x_m, y_m, &ix, &iy)) return std::nullopt;
  const int column = Column(ix, iy);
  if (first_[static_cast<std::size_t>(column)] == first_[static_cast<std::size_t>(column) + 1])
    return std::nullopt;
  return NodeZ(first_[static_cast<std::size_t>(column)]);
}

bool MultiLevelGrid::IsFootprintFree(double x_m, double y_m, double radius_m) const {
  const auto z = GroundHeight(x_m, y_m);
  return z.has_value() && IsFootprintFreeNear(x_m, y_m, *z, radius_m);
}

// ---- LeveledTerrain
// ----------------------------------------------------------------------------------------

LeveledTerrain::LeveledTerrain(std::shared_ptr<const TraversabilityGrid> main_level,
                               std::shared_ptr<const MultiLevelGrid> levels)
    : main_(std::move(main_level)), levels_(std::move(levels)) {
  if (!main_ || !levels_) throw std::invalid_argument("LeveledTerrain: a grid is null");
}

bool LeveledTerrain::OnMainLevel(double x_m, double y_m, double z_m) const {
  const auto ground = main_->GroundHeight(x_m, y_m);
  return ground.has_value() && std::abs(*ground - z_m) <= main_->options().max_step_m + 0.05;
}

bool LeveledTerrain::IsFootprintFree(double x_m, double y_m, double radius_m) const {
  return main_->IsFootprintFree(x_m, y_m, radius_m);
}

std::optional<double> LeveledTerrain::GroundHeight(double x_m, double y_m) const {
  return main_->GroundHeight(x_m, y_m);
}

bool LeveledTerrain::IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const {
  // The main level's single ground per column reads a junction of levels (the top of a flight next to a
  // landing over a lower floor) as a drop: free where either grid finds the body free on its level.
  return (OnMainLevel(x_m, y_m, z_m) && main_->IsFootprintFree(x_m, y_m, radius_m)) ||
         levels_->IsFootprintFreeNear(x_m, y_m, z_m, radius_m);
}

std::optional<double> LeveledTerrain::GroundHeightNear(double x_m, double y_m, double z_m) const {
  return OnMainLevel(x_m, y_m, z_m) ? main_->GroundHeight(x_m, y_m)
                                    : levels_->GroundHeightNear(x_m, y_m, z_m);
}

// ---- A* over (cell, surface)
// --------------------------------------------------------------------------------

namespace {

using State = internal::LevelState;

// A* bookkeeping of one state.
struct Record {
  double g = std::numeric_limits<double>::infinity();
  std::int64_t parent = -1;
  bool closed = false;
  State state;
};

// PlanPathMultiLevel's per-surface records, reset after each search at the surfaces it touched
// (search_scratch.h); unknown-space states live in a hash map.
struct LevelSearchScratch {
  std::vector<Record> known;
  std::vector<int> touched;  // known surfaces whose record was written
  std::unordered_map<std::int64_t, Record> virtuals;

  void Prepare(std::size_t n_nodes) {
    for (const int i : touched) known[static_cast<std::size_t>(i)] = Record{};
    touched.clear();
    virtuals.clear();
    if (known.size() != n_nodes) known.assign(n_nodes, Record{});
  }
};

internal::ScratchPool<LevelSearchScratch>& LevelScratchPool() {
  static internal::ScratchPool<LevelSearchScratch> pool;
  return pool;
}

}  // namespace

namespace {

// Walks a -> b (x, y, surface z; metres, frame W) in quarter-cell steps over connected traversable surfaces
// (or unknown space) whose clearance is at least min_clearance_m; true when it ends within a step of b.z.
bool WalkSegment(const MultiLevelSearch& search, const MultiLevelGrid& grid, const Eigen::Vector3d& a,
                 const Eigen::Vector3d& b, double min_clearance_m) {
  const double c = grid.cell_size_m();
  const double length = (b - a).head<2>().norm();
  const int n = std::max(1, static_cast<int>(std::ceil(length / (0.25 * c))));
  double z = a.z();
  int px = -1, py = -1;
  for (int i = 0; i <= n; ++i) {
    const Eigen::Vector2d p = a.head<2>() + (b - a).head<2>() * (static_cast<double>(i) / n);
    int cx = 0, cy = 0;
    if (!grid.CellOf(p.x(), p.y(), &cx, &cy)) return false;
    if (cx == px && cy == py) continue;
    const std::optional<State> s = search.Enter(cx, cy, z);
    if (!s || search.Clearance(*s) < min_clearance_m) return false;
    z = s->z;
    px = cx;
    py = cy;
  }
  return std::abs(z - b.z()) <= grid.options().max_step_m + kEps_m;
}

}  // namespace

double PartialRemainingM(const Eigen::Vector3d& p_W, const Eigen::Vector2d& goal_W, double goal_z_m,
                         double level_tolerance_m) {
  constexpr double kHeightWeight = 30.0;
  const double off_level =
      std::isfinite(goal_z_m)
          ? std::max(0.0, std::abs(p_W.z() - goal_z_m) - std::max(0.0, level_tolerance_m) - kEps_m)
          : 0.0;
  return (p_W.head<2>() - goal_W).norm() + kHeightWeight * off_level;
}

bool SegmentTraversableMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& a_W,
                                  const Eigen::Vector3d& b_W, double min_clearance_m, double robot_radius_m) {
  AStarOptions options;
  options.robot_radius_m = robot_radius_m;
  const MultiLevelSearch search(grid, options);
  return a_W.allFinite() && b_W.allFinite() && WalkSegment(search, grid, a_W, b_W, min_clearance_m);
}

namespace {

// The goal of a multi-level plan: a known surface, or unknown space at a height.
struct LevelGoal {
  int ix = 0, iy = 0;
  int node = -1;          // -1: unknown space
  double target_z = 0.0;  // the height asked for (default: the start's level)
  double level_z = 0.0;   // the goal surface's height, or target_z in unknown space
  bool Reached(const State& s) const {
    if (s.ix != ix || s.iy != iy) return false;
    return node >= 0 ? s.node == node : std::abs(s.z - target_z) <= kLevelMatch_m;
  }
};

int LowestNode(const MultiLevelGrid& grid, int column) {
  return grid.FirstNode(column) < grid.FirstNode(column + 1) ? grid.FirstNode(column) : -1;
}

// The start state: the surface under the robot nearest its height, unknown space there, or the nearest
// traversable cell within start_escape_radius_m (`used_escape`). `start_z` becomes the start surface's
// height. nullopt, and why, when there is none.
std::optional<State> FindLevelStart(const MultiLevelGrid& grid, const MultiLevelSearch& search,
                                    const AStarOptions& options, const Eigen::Vector3d& start_W, int sx,
                                    int sy, double* start_z_out, bool* used_escape, std::string* why) {
  const double step_m = grid.options().max_step_m;
  const double c = grid.cell_size_m();
  double start_z = start_W.z();
  const int start_node = std::isfinite(start_z) ? grid.NodeNear(sx, sy, start_z, std::max(0.5, step_m))
                                                : LowestNode(grid, grid.Column(sx, sy));
  if (start_node >= 0) start_z = grid.NodeZ(start_node);
  *start_z_out = start_z;
  std::optional<State> start;
  if (start_node >= 0 && search.Traversable(start_node)) {
    start = State{sx, sy, start_z, start_node};
  } else if (start_node < 0 && std::isfinite(start_z) && grid.IsUnknownAt(sx, sy, start_z)) {
    start = State{sx, sy, start_z, -1};
  } else if (start_node >= 0 && options.start_escape_radius_m > 0.0 &&
             (options.start_is_robot || grid.IsFootprintFreeNear(start_W.x(), start_W.y(), start_z,
                                                                 options.start_footprint_radius_m))) {
    const int span = static_cast<int>(std::ceil(options.start_escape_radius_m / c)) + 1;
    double best_d = kInf;
    for (int cx = sx - span; cx <= sx + span; ++cx) {
      for (int cy = sy - span; cy <= sy + span; ++cy) {
        const int n = grid.NodeNear(cx, cy, start_z, step_m);
        if (n < 0 || !search.Traversable(n)) continue;
        const double d = (grid.CellCenter(cx, cy) - start_W.head<2>()).norm();
        if (d <= options.start_escape_radius_m && d < best_d) {
          best_d = d;
          start = State{cx, cy, grid.NodeZ(n), n};
        }
      }
    }
    *used_escape = start.has_value();
  }
  if (!start) {
    *why = "start " + Point2(start_W.head<2>()) + " " +
           (start_node < 0 ? "has no walkable surface near z " + core::Fixed(start_W.z(), 2)
                           : "is not traversable (clearance " + core::Fixed(grid.ClearanceM(start_node), 2) +
                                 " m <= robot_radius_m " + core::Fixed(search.radius_m(), 2) +
                                 " m) and no traversable cell lies within start_escape_radius_m");
  }
  return start;
}

// The goal: the surface nearest the named height (default: the start's level, else the lowest), or unknown
// space there. "" or why not.
std::string FindLevelGoal(const MultiLevelGrid& grid, const MultiLevelSearch& search,
                          const Eigen::Vector2d& goal_W, double goal_z_m, double start_z, int gx, int gy,
                          LevelGoal* goal) {
  const int goal_column = grid.Column(gx, gy);
  goal->ix = gx;
  goal->iy = gy;
  goal->target_z = std::isfinite(goal_z_m) ? goal_z_m : start_z;
  goal->node = grid.NodeNear(gx, gy, goal->target_z, kLevelMatch_m);
  if (goal->node < 0 && !std::isfinite(goal_z_m)) goal->node = LowestNode(grid, goal_column);
  const bool goal_unknown = goal->node < 0 && grid.IsUnknownAt(gx, gy, goal->target_z);
  if (goal->node < 0 && !goal_unknown) {
    std::string surfaces;
    for (int n = grid.FirstNode(goal_column); n < grid.FirstNode(goal_column + 1); ++n) {
      surfaces += (surfaces.empty() ? "" : ", ") + core::Fixed(grid.NodeZ(n), 2);
    }
    return "goal " + Point2(goal_W) + " has no walkable surface within " + core::Fixed(kLevelMatch_m, 2) +
           " m of z " + core::Fixed(goal->target_z, 2) +
           (surfaces.empty() ? " (none in that column)" : " (surfaces at z " + surfaces + ")");
  }
  if (goal->node >= 0 && !search.Traversable(goal->node)) {
    return "goal " + Point2(goal_W) + " at z " + core::Fixed(grid.NodeZ(goal->node), 2) +
           " is not traversable (clearance " + core::Fixed(grid.ClearanceM(goal->node), 2) +
           " m <= robot_radius_m " + core::Fixed(search.radius_m(), 2) + " m)";
  }
  goal->level_z = goal->node >= 0 ? grid.NodeZ(goal->node) : goal->target_z;
  return "";
}

// A*'s records of one search: known surfaces in flat arrays (reset where written), unknown-space states in a
// hash map.
class LevelRecords {
 public:
  LevelRecords(LevelSearchScratch* scratch, int n_nodes) : scratch_(*scratch), n_nodes_(n_nodes) {
    scratch_.Prepare(static_cast<std::size_t>(n_nodes));
  }
  Record& operator[](std::int64_t key) {
    return key < n_nodes_ ? scratch_.known[static_cast<std::size_t>(key)] : scratch_.virtuals[key];
  }
  // A known surface's record leaves its reset state.
  void NoteWritten(std::int64_t key) {
    if (key < n_nodes_) scratch_.touched.push_back(static_cast<int>(key));
  }

 private:
  LevelSearchScratch& scratch_;
  int n_nodes_;
};

// Where a search ended: the goal's key (-1: not reached), and for a partial plan the reachable state nearest
// the goal (PartialRemainingM).
struct LevelSearchEnd {
  std::int64_t goal_key = -1;
  std::int64_t best_key = -1;
  double best_remaining = 0.0;
  double start_remaining = 0.0;
  bool capped = false;  // stopped at max_expansions
  int max_expansions = 0;
};

// SearchLevels' costs over the grid toward `goal`: the heuristic, the cost of a move, the distance left for a
// partial plan, and the moves themselves.
class LevelCosts {
 public:
  LevelCosts(const MultiLevelGrid& grid, const MultiLevelSearch& search, const AStarOptions& options,
             const LevelGoal& goal, const Eigen::Vector2d& goal_W)
      : grid_(grid),
        search_(search),
        options_(options),
        goal_(goal),
        goal_W_(goal_W),
        cell_m_(grid.cell_size_m()),
        level_slack_m_(goal.node >= 0 ? 0.0 : kLevelMatch_m) {}  // an unknown goal matches within this

  // Octile distance plus the height still to climb or descend at step_height_cost per metre: every path
  // changes height by at least that much, so the heuristic stays admissible and consistent, and a search
  // toward another floor follows the stairs before it fills the floor it stands on.
  double Heuristic(const State& s) const {
    const int a = std::abs(s.ix - goal_.ix);
    const int b = std::abs(s.iy - goal_.iy);
    return (std::max(a, b) + (kSqrt2 - 1.0) * std::min(a, b)) * cell_m_ +
           options_.step_height_cost * std::max(0.0, std::abs(s.z - goal_.level_z) - level_slack_m_);
  }

  // How far a state is from the goal, for a partial plan (PartialRemainingM).
  double Remaining(const State& s) const {
    const Eigen::Vector2d p = grid_.CellCenter(s.ix, s.iy);
    return PartialRemainingM(Eigen::Vector3d(p.x(), p.y(), s.z), goal_W_, goal_.level_z, cell_m_);
  }

  // The state entered from `s` in direction k (kDx, kDy), or nullopt: unknown space off the goal's level only
  // bridges gaps, and a diagonal move needs both cells beside it enterable.
  std::optional<State> Neighbour(const State& s, int k) const {
    std::optional<State> next = search_.Enter(s.ix + kDx[k], s.iy + kDy[k], s.z);
    if (!next) return std::nullopt;
    const bool diagonal = kDx[k] != 0 && kDy[k] != 0;
    if (next->node < 0) {
      next->unknown_run_m =
          (s.node < 0 ? s.unknown_run_m : 0.0f) + static_cast<float>((diagonal ? kSqrt2 : 1.0) * cell_m_);
      if (next->unknown_run_m > kMaxUnknownBridgeOffLevelM &&
          std::abs(next->z - goal_.level_z) > kLevelMatch_m) {
        return std::nullopt;
      }
    }
    if (diagonal && (!search_.Enter(s.ix + kDx[k], s.iy, s.z) || !search_.Enter(s.ix, s.iy + kDy[k], s.z))) {
      return std::nullopt;
    }
    return next;
  }

  // The cost of the move from `s` to `next` in direction k: its length, more where clearance is short or the
  // space unknown, plus the height changed.
  double MoveCost(const State& s, const State& next, int k) const {
    const bool diagonal = kDx[k] != 0 && kDy[k] != 0;
    const double move = (diagonal ? kSqrt2 : 1.0) * cell_m_;
    const double unknown = next.node < 0 ? options_.unknown_cost : 0.0;
    return move * (1.0 + Penalty(search_.Clearance(next)) + unknown) +
           options_.step_height_cost * std::abs(next.z - s.z);
  }

 private:
  double Penalty(double clearance) const {
    if (options_.preferred_clearance_m <= 0.0 || options_.clearance_cost <= 0.0 || !std::isfinite(clearance))
      return 0.0;
    return options_.clearance_cost *
           std::clamp((options_.preferred_clearance_m - clearance) / options_.preferred_clearance_m, 0.0,
                      1.0);
  }

  const MultiLevelGrid& grid_;
  const MultiLevelSearch& search_;
  const AStarOptions& options_;
  const LevelGoal& goal_;
  const Eigen::Vector2d& goal_W_;
  const double cell_m_;
  const double level_slack_m_;
};

// A* over (cell, surface) from `start` to `goal`; expansions counted into `expansions`.
LevelSearchEnd SearchLevels(const MultiLevelGrid& grid, const MultiLevelSearch& search,
                            const AStarOptions& options, const State& start, const LevelGoal& goal,
                            const Eigen::Vector2d& goal_W, LevelRecords* records_in, int* expansions) {
  LevelRecords& record = *records_in;
  const LevelCosts costs(grid, search, options, goal, goal_W);
  using Entry = std::pair<double, std::int64_t>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const std::int64_t start_key = search.Key(start);
  record[start_key] = Record{0.0, -1, false, start};
  record.NoteWritten(start_key);
  open.emplace(costs.Heuristic(start), start_key);
  LevelSearchEnd end;
  end.best_key = start_key;
  end.best_remaining = costs.Remaining(start);
  end.start_remaining = end.best_remaining;
  // A partial plan is a best effort: its search is bounded tighter (an unreachable level would otherwise
  // expand every cell of a mostly unknown map).
  end.max_expansions = options.allow_partial ? std::min(options.max_expansions, kPartialMaxExpansions)
                                             : options.max_expansions;
  while (!open.empty()) {
    const auto [f, key] = open.top();
    open.pop();
    Record& rec = record[key];
    if (rec.closed) continue;
    rec.closed = true;
    if (++*expansions > end.max_expansions) {
      end.capped = true;
      break;
    }
    const State s = rec.state;
    const double g_here = rec.g;
    if (goal.Reached(s)) {
      end.goal_key = key;
      break;
    }
    if (options.allow_partial) {
      const double r = costs.Remaining(s);
      if (r < end.best_remaining - 1e-9) {
        end.best_remaining = r;
        end.best_key = key;
      }
    }
    for (int k = 0; k < 8; ++k) {
      const std::optional<State> next = costs.Neighbour(s, k);
      if (!next) continue;
      const std::int64_t next_key = search.Key(*next);
      Record& nr = record[next_key];
      if (nr.closed) continue;
      const double candidate = g_here + costs.MoveCost(s, *next, k);
      if (candidate < nr.g) {
        if (!std::isfinite(nr.g)) record.NoteWritten(next_key);
        nr.g = candidate;
        nr.parent = key;
        nr.state = *next;
        open.emplace(candidate + costs.Heuristic(*next), next_key);
      }
    }
  }
  return end;
}

// The path the search found to `end_key`: start point, cell centres with their surface heights, the goal
// point (unless partial); shortcuts only over points of one level.
std::vector<Eigen::Vector3d> LevelPathPoints(const MultiLevelGrid& grid, const MultiLevelSearch& search,
                                             const AStarOptions& options, LevelRecords* records_in,
                                             std::int64_t end_key, const Eigen::Vector3d& start_point,
                                             const Eigen::Vector2d& goal_W, const PlanResult& result) {
  LevelRecords& record = *records_in;
  std::vector<State> states;
  for (std::int64_t key = end_key; key >= 0; key = record[key].parent) states.push_back(record[key].state);
  std::reverse(states.begin(), states.end());
  std::vector<Eigen::Vector3d> points;
  std::vector<double> clearance;
  for (const State& s : states) {
    const Eigen::Vector2d p = grid.CellCenter(s.ix, s.iy);
    points.emplace_back(p.x(), p.y(), s.z);
    clearance.push_back(search.Clearance(s));
  }
  internal::AttachStart(start_point, result.used_start_escape, &points, &clearance);
  if (!result.partial) points.back() = Eigen::Vector3d(goal_W.x(), goal_W.y(), states.back().z);
  if (options.simplify_path) {
    const double step_m = grid.options().max_step_m;
    internal::ShortcutPath(
        options.preferred_clearance_m, clearance,
        [&](std::size_t anchor, std::size_t j, double need) {
          // Keep the corners of a climb: shortcuts only over points of (nearly) one height.
          return std::abs(points[j].z() - points[anchor].z()) <= step_m + kEps_m &&
                 WalkSegment(search, grid, points[anchor], points[j], need);
        },
        &points);
  }
  return points;
}

// A request's start and goal: finite, on the map (their cells into (*sx, *sy) and (*gx, *gy)); else the
// status and why.
std::optional<std::pair<PlanResult::Status, std::string>> CheckLevelRequest(const MultiLevelGrid& grid,
                                                                            const Eigen::Vector3d& start_W,
                                                                            const Eigen::Vector2d& goal_W,
                                                                            double goal_z_m, int* sx, int* sy,
                                                                            int* gx, int* gy) {
  using Status = PlanResult::Status;
  const std::string extent =
      "x in [" + core::Fixed(grid.p_W_min().x(), 2) + ", " + core::Fixed(grid.p_W_max().x(), 2) +
      "], y in [" + core::Fixed(grid.p_W_min().y(), 2) + ", " + core::Fixed(grid.p_W_max().y(), 2) + "]";
  if (!start_W.head<2>().allFinite()) {
    return std::make_pair(Status::kInvalidStart, "start " + Point2(start_W.head<2>()) + " is not finite");
  }
  if (!goal_W.allFinite() || std::isinf(goal_z_m)) {
    return std::make_pair(Status::kInvalidGoal,
                          "goal " + Point2(goal_W) + " (z " + core::Fixed(goal_z_m, 2) + ") is not finite");
  }
  if (!grid.CellOf(start_W.x(), start_W.y(), sx, sy)) {
    return std::make_pair(Status::kOutOfMap,
                          "start " + Point2(start_W.head<2>()) + " is outside the map " + extent);
  }
  if (!grid.CellOf(goal_W.x(), goal_W.y(), gx, gy)) {
    return std::make_pair(Status::kOutOfMap, "goal " + Point2(goal_W) + " is outside the map " + extent);
  }
  return std::nullopt;
}

}  // namespace

PlanResult PlanPathMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& start_W,
                              const Eigen::Vector2d& goal_W, double goal_z_m, const AStarOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto t0 = std::chrono::steady_clock::now();
  PlanResult result;
  using Status = PlanResult::Status;
  auto finish = [&](Status status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.planning_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
  };
  int sx = 0, sy = 0, gx = 0, gy = 0;
  if (auto bad = CheckLevelRequest(grid, start_W, goal_W, goal_z_m, &sx, &sy, &gx, &gy)) {
    return finish(bad->first, bad->second);
  }
  const MultiLevelSearch search(grid, options);
  double start_z = start_W.z();
  const std::optional<State> start =
      FindLevelStart(grid, search, options, start_W, sx, sy, &start_z, &result.used_start_escape, &why);
  if (!start) return finish(Status::kStartBlocked, why);
  LevelGoal goal;
  why = FindLevelGoal(grid, search, goal_W, goal_z_m, start_z, gx, gy, &goal);
  if (!why.empty()) return finish(Status::kGoalBlocked, why);

  auto scratch = LevelScratchPool().Take();
  LevelRecords record(&*scratch, grid.node_count());
  const LevelSearchEnd end =
      SearchLevels(grid, search, options, *start, goal, goal_W, &record, &result.expansions);
  const std::string searched = std::to_string(result.expansions) + " cells expanded" +
                               (end.capped ? ", the search limit " + std::to_string(end.max_expansions) : "");
  std::int64_t path_end = end.goal_key;
  std::string partial_note;
  // A partial plan toward another level must climb (or descend) more than one step of the platform: one that
  // only comes nearer in x-y leads a robot under the goal, not to it (a wheeled robot at the foot of stairs
  // it cannot climb), and one step's worth can be a quantized tread (a 0.2 m rise read as 0.1 m).
  const double step_m = grid.options().max_step_m;
  const double start_dz = std::abs(start_z - goal.level_z);
  const bool height_progress =
      start_dz <= kLevelMatch_m ||
      std::abs(record[end.best_key].state.z - goal.level_z) <
          start_dz - (std::isnan(options.partial_min_climb_m) ? step_m : options.partial_min_climb_m) -
              0.5 * grid.cell_size_m();
  if (path_end < 0 && options.allow_partial && end.best_key != search.Key(*start) &&
      end.best_remaining < end.start_remaining - 0.5 && height_progress) {
    const State& b = record[end.best_key].state;
    path_end = end.best_key;
    result.partial = true;
    partial_note = "; partial: the map connects no route to the goal at z " + core::Fixed(goal.level_z, 2) +
                   " yet, this path ends at the reachable point nearest it, " +
                   Point2(grid.CellCenter(b.ix, b.iy)) + " at z " + core::Fixed(b.z, 2);
  }
  if (path_end < 0) {
    std::ostringstream msg;
    msg << "goal " << Point2(goal_W) << " at z " << core::Fixed(goal.level_z, 2)
        << " is unreachable from start " << Point2(start_W.head<2>()) << " at z " << core::Fixed(start_z, 2)
        << ": no traversable path over the map's levels (" << searched << ")";
    return finish(Status::kUnreachable, msg.str());
  }
  result.path_W = LevelPathPoints(grid, search, options, &record, path_end,
                                  Eigen::Vector3d(start_W.x(), start_W.y(), start_z), goal_W, result);
  result.length_m = PathLength2D(result.path_W);
  std::ostringstream msg;
  msg << "path from " << Point2(start_W.head<2>()) << " at z " << core::Fixed(start_z, 2) << " to "
      << Point2(goal_W) << " at z " << core::Fixed(result.path_W.back().z(), 2) << ": "
      << core::Fixed(result.length_m, 2) << " m, " << result.path_W.size() << " waypoints, " << searched
      << " over the map's levels" << (result.used_start_escape ? " (started from an escape cell)" : "")
      << partial_note;
  return finish(Status::kSuccess, msg.str());
}

}  // namespace cairn::nav
