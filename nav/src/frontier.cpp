// Copyright Cairn authors.
#include "cairn/nav/frontier.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <utility>

#include "multilevel_search.h"
#include "option_range.h"

namespace cairn::nav {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kDx4[4] = {1, -1, 0, 0};
constexpr int kDy4[4] = {0, 0, 1, -1};
constexpr int kDx8[8] = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr int kDy8[8] = {0, 1, 1, 1, 0, -1, -1, -1};
// FrontierOptions::progress is called once per this many states taken from a search's queue (about 10 ms).
constexpr std::size_t kProgressEvery = 1 << 15;

// How far from the robot's position a traversable start cell is looked for, metres.
constexpr double kStartSearchM = 1.0;

constexpr double kPi = 3.14159265358979323846;
// Clearance a frontier's target keeps beyond the footprint where the cluster allows it, metres.
constexpr double kTargetMarginM = 0.15;

// Unknown cells a lidar at cell (tx, ty) could see within `radius_m`: rays from the cell's centre, as many as
// there are cells around the circle of that radius (every cell within it is crossed by one),
// each marching cell by cell through known-free and unknown cells until a cell with an obstacle (a wall) or
// the radius; a cell crossed by several rays counts once (`stamp`, marked with `id`), a cell `peer_seen`
// marks (when not empty) not at all.
std::int64_t VisibleUnknownCells(const TraversabilityGrid& grid, int tx, int ty, double radius_m, int id,
                                 std::vector<int>* stamp, const std::vector<char>& peer_seen) {
  const double cell_m = grid.cell_size_m();
  const Eigen::Vector2d origin = grid.CellCenter(tx, ty);
  const int steps = static_cast<int>(std::ceil(radius_m / (0.5 * cell_m)));
  const int rays = static_cast<int>(std::ceil(2.0 * kPi * radius_m / cell_m));
  std::int64_t unknown = 0;
  for (int r = 0; r < rays; ++r) {
    const double angle = 2.0 * kPi * r / rays;
    const Eigen::Vector2d step = 0.5 * cell_m * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    for (int k = 1; k <= steps; ++k) {
      int ix = 0;
      int iy = 0;
      if (!grid.CellOf(origin.x() + k * step.x(), origin.y() + k * step.y(), &ix, &iy)) break;
      const CellState state = grid.State(ix, iy);
      if (state == CellState::kObstacle) break;
      if (state != CellState::kUnknown) continue;
      const std::size_t i = static_cast<std::size_t>(iy) * grid.nx() + ix;
      if (!peer_seen.empty() && peer_seen[i]) continue;  // a peer has seen it
      int& s = (*stamp)[i];
      if (s == id) continue;
      s = id;
      ++unknown;
    }
  }
  return unknown;
}

// Chamfer distance (1, sqrt 2, in cells; two passes) from every cell of an nx x ny grid (index ix + nx * iy)
// to the nearest cell `known(ix, iy)` marks; infinity when none is.
template <class Known>
std::vector<float> ChamferToKnown(int nx, int ny, Known&& known) {
  auto index = [nx](int ix, int iy) {
    return static_cast<std::size_t>(ix) + static_cast<std::size_t>(nx) * iy;
  };
  std::vector<float> to_known(static_cast<std::size_t>(nx) * ny, std::numeric_limits<float>::infinity());
  if (nx <= 0 || ny <= 0) return to_known;
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      if (known(ix, iy)) to_known[index(ix, iy)] = 0.0f;
    }
  }
  // Each pass takes a row's terms from the row before first (independent cells: vectorized), then runs along
  // the row (one dependent min per cell). The same minima in another order: the same distances.
  constexpr float kDiag = 1.41421356f;
  auto from_row = [&](int iy, int from_iy) {
    float* d = &to_known[index(0, iy)];
    const float* o = &to_known[index(0, from_iy)];
    for (int ix = 0; ix < nx; ++ix) d[ix] = std::min(d[ix], o[ix] + 1.0f);
    for (int ix = 1; ix < nx; ++ix) d[ix] = std::min(d[ix], o[ix - 1] + kDiag);
    for (int ix = 0; ix + 1 < nx; ++ix) d[ix] = std::min(d[ix], o[ix + 1] + kDiag);
  };
  for (int iy = 0; iy < ny; ++iy) {
    if (iy > 0) from_row(iy, iy - 1);
    float* d = &to_known[index(0, iy)];
    for (int ix = 1; ix < nx; ++ix) d[ix] = std::min(d[ix], d[ix - 1] + 1.0f);
  }
  for (int iy = ny - 1; iy >= 0; --iy) {
    if (iy + 1 < ny) from_row(iy, iy + 1);
    float* d = &to_known[index(0, iy)];
    for (int ix = nx - 2; ix >= 0; --ix) d[ix] = std::min(d[ix], d[ix + 1] + 1.0f);
  }
  return to_known;
}

// The x-y cells of `grid` (a TraversabilityGrid or a MultiLevelGrid: index ix + nx * iy) inside a cell that
// `peers` marks, 1 each; empty when there are no peers.
template <class Grid>
std::vector<char> PeerSeenCells(const Grid& grid, const PeerCoverage* peers) {
  std::vector<char> seen;
  if (peers == nullptr || peers->size() == 0) return seen;
  seen.assign(static_cast<std::size_t>(grid.nx()) * static_cast<std::size_t>(grid.ny()), 0);
  const double c = peers->cell_m();
  peers->ForEach([&](const Eigen::Vector2d& corner) {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    const Eigen::Vector2d lo = corner.cwiseMax(grid.p_W_min());
    const Eigen::Vector2d hi = (corner.array() + c).matrix().cwiseMin(grid.p_W_max());
    if (lo.x() >= hi.x() || lo.y() >= hi.y()) return;
    if (!grid.CellOf(lo.x(), lo.y(), &x0, &y0) || !grid.CellOf(hi.x() - 1e-9, hi.y() - 1e-9, &x1, &y1))
      return;
    for (int iy = y0; iy <= y1; ++iy) {
      for (int ix = x0; ix <= x1; ++ix)
        seen[static_cast<std::size_t>(ix) + static_cast<std::size_t>(grid.nx()) * iy] = 1;
    }
  });
  return seen;
}

