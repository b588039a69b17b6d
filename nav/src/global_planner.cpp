// Copyright Cairn authors.
#include "cairn/nav/global_planner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "cairn/core/range_check.h"
#include "path_internal.h"

namespace cairn::nav {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr double kPi = 3.14159265358979323846;

bool InRange(const std::string& field, double value, double lo, double hi, bool lo_open, std::string* why) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok && why != nullptr) {
    std::ostringstream out;
    out << field << " = " << value << " must be finite and in " << (lo_open ? "(" : "[") << lo << ", " << hi
        << "]";
    *why = out.str();
  }
  return ok;
}

}  // namespace

bool PlatformProfile::IsValid(std::string* why) const {
  const std::string p = "platform " + (name.empty() ? std::string("''") : name) + ": ";
  if (name.empty()) {
    if (why != nullptr) *why = "platform name is empty";
    return false;
  }
  std::string inner;
  if (!limits.IsValid(&inner)) {
    if (why != nullptr) *why = p + inner;
    return false;
  }
  if (!traversability.IsValid(&inner)) {
    if (why != nullptr) *why = p + inner;
    return false;
  }
  return InRange(p + "footprint_radius_m", footprint_radius_m, 0.0, 2.0, true, why) &&
         InRange(p + "cruise_speed_mps", cruise_speed_mps, 0.0, limits.max_speed_mps, true, why) &&
         InRange(p + "local_heading_range_rad", local_heading_range_rad, 0.0, kPi + 1e-9, true, why);
}

PlatformProfile GetPlatformProfile(const std::string& name) {
  PlatformProfile p;
  p.name = name;
  p.footprint_radius_m = 0.3;
  p.traversability.robot_radius_m = 0.3;
  p.traversability.robot_height_m = 0.8;
  if (name == "wheeled") {
    p.limits = core::VelocityLimits::Wheeled();
    p.limits.max_speed_mps = 1.5;
    p.cruise_speed_mps = 1.0;
    p.traversability.max_step_m = 0.15;
    p.local_heading_range_rad = 100.0 * kPi / 180.0;
    return p;
  }
  if (name == "legged") {
    p.limits = core::VelocityLimits::Legged();
    p.cruise_speed_mps = 0.5;
    p.traversability.max_step_m = 0.30;  // see platform.h: the voxel map's quantization of a 0.2 m rise
    p.local_heading_range_rad = kPi;
    return p;
  }
  std::string names;
  for (const auto& n : PlatformNames()) names += (names.empty() ? "" : ", ") + n;
  throw std::invalid_argument("platform '" + name + "' is not supported (valid: " + names + ")");
}

std::vector<std::string> PlatformNames() { return {"wheeled", "legged"}; }

bool GlobalPlannerOptions::IsValid(std::string* why) const {
  std::string inner;
  if (!astar.IsValid(&inner)) {
    if (why != nullptr) *why = "GlobalPlannerOptions::astar: " + inner;
    return false;
  }
  return InRange("GlobalPlannerOptions::diagnose_max_step_m", diagnose_max_step_m, 0.0, 2.0, false, why);
}

GlobalPlanner::GlobalPlanner(std::shared_ptr<const core::VoxelGrid> world,
                             std::vector<PlatformProfile> profiles, const GlobalPlannerOptions& options)
    : options_(options), profiles_(std::move(profiles)), world_(std::move(world)) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
  if (!world_) throw std::invalid_argument("GlobalPlanner: world is null");
  if (profiles_.empty()) throw std::invalid_argument("GlobalPlanner: no platform profile given");
  std::set<std::string> names;
  for (const auto& p : profiles_) {
    if (!p.IsValid(&why)) throw std::invalid_argument(why);
    if (!names.insert(p.name).second)
      throw std::invalid_argument("GlobalPlanner: platform '" + p.name + "' given twice");
  }
  map_memory_bytes_ = world_->MemoryBytes();
}

