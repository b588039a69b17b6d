// Copyright Cairn authors.
#include "cairn/nav/astar.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <queue>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "path_internal.h"
#include "search_scratch.h"

namespace cairn::nav {
namespace {

// PlanPath's per-cell arrays, reset after each search at the cells it touched (search_scratch.h).
struct GridSearchScratch {
  std::vector<double> g;
  std::vector<int> parent;
  std::vector<std::uint8_t> closed;
  std::vector<int> touched;  // cells whose g was set

  void Prepare(std::size_t n) {
    for (const int i : touched) {
      g[static_cast<std::size_t>(i)] = std::numeric_limits<double>::infinity();
      parent[static_cast<std::size_t>(i)] = -1;
      closed[static_cast<std::size_t>(i)] = 0;
    }
    touched.clear();
    if (g.size() != n) {
      g.assign(n, std::numeric_limits<double>::infinity());
      parent.assign(n, -1);
      closed.assign(n, 0);
    }
  }
};

using internal::FormatPoint;
using internal::MapExtent;

internal::ScratchPool<GridSearchScratch>& GridScratchPool() {
  static internal::ScratchPool<GridSearchScratch> pool;
  return pool;
}

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kSqrt2 = 1.41421356237309504880;

std::string DescribeCell(const TraversabilityGrid& grid, int ix, int iy) {
  std::ostringstream out;
  out.precision(2);
  out << std::fixed << "cell state " << ToString(grid.State(ix, iy));
  // Unknown space a robot's own map counts as traversable is, like free ground, blocked by a nearby wall.
  const bool open = grid.State(ix, iy) == CellState::kFree ||
                    (grid.State(ix, iy) == CellState::kUnknown && !grid.options().unknown_is_lethal);
  if (open) {
    if (grid.IsLethal(ix, iy)) {
      out << ", top of a step higher than max_step_m " << grid.options().max_step_m << " m";
    } else {
      out << ", clearance " << grid.ClearanceM(ix, iy) << " m <= robot_radius_m "
          << grid.options().robot_radius_m << " m";
    }
  }
  return out.str();
}

double Octile(int dx, int dy) {
  const int a = std::abs(dx);
  const int b = std::abs(dy);
  return std::max(a, b) + (kSqrt2 - 1.0) * std::min(a, b);
}

}  // namespace

const char* ToString(PlanResult::Status status) {
  switch (status) {
    case PlanResult::Status::kSuccess:
      return "kSuccess";
    case PlanResult::Status::kInvalidGoal:
      return "kInvalidGoal";
    case PlanResult::Status::kInvalidStart:
      return "kInvalidStart";
    case PlanResult::Status::kOutOfMap:
      return "kOutOfMap";
    case PlanResult::Status::kGoalBlocked:
      return "kGoalBlocked";
    case PlanResult::Status::kStartBlocked:
      return "kStartBlocked";
    case PlanResult::Status::kUnreachable:
      return "kUnreachable";
  }
  return "?";
}

bool AStarOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi) {
    if (std::isfinite(value) && value >= lo && value <= hi) return true;
    msg << "AStarOptions::" << field << " = " << value << " must be finite and in [" << lo << ", " << hi
        << "]";
    return false;
  };
  const bool ok =
      range("step_height_cost", step_height_cost, 0.0, 100.0) &&
      range("preferred_clearance_m", preferred_clearance_m, 0.0, 10.0) &&
      range("clearance_cost", clearance_cost, 0.0, 100.0) &&
      range("unknown_cost", unknown_cost, 0.0, 100.0) &&
      range("start_escape_radius_m", start_escape_radius_m, 0.0, 5.0) &&
      range("start_footprint_radius_m", start_footprint_radius_m, 0.0, 5.0) &&
      (std::isnan(robot_radius_m) || range("robot_radius_m", robot_radius_m, 0.0, 5.0)) &&
      (std::isnan(partial_min_climb_m) || range("partial_min_climb_m", partial_min_climb_m, 0.0, 5.0)) &&
      range("max_expansions", max_expansions, 1000, 1e8);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

double PathLength2D(const std::vector<Eigen::Vector3d>& path_W) {
  double length = 0.0;
  for (std::size_t i = 1; i < path_W.size(); ++i) length += (path_W[i] - path_W[i - 1]).head<2>().norm();
  return length;
}