// The frontier cells of one 8-connected component cut into pieces of at most `piece_cells` cells along x and
// along y, counted from the component's minimum cell (`cell_xy` gives a cell's column indices).
template <class Cell, class CellXY>
std::map<std::pair<int, int>, std::vector<Cell>> CutIntoPieces(const std::vector<Cell>& component,
                                                               CellXY&& cell_xy, int piece_cells) {
  int min_x = std::numeric_limits<int>::max();
  int min_y = std::numeric_limits<int>::max();
  for (const Cell& c : component) {
    const auto [x, y] = cell_xy(c);
    min_x = std::min(min_x, x);
    min_y = std::min(min_y, y);
  }
  std::map<std::pair<int, int>, std::vector<Cell>> pieces;
  for (const Cell& c : component) {
    const auto [x, y] = cell_xy(c);
    pieces[{(x - min_x) / piece_cells, (y - min_y) / piece_cells}].push_back(c);
  }
  return pieces;
}

// A piece's target: among `cells`, the reachable one (finite `cost_m(cell)`) nearest the centroid, each 0.1 m
// its clearance (`clearance_m(cell)`) falls short of robot_radius_m + kTargetMarginM counting as 0.4 m
// farther: a cell the footprint barely fits on is a goal the planner may refuse once the next scan moves the
// wall a voxel. The nearest of any cell when none is reachable.
template <class Cell, class Center, class Clearance, class Cost>
Cell ChooseTarget(const std::vector<Cell>& cells, const Eigen::Vector2d& centroid_M, double robot_radius_m,
                  Center&& center_M, Clearance&& clearance_m, Cost&& cost_m) {
  double best_reachable = kInf;
  double best_any = kInf;
  Cell target = cells.front();
  Cell fallback = cells.front();
  for (const Cell& c : cells) {
    const double short_m = std::max(0.0, robot_radius_m + kTargetMarginM - clearance_m(c));
    const double d = (center_M(c) - centroid_M).norm() + 4.0 * short_m;
    if (cost_m(c) < kInf && d < best_reachable) {
      best_reachable = d;
      target = c;
    }
    if (d < best_any) {
      best_any = d;
      fallback = c;
    }
  }
  return best_reachable == kInf ? fallback : target;
}

// How a search reads its cells (a 2.5D cell, or a surface of the map's levels) for AppendClusters():
// callables taking a cell.
template <class Center, class Clearance, class Cost, class ViaTight, class GroundZ, class UnknownCells>
struct CellView {
  Center center_m;             // x-y of its centre, metres, frame M
  Clearance clearance_m;       // to the nearest lethal cell, metres
  Cost cost_m;                 // travel cost from the robot, metres; infinity when unreachable
  ViaTight via_tight;          // the cheapest path to it passes a tight cell
  GroundZ ground_z_m;          // its ground height, metres, frame M
  UnknownCells unknown_cells;  // the unknown cells visible around it (the gain, in cells)
};
template <class... Fn>
CellView<Fn...> MakeCellView(Fn... fn) {
  return {std::move(fn)...};
}

// Appends to `clusters` one FrontierCluster per piece (CutIntoPieces()) of at least options.min_cells cells
// and options.min_gain_m2 gain, the same way for both searches; `view` (a CellView) reads the cells, each
// cell_area_m2.
template <class Cell, class View>
void AppendClusters(const std::map<std::pair<int, int>, std::vector<Cell>>& pieces,
                    const FrontierOptions& options, double robot_radius_m, double cell_area_m2,
                    const View& view, std::vector<FrontierCluster>* clusters) {
  for (const auto& [key, cells] : pieces) {
    if (static_cast<int>(cells.size()) < options.min_cells) continue;
    FrontierCluster cluster;
    cluster.cells = static_cast<int>(cells.size());
    for (const Cell& c : cells) cluster.centroid_M += view.center_m(c);
    cluster.centroid_M /= cluster.cells;
    const Cell target = ChooseTarget(
        cells, cluster.centroid_M, robot_radius_m, [&view](const Cell& c) { return view.center_m(c); },
        [&view](const Cell& c) { return view.clearance_m(c); },
        [&view](const Cell& c) { return view.cost_m(c); });
    cluster.gain_m2 = static_cast<double>(view.unknown_cells(target)) * cell_area_m2;
    if (cluster.gain_m2 < options.min_gain_m2) continue;
    cluster.target_M = view.center_m(target);
    cluster.target_ground_z_m = view.ground_z_m(target);
    cluster.travel_cost_m = view.cost_m(target);
    cluster.through_tight_gap = view.via_tight(target);
    cluster.utility =
        cluster.reachable() ? cluster.gain_m2 / (cluster.travel_cost_m + options.cost_offset_m) : 0.0;
    clusters->push_back(cluster);
  }
}

}  // namespace