void GlobalPlanner::CountMapMemoryLocked() {
  std::size_t bytes = world_->MemoryBytes() + (seen_free_ ? seen_free_->MemoryBytes() : 0);
  for (const auto* cache : {&grids_, &diagnose_grids_}) {
    for (const auto& [platform, grid] : *cache) bytes += grid->MemoryBytes();
  }
  for (const auto* cache : {&levels_, &diagnose_levels_}) {
    for (const auto& [platform, levels] : *cache) bytes += levels->MemoryBytes();
  }
  map_memory_bytes_.store(bytes, std::memory_order_relaxed);
}

const PlatformProfile* GlobalPlanner::Profile(const std::string& platform) const {
  for (const auto& p : profiles_) {
    if (p.name == platform) return &p;
  }
  return nullptr;
}

std::string GlobalPlanner::PlatformList() const {
  std::string names;
  for (const auto& p : profiles_) names += (names.empty() ? "" : ", ") + p.name;
  return names;
}

std::uint64_t GlobalPlanner::map_version() const { return map_version_.load(); }

void GlobalPlanner::UpdateWorld(std::shared_ptr<const core::VoxelGrid> world) {
  if (!world) throw std::invalid_argument("GlobalPlanner::UpdateWorld: world is null");
  std::lock_guard<std::mutex> guard(mutex_);
  world_ = std::move(world);
  seen_free_.reset();
  ++map_version_;
  grids_.clear();
  diagnose_grids_.clear();
  levels_.clear();
  diagnose_levels_.clear();
  sensor_max_z_m_ = std::numeric_limits<double>::quiet_NaN();
  CountMapMemoryLocked();
}

void GlobalPlanner::UpdateMap(std::shared_ptr<const core::VoxelGrid> world, const std::string& platform,
                              std::shared_ptr<const TraversabilityGrid> grid,
                              std::shared_ptr<const core::VoxelGrid> seen_free,
                              std::shared_ptr<const TraversabilityGrid> diagnose_grid,
                              std::shared_ptr<const MultiLevelGrid> levels, double sensor_max_z_m,
                              std::shared_ptr<const MultiLevelGrid> diagnose_levels) {
  if (!world || !grid) throw std::invalid_argument("GlobalPlanner::UpdateMap: world or grid is null");
  if (Profile(platform) == nullptr) {
    throw std::invalid_argument("GlobalPlanner::UpdateMap: platform '" + platform +
                                "' is not served (valid: " + PlatformList() + ")");
  }
  std::lock_guard<std::mutex> guard(mutex_);
  world_ = std::move(world);
  seen_free_ = std::move(seen_free);
  ++map_version_;
  grids_.clear();
  diagnose_grids_.clear();
  grids_.emplace(platform, std::move(grid));
  if (diagnose_grid) diagnose_grids_.emplace(platform, std::move(diagnose_grid));
  levels_.clear();
  diagnose_levels_.clear();
  if (levels) levels_.emplace(platform, std::move(levels));
  if (diagnose_levels) diagnose_levels_.emplace(platform, std::move(diagnose_levels));
  sensor_max_z_m_ = sensor_max_z_m;
  CountMapMemoryLocked();
}

TraversabilityOptions GlobalPlanner::LevelOptionsFor(const PlatformProfile& profile) const {
  TraversabilityOptions t = TerrainOptionsFor(profile);
  t.cell_size_m = 0.0;
  t.reference_height_m = std::numeric_limits<double>::quiet_NaN();
  t.ground_search_min_z_m = -std::numeric_limits<double>::infinity();
  t.ground_search_max_z_m = std::numeric_limits<double>::infinity();
  return t;
}

std::shared_ptr<const MultiLevelGrid> GlobalPlanner::Levels(const std::string& platform) {
  std::lock_guard<std::mutex> guard(mutex_);
  return LevelsLocked(platform, false);
}

