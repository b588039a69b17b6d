// Copyright Cairn authors.
#include "cairn/nav/sampling.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>

namespace cairn::nav {

std::vector<std::size_t> LargestTraversableComponent(const TraversabilityGrid& grid) {
  const int nx = grid.nx();
  const int ny = grid.ny();
  std::vector<int> label(static_cast<std::size_t>(nx) * ny, -1);
  std::vector<std::size_t> best;
  std::vector<std::size_t> current;
  std::vector<std::size_t> stack;
  int next_label = 0;
  for (int y0 = 0; y0 < ny; ++y0) {
    for (int x0 = 0; x0 < nx; ++x0) {
      const std::size_t seed_index = grid.Index(x0, y0);
      if (label[seed_index] >= 0 || !grid.IsTraversable(x0, y0)) continue;
      current.clear();
      stack.assign(1, seed_index);
      label[seed_index] = next_label;
      while (!stack.empty()) {
        const std::size_t i = stack.back();
        stack.pop_back();
        current.push_back(i);
        const int cx = static_cast<int>(i % static_cast<std::size_t>(nx));
        const int cy = static_cast<int>(i / static_cast<std::size_t>(nx));
        static const int kDx[4] = {1, -1, 0, 0};
        static const int kDy[4] = {0, 0, 1, -1};
        for (int k = 0; k < 4; ++k) {
          const int mx = cx + kDx[k];
          const int my = cy + kDy[k];
          if (!grid.InGrid(mx, my) || !grid.IsTraversable(mx, my)) continue;
          const std::size_t j = grid.Index(mx, my);
          if (label[j] >= 0) continue;
          label[j] = next_label;
          stack.push_back(j);
        }
      }
      ++next_label;
      if (current.size() > best.size()) best.swap(current);
    }
  }
  std::sort(best.begin(), best.end());
  return best;
}

std::vector<Eigen::Vector3d> SampleFreeStarts(const TraversabilityGrid& grid, int n, double min_spacing_m,
                                              std::uint32_t seed) {
  if (n < 0) throw std::invalid_argument("SampleFreeStarts: n = " + std::to_string(n) + " must be >= 0");
  if (!std::isfinite(min_spacing_m) || min_spacing_m < 0.0) {
    throw std::invalid_argument("SampleFreeStarts: min_spacing_m = " + std::to_string(min_spacing_m) +
                                " must be finite and >= 0");
  }
  std::vector<std::size_t> cells = LargestTraversableComponent(grid);
  // Fisher-Yates shuffle with an explicit formula (std::shuffle's use of the engine is implementation
  // defined; this keeps results identical across standard libraries).
  std::mt19937 rng(seed);
  for (std::size_t i = cells.size(); i > 1; --i) {
    const std::size_t j = static_cast<std::size_t>(rng() % i);
    std::swap(cells[i - 1], cells[j]);
  }
  const int nx = grid.nx();
  const double preferred_clearance_m = grid.options().robot_radius_m + 0.2;
  std::vector<Eigen::Vector3d> starts;
  for (int pass = 0; pass < 2 && static_cast<int>(starts.size()) < n; ++pass) {
    for (const std::size_t i : cells) {
      if (static_cast<int>(starts.size()) >= n) break;
      const int cx = static_cast<int>(i % static_cast<std::size_t>(nx));
      const int cy = static_cast<int>(i / static_cast<std::size_t>(nx));
      const bool preferred = grid.ClearanceM(cx, cy) >= preferred_clearance_m;
      if (pass == 0 ? !preferred : preferred) continue;  // Pass 1 only adds the cells pass 0 skipped.
      const Eigen::Vector2d c = grid.CellCenter(cx, cy);
      bool far_enough = true;
      for (const Eigen::Vector3d& s : starts)
        far_enough = far_enough && (s.head<2>() - c).norm() >= min_spacing_m;
      if (far_enough) starts.emplace_back(c.x(), c.y(), grid.Ground(cx, cy));
    }
  }
  return starts;
}

}  // namespace cairn::nav
