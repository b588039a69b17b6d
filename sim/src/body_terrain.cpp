// Copyright Cairn authors.
#include "cairn/sim/body_terrain.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <limits>
#include <random>
#include <sstream>
#include <stdexcept>

namespace cairn::sim {
namespace {

// Heights are multiples of the voxel edge; comparisons allow for their rounding.
constexpr double kEps_m = 1e-6;

bool FieldInRange(const char* field, double value, double lo, double hi, bool lo_open, std::string* why) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok && why != nullptr) {
    std::ostringstream o;
    o << "body." << field << " = " << value << " must be finite and in " << (lo_open ? "(" : "[") << lo
      << ", " << hi << "]";
    *why = o.str();
  }
  return ok;
}

}  // namespace

bool BodyOptions::IsValid(std::string* why) const {
  return FieldInRange("max_step_m", max_step_m, 0.0, 5.0, false, why) &&
         FieldInRange("body_height_m", body_height_m, 0.0, 10.0, true, why);
}

BodyTerrain::BodyTerrain(std::shared_ptr<const World> world, const BodyOptions& options)
    : world_(std::move(world)), options_(options) {
  if (!world_) throw std::invalid_argument("BodyTerrain: world is null");
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument("BodyTerrain: " + why);
  nx_ = world_->dims().x();
  ny_ = world_->dims().y();
  nz_ = world_->dims().z();
  resolution_m_ = world_->resolution_m();
  p_W_min_ = world_->p_W_min();
  const int need = std::max(1, static_cast<int>(std::ceil(options_.body_height_m / resolution_m_ - kEps_m)));
  first_.assign(static_cast<std::size_t>(nx_) * static_cast<std::size_t>(ny_) + 1, 0);
  std::vector<std::int32_t> column;
  for (int ix = 0; ix < nx_; ++ix) {
    for (int iy = 0; iy < ny_; ++iy) {
      // Occupied voxels top down, 64 at a time through free space; a surface is one with `need` free voxels
      // above it inside the map.
      column.clear();
      int above = nz_;  // the occupied voxel above the current one (nz_: none, the map's top)
      for (int iz = world_->HighestOccupiedInColumn(ix, iy, nz_ - 1); iz >= 0;
           iz = world_->HighestOccupiedInColumn(ix, iy, iz - 1)) {
        const int free_above = above - iz - 1;
        const bool inside = iz + need <= nz_ - 1;
        if (free_above >= need && inside) column.push_back(iz);
        above = iz;
        if (iz == 0) break;
      }
      const std::size_t c = static_cast<std::size_t>(ix) * static_cast<std::size_t>(ny_) + iy;
      surfaces_.insert(surfaces_.end(), column.rbegin(), column.rend());
      first_[c + 1] = static_cast<std::int64_t>(surfaces_.size());
    }
  }
  // The main floor: the most common lowest surface.
  std::vector<std::int64_t> lowest_count(static_cast<std::size_t>(nz_), 0);
  for (std::size_t c = 0; c + 1 < first_.size(); ++c) {
    if (first_[c] < first_[c + 1]) ++lowest_count[static_cast<std::size_t>(surfaces_[first_[c]])];
  }
  const auto mode = std::max_element(lowest_count.begin(), lowest_count.end()) - lowest_count.begin();
  main_floor_z_m_ = p_W_min_.z() + (static_cast<double>(mode) + 1) * resolution_m_;
}

std::int64_t BodyTerrain::ColumnAt(double x_m, double y_m) const {
  if (!std::isfinite(x_m) || !std::isfinite(y_m)) return -1;
  const double fx = std::floor((x_m - p_W_min_.x()) / resolution_m_);
  const double fy = std::floor((y_m - p_W_min_.y()) / resolution_m_);
  if (fx < 0 || fy < 0 || fx >= nx_ || fy >= ny_) return -1;
  return static_cast<std::int64_t>(fx) * ny_ + static_cast<std::int64_t>(fy);
}

std::optional<double> BodyTerrain::SurfaceNear(std::int64_t column, double z_m, double within_m) const {
  std::optional<double> best;
  const auto c = static_cast<std::size_t>(column);
  for (std::int64_t i = first_[c]; i < first_[c + 1]; ++i) {
    const double top_m = p_W_min_.z() + (surfaces_[static_cast<std::size_t>(i)] + 1) * resolution_m_;
    if (std::abs(top_m - z_m) <= within_m + kEps_m &&
        (!best || std::abs(top_m - z_m) < std::abs(*best - z_m)))
      best = top_m;
  }
  return best;
}

std::optional<double> BodyTerrain::MainSurface(std::int64_t column) const {
  return SurfaceNear(column, main_floor_z_m_, std::numeric_limits<double>::infinity());
}