std::shared_ptr<const MultiLevelGrid> GlobalPlanner::LevelsLocked(const std::string& platform,
                                                                  bool diagnose) {
  const PlatformProfile* profile = Profile(platform);
  if (profile == nullptr) return nullptr;
  auto& cache = diagnose ? diagnose_levels_ : levels_;
  auto it = cache.find(platform);
  if (it != cache.end()) return it->second;
  TraversabilityOptions t = LevelOptionsFor(*profile);
  if (diagnose) t.max_step_m = std::max(t.max_step_m, options_.diagnose_max_step_m);
  auto levels = std::make_shared<const MultiLevelGrid>(world_, t, seen_free_, sensor_max_z_m_);
  cache.emplace(platform, levels);
  CountMapMemoryLocked();
  return levels;
}

bool GlobalPlanner::NeedsLevels(const GlobalPlanRequest& request, const TraversabilityGrid& grid) const {
  if (std::isfinite(request.goal_z_m)) return true;
  if (!std::isfinite(request.start_z_m)) return false;
  return !grid.OnLevel(request.start_W.x(), request.start_W.y(), request.start_z_m);
}

TraversabilityOptions GlobalPlanner::TerrainOptionsFor(const PlatformProfile& profile) const {
  TraversabilityOptions t = profile.traversability;
  t.cell_size_m = options_.reading.cell_size_m;
  t.reference_height_m = options_.reading.reference_height_m;
  t.ground_search_min_z_m = options_.reading.ground_search_min_z_m;
  t.ground_search_max_z_m = options_.reading.ground_search_max_z_m;
  t.unknown_is_lethal = options_.reading.unknown_is_lethal;
  return t;
}

std::optional<TraversabilityOptions> GlobalPlanner::DiagnoseTerrainOptionsFor(
    const PlatformProfile& profile) const {
  if (options_.diagnose_max_step_m <= profile.traversability.max_step_m) return std::nullopt;
  TraversabilityOptions t = TerrainOptionsFor(profile);
  t.max_step_m = options_.diagnose_max_step_m;
  return t;
}

std::shared_ptr<const TraversabilityGrid> GlobalPlanner::Grid(const std::string& platform) {
  std::lock_guard<std::mutex> guard(mutex_);
  return GridLocked(platform, false);
}

std::shared_ptr<const TraversabilityGrid> GlobalPlanner::GridLocked(const std::string& platform,
                                                                    bool diagnose) {
  const PlatformProfile* profile = Profile(platform);
  if (profile == nullptr) return nullptr;
  auto& cache = diagnose ? diagnose_grids_ : grids_;
  auto it = cache.find(platform);
  if (it != cache.end()) return it->second;
  TraversabilityOptions t = TerrainOptionsFor(*profile);
  if (diagnose) t = DiagnoseTerrainOptionsFor(*profile).value_or(t);
  auto grid = std::make_shared<const TraversabilityGrid>(*world_, t, seen_free_.get());
  cache.emplace(platform, grid);
  CountMapMemoryLocked();
  return grid;
}

GlobalPlan GlobalPlanner::Plan(const GlobalPlanRequest& request) {
  const auto t0 = std::chrono::steady_clock::now();
  GlobalPlan plan;
  // The mutex guards the map and the grid caches only: the grids are immutable, so searches run unlocked
  // (a plan over a mostly unknown map must not hold up the control loop's CheckPath or a map update).
  std::unique_lock<std::mutex> guard(mutex_);
  plan.map_version = map_version_;
  const PlatformProfile* profile = Profile(request.platform);
  if (profile == nullptr) {
    plan.platform_known = false;
    plan.reason =
        "platform '" + request.platform + "' is not served by this planner (valid: " + PlatformList() + ")";
    plan.result.message = plan.reason;
    return plan;
  }
  AStarOptions astar = options_.astar;
  astar.start_footprint_radius_m = profile->footprint_radius_m;
  astar.start_is_robot = request.start_is_robot;
  if (std::isfinite(request.preferred_clearance_m)) {
    astar.preferred_clearance_m = std::clamp(request.preferred_clearance_m, 0.0, 10.0);
  }
  if (std::isfinite(request.robot_radius_m))
    astar.robot_radius_m = std::clamp(request.robot_radius_m, 0.0, 5.0);
  const auto grid = GridLocked(request.platform, false);
  int cell_x = 0, cell_y = 0;
  if (request.allow_partial && request.goal_W.allFinite() &&
      !grid->CellOf(request.goal_W.x(), request.goal_W.y(), &cell_x, &cell_y) &&
      grid->CellOf(request.start_W.x(), request.start_W.y(), &cell_x, &cell_y)) {
    guard.unlock();
    GlobalPlan edge = PlanToMapEdge(request, *grid);
    edge.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return edge;
  }
  const bool needs_levels = NeedsLevels(request, *grid);
  const auto levels = needs_levels ? LevelsLocked(request.platform, false) : nullptr;
  guard.unlock();
  if (needs_levels) {
    PlanOnLevels(request, *profile, astar, *levels, &plan);
  } else {
    PlanOnGrid(request, *profile, astar, *grid, &plan);
  }
  plan.total_time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return plan;
}