bool FrontierOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi, bool lo_open) {
    return internal::InOptionRange(msg, "FrontierOptions", field, value, lo, hi, lo_open);
  };
  bool ok = range("min_gain_m2", min_gain_m2, 0, 1e4, false) &&
            range("gain_radius_m", gain_radius_m, 0, 100, true) &&
            range("max_cluster_extent_m", max_cluster_extent_m, 0.5, 100, false) &&
            range("cost_offset_m", cost_offset_m, 0, 1000, true) &&
            range("unknown_cost", unknown_cost, 0, 100, false) &&
            range("unknown_reach_m", unknown_reach_m, 0, 50, false) &&
            range("viewpoint_radius_m", viewpoint_radius_m, 0, 10, false) &&
            range("tight_cost", tight_cost, 0, 100, false);
  if (ok && !(search_horizon_m > 0)) {
    msg << "FrontierOptions::search_horizon_m = " << search_horizon_m
        << " must be > 0 (infinity: no horizon)";
    ok = false;
  }
  if (ok && !(tight_radius_m > 0)) {
    msg << "FrontierOptions::tight_radius_m = " << tight_radius_m << " must be > 0 (infinity: off)";
    ok = false;
  }
  if (ok && (min_cells < 1 || min_cells > 10000)) {
    msg << "FrontierOptions::min_cells = " << min_cells << " must be in [1, 10000]";
    ok = false;
  }
  if (ok && !region_M.isEmpty() && !(region_M.min().allFinite() && region_M.max().allFinite())) {
    msg << "FrontierOptions::region_M must have finite corners";
    ok = false;
  }
  if (ok && (std::isnan(min_z_m) || std::isnan(max_z_m) || !(min_z_m <= max_z_m))) {
    msg << "FrontierOptions::min_z_m = " << min_z_m << " must be <= max_z_m = " << max_z_m;
    ok = false;
  }
  if (ok && (std::isnan(peer_coverage_min_z_m) || std::isnan(peer_coverage_max_z_m) ||
             !(peer_coverage_min_z_m <= peer_coverage_max_z_m))) {
    msg << "FrontierOptions::peer_coverage_min_z_m = " << peer_coverage_min_z_m
        << " must be <= peer_coverage_max_z_m = " << peer_coverage_max_z_m;
    ok = false;
  }
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

void SortFrontierClusters(std::vector<FrontierCluster>* clusters) {
  std::stable_sort(clusters->begin(), clusters->end(),
                   [](const FrontierCluster& a, const FrontierCluster& b) {
                     if (a.reachable() != b.reachable()) return a.reachable();
                     return a.reachable() ? a.utility > b.utility : a.gain_m2 > b.gain_m2;
                   });
}

int FrontierSet::reachable() const {
  return static_cast<int>(std::count_if(clusters.begin(), clusters.end(),
                                        [](const FrontierCluster& c) { return c.reachable(); }));
}

PeerCoverage::PeerCoverage(double cell_m) : cell_m_(cell_m) {
  if (!(cell_m > 0 && cell_m <= 10)) {
    throw std::invalid_argument("PeerCoverage: cell_m = " + std::to_string(cell_m) + " must be in (0, 10]");
  }
}

std::int64_t PeerCoverage::Key(const Eigen::Vector2d& p_M) const {
  const auto ix = static_cast<std::int64_t>(std::floor(p_M.x() / cell_m_));
  const auto iy = static_cast<std::int64_t>(std::floor(p_M.y() / cell_m_));
  return static_cast<std::int64_t>(static_cast<std::uint64_t>(ix) << 32) ^ (iy & 0xffffffffLL);
}

Eigen::Vector2d PeerCoverage::Corner(std::int64_t key) const {
  const auto ix = static_cast<std::int32_t>(key >> 32);
  const auto iy = static_cast<std::int32_t>(key & 0xffffffffLL);
  return {ix * cell_m_, iy * cell_m_};
}

void PeerCoverage::Mark(const Eigen::Vector2d& p_M) {
  if (p_M.allFinite()) cells_.insert(Key(p_M));
}

bool PeerCoverage::Covered(const Eigen::Vector2d& p_M) const {
  return p_M.allFinite() && cells_.count(Key(p_M)) > 0;
}

void PeerCoverage::Add(const CoverageBitmap& bitmap) {
  if (std::abs(bitmap.cell_m - cell_m_) > 1e-9) {
    throw std::invalid_argument("PeerCoverage::Add: bitmap cell_m = " + std::to_string(bitmap.cell_m) +
                                " differs from the coverage's " + std::to_string(cell_m_));
  }
  if (const std::string why = bitmap.Check(); !why.empty())
    throw std::invalid_argument("PeerCoverage::Add: " + why);
  for (int j = 0; j < bitmap.ny; ++j) {
    for (int i = 0; i < bitmap.nx; ++i) {
      if (!bitmap.Covered(i, j)) continue;
      const std::int64_t ix = bitmap.origin_cell.x() + i, iy = bitmap.origin_cell.y() + j;
      cells_.insert(static_cast<std::int64_t>(static_cast<std::uint64_t>(ix) << 32) ^ (iy & 0xffffffffLL));
    }
  }
}

int CoverageBitmap::CountCovered() const {
  int n = 0;
  for (const std::uint8_t b : bits) n += __builtin_popcount(b);
  return n;
}

std::string CoverageBitmap::Check() const {
  std::ostringstream why;
  if (!(cell_m > 0 && cell_m <= 10)) {
    why << "cell_m = " << cell_m << " must be in (0, 10]";
  } else if (nx < 0 || ny < 0) {
    why << "nx = " << nx << ", ny = " << ny << " must not be negative";
  } else if (static_cast<std::int64_t>(nx) * ny > kMaxCells) {
    why << "nx * ny = " << static_cast<std::int64_t>(nx) * ny << " cells is over the limit of " << kMaxCells;
  } else if (std::abs(origin_cell.x()) > (1 << 24) || std::abs(origin_cell.y()) > (1 << 24)) {
    why << "origin_cell = (" << origin_cell.x() << ", " << origin_cell.y() << ") is beyond +-2^24 cells";
  } else if (bits.size() != (static_cast<std::size_t>(nx) * ny + 7) / 8) {
    why << "bits has " << bits.size() << " bytes, " << (static_cast<std::size_t>(nx) * ny + 7) / 8
        << " expected for " << nx << " x " << ny << " cells";
  }
  return why.str();
}