bool SegmentTraversable(const TraversabilityGrid& grid, const Eigen::Vector2d& a_W,
                        const Eigen::Vector2d& b_W, double min_clearance_m) {
  int ix = 0;
  int iy = 0;
  int jx = 0;
  int jy = 0;
  if (!grid.CellOf(a_W.x(), a_W.y(), &ix, &iy) || !grid.CellOf(b_W.x(), b_W.y(), &jx, &jy)) return false;
  auto ok = [&](int cx, int cy) {
    return grid.InGrid(cx, cy) && grid.IsTraversable(cx, cy) && grid.ClearanceM(cx, cy) >= min_clearance_m;
  };
  // Grid traversal of Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing" (Eurographics
  // 1987), extended to visit both side cells when the segment passes exactly through a cell corner.
  const double c = grid.cell_size_m();
  const Eigen::Vector2d d = b_W - a_W;
  const int step_x = d.x() > 0 ? 1 : (d.x() < 0 ? -1 : 0);
  const int step_y = d.y() > 0 ? 1 : (d.y() < 0 ? -1 : 0);
  const double x_min = grid.p_W_min().x();
  const double y_min = grid.p_W_min().y();
  double t_max_x = step_x != 0 ? ((ix + (step_x > 0 ? 1 : 0)) * c + x_min - a_W.x()) / d.x() : kInf;
  double t_max_y = step_y != 0 ? ((iy + (step_y > 0 ? 1 : 0)) * c + y_min - a_W.y()) / d.y() : kInf;
  const double t_delta_x = step_x != 0 ? c / std::abs(d.x()) : kInf;
  const double t_delta_y = step_y != 0 ? c / std::abs(d.y()) : kInf;
  if (!ok(jx, jy)) return false;
  const int max_steps = std::abs(jx - ix) + std::abs(jy - iy) + 2;
  for (int n = 0; n <= max_steps; ++n) {
    if (!ok(ix, iy)) return false;
    if (ix == jx && iy == jy) return true;
    if (std::min(t_max_x, t_max_y) >= 1.0 - 1e-12) return true;  // The segment ends on this cell's boundary.
    if (std::abs(t_max_x - t_max_y) < 1e-12) {
      if (!ok(ix + step_x, iy) || !ok(ix, iy + step_y)) return false;
      ix += step_x;
      iy += step_y;
      t_max_x += t_delta_x;
      t_max_y += t_delta_y;
    } else if (t_max_x < t_max_y) {
      ix += step_x;
      t_max_x += t_delta_x;
    } else {
      iy += step_y;
      t_max_y += t_delta_y;
    }
  }
  return false;  // Rounding made the walk miss the end cell: be conservative.
}