void GlobalPlanner::PlanOnLevels(const GlobalPlanRequest& request, const PlatformProfile& profile,
                                 AStarOptions astar, const MultiLevelGrid& levels, GlobalPlan* plan) {
  const Eigen::Vector3d start(request.start_W.x(), request.start_W.y(), request.start_z_m);
  astar.allow_partial = request.allow_partial;
  plan->result = PlanPathMultiLevel(levels, start, request.goal_W, request.goal_z_m, astar);
  const bool short_of_goal = plan->result.partial || plan->result.status == PlanResult::Status::kUnreachable;
  if (short_of_goal && request.diagnose && options_.diagnose_max_step_m > profile.traversability.max_step_m) {
    const std::string diagnosis = DiagnoseStepOnLevels(request, profile, astar, start, plan->result);
    if (!diagnosis.empty()) {
      plan->result.status = PlanResult::Status::kUnreachable;
      plan->result.path_W.clear();
      plan->result.partial = false;
      plan->reason = diagnosis;
    }
  }
  if (!plan->result.IsUsable() && plan->reason.empty()) plan->reason = plan->result.message;
}

std::string GlobalPlanner::DiagnoseStepOnLevels(const GlobalPlanRequest& request,
                                                const PlatformProfile& profile, const AStarOptions& astar,
                                                const Eigen::Vector3d& start_W, const PlanResult& result) {
  std::shared_ptr<const MultiLevelGrid> relaxed;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    relaxed = LevelsLocked(request.platform, true);
  }
  AStarOptions cells = astar;
  cells.simplify_path = false;
  cells.partial_min_climb_m =
      profile.traversability.max_step_m;  // progress measured in this platform's steps
  const PlanResult r = PlanPathMultiLevel(*relaxed, start_W, request.goal_W, request.goal_z_m, cells);
  const double goal_z = std::isfinite(request.goal_z_m) ? request.goal_z_m : start_W.z();
  auto height_gap = [goal_z](const PlanResult& p) {
    return p.path_W.empty() || !std::isfinite(goal_z) ? kInf : std::abs(p.path_W.back().z() - goal_z);
  };
  const bool relaxed_better =
      r.IsUsable() && (!r.partial || !result.IsUsable() || height_gap(r) < height_gap(result) - 0.5);
  if (!relaxed_better) return "";
  double step = 0.0;
  Eigen::Vector2d at = request.start_W;
  for (std::size_t i = 1; i < r.path_W.size(); ++i) {
    const double dz = std::abs(r.path_W[i].z() - r.path_W[i - 1].z());
    if (dz > profile.traversability.max_step_m + 1e-9) {
      step = dz;
      at = r.path_W[i].head<2>();
      break;
    }
  }
  // A route that is only partial either way names a step only when another platform served here climbs it
  // (stairs for a wheeled robot), not an artefact of the relaxed limit (a wall's edge seen at 0.4 m).
  bool another_climbs = !r.partial;
  for (const auto& other : profiles_) {
    another_climbs =
        another_climbs || (other.name != profile.name && other.traversability.max_step_m + 1e-9 >= step);
  }
  return another_climbs ? DescribeStep(profile, step, at) : "";
}