std::optional<double> BodyTerrain::SupportAt(double x_m, double y_m, double z_m, bool main) const {
  const std::int64_t centre = ColumnAt(x_m, y_m);
  if (centre < 0) return std::nullopt;
  auto support = [&](std::int64_t column) {
    return main ? MainSurface(column) : SurfaceNear(column, z_m, options_.max_step_m);
  };
  if (const std::optional<double> own = support(centre)) return own;
  // A hole of one voxel in a scanned floor: the ground around it holds the body up.
  const int ix = static_cast<int>(centre / ny_), iy = static_cast<int>(centre % ny_);
  std::optional<double> best;
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      const int jx = ix + dx, jy = iy + dy;
      if ((dx == 0 && dy == 0) || jx < 0 || jy < 0 || jx >= nx_ || jy >= ny_) continue;
      const std::optional<double> s = support(static_cast<std::int64_t>(jx) * ny_ + jy);
      if (!s) continue;
      const double from_m = main ? main_floor_z_m_ : z_m;
      const bool better = !best || std::abs(*s - from_m) < std::abs(*best - from_m);
      if (better) best = s;
    }
  }
  if (best && Blocks(centre, *best)) return std::nullopt;  // not a hole: a wall, a riser, a post
  return best;
}

bool BodyTerrain::Blocks(std::int64_t column, double ground_m) const {
  // Voxels whose top is above a step over the ground and whose bottom is below the body's top.
  const double lo = (ground_m + options_.max_step_m + kEps_m - p_W_min_.z()) / resolution_m_;
  const double hi = (ground_m + options_.body_height_m - kEps_m - p_W_min_.z()) / resolution_m_;
  const int iz_lo = static_cast<int>(std::max(0.0, std::floor(lo)));
  const int iz_hi = static_cast<int>(std::min(static_cast<double>(nz_ - 1), std::ceil(hi) - 1.0));
  if (iz_hi < iz_lo || iz_hi < 0) return false;
  const int ix = static_cast<int>(column / ny_), iy = static_cast<int>(column % ny_);
  return world_->HighestOccupiedInColumn(ix, iy, iz_hi) >= iz_lo;
}

bool BodyTerrain::FootprintFreeOn(double x_m, double y_m, double ground_m, double radius_m) const {
  const std::int64_t centre = ColumnAt(x_m, y_m);
  if (centre < 0) return false;
  const int cx = static_cast<int>(centre / ny_), cy = static_cast<int>(centre % ny_);
  const int reach = static_cast<int>(std::ceil(radius_m / resolution_m_)) + 1;
  const int side = 2 * reach + 1;
  auto in_disk = [&](int dx, int dy) {
    if (dx == 0 && dy == 0) return true;
    const double px = p_W_min_.x() + (cx + dx + 0.5) * resolution_m_ - x_m;
    const double py = p_W_min_.y() + (cy + dy + 0.5) * resolution_m_ - y_m;
    return px * px + py * py <= radius_m * radius_m;
  };
  auto column_of = [&](int dx, int dy) -> std::int64_t {
    const int jx = cx + dx, jy = cy + dy;
    if (jx < 0 || jy < 0 || jx >= nx_ || jy >= ny_) return -1;
    return static_cast<std::int64_t>(jx) * ny_ + jy;
  };
  // Ground reached in each column of the disk (NaN: not reached), walked outwards from the centre.
  std::vector<double> ground(static_cast<std::size_t>(side) * side, std::numeric_limits<double>::quiet_NaN());
  std::vector<char> seen(ground.size(), 0);
  auto slot = [&](int dx, int dy) { return static_cast<std::size_t>(dx + reach) * side + (dy + reach); };
  std::deque<std::pair<int, int>> open;
  if (const std::optional<double> own = SurfaceNear(centre, ground_m, options_.max_step_m)) {
    ground[slot(0, 0)] = *own;
  } else if (Blocks(centre, ground_m)) {
    return false;
  } else {
    ground[slot(0, 0)] = ground_m;  // a hole under the centre: the ground around it holds the body
  }
  seen[slot(0, 0)] = 1;
  open.emplace_back(0, 0);
  constexpr int kSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  while (!open.empty()) {
    const auto [px, py] = open.front();
    open.pop_front();
    const double from_m = ground[slot(px, py)];
    for (const auto& step : kSteps) {
      const int dx = px + step[0], dy = py + step[1];
      if (std::abs(dx) > reach || std::abs(dy) > reach || seen[slot(dx, dy)] || !in_disk(dx, dy)) continue;
      seen[slot(dx, dy)] = 1;
      const std::int64_t column = column_of(dx, dy);
      if (column < 0) return false;  // the edge of the world is a wall
      if (const std::optional<double> s = SurfaceNear(column, from_m, options_.max_step_m)) {
        ground[slot(dx, dy)] = *s;
        open.emplace_back(dx, dy);
      } else if (Blocks(column, from_m)) {
        return false;
      }
    }
  }
  // Columns cut off from the centre by drops or holes are read against the centre's ground. The body tips
  // unless the ground holds at least half of its footprint (a ledge, a beam's top, a table too small).
  int in_footprint = 0, held = 0;
  for (int dx = -reach; dx <= reach; ++dx) {
    for (int dy = -reach; dy <= reach; ++dy) {
      if (!in_disk(dx, dy)) continue;
      ++in_footprint;
      held += !std::isnan(ground[slot(dx, dy)]);
      if (seen[slot(dx, dy)]) continue;
      const std::int64_t column = column_of(dx, dy);
      if (column < 0 || Blocks(column, ground_m)) return false;
    }
  }
  return 2 * held >= in_footprint;
}