namespace {

// A start on a cell this plan may not cross (the robot's centre over a step's edge, near a wall after a
// recovery): the nearest traversable cell within start_escape_radius_m, if the body there is free. False,
// and why, otherwise.
template <typename Traversable>
bool EscapeStart(const TraversabilityGrid& grid, const Eigen::Vector2d& start_W, const AStarOptions& options,
                 const Traversable& traversable, int* sx, int* sy, std::string* why) {
  const double c = grid.cell_size_m();
  const bool body_free = options.start_is_robot ||
                         grid.IsFootprintFree(start_W.x(), start_W.y(), options.start_footprint_radius_m);
  int best_x = -1;
  int best_y = -1;
  if (body_free && options.start_escape_radius_m > 0.0) {
    const double r = options.start_escape_radius_m;
    const int span = static_cast<int>(std::ceil(r / c)) + 1;
    double best_d = kInf;
    for (int cx = *sx - span; cx <= *sx + span; ++cx) {
      for (int cy = *sy - span; cy <= *sy + span; ++cy) {
        if (!grid.InGrid(cx, cy) || !traversable(cx, cy)) continue;
        const double dist = (grid.CellCenter(cx, cy) - start_W).norm();
        if (dist <= r && dist < best_d) {
          best_d = dist;
          best_x = cx;
          best_y = cy;
        }
      }
    }
  }
  if (best_x < 0) {
    std::ostringstream msg;
    msg << "start " << FormatPoint(start_W) << " is not traversable (" << DescribeCell(grid, *sx, *sy)
        << ") and ";
    if (!body_free) {
      msg << "the robot body (radius " << options.start_footprint_radius_m << " m) there is not free";
    } else {
      msg << "no traversable cell lies within start_escape_radius_m " << options.start_escape_radius_m
          << " m";
    }
    *why = msg.str();
    return false;
  }
  *sx = best_x;
  *sy = best_y;
  return true;
}

// A* over the grid's 8-connected cells from (sx, sy) to (gx, gy) (octile heuristic; costs: distance, the
// clearance penalty, unknown ground, steps); true when the goal was reached. `scratch` holds the costs and
// parents; expansions are counted into `expansions`.
template <typename Traversable>
bool SearchGrid(const TraversabilityGrid& grid, const AStarOptions& options, const Traversable& traversable,
                int sx, int sy, int gx, int gy, GridSearchScratch* scratch, int* expansions) {
  const double c = grid.cell_size_m();
  const int nx = grid.nx();
  const std::size_t n = static_cast<std::size_t>(nx) * grid.ny();
  scratch->Prepare(n);
  std::vector<double>& g = scratch->g;
  std::vector<int>& parent = scratch->parent;
  std::vector<std::uint8_t>& closed = scratch->closed;
  std::vector<int>& touched = scratch->touched;
  using Entry = std::pair<double, int>;  // (f, linear index)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  auto heuristic = [&](int cx, int cy) { return Octile(cx - gx, cy - gy) * c; };
  auto penalty = [&](int cx, int cy) {
    if (options.preferred_clearance_m <= 0.0 || options.clearance_cost <= 0.0) return 0.0;
    const double deficit =
        (options.preferred_clearance_m - grid.ClearanceM(cx, cy)) / options.preferred_clearance_m;
    return options.clearance_cost * std::clamp(deficit, 0.0, 1.0);
  };
  const int start_index = static_cast<int>(grid.Index(sx, sy));
  const int goal_index = static_cast<int>(grid.Index(gx, gy));
  g[static_cast<std::size_t>(start_index)] = 0.0;
  touched.push_back(start_index);
  open.emplace(heuristic(sx, sy), start_index);
  static const int kDx[8] = {1, -1, 0, 0, 1, 1, -1, -1};
  static const int kDy[8] = {0, 0, 1, -1, 1, -1, 1, -1};
  bool found = false;
  while (!open.empty()) {
    const auto [f, index] = open.top();
    open.pop();
    const auto ui = static_cast<std::size_t>(index);
    if (closed[ui]) continue;
    closed[ui] = 1;
    ++*expansions;
    if (index == goal_index) {
      found = true;
      break;
    }
    const int cx = index % nx;
    const int cy = index / nx;
    for (int k = 0; k < 8; ++k) {
      const int mx = cx + kDx[k];
      const int my = cy + kDy[k];
      if (!grid.InGrid(mx, my) || !traversable(mx, my)) continue;
      const bool diagonal = kDx[k] != 0 && kDy[k] != 0;
      if (diagonal && (!traversable(cx + kDx[k], cy) || !traversable(cx, cy + kDy[k]))) continue;
      const std::size_t mi = grid.Index(mx, my);
      if (closed[mi]) continue;
      const double move = (diagonal ? kSqrt2 : 1.0) * c;
      // Unknown ground (NaN) adds no step cost but the unknown-space factor.
      const double dz = grid.Ground(mx, my) - grid.Ground(cx, cy);
      const double unknown = grid.State(mx, my) == CellState::kUnknown ? options.unknown_cost : 0.0;
      const double cost = move * (1.0 + penalty(mx, my) + unknown) +
                          (std::isfinite(dz) ? options.step_height_cost * std::abs(dz) : 0.0);
      const double candidate = g[ui] + cost;
      if (candidate < g[mi]) {
        if (!std::isfinite(g[mi])) touched.push_back(static_cast<int>(mi));
        g[mi] = candidate;
        parent[mi] = index;
        open.emplace(candidate + heuristic(mx, my), static_cast<int>(mi));
      }
    }
  }
  return found;
}

// The path of cells the search found, from the start point to the goal point (heights over unknown cells
// carried from the nearest known point), shortcut when the options say so.
std::vector<Eigen::Vector3d> PathOfCells(const TraversabilityGrid& grid, const AStarOptions& options,
                                         const std::vector<int>& parent, int goal_index, int gx, int gy,
                                         const Eigen::Vector2d& start_W, const Eigen::Vector2d& goal_W,
                                         bool used_start_escape) {
  const int nx = grid.nx();
  std::vector<int> cells;
  for (int i = goal_index; i >= 0; i = parent[static_cast<std::size_t>(i)]) cells.push_back(i);
  std::reverse(cells.begin(), cells.end());
  auto vertex = [&](int index) {
    const int cx = index % nx;
    const int cy = index / nx;
    const Eigen::Vector2d p = grid.CellCenter(cx, cy);
    return Eigen::Vector3d(p.x(), p.y(), grid.Ground(cx, cy));
  };
  std::vector<Eigen::Vector3d> points;
  std::vector<double> clearance;  // Per point: clearance of its cell.
  for (const int index : cells) {
    points.push_back(vertex(index));
    clearance.push_back(grid.ClearanceM(index % nx, index / nx));
  }
  // The exact start replaces the first cell centre, unless the search started from an escape cell (then the
  // start is prepended); the exact goal replaces the last cell centre.
  const double start_z = grid.GroundHeight(start_W.x(), start_W.y()).value_or(points.front().z());
  const Eigen::Vector3d start_point(start_W.x(), start_W.y(), start_z);
  internal::AttachStart(start_point, used_start_escape, &points, &clearance);
  points.back() = Eigen::Vector3d(goal_W.x(), goal_W.y(), grid.Ground(gx, gy));
  {  // Heights over unknown cells: carried from the nearest known point before (else after) on the path.
    double known = grid.summary().reference_height_m;
    for (const auto& p : points) {
      if (std::isfinite(p.z())) {
        known = p.z();
        break;
      }
    }
    for (auto& p : points) {
      if (std::isfinite(p.z())) {
        known = p.z();
      } else {
        p.z() = known;
      }
    }
  }

  if (options.simplify_path) {
    internal::ShortcutPath(
        options.preferred_clearance_m, clearance,
        [&](std::size_t anchor, std::size_t j, double need) {
          return SegmentTraversable(grid, points[anchor].head<2>(), points[j].head<2>(), need);
        },
        &points);
  }
  return points;
}

}  // namespace