CoverageBitmap SeenCoverage(const TraversabilityGrid& grid, double cell_m) {
  if (!(cell_m > 0 && cell_m <= 10) || cell_m < grid.cell_size_m() - 1e-9) {
    throw std::invalid_argument("SeenCoverage: cell_m = " + std::to_string(cell_m) +
                                " must be in (0, 10] and at " + "least the grid's cell of " +
                                std::to_string(grid.cell_size_m()) + " m");
  }
  CoverageBitmap out;
  out.cell_m = cell_m;
  const Eigen::Vector2d lo = grid.p_W_min(), hi = grid.p_W_max();
  out.origin_cell = {static_cast<int>(std::floor(lo.x() / cell_m)),
                     static_cast<int>(std::floor(lo.y() / cell_m))};
  out.nx = static_cast<int>(std::ceil(hi.x() / cell_m)) - out.origin_cell.x();
  out.ny = static_cast<int>(std::ceil(hi.y() / cell_m)) - out.origin_cell.y();
  const std::size_t n = static_cast<std::size_t>(out.nx) * out.ny;
  std::vector<std::uint16_t> seen(n, 0), total(n, 0);
  for (int y = 0; y < grid.ny(); ++y) {
    for (int x = 0; x < grid.nx(); ++x) {
      const Eigen::Vector2d c = grid.CellCenter(x, y);
      const int i =
          std::clamp(static_cast<int>(std::floor(c.x() / cell_m)) - out.origin_cell.x(), 0, out.nx - 1);
      const int j =
          std::clamp(static_cast<int>(std::floor(c.y() / cell_m)) - out.origin_cell.y(), 0, out.ny - 1);
      const std::size_t k = static_cast<std::size_t>(j) * out.nx + i;
      ++total[k];
      if (grid.State(x, y) != CellState::kUnknown) ++seen[k];
    }
  }
  out.bits.assign((n + 7) / 8, 0);
  for (std::size_t k = 0; k < n; ++k) {
    if (total[k] > 0 && 2 * seen[k] >= total[k]) out.bits[k / 8] |= static_cast<std::uint8_t>(1U << (k % 8));
  }
  return out;
}

namespace {

// FindFrontiers' search on one traversability grid: its frontier cells, the travel cost to each cell from the
// robot, and the clusters of frontier cells.
class GridFrontierSearch {
 public:
  GridFrontierSearch(const TraversabilityGrid& grid, const FrontierOptions& options)
      : grid_(grid),
        options_(options),
        nx_(grid.nx()),
        ny_(grid.ny()),
        cell_m_(grid.cell_size_m()),
        n_(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_)),
        reach_cells_(static_cast<float>(options.unknown_reach_m / cell_m_)),
        pass_radius_m_(std::min(grid.options().robot_radius_m, options.tight_radius_m)) {
    to_known_ =
        ChamferToKnown(nx_, ny_, [&](int ix, int iy) { return grid.State(ix, iy) == CellState::kFree; });
  }

  // 1. Frontier cells (traversable known-free cells in scope beside an unknown one), and the explored area.
  void MarkFrontierCells(FrontierSet* result) {
    frontier_.assign(n_, 0);
    int free_cells = 0;
    for (int iy = 0; iy < ny_; ++iy) {
      for (int ix = 0; ix < nx_; ++ix) {
        if (grid_.State(ix, iy) != CellState::kFree || !InScope(ix, iy)) continue;
        ++free_cells;
        if (!grid_.IsTraversable(ix, iy)) continue;
        for (int d = 0; d < 4; ++d) {
          const int jx = ix + kDx4[d];
          const int jy = iy + kDy4[d];
          if (grid_.InGrid(jx, jy) && grid_.State(jx, jy) == CellState::kUnknown) {
            frontier_[Index(ix, iy)] = 1;
            ++result->frontier_cells;
            break;
          }
        }
      }
    }
    result->known_free_m2 = free_cells * cell_m_ * cell_m_;
  }

