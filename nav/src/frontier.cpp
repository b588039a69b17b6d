// Copyright Cairn authors.
#include "cairn/nav/frontier.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "option_range.h"

namespace cairn::nav {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kDx4[4] = {1, -1, 0, 0};
constexpr int kDy4[4] = {0, 0, 1, -1};
constexpr int kDx8[8] = {1, 1, 0, -1, -1, -1, 0, 1};
constexpr int kDy8[8] = {0, 1, 1, 1, 0, -1, -1, -1};

// How far from the robot's position a traversable start cell is looked for, metres.
constexpr double kStartSearchM = 1.0;

constexpr double kPi = 3.14159265358979323846;
// Clearance a frontier's target keeps beyond the footprint where the cluster allows it, metres.
constexpr double kTargetMarginM = 0.15;

// Unknown cells a lidar at cell (tx, ty) could see within `radius_m`: rays from the cell's centre, as many as
// there are cells around the circle of that radius (every cell within it is crossed by one),
// each marching cell by cell through known-free and unknown cells until a cell with an obstacle (a wall) or
// the radius; a cell crossed by several rays counts once (`stamp`, marked with `id`), a cell `peer_seen` marks
// (when not empty) not at all.
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

}  // namespace

bool FrontierOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi, bool lo_open) {
    return internal::InOptionRange(msg, "FrontierOptions", field, value, lo, hi, lo_open);
  };
  bool ok = range("min_gain_m2", min_gain_m2, 0, 1e4, false) && range("gain_radius_m", gain_radius_m, 0, 100, true) &&
            range("max_cluster_extent_m", max_cluster_extent_m, 0.5, 100, false) &&
            range("cost_offset_m", cost_offset_m, 0, 1000, true) && range("unknown_cost", unknown_cost, 0, 100, false) &&
            range("unknown_reach_m", unknown_reach_m, 0, 50, false);
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
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

int FrontierSet::reachable() const {
  return static_cast<int>(
      std::count_if(clusters.begin(), clusters.end(), [](const FrontierCluster& c) { return c.reachable(); }));
}

PeerCoverage::PeerCoverage(double cell_m) : cell_m_(cell_m) {
  if (!(cell_m > 0 && cell_m <= 10)) {
    throw std::invalid_argument("PeerCoverage: cell_m = " + std::to_string(cell_m) + " must be in (0, 10]");
  }
}

std::int64_t PeerCoverage::Key(const Eigen::Vector2d& p_M) const {
  const auto ix = static_cast<std::int64_t>(std::floor(p_M.x() / cell_m_));
  const auto iy = static_cast<std::int64_t>(std::floor(p_M.y() / cell_m_));
  return (ix << 32) ^ (iy & 0xffffffffLL);
}

Eigen::Vector2d PeerCoverage::Corner(std::int64_t key) const {
  const auto ix = static_cast<std::int32_t>(key >> 32);
  const auto iy = static_cast<std::int32_t>(key & 0xffffffffLL);
  return {ix * cell_m_, iy * cell_m_};
}

void PeerCoverage::Mark(const Eigen::Vector2d& p_M) {
  if (p_M.allFinite()) cells_.insert(Key(p_M));
}

bool PeerCoverage::Covered(const Eigen::Vector2d& p_M) const { return p_M.allFinite() && cells_.count(Key(p_M)) > 0; }