void GlobalPlanner::PlanOnGrid(const GlobalPlanRequest& request, const PlatformProfile& profile,
                               const AStarOptions& astar, const TraversabilityGrid& grid, GlobalPlan* plan) {
  plan->result = PlanPath(grid, request.start_W, request.goal_W, astar);
  int cell_x = 0, cell_y = 0;
  if (grid.CellOf(request.goal_W.x(), request.goal_W.y(), &cell_x, &cell_y)) {
    plan->goal_unmapped = grid.State(cell_x, cell_y) == CellState::kUnknown;
  }
  if (plan->result.status == PlanResult::Status::kGoalBlocked) {
    const double radius_m =
        std::isfinite(astar.robot_radius_m) ? astar.robot_radius_m : grid.options().robot_radius_m;
    if (const auto free = NearestTraversable(grid, request.goal_W, radius_m, kNearestFreeSearchM)) {
      plan->nearest_free_W = *free;
    }
  }
  if (plan->result.IsUsable()) return;
  plan->reason = plan->result.message;
  if (plan->result.status == PlanResult::Status::kUnreachable ||
      plan->result.status == PlanResult::Status::kGoalBlocked) {
    const std::string diagnosis = DiagnoseUnreachable(profile, request, astar);
    if (!diagnosis.empty()) plan->reason = diagnosis;
  }
}

GlobalPlan GlobalPlanner::PlanToMapEdge(const GlobalPlanRequest& request, const TraversabilityGrid& grid) {
  // The goal projected onto the map's extent shrunk by kEdgeInsetM, then points 1 m apart back toward the
  // start until one is reachable (the projection may fall in a wall the map shows).
  constexpr double kEdgeInsetM = 1.0;
  constexpr int kEdgeTries = 10;
  const Eigen::Vector2d inset =
      Eigen::Vector2d::Constant(kEdgeInsetM).cwiseMin(0.25 * (grid.p_W_max() - grid.p_W_min()));
  const Eigen::Vector2d lo = grid.p_W_min() + inset, hi = grid.p_W_max() - inset;
  const Eigen::Vector2d edge = request.goal_W.cwiseMax(lo).cwiseMin(hi);
  const Eigen::Vector2d back = request.start_W - edge;
  const Eigen::Vector2d toward_start =
      back.norm() > 0 ? Eigen::Vector2d(back.normalized()) : Eigen::Vector2d::Zero();
  const std::string extent = internal::MapExtent(grid);
  const std::string goal = internal::FormatPoint(request.goal_W);
  GlobalPlan first;
  for (int i = 0; i <= kEdgeTries && i <= back.norm(); ++i) {
    GlobalPlanRequest inner = request;
    inner.goal_W = edge + static_cast<double>(i) * toward_start;
    GlobalPlan plan = Plan(inner);  // inside the map: no recursion
    if (plan.IsUsable()) {
      plan.result.partial = true;
      plan.goal_unmapped = true;
      plan.result.message = "the goal " + goal + " lies beyond the navigation map (" + extent +
                            "): planned to its edge, the map grows as the robot maps toward it";
      return plan;
    }
    if (i == 0) first = plan;
  }
  first.goal_unmapped = true;
  first.reason = "the goal " + goal + " lies beyond the navigation map (" + extent +
                 ") and the map shows no way to its edge toward it: " + first.reason;
  return first;
}