  // The robot's own cell: known free, or unknown but passable (it stands in its lidar's blind ring, where no
  // beam reaches the floor); else the nearest traversable free cell within kStartSearchM. false: none.
  bool StartCell(const Eigen::Vector2d& robot_M, int* sx, int* sy) const {
    if (int rx = 0, ry = 0; grid_.CellOf(robot_M.x(), robot_M.y(), &rx, &ry) &&
                            (grid_.State(rx, ry) == CellState::kFree || Passable(rx, ry))) {
      *sx = rx;
      *sy = ry;
      return true;
    }
    const int reach = static_cast<int>(std::ceil(kStartSearchM / cell_m_));
    double best = kInf;
    int cx = 0;
    int cy = 0;
    const bool inside =
        grid_.CellOf(std::clamp(robot_M.x(), grid_.p_W_min().x(), grid_.p_W_max().x() - 1e-9),
                     std::clamp(robot_M.y(), grid_.p_W_min().y(), grid_.p_W_max().y() - 1e-9), &cx, &cy);
    for (int dy = -reach; inside && dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const int jx = cx + dx;
        const int jy = cy + dy;
        if (!grid_.InGrid(jx, jy) || grid_.State(jx, jy) != CellState::kFree || !grid_.IsTraversable(jx, jy))
          continue;
        const double d = (grid_.CellCenter(jx, jy) - robot_M).norm();
        if (d <= kStartSearchM && d < best) {
          best = d;
          *sx = jx;
          *sy = jy;
        }
      }
    }
    return best < kInf;
  }

  // 2. Travel cost: Dijkstra from (sx, sy) over passable cells, known-free or unknown (sx < 0: none reached).
  void TravelCosts(int sx, int sy) {
    via_tight_.assign(n_, 0);
    cost_.assign(n_, kInf);
    if (sx < 0) return;
    using Item = std::pair<double, std::size_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
    cost_[Index(sx, sy)] = 0.0;
    open.emplace(0.0, Index(sx, sy));
    std::size_t pops = 0;
    while (!open.empty()) {
      const auto [c, i] = open.top();
      open.pop();
      if (options_.progress && ++pops % kProgressEvery == 0) options_.progress();
      if (c > cost_[i]) continue;
      const int ix = static_cast<int>(i % static_cast<std::size_t>(nx_));
      const int iy = static_cast<int>(i / static_cast<std::size_t>(nx_));
      for (int d = 0; d < 8; ++d) {
        const int jx = ix + kDx8[d];
        const int jy = iy + kDy8[d];
        if (!grid_.InGrid(jx, jy) || !Passable(jx, jy)) continue;
        // A diagonal step needs both cells beside it passable too (no corner cutting past a wall).
        if (kDx8[d] != 0 && kDy8[d] != 0 && (!Passable(ix + kDx8[d], iy) || !Passable(ix, iy + kDy8[d]))) {
          continue;
        }
        const bool tight = !grid_.IsTraversable(jx, jy);
        const double per_m =
            (grid_.State(jx, jy) == CellState::kUnknown ? 1.0 + options_.unknown_cost : 1.0) +
            (tight ? options_.tight_cost : 0.0);
        const double step = (kDx8[d] != 0 && kDy8[d] != 0 ? std::sqrt(2.0) : 1.0) * cell_m_ * per_m;
        const std::size_t j = Index(jx, jy);
        if (c + step < cost_[j]) {
          cost_[j] = c + step;
          via_tight_[j] = static_cast<char>(via_tight_[i] || tight);
          open.emplace(cost_[j], j);
        }
      }
    }
  }

  // 3. Clusters: 8-connected components of frontier cells, cut into pieces of at most max_cluster_extent_m,
  // with their costs and gains (unknown cells visible from them that no peer saw: `peer_seen`).
  void Cluster(const std::vector<char>& peer_seen, FrontierSet* result) {
    std::vector<char> seen(n_, 0);
    std::vector<int> gain_stamp(n_, -1);
    int gain_id = 0;
    using Cell2 = std::pair<int, int>;
    const auto view =
        MakeCellView([&](const Cell2& c) { return grid_.CellCenter(c.first, c.second); },
                     [&](const Cell2& c) { return grid_.ClearanceM(c.first, c.second); },
                     [&](const Cell2& c) { return cost_[Index(c.first, c.second)]; },
                     [&](const Cell2& c) { return via_tight_[Index(c.first, c.second)] != 0; },
                     [&](const Cell2& c) { return grid_.Ground(c.first, c.second); },
                     [&](const Cell2& c) {
                       return VisibleUnknownCells(grid_, c.first, c.second, options_.gain_radius_m, ++gain_id,
                                                  &gain_stamp, peer_seen);
                     });
    std::vector<Cell2> component;
    std::vector<Cell2> stack;
    const int piece_cells =
        std::max(1, static_cast<int>(std::floor(options_.max_cluster_extent_m / cell_m_)));
    for (int iy0 = 0; iy0 < ny_; ++iy0) {
      for (int ix0 = 0; ix0 < nx_; ++ix0) {
        if (!frontier_[Index(ix0, iy0)] || seen[Index(ix0, iy0)]) continue;
        component.clear();
        stack.assign(1, {ix0, iy0});
        seen[Index(ix0, iy0)] = 1;
        while (!stack.empty()) {
          const auto [ix, iy] = stack.back();
          stack.pop_back();
          component.emplace_back(ix, iy);
          for (int d = 0; d < 8; ++d) {
            const int jx = ix + kDx8[d];
            const int jy = iy + kDy8[d];
            if (!grid_.InGrid(jx, jy) || !frontier_[Index(jx, jy)] || seen[Index(jx, jy)]) continue;
            seen[Index(jx, jy)] = 1;
            stack.emplace_back(jx, jy);
          }
        }
        AppendClusters(CutIntoPieces(
                           component, [](const Cell2& c) { return c; }, piece_cells),
                       options_, grid_.options().robot_radius_m, cell_m_ * cell_m_, view, &result->clusters);
      }
    }
  }

 private:
  std::size_t Index(int ix, int iy) const {
    return static_cast<std::size_t>(ix) + static_cast<std::size_t>(nx_) * iy;
  }
  bool InScope(int ix, int iy) const {
    if (!options_.region_M.isEmpty() && !options_.region_M.contains(grid_.CellCenter(ix, iy))) return false;
    const double z = grid_.Ground(ix, iy);
    return z >= options_.min_z_m && z <= options_.max_z_m;
  }
  // Passable for the search: known free, or unknown within unknown_reach_m of known free; clear for a body of
  // pass_radius_m either way.
  bool Passable(int ix, int iy) const {
    const CellState state = grid_.State(ix, iy);
    if (state == CellState::kUnknown) {
      return to_known_[Index(ix, iy)] <= reach_cells_ && grid_.IsTraversableFor(ix, iy, pass_radius_m_);
    }
    return state == CellState::kFree && grid_.IsTraversableFor(ix, iy, pass_radius_m_);
  }

  const TraversabilityGrid& grid_;
  const FrontierOptions& options_;
  const int nx_, ny_;
  const double cell_m_;
  const std::size_t n_;
  const float reach_cells_;
  const double pass_radius_m_;
  std::vector<float> to_known_;  // distance to the nearest known-free cell, cells (chamfer)
  std::vector<char> frontier_;   // frontier cells
  std::vector<double> cost_;     // travel cost from the robot, m (kInf: not reached)
  std::vector<char> via_tight_;  // the cheapest path to the cell passes a tight cell
};

}  // namespace

FrontierSet FindFrontiers(const TraversabilityGrid& grid, const Eigen::Vector2d& robot_M,
                          const FrontierOptions& options, const PeerCoverage* peers) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  FrontierSet result;
  GridFrontierSearch search(grid, options);
  search.MarkFrontierCells(&result);
  int sx = -1;
  int sy = -1;
  result.robot_on_grid = search.StartCell(robot_M, &sx, &sy);
  search.TravelCosts(result.robot_on_grid ? sx : -1, sy);
  search.Cluster(PeerSeenCells(grid, peers), &result);
  SortFrontierClusters(&result.clusters);
  return result;
}