void PeerCoverage::Add(const CoverageBitmap& bitmap) {
  if (std::abs(bitmap.cell_m - cell_m_) > 1e-9) {
    throw std::invalid_argument("PeerCoverage::Add: bitmap cell_m = " + std::to_string(bitmap.cell_m) +
                                " differs from the coverage's " + std::to_string(cell_m_));
  }
  if (const std::string why = bitmap.Check(); !why.empty()) throw std::invalid_argument("PeerCoverage::Add: " + why);
  for (int j = 0; j < bitmap.ny; ++j) {
    for (int i = 0; i < bitmap.nx; ++i) {
      if (!bitmap.Covered(i, j)) continue;
      const std::int64_t ix = bitmap.origin_cell.x() + i, iy = bitmap.origin_cell.y() + j;
      cells_.insert((ix << 32) ^ (iy & 0xffffffffLL));
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
    throw std::invalid_argument("SeenCoverage: cell_m = " + std::to_string(cell_m) + " must be in (0, 10] and at " +
                                "least the grid's cell of " + std::to_string(grid.cell_size_m()) + " m");
  }
  CoverageBitmap out;
  out.cell_m = cell_m;
  const Eigen::Vector2d lo = grid.p_W_min(), hi = grid.p_W_max();
  out.origin_cell = {static_cast<int>(std::floor(lo.x() / cell_m)), static_cast<int>(std::floor(lo.y() / cell_m))};
  out.nx = static_cast<int>(std::ceil(hi.x() / cell_m)) - out.origin_cell.x();
  out.ny = static_cast<int>(std::ceil(hi.y() / cell_m)) - out.origin_cell.y();
  const std::size_t n = static_cast<std::size_t>(out.nx) * out.ny;
  std::vector<std::uint16_t> seen(n, 0), total(n, 0);
  for (int y = 0; y < grid.ny(); ++y) {
    for (int x = 0; x < grid.nx(); ++x) {
      const Eigen::Vector2d c = grid.CellCenter(x, y);
      const int i = std::clamp(static_cast<int>(std::floor(c.x() / cell_m)) - out.origin_cell.x(), 0, out.nx - 1);
      const int j = std::clamp(static_cast<int>(std::floor(c.y() / cell_m)) - out.origin_cell.y(), 0, out.ny - 1);
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

FrontierSet FindFrontiers(const TraversabilityGrid& grid, const Eigen::Vector2d& robot_M,
                          const FrontierOptions& options, const PeerCoverage* peers) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const int nx = grid.nx();
  const int ny = grid.ny();
  const double cell_m = grid.cell_size_m();
  const std::size_t n = static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny);
  auto index = [nx](int ix, int iy) { return static_cast<std::size_t>(ix) + static_cast<std::size_t>(nx) * iy; };
  auto in_scope = [&](int ix, int iy) {
    if (!options.region_M.isEmpty() && !options.region_M.contains(grid.CellCenter(ix, iy))) return false;
    const double z = grid.Ground(ix, iy);
    return z >= options.min_z_m && z <= options.max_z_m;
  };

  FrontierSet result;
  // What peers have seen, on this grid's cells.
  std::vector<char> peer_seen;
  if (peers != nullptr && peers->size() > 0) {
    peer_seen.assign(n, 0);
    const double c = peers->cell_m();
    peers->ForEach([&](const Eigen::Vector2d& corner) {
      int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
      const Eigen::Vector2d lo = corner.cwiseMax(grid.p_W_min()), hi = (corner.array() + c).matrix().cwiseMin(grid.p_W_max());
      if (lo.x() >= hi.x() || lo.y() >= hi.y()) return;
      if (!grid.CellOf(lo.x(), lo.y(), &x0, &y0) || !grid.CellOf(hi.x() - 1e-9, hi.y() - 1e-9, &x1, &y1)) return;
      for (int iy = y0; iy <= y1; ++iy) {
        for (int ix = x0; ix <= x1; ++ix) peer_seen[index(ix, iy)] = 1;
      }
    });
  }
  // 1. Frontier cells, and the explored area.
  std::vector<char> frontier(n, 0);
  int free_cells = 0;
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      if (grid.State(ix, iy) != CellState::kFree || !in_scope(ix, iy)) continue;
      ++free_cells;
      if (!grid.IsTraversable(ix, iy)) continue;
      for (int d = 0; d < 4; ++d) {
        const int jx = ix + kDx4[d];
        const int jy = iy + kDy4[d];
        if (grid.InGrid(jx, jy) && grid.State(jx, jy) == CellState::kUnknown) {
          frontier[index(ix, iy)] = 1;
          ++result.frontier_cells;
          break;
        }
      }
    }
  }
  result.known_free_m2 = free_cells * cell_m * cell_m;

  // 2. Travel cost: Dijkstra from the robot's cell over traversable cells, known-free or unknown.
  // Chamfer distance (1, sqrt 2, in cells) from every cell to the nearest known-free cell, two passes.
  std::vector<float> to_known(n, std::numeric_limits<float>::infinity());
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      if (grid.State(ix, iy) == CellState::kFree) to_known[index(ix, iy)] = 0.0f;
    }
  }
  constexpr float kDiag = 1.41421356f;
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      float& d = to_known[index(ix, iy)];
      if (ix > 0) d = std::min(d, to_known[index(ix - 1, iy)] + 1.0f);
      if (iy > 0) {
        d = std::min(d, to_known[index(ix, iy - 1)] + 1.0f);
        if (ix > 0) d = std::min(d, to_known[index(ix - 1, iy - 1)] + kDiag);
        if (ix + 1 < nx) d = std::min(d, to_known[index(ix + 1, iy - 1)] + kDiag);
      }
    }
  }
  for (int iy = ny - 1; iy >= 0; --iy) {
    for (int ix = nx - 1; ix >= 0; --ix) {
      float& d = to_known[index(ix, iy)];
      if (ix + 1 < nx) d = std::min(d, to_known[index(ix + 1, iy)] + 1.0f);
      if (iy + 1 < ny) {
        d = std::min(d, to_known[index(ix, iy + 1)] + 1.0f);
        if (ix + 1 < nx) d = std::min(d, to_known[index(ix + 1, iy + 1)] + kDiag);
        if (ix > 0) d = std::min(d, to_known[index(ix - 1, iy + 1)] + kDiag);
      }
    }
  }
  const float reach_cells = static_cast<float>(options.unknown_reach_m / cell_m);
  auto passable = [&](int ix, int iy) {
    const CellState state = grid.State(ix, iy);
    if (state == CellState::kUnknown) return to_known[index(ix, iy)] <= reach_cells && grid.IsTraversable(ix, iy);
    return state == CellState::kFree && grid.IsTraversable(ix, iy);
  };
  std::vector<double> cost(n, kInf);
  int sx = -1;
  int sy = -1;
  // The robot's own cell: known free, or unknown but passable (it stands in its lidar's blind ring, where no
  // beam reaches the floor).
  if (int rx = 0, ry = 0; grid.CellOf(robot_M.x(), robot_M.y(), &rx, &ry) &&
                          (grid.State(rx, ry) == CellState::kFree || passable(rx, ry))) {
    sx = rx;
    sy = ry;
  } else {
    const int reach = static_cast<int>(std::ceil(kStartSearchM / cell_m));
    double best = kInf;
    int cx = 0;
    int cy = 0;
    const bool inside = grid.CellOf(std::clamp(robot_M.x(), grid.p_W_min().x(), grid.p_W_max().x() - 1e-9),
                                    std::clamp(robot_M.y(), grid.p_W_min().y(), grid.p_W_max().y() - 1e-9), &cx, &cy);
    for (int dy = -reach; inside && dy <= reach; ++dy) {
      for (int dx = -reach; dx <= reach; ++dx) {
        const int jx = cx + dx;
        const int jy = cy + dy;
        if (!grid.InGrid(jx, jy) || grid.State(jx, jy) != CellState::kFree || !grid.IsTraversable(jx, jy)) continue;
        const double d = (grid.CellCenter(jx, jy) - robot_M).norm();
        if (d <= kStartSearchM && d < best) {
          best = d;
          sx = jx;
          sy = jy;
        }
      }
    }
  }
  if (sx >= 0) {
    result.robot_on_grid = true;
    using Item = std::pair<double, std::size_t>;
    std::priority_queue<Item, std::vector<Item>, std::greater<Item>> open;
    cost[index(sx, sy)] = 0.0;
    open.emplace(0.0, index(sx, sy));
    while (!open.empty()) {
      const auto [c, i] = open.top();
      open.pop();
      if (c > cost[i]) continue;
      const int ix = static_cast<int>(i % static_cast<std::size_t>(nx));
      const int iy = static_cast<int>(i / static_cast<std::size_t>(nx));
      for (int d = 0; d < 8; ++d) {
        const int jx = ix + kDx8[d];
        const int jy = iy + kDy8[d];
        if (!grid.InGrid(jx, jy) || !passable(jx, jy)) continue;
        // A diagonal step needs both cells beside it passable too (no corner cutting past a wall).
        if (kDx8[d] != 0 && kDy8[d] != 0 && (!passable(ix + kDx8[d], iy) || !passable(ix, iy + kDy8[d]))) {
          continue;
        }
        const double per_m = grid.State(jx, jy) == CellState::kUnknown ? 1.0 + options.unknown_cost : 1.0;
        const double step = (kDx8[d] != 0 && kDy8[d] != 0 ? std::sqrt(2.0) : 1.0) * cell_m * per_m;
        const std::size_t j = index(jx, jy);
        if (c + step < cost[j]) {
          cost[j] = c + step;
          open.emplace(cost[j], j);
        }
      }
    }
  }

  // 3. Clusters: 8-connected components of frontier cells, cut into pieces of at most max_cluster_extent_m.
  std::vector<char> seen(n, 0);
  std::vector<int> gain_stamp(n, -1);
  int gain_id = 0;
  std::vector<std::pair<int, int>> component;
  std::vector<std::pair<int, int>> stack;
  const int piece_cells = std::max(1, static_cast<int>(std::floor(options.max_cluster_extent_m / cell_m)));
  for (int iy0 = 0; iy0 < ny; ++iy0) {
    for (int ix0 = 0; ix0 < nx; ++ix0) {
      if (!frontier[index(ix0, iy0)] || seen[index(ix0, iy0)]) continue;
      component.clear();
      stack.assign(1, {ix0, iy0});
      seen[index(ix0, iy0)] = 1;
      int min_x = ix0;
      int min_y = iy0;
      while (!stack.empty()) {
        const auto [ix, iy] = stack.back();
        stack.pop_back();
        component.emplace_back(ix, iy);
        min_x = std::min(min_x, ix);
        min_y = std::min(min_y, iy);
        for (int d = 0; d < 8; ++d) {
          const int jx = ix + kDx8[d];
          const int jy = iy + kDy8[d];
          if (!grid.InGrid(jx, jy) || !frontier[index(jx, jy)] || seen[index(jx, jy)]) continue;
          seen[index(jx, jy)] = 1;
          stack.emplace_back(jx, jy);
        }
      }
      std::map<std::pair<int, int>, std::vector<std::pair<int, int>>> pieces;
      for (const auto& c : component) pieces[{(c.first - min_x) / piece_cells, (c.second - min_y) / piece_cells}].push_back(c);
      for (const auto& [key, cells] : pieces) {
        if (static_cast<int>(cells.size()) < options.min_cells) continue;
        FrontierCluster cluster;
        cluster.cells = static_cast<int>(cells.size());
        for (const auto& [ix, iy] : cells) cluster.centroid_M += grid.CellCenter(ix, iy);
        cluster.centroid_M /= cluster.cells;
        // Target: the reachable cell nearest the centroid (any cell nearest it when none is reachable).
        double best_reachable = kInf;
        double best_any = kInf;
        std::pair<int, int> target = cells.front();
        std::pair<int, int> fallback = cells.front();
        for (const auto& [ix, iy] : cells) {
          // Nearest the centroid, but away from walls: a cell the footprint barely fits on is a goal the
          // planner may refuse once the next scan moves the wall a voxel (kTargetMarginM of clearance kept).
          const double short_m =
              std::max(0.0, grid.options().robot_radius_m + kTargetMarginM - grid.ClearanceM(ix, iy));
          const double d = (grid.CellCenter(ix, iy) - cluster.centroid_M).norm() + 4.0 * short_m;
          if (cost[index(ix, iy)] < kInf && d < best_reachable) {
            best_reachable = d;
            target = {ix, iy};
          }
          if (d < best_any) {
            best_any = d;
            fallback = {ix, iy};
          }
        }
        if (best_reachable == kInf) target = fallback;
        cluster.gain_m2 = VisibleUnknownCells(grid, target.first, target.second, options.gain_radius_m,
                                              ++gain_id, &gain_stamp, peer_seen) *
                          cell_m * cell_m;
        if (cluster.gain_m2 < options.min_gain_m2) continue;
        cluster.target_M = grid.CellCenter(target.first, target.second);
        cluster.target_ground_z_m = grid.Ground(target.first, target.second);
        cluster.travel_cost_m = cost[index(target.first, target.second)];
        cluster.utility = cluster.reachable() ? cluster.gain_m2 / (cluster.travel_cost_m + options.cost_offset_m) : 0.0;
        result.clusters.push_back(cluster);
      }
    }
  }
  std::stable_sort(result.clusters.begin(), result.clusters.end(), [](const FrontierCluster& a, const FrontierCluster& b) {
    if (a.reachable() != b.reachable()) return a.reachable();
    return a.reachable() ? a.utility > b.utility : a.gain_m2 > b.gain_m2;
  });
  return result;
}

}  // namespace cairn::nav