std::string GlobalPlanner::DiagnoseUnreachable(const PlatformProfile& profile,
                                               const GlobalPlanRequest& request, const AStarOptions& astar) {
  if (options_.diagnose_max_step_m <= profile.traversability.max_step_m) return "";
  std::shared_ptr<const TraversabilityGrid> relaxed;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    relaxed = GridLocked(profile.name, true);
  }
  const PlanResult r = PlanPath(*relaxed, request.start_W, request.goal_W, astar);
  if (!r.IsUsable()) return "";
  // The largest ground height change between neighbouring cells along the relaxed route.
  const double step_m = relaxed->cell_size_m() * 0.5;
  double worst_step = 0.0;
  Eigen::Vector2d worst_at = request.start_W;
  double previous = std::numeric_limits<double>::quiet_NaN();
  for (std::size_t i = 1; i < r.path_W.size(); ++i) {
    const Eigen::Vector2d a = r.path_W[i - 1].head<2>();
    const Eigen::Vector2d b = r.path_W[i].head<2>();
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step_m)));
    for (int k = (i == 1 ? 0 : 1); k <= n; ++k) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(k) / n);
      const auto ground = relaxed->GroundHeight(p.x(), p.y());
      if (!ground) continue;
      if (std::isfinite(previous) && std::abs(*ground - previous) > worst_step) {
        worst_step = std::abs(*ground - previous);
        worst_at = p;
      }
      previous = *ground;
    }
  }
  return DescribeStep(profile, worst_step, worst_at);
}

std::string GlobalPlanner::DescribeStep(const PlatformProfile& profile, double worst_step,
                                        const Eigen::Vector2d& worst_at) const {
  if (worst_step <= profile.traversability.max_step_m + 1e-9) return "";
  std::string text = "unreachable for platform " + profile.name + ": the only route climbs a " +
                     core::Fixed(worst_step, 2) + " m step at (" + core::Fixed(worst_at.x(), 2) + ", " +
                     core::Fixed(worst_at.y(), 2) + "), above its max_step_m " +
                     core::Fixed(profile.traversability.max_step_m, 2) + " m";
  for (const auto& other : profiles_) {
    if (other.name != profile.name && other.traversability.max_step_m + 1e-9 >= worst_step) {
      text += " (platform " + other.name + " climbs up to " +
              core::Fixed(other.traversability.max_step_m, 2) + " m)";
      break;
    }
  }
  return text;
}

PathCheck GlobalPlanner::CheckPath(const std::vector<Eigen::Vector3d>& path_W, const std::string& platform,
                                   int from_segment) {
  PathCheck check;
  std::unique_lock<std::mutex> guard(mutex_);
  const auto grid = GridLocked(platform, false);
  if (grid == nullptr) {
    check.valid = false;
    check.message =
        "platform '" + platform + "' is not served by this planner (valid: " + PlatformList() + ")";
    return check;
  }
  if (path_W.empty()) {
    check.valid = false;
    check.message = "path is empty";
    return check;
  }
  // A path off the main level (an upper floor, stairs above another flight) is checked over the levels.
  bool off_main_level = false;
  for (const Eigen::Vector3d& p : path_W) {
    const auto ground = grid->GroundHeight(p.x(), p.y());
    if (std::isfinite(p.z()) && (!ground || std::abs(*ground - p.z()) > grid->options().max_step_m + 0.05)) {
      off_main_level = true;
      break;
    }
  }
  const auto levels = off_main_level ? LevelsLocked(platform, false) : nullptr;
  guard.unlock();
  for (std::size_t i = static_cast<std::size_t>(std::max(0, from_segment)); i + 1 < path_W.size(); ++i) {
    const bool traversable = levels ? SegmentTraversableMultiLevel(*levels, path_W[i], path_W[i + 1])
                                    : SegmentTraversable(*grid, path_W[i].head<2>(), path_W[i + 1].head<2>());
    if (!traversable) {
      check.valid = false;
      check.first_blocked_segment = static_cast<int>(i);
      check.message = "path segment " + std::to_string(i) + " from (" + core::Fixed(path_W[i].x(), 2) + ", " +
                      core::Fixed(path_W[i].y(), 2) + ") to (" + core::Fixed(path_W[i + 1].x(), 2) + ", " +
                      core::Fixed(path_W[i + 1].y(), 2) + ") is no longer traversable";
      return check;
    }
  }
  return check;
}