namespace {

// Unknown cells a lidar at surface `node` could see within `radius_m` (as VisibleUnknownCells, on the
// surfaces): each ray climbs or descends with the connected surface of each column it crosses, goes on at its
// height through unknown space and stops at a blocked column (a wall, a drop, a step too high). A column
// counts once (`stamp`), not at all when `peer_seen` marks it and the height lies in [peer_min_z_m,
// peer_max_z_m].
std::int64_t VisibleUnknownOnLevels(const MultiLevelGrid& grid, int tx, int ty, double z0, double radius_m,
                                    int id, std::vector<int>* stamp, const std::vector<char>& peer_seen,
                                    double peer_min_z_m, double peer_max_z_m) {
  const double cell_m = grid.cell_size_m();
  const Eigen::Vector2d origin = grid.CellCenter(tx, ty);
  const int steps = static_cast<int>(std::ceil(radius_m / (0.5 * cell_m)));
  const int rays = static_cast<int>(std::ceil(2.0 * kPi * radius_m / cell_m));
  const double max_step_m = grid.options().max_step_m;
  std::int64_t unknown = 0;
  for (int r = 0; r < rays; ++r) {
    const double angle = 2.0 * kPi * r / rays;
    const Eigen::Vector2d step = 0.5 * cell_m * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    double z = z0;
    int px = tx;
    int py = ty;
    for (int k = 1; k <= steps; ++k) {
      int ix = 0;
      int iy = 0;
      if (!grid.CellOf(origin.x() + k * step.x(), origin.y() + k * step.y(), &ix, &iy)) break;
      if (ix == px && iy == py) continue;
      px = ix;
      py = iy;
      if (const int m = grid.NodeNear(ix, iy, z, max_step_m); m >= 0) {
        z = grid.NodeZ(m);
        continue;
      }
      if (!grid.IsUnknownAt(ix, iy, z) && !grid.IsUnseenStepAt(ix, iy, z)) break;  // blocked
      const std::size_t i = static_cast<std::size_t>(grid.Column(ix, iy));
      if (!peer_seen.empty() && peer_seen[i] && z >= peer_min_z_m && z <= peer_max_z_m) continue;
      int& s = (*stamp)[i];
      if (s == id) continue;
      s = id;
      ++unknown;
    }
  }
  return unknown;
}

}  // namespace

double VisibleUnknownM2(const MultiLevelGrid& grid, const Eigen::Vector3d& p_M, double radius_m) {
  int tx = 0, ty = 0;
  if (!p_M.allFinite() || !(radius_m > 0) || !grid.CellOf(p_M.x(), p_M.y(), &tx, &ty)) return 0.0;
  std::vector<int> stamp(static_cast<std::size_t>(grid.nx()) * grid.ny(), -1);
  return VisibleUnknownOnLevels(grid, tx, ty, p_M.z(), std::min(radius_m, 100.0), 0, &stamp, {}, 0.0, 0.0) *
         grid.cell_size_m() * grid.cell_size_m();
}

namespace {

// FindFrontiersMultiLevel's search on a multi-level grid: its frontier surfaces, the travel cost to each
// surface (and to unknown space near them) from the robot, and the clusters of frontier surfaces.
class LevelFrontierSearch {
 public:
  using State = internal::LevelState;

  LevelFrontierSearch(const MultiLevelGrid& grid, const FrontierOptions& options)
      : grid_(grid),
        options_(options),
        nx_(grid.nx()),
        cell_m_(grid.cell_size_m()),
        max_step_m_(grid.options().max_step_m),
        nodes_(static_cast<std::size_t>(grid.node_count())),
        reach_cells_(static_cast<float>(options.unknown_reach_m / cell_m_)),
        moves_(grid, MovesFor(options)),
        cost_(nodes_, kInf),
        via_tight_(nodes_, 0) {
    to_known_ = ChamferToKnown(nx_, grid.ny(), [&](int ix, int iy) {
      return grid.FirstNode(grid.Column(ix, iy)) < grid.FirstNode(grid.Column(ix, iy) + 1);
    });
  }

  // 1. Frontier surfaces (traversable, in scope, a 4-neighbour unknown at their height) and the explored
  // area.
  void MarkFrontierSurfaces(FrontierSet* result) {
    frontier_.assign(nodes_, 0);
    int known_nodes = 0;
    for (int node = 0; node < grid_.node_count(); ++node) {
      if (!InScope(node)) continue;
      ++known_nodes;
      if (!grid_.IsTraversable(node)) continue;
      const auto [ix, iy] = ColumnXy(grid_.NodeColumn(node));
      const double z = grid_.NodeZ(node);
      for (int d = 0; d < 4; ++d) {
        const int jx = ix + kDx4[d];
        const int jy = iy + kDy4[d];
        if (grid_.InGrid(jx, jy) && grid_.NodeNear(jx, jy, z, max_step_m_) < 0 &&
            (grid_.IsUnknownAt(jx, jy, z) || grid_.IsUnseenStepAt(jx, jy, z))) {
          frontier_[static_cast<std::size_t>(node)] = 1;
          ++result->frontier_cells;
          break;
        }
      }
    }
    result->known_free_m2 = known_nodes * cell_m_ * cell_m_;
  }

  // Start: the robot's surface when traversable; else every traversable surface within kStartSearchM of it
  // (at its height, within max(0.5 m, a step)) at its planar distance — a robot-built map shows a ragged,
  // holed floor right around the robot, which its lidar does not see — and its unknown column at its height.
  std::vector<std::pair<State, double>> Starts(const Eigen::Vector3d& robot_M) const {
    std::vector<std::pair<State, double>> starts;
    int rx = 0, ry = 0;
    if (!std::isfinite(robot_M.z()) || !grid_.CellOf(robot_M.x(), robot_M.y(), &rx, &ry)) return starts;
    const double dz = std::max(0.5, max_step_m_);
    const int m = grid_.NodeNear(rx, ry, robot_M.z(), dz);
    if (m >= 0 && grid_.IsTraversable(m)) {
      starts.emplace_back(State{rx, ry, grid_.NodeZ(m), m}, 0.0);
      return starts;
    }
    if (m < 0 && grid_.IsUnknownAt(rx, ry, robot_M.z()))
      starts.emplace_back(State{rx, ry, robot_M.z(), -1}, 0.0);
    const int reach = static_cast<int>(std::ceil(kStartSearchM / cell_m_));
    for (int dy = -reach; dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const int n = grid_.NodeNear(rx + dx, ry + dy, robot_M.z(), dz);
        if (n < 0 || !grid_.IsTraversable(n)) continue;
        const double d = (grid_.CellCenter(rx + dx, ry + dy) - robot_M.head<2>()).norm();
        if (d <= kStartSearchM) starts.emplace_back(State{rx + dx, ry + dy, grid_.NodeZ(n), n}, d);
      }
    }
    return starts;
  }