PlanResult PlanPath(const TraversabilityGrid& grid, const Eigen::Vector2d& start_W,
                    const Eigen::Vector2d& goal_W, const AStarOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  const auto t0 = std::chrono::steady_clock::now();
  PlanResult result;
  // Traversable for this plan: the grid's layer, or clearance above a reduced radius.
  const bool reduced =
      std::isfinite(options.robot_radius_m) && options.robot_radius_m < grid.options().robot_radius_m - 1e-9;
  const double radius_m = reduced ? options.robot_radius_m : grid.options().robot_radius_m;
  auto traversable = [&grid, radius_m](int cx, int cy) { return grid.IsTraversableFor(cx, cy, radius_m); };
  auto finish = [&](PlanResult::Status status, std::string message) {
    result.status = status;
    result.message = std::move(message);
    result.planning_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return result;
  };
  using Status = PlanResult::Status;
  if (!start_W.allFinite())
    return finish(Status::kInvalidStart, "start " + FormatPoint(start_W) + " is not finite");
  if (!goal_W.allFinite())
    return finish(Status::kInvalidGoal, "goal " + FormatPoint(goal_W) + " is not finite");
  int sx = 0;
  int sy = 0;
  int gx = 0;
  int gy = 0;
  if (!grid.CellOf(start_W.x(), start_W.y(), &sx, &sy)) {
    return finish(Status::kOutOfMap,
                  "start " + FormatPoint(start_W) + " is outside the map " + MapExtent(grid));
  }
  if (!grid.CellOf(goal_W.x(), goal_W.y(), &gx, &gy)) {
    return finish(Status::kOutOfMap,
                  "goal " + FormatPoint(goal_W) + " is outside the map " + MapExtent(grid));
  }
  if (!traversable(gx, gy)) {
    return finish(Status::kGoalBlocked,
                  "goal " + FormatPoint(goal_W) + " is not traversable (" + DescribeCell(grid, gx, gy) + ")");
  }
  if (!traversable(sx, sy)) {
    std::string blocked;
    if (!EscapeStart(grid, start_W, options, traversable, &sx, &sy, &blocked))
      return finish(Status::kStartBlocked, blocked);
    result.used_start_escape = true;
  }
  auto scratch = GridScratchPool().Take();
  if (!SearchGrid(grid, options, traversable, sx, sy, gx, gy, &*scratch, &result.expansions)) {
    std::ostringstream msg;
    msg << "goal " << FormatPoint(goal_W) << " is unreachable from start " << FormatPoint(start_W)
        << ": no traversable path (" << result.expansions
        << " cells expanded; they lie in different regions)";
    return finish(Status::kUnreachable, msg.str());
  }
  result.path_W = PathOfCells(grid, options, scratch->parent, static_cast<int>(grid.Index(gx, gy)), gx, gy,
                              start_W, goal_W, result.used_start_escape);
  result.length_m = PathLength2D(result.path_W);
  std::ostringstream msg;
  msg.precision(2);
  msg << std::fixed << "path from " << FormatPoint(start_W) << " to " << FormatPoint(goal_W) << ": "
      << result.length_m << " m, " << result.path_W.size() << " waypoints, " << result.expansions
      << " cells expanded" << (result.used_start_escape ? " (started from an escape cell)" : "");
  return finish(Status::kSuccess, msg.str());
}

}  // namespace cairn::nav