bool BodyTerrain::IsFootprintFree(double x_m, double y_m, double radius_m) const {
  const std::optional<double> ground = SupportAt(x_m, y_m, 0.0, /*main=*/true);
  return ground && FootprintFreeOn(x_m, y_m, *ground, radius_m);
}

std::optional<double> BodyTerrain::GroundHeight(double x_m, double y_m) const {
  return SupportAt(x_m, y_m, 0.0, /*main=*/true);
}

bool BodyTerrain::IsFootprintFreeNear(double x_m, double y_m, double z_m, double radius_m) const {
  const std::optional<double> ground = SupportAt(x_m, y_m, z_m, /*main=*/false);
  return ground && FootprintFreeOn(x_m, y_m, *ground, radius_m);
}

std::optional<double> BodyTerrain::GroundHeightNear(double x_m, double y_m, double z_m) const {
  return SupportAt(x_m, y_m, z_m, /*main=*/false);
}

std::vector<Eigen::Vector3d> BodyTerrain::SampleFreeStarts(int n, double min_spacing_m, double radius_m,
                                                           std::uint32_t seed) const {
  if (n < 0) throw std::invalid_argument("SampleFreeStarts: n = " + std::to_string(n) + " must be >= 0");
  if (!std::isfinite(min_spacing_m) || min_spacing_m < 0.0 || !std::isfinite(radius_m) || radius_m < 0.0) {
    throw std::invalid_argument("SampleFreeStarts: min_spacing_m = " + std::to_string(min_spacing_m) +
                                " and radius_m = " + std::to_string(radius_m) + " must be finite and >= 0");
  }
  // Regions of main surfaces joined by steps of at most max_step_m (4-connected); keep the largest.
  const std::size_t columns = first_.size() - 1;
  std::vector<char> visited(columns, 0);
  std::vector<std::int64_t> largest, current, open;
  for (std::size_t c0 = 0; c0 < columns; ++c0) {
    if (visited[c0] || !MainSurface(static_cast<std::int64_t>(c0))) continue;
    current.clear();
    open.assign(1, static_cast<std::int64_t>(c0));
    visited[c0] = 1;
    while (!open.empty()) {
      const std::int64_t c = open.back();
      open.pop_back();
      current.push_back(c);
      const double z = *MainSurface(c);
      const int ix = static_cast<int>(c / ny_), iy = static_cast<int>(c % ny_);
      const int next[4][2] = {{ix + 1, iy}, {ix - 1, iy}, {ix, iy + 1}, {ix, iy - 1}};
      for (const auto& [jx, jy] : next) {
        if (jx < 0 || jy < 0 || jx >= nx_ || jy >= ny_) continue;
        const std::int64_t d = static_cast<std::int64_t>(jx) * ny_ + jy;
        if (visited[static_cast<std::size_t>(d)]) continue;
        const std::optional<double> zd = MainSurface(d);
        if (!zd || std::abs(*zd - z) > options_.max_step_m + kEps_m) continue;
        visited[static_cast<std::size_t>(d)] = 1;
        open.push_back(d);
      }
    }
    if (current.size() > largest.size()) largest.swap(current);
  }
  // Fisher-Yates with an explicit formula: std::shuffle's use of the engine is implementation defined.
  std::mt19937 rng(seed);
  for (std::size_t i = largest.size(); i > 1; --i) std::swap(largest[i - 1], largest[rng() % i]);
  std::vector<Eigen::Vector3d> starts;
  for (int pass = 0; pass < 2 && static_cast<int>(starts.size()) < n; ++pass) {
    for (const std::int64_t c : largest) {
      if (static_cast<int>(starts.size()) >= n) break;
      // NOLINTNEXTLINE(bugprone-integer-division): c / ny_ is the column's x index, floored on purpose
      const double x = p_W_min_.x() + (static_cast<double>(c / ny_) + 0.5) * resolution_m_;
      const double y = p_W_min_.y() + (static_cast<double>(c % ny_) + 0.5) * resolution_m_;
      const double z = *MainSurface(c);
      const bool roomy = FootprintFreeOn(x, y, z, radius_m + 0.2);
      if (pass == 0 ? !roomy : roomy || !FootprintFreeOn(x, y, z, radius_m)) continue;
      bool far_enough = true;
      for (const Eigen::Vector3d& s : starts)
        far_enough = far_enough && (s.head<2>() - Eigen::Vector2d(x, y)).norm() >= min_spacing_m;
      if (far_enough) starts.emplace_back(x, y, z);
    }
  }
  return starts;
}

}  // namespace cairn::sim