  // 2. Travel cost: Dijkstra from `starts` over connected traversable surfaces and unknown space entered at
  // the height of the surface left (PlanPathMultiLevel's moves), unknown columns only within unknown_reach_m
  // of a column with a known surface (the robot stands in its lidar's blind ring, unseen floor all around
  // it); it stops search_horizon_m past the first frontier surface settled (sets searched_to_cost_m). Once
  // per search.
  void TravelCosts(const std::vector<std::pair<State, double>>& starts, FrontierSet* result) {
    struct Item {
      double cost;
      State state;
      bool operator>(const Item& other) const { return cost > other.cost; }
    };
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
    for (const auto& [state, d] : starts) {
      double& c = *Slot(state).first;
      if (d < c) {
        c = d;
        open.push({d, state});
      }
    }
    std::size_t pops = 0;
    double stop_cost = kInf;  // the first frontier surface settled + search_horizon_m
    while (!open.empty()) {
      const Item item = open.top();
      open.pop();
      if (options_.progress && ++pops % kProgressEvery == 0) options_.progress();
      const State& s = item.state;
      if (item.cost > *Slot(s).first) continue;
      if (item.cost > stop_cost) {
        result->searched_to_cost_m = stop_cost;
        break;
      }
      if (s.node >= 0 && frontier_[static_cast<std::size_t>(s.node)] && stop_cost == kInf)
        stop_cost = item.cost + options_.search_horizon_m;
      const char from_tight = *Slot(s).second;
      const std::array<std::optional<State>, 8> enter = Neighbours(s);
      for (int d = 0; d < 8; ++d) {
        const std::optional<State>& next = enter[d];
        if (!next) continue;
        const double length_m = (d % 2 == 1 ? std::sqrt(2.0) : 1.0) * cell_m_;
        if (next->node < 0 &&
            to_known_[static_cast<std::size_t>(grid_.Column(next->ix, next->iy))] > reach_cells_)
          continue;
        const bool tight = next->node >= 0 && !grid_.IsTraversable(next->node);
        const double c = item.cost + length_m * ((next->node < 0 ? 1.0 + options_.unknown_cost : 1.0) +
                                                 (tight ? options_.tight_cost : 0.0));
        const auto [best, best_via_tight] = Slot(*next);
        if (c < *best) {
          *best = c;
          *best_via_tight = static_cast<char>(from_tight || tight);
          open.push({c, *next});
        }
      }
    }
  }

  // 3. Clusters: components of frontier surfaces connected across 8-neighbouring columns (within a step),
  // cut into pieces of at most max_cluster_extent_m along x and y, with their costs and gains (unknown space
  // visible from them that no peer saw: `peer_seen`, per column).
  void Cluster(const std::vector<char>& peer_seen, FrontierSet* result) {
    std::vector<char> seen(nodes_, 0);
    std::vector<int> gain_stamp(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(grid_.ny()), -1);
    int gain_id = 0;
    const auto view = MakeCellView(
        [&](int node) { return NodeCenter(node); }, [&](int node) { return grid_.ClearanceM(node); },
        [&](int node) { return cost_[static_cast<std::size_t>(node)]; },
        [&](int node) { return via_tight_[static_cast<std::size_t>(node)] != 0; },
        [&](int node) { return grid_.NodeZ(node); },
        [&](int node) {
          const auto [tx, ty] = ColumnXy(grid_.NodeColumn(node));
          return VisibleUnknownOnLevels(grid_, tx, ty, grid_.NodeZ(node), options_.gain_radius_m, ++gain_id,
                                        &gain_stamp, peer_seen, options_.peer_coverage_min_z_m,
                                        options_.peer_coverage_max_z_m);
        });
    std::vector<int> component;
    std::vector<int> stack;
    const int piece_cells =
        std::max(1, static_cast<int>(std::floor(options_.max_cluster_extent_m / cell_m_)));
    for (int node0 = 0; node0 < grid_.node_count(); ++node0) {
      if (!frontier_[static_cast<std::size_t>(node0)] || seen[static_cast<std::size_t>(node0)]) continue;
      if (options_.progress) options_.progress();  // each cluster's gain reads the map around it
      component.clear();
      stack.assign(1, node0);
      seen[static_cast<std::size_t>(node0)] = 1;
      while (!stack.empty()) {
        const int node = stack.back();
        stack.pop_back();
        component.push_back(node);
        const auto [ix, iy] = ColumnXy(grid_.NodeColumn(node));
        for (int d = 0; d < 8; ++d) {
          const int m = grid_.NodeNear(ix + kDx8[d], iy + kDy8[d], grid_.NodeZ(node), max_step_m_);
          if (m < 0 || !frontier_[static_cast<std::size_t>(m)] || seen[static_cast<std::size_t>(m)]) continue;
          seen[static_cast<std::size_t>(m)] = 1;
          stack.push_back(m);
        }
      }
      AppendClusters(CutIntoPieces(
                         component, [&](int node) { return ColumnXy(grid_.NodeColumn(node)); }, piece_cells),
                     options_, grid_.options().robot_radius_m, cell_m_ * cell_m_, view, &result->clusters);
    }
  }