std::optional<Eigen::Vector2d> NearestTraversable(const TraversabilityGrid& grid, const Eigen::Vector2d& p_W,
                                                  double radius_m, double max_distance_m) {
  if (!p_W.allFinite() || !(max_distance_m >= 0.0)) return std::nullopt;
  const double c = grid.cell_size_m();
  // The cell containing p_W, possibly outside the grid (its rings may still reach into it).
  const int cx = static_cast<int>(std::floor((p_W.x() - grid.p_W_min().x()) / c));
  const int cy = static_cast<int>(std::floor((p_W.y() - grid.p_W_min().y()) / c));
  const int max_ring = static_cast<int>(std::ceil(max_distance_m / c)) + 1;
  std::optional<Eigen::Vector2d> best[2];  // [0]: ground seen, [1]: unknown space
  double best_d[2] = {kInf, kInf};
  // Square rings around the cell: every cell of ring r is at least (r - 1) cells from p_W, so the search
  // stops once that exceeds the best seen distance found (or the limit).
  auto visit = [&](int ix, int iy) {
    if (!grid.InGrid(ix, iy) || !grid.IsTraversableFor(ix, iy, radius_m)) return;
    const Eigen::Vector2d q = grid.CellCenter(ix, iy);
    const double d = (q - p_W).norm();
    const int kind = grid.State(ix, iy) == CellState::kUnknown ? 1 : 0;
    if (d <= max_distance_m && d < best_d[kind]) {
      best_d[kind] = d;
      best[kind] = q;
    }
  };
  for (int r = 0; r <= max_ring; ++r) {
    if ((r - 1) * c > std::min(best_d[0], max_distance_m)) break;
    if (r == 0) {
      visit(cx, cy);
      continue;
    }
    for (int k = -r; k < r; ++k) {  // the ring's four sides, each from one corner to the next
      visit(cx + k, cy - r);
      visit(cx + r, cy + k);
      visit(cx - k, cy + r);
      visit(cx - r, cy - k);
    }
  }
  return best[0] ? best[0] : best[1];
}

void LethalCellsNear(const TraversabilityGrid& grid, double x_WB_m, double y_WB_m, double yaw_WB_rad,
                     double range_m, std::vector<Eigen::Vector3f>* points_B) {
  points_B->clear();
  if (!(range_m > 0.0) || !std::isfinite(x_WB_m) || !std::isfinite(y_WB_m) || !std::isfinite(yaw_WB_rad))
    return;
  const double c = grid.cell_size_m();
  const int x_lo = static_cast<int>(std::floor((x_WB_m - range_m - grid.p_W_min().x()) / c));
  const int x_hi = static_cast<int>(std::floor((x_WB_m + range_m - grid.p_W_min().x()) / c));
  const int y_lo = static_cast<int>(std::floor((y_WB_m - range_m - grid.p_W_min().y()) / c));
  const int y_hi = static_cast<int>(std::floor((y_WB_m + range_m - grid.p_W_min().y()) / c));
  const double cos_yaw = std::cos(yaw_WB_rad);
  const double sin_yaw = std::sin(yaw_WB_rad);
  const double r2 = range_m * range_m;
  for (int ix = x_lo; ix <= x_hi; ++ix) {
    for (int iy = y_lo; iy <= y_hi; ++iy) {
      const Eigen::Vector2d p_W = grid.CellCenter(ix, iy);
      const double dx = p_W.x() - x_WB_m;
      const double dy = p_W.y() - y_WB_m;
      if (dx * dx + dy * dy > r2) continue;
      if (grid.InGrid(ix, iy) && !grid.IsLethal(ix, iy)) continue;
      // p_B = R_WB^T (p_W - p_WB).
      points_B->emplace_back(static_cast<float>(cos_yaw * dx + sin_yaw * dy),
                             static_cast<float>(-sin_yaw * dx + cos_yaw * dy), 0.0f);
    }
  }
}

}  // namespace cairn::nav