  // 4. Viewpoints: each cluster none of whose surfaces was reached gets as its target the reachable
  // traversable surface nearest its target within viewpoint_radius_m (3-D) from which a robot at mid-body
  // height sees a robot standing there (MultiLevelGrid::IsSightClear), if any.
  void AddViewpoints(FrontierSet* result) const {
    const double radius_m = options_.viewpoint_radius_m;
    if (!(radius_m > 0)) return;
    const double eye_m = 0.5 * grid_.options().robot_height_m;
    const int reach = static_cast<int>(std::ceil(radius_m / cell_m_));
    struct Candidate {
      double distance_m;
      int node;
    };
    std::vector<Candidate> candidates;
    for (FrontierCluster& cluster : result->clusters) {
      if (cluster.reachable()) continue;
      int tx = 0, ty = 0;
      if (!grid_.CellOf(cluster.target_M.x(), cluster.target_M.y(), &tx, &ty)) continue;
      const Eigen::Vector3d target(cluster.target_M.x(), cluster.target_M.y(), cluster.target_ground_z_m);
      candidates.clear();
      for (int iy = ty - reach; iy <= ty + reach; ++iy) {
        for (int ix = tx - reach; ix <= tx + reach; ++ix) {
          if (!grid_.InGrid(ix, iy)) continue;
          const int column = grid_.Column(ix, iy);
          for (int node = grid_.FirstNode(column); node < grid_.FirstNode(column + 1); ++node) {
            if (!(cost_[static_cast<std::size_t>(node)] < kInf) || !grid_.IsTraversable(node)) continue;
            const Eigen::Vector2d c = grid_.CellCenter(ix, iy);
            const double d = (Eigen::Vector3d(c.x(), c.y(), grid_.NodeZ(node)) - target).norm();
            if (d <= radius_m) candidates.push_back({d, node});
          }
        }
      }
      std::sort(candidates.begin(), candidates.end(),
                [](const Candidate& a, const Candidate& b) { return a.distance_m < b.distance_m; });
      for (const Candidate& candidate : candidates) {
        const Eigen::Vector2d c = NodeCenter(candidate.node);
        const Eigen::Vector3d eye(c.x(), c.y(), grid_.NodeZ(candidate.node) + eye_m);
        if (!grid_.IsSightClear(eye, target + Eigen::Vector3d(0, 0, eye_m))) continue;
        const auto i = static_cast<std::size_t>(candidate.node);
        cluster.target_M = c;
        cluster.target_ground_z_m = grid_.NodeZ(candidate.node);
        cluster.travel_cost_m = cost_[i];
        cluster.through_tight_gap = via_tight_[i] != 0;
        cluster.utility = cluster.gain_m2 / (cluster.travel_cost_m + options_.cost_offset_m);
        cluster.viewpoint = true;
        break;
      }
    }
  }

 private:
  // An unknown state's cost and via_tight, one hash look-up for both.
  struct Virtual {
    double cost = kInf;
    char via_tight = 0;
  };

  static AStarOptions MovesFor(const FrontierOptions& options) {
    AStarOptions moves;
    moves.robot_radius_m =
        options.tight_radius_m;  // the search takes the least of this and the grid's radius
    return moves;
  }
  std::pair<int, int> ColumnXy(int column) const { return {column % nx_, column / nx_}; }
  Eigen::Vector2d NodeCenter(int node) const {
    const auto [ix, iy] = ColumnXy(grid_.NodeColumn(node));
    return grid_.CellCenter(ix, iy);
  }
  bool InScope(int node) const {
    if (!options_.region_M.isEmpty() && !options_.region_M.contains(NodeCenter(node))) return false;
    const double z = grid_.NodeZ(node);
    return z >= options_.min_z_m && z <= options_.max_z_m;
  }
  // A state's cost and via_tight.
  std::pair<double*, char*> Slot(const State& s) {
    if (s.node >= 0) {
      return {&cost_[static_cast<std::size_t>(s.node)], &via_tight_[static_cast<std::size_t>(s.node)]};
    }
    Virtual& v = virtual_states_[moves_.Key(s)];
    return {&v.cost, &v.via_tight};
  }
  // The four sides first (even d), then the corners (odd d, between sides d - 1 and d + 1), entered only when
  // both sides are: no corner cutting past a wall. Each neighbour is entered once.
  std::array<std::optional<State>, 8> Neighbours(const State& s) const {
    std::array<std::optional<State>, 8> enter;
    for (int d = 0; d < 8; d += 2) enter[d] = moves_.Enter(s.ix + kDx8[d], s.iy + kDy8[d], s.z);
    for (int d = 1; d < 8; d += 2) {
      if (enter[d - 1] && enter[(d + 1) % 8]) enter[d] = moves_.Enter(s.ix + kDx8[d], s.iy + kDy8[d], s.z);
    }
    return enter;
  }

  const MultiLevelGrid& grid_;
  const FrontierOptions& options_;
  const int nx_;
  const double cell_m_;
  const double max_step_m_;
  const std::size_t nodes_;
  const float reach_cells_;
  const MultiLevelSearch moves_;
  std::vector<double> cost_;     // travel cost from the robot, m, by node (kInf: not reached)
  std::vector<char> via_tight_;  // the cheapest path to the surface passes a tight surface
  std::vector<float> to_known_;  // distance to the nearest column with a known surface, cells (chamfer)
  std::vector<char> frontier_;   // frontier surfaces, by node
  std::unordered_map<std::int64_t, Virtual> virtual_states_;
};

}  // namespace

FrontierSet FindFrontiersMultiLevel(const MultiLevelGrid& grid, const Eigen::Vector3d& robot_M,
                                    const FrontierOptions& options, const PeerCoverage* peers) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  FrontierSet result;
  LevelFrontierSearch search(grid, options);
  search.MarkFrontierSurfaces(&result);
  const auto starts = search.Starts(robot_M);
  if (!starts.empty()) {
    result.robot_on_grid = true;
    search.TravelCosts(starts, &result);
  }
  search.Cluster(PeerSeenCells(grid, peers), &result);
  search.AddViewpoints(&result);
  for (FrontierCluster& cluster : result.clusters) cluster.on_main_level = false;  // see FrontierCluster
  SortFrontierClusters(&result.clusters);
  if (result.reachable() == 0 && std::isfinite(result.searched_to_cost_m)) {
    // The frontiers within the horizon were too small or too poor to keep: the whole map decides.
    FrontierOptions whole_map = options;
    whole_map.search_horizon_m = kInf;
    return FindFrontiersMultiLevel(grid, robot_M, whole_map, peers);
  }
  return result;
}

}  // namespace cairn::nav
