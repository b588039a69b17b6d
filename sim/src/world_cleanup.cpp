// Copyright Cairn authors.
//
// Clean-up of scanned worlds after loading (.bt, .ot, .pcd): support filter and floor hole filling. See
// WorldLoadOptions and LoadWorld() in world.h for the rules; no third-party header beyond Eigen.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <vector>

#include "world_loaders.h"

namespace cairn::sim::internal {
namespace {

constexpr int kSectors = 8;               // Directions (45 deg sectors) in which a hole must be closed.
constexpr double kGapSearchDepthM = 5.0;  // Depth below a hole searched for a seen gap bottom, metres.

int CeilVoxels(double length_m, double res_m) {
  return std::max(1, static_cast<int>(std::ceil(length_m / res_m - 1e-9)));
}

// 1. Support filter. A voxel stays if (PCD) it holds pcd_min_points_per_voxel points, or it has
// min_support_neighbors occupied voxels in the cube of half-edge r around it (counted on the input grid, so
// the result does not depend on the visiting order).
void RemoveUnsupported(World* world, const WorldLoadOptions& options, const PointCounts* counts,
                       WorldLoadReport* report) {
  if (options.support_radius_m <= 0.0) return;
  const double res = world->resolution_m();
  const int r = std::max(1, static_cast<int>(std::lround(options.support_radius_m / res)));
  const Eigen::Vector3i& dims = world->dims();
  std::vector<Eigen::Vector3i> remove;
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3i v(ix, iy, iz);
        if (!world->IsOccupiedIndex(v)) continue;
        if (counts != nullptr) {
          const auto it = counts->find(world->LinearIndex(v));
          if (it != counts->end() && it->second >= options.pcd_min_points_per_voxel) continue;
        }
        int neighbours = 0;
        for (int dx = -r; dx <= r && neighbours < options.min_support_neighbors; ++dx) {
          for (int dy = -r; dy <= r && neighbours < options.min_support_neighbors; ++dy) {
            for (int dz = -r; dz <= r; ++dz) {
              if ((dx | dy | dz) == 0) continue;
              if (world->IsOccupiedIndex({ix + dx, iy + dy, iz + dz}) &&
                  ++neighbours >= options.min_support_neighbors) {
                break;
              }
            }
          }
        }
        if (neighbours < options.min_support_neighbors) remove.push_back(v);
      }
    }
  }
  for (const Eigen::Vector3i& v : remove) world->SetOccupied(v, false);
  report->voxels_removed_unsupported = static_cast<std::int64_t>(remove.size());
}

// Floor surface levels of every column, compressed (CSR): levels of column c are
// levels[offset[c] .. offset[c + 1]), ascending.
struct FloorLevels {
  std::vector<std::int64_t> offset;
  std::vector<std::int32_t> levels;

  // The floor level of column c in [k - 1, k + 1] (k itself preferred), or -1.
  int Near(std::size_t c, int k) const {
    int found = -1;
    for (std::int64_t i = offset[c]; i < offset[c + 1]; ++i) {
      const int l = levels[static_cast<std::size_t>(i)];
      if (l == k) return k;
      if (l == k - 1 || l == k + 1) found = l;
    }
    return found;
  }
};

struct SectorOffset {
  int dx, dy;
  double distance;  // Cells.
  int sector;
};

// Cell offsets within `radius` cells (the centre excluded), by increasing distance, with their direction
// sector (kSectors equal angular sectors).
std::vector<SectorOffset> DiskOffsets(int radius) {
  std::vector<SectorOffset> out;
  constexpr double kPi = 3.14159265358979323846;
  for (int dx = -radius; dx <= radius; ++dx) {
    for (int dy = -radius; dy <= radius; ++dy) {
      const double d = std::hypot(dx, dy);
      if ((dx == 0 && dy == 0) || d > radius + 1e-9) continue;
      const double angle = std::atan2(dy, dx) + kPi;  // [0, 2 pi]
      const int sector = std::min(kSectors - 1, static_cast<int>(angle / (2.0 * kPi) * kSectors));
      out.push_back({dx, dy, d, sector});
    }
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const SectorOffset& a, const SectorOffset& b) { return a.distance < b.distance; });
  return out;
}

// Directions across a strip: x, y and the two diagonals (a strip at any angle is within 22.5 deg of one, so
// its width along that one is at most 1.09 times its true width).
constexpr std::array<std::array<int, 2>, 4> kAcross = {{{1, 0}, {0, 1}, {1, 1}, {1, -1}}};
// A strip is at least this many times as long as its largest width (WorldLoadOptions::fill_strip_max_m). The
// narrow part of a wedge (the corner of a larger opening) is shorter: width w ends at w / (2 tan(a / 2)) from
// the tip of a wedge of angle a, so wedges of more than 28 deg are never taken for strips.
constexpr double kStripMinLengthPerWidth = 2.0;

// Lines of cells along a direction (dx, dy) of an nx x ny grid (cell (x, y) at index x * ny + y), with dx =
// 1, or dx = 0 and dy = 1 (a line read backwards is the same line).
struct Lines {
  int nx, ny, dx, dy;
  // Index step from a cell to the next one on its line.
  std::ptrdiff_t Step() const { return static_cast<std::ptrdiff_t>(dx) * ny + dy; }
  // Calls visit(id, c) for every cell c, in order along each line, reading the grid in memory order. The
  // line through (x, y) has id y (direction (1, 0)), x ((0, 1)), y - x + nx - 1 ((1, 1)) or x + y ((1, -1)),
  // in [0, nx + ny).
  template <typename Visit>
  void Sweep(const Visit& visit) const {
    for (int x = 0; x < nx; ++x) {
      // id = base + per_y * y.
      const int base = dx == 0 ? x : dy == 0 ? 0 : dy == 1 ? nx - 1 - x : x;
      const int per_y = dx == 0 ? 0 : 1;
      const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(x) * ny;
      for (int y = 0; y < ny; ++y) visit(base + per_y * y, row + y);
    }
  }
};

// `out` = `in` (nx x ny, cell (x, y) at x * ny + y) dilated by r cells both ways along direction (dx, dy).
void DilateAlong(const std::vector<std::uint8_t>& in, int nx, int ny, int dx, int dy, int r,
                 std::vector<std::uint8_t>* out) {
  out->assign(in.size(), 0);
  for (int j = -r; j <= r; ++j) {
    const int sx = j * dx, sy = j * dy;
    const int y0 = std::max(0, -sy), y1 = std::min(ny, ny - sy);
    for (int x = std::max(0, -sx); x < std::min(nx, nx - sx); ++x) {
      std::uint8_t* o = out->data() + static_cast<std::size_t>(x) * ny;
      const std::uint8_t* i = in.data() + static_cast<std::size_t>(x + sx) * ny + sy;
      int y = y0;
      for (; y + 8 <= y1; y += 8) {  // Eight cells at a time (the rows do not overlap: out != in).
        std::uint64_t a = 0, b = 0;
        std::memcpy(&a, o + y, 8);
        std::memcpy(&b, i + y, 8);
        a |= b;
        std::memcpy(o + y, &a, 8);
      }
      for (; y < y1; ++y) o[y] |= i[y];
    }
  }
}

// Strips of one level (see WorldLoadOptions::fill_strip_max_m): marks in `strip` the cells of gaps of the
// sampled floor `band` (nx x ny, cell (x, y) at x * ny + y) across one direction of kAcross, between floor on
// both sides, with no cell of `barrier` in the gap (an obstacle standing on the level, or the scan saw
// something below the level there: the gap is a real opening, e.g. between two racks over the floor), that
// run on along the strip for kStripMinLengthPerWidth * strip_cells. A sparse floor's edges are ragged (at 20
// points/m^2 and 0.1 m, 82 % of the edge voxels are empty), so:
//  - the floor is first dilated along the strip by half the largest width (which does not narrow the gap
//    across), so that floor seen within that distance along the edge marks the edge;
//  - edges are then found as in hysteresis thresholding (Canny, "A Computational Approach to Edge
//    Detection", PAMI 1986): a run along the strip of gaps at most 1.5 * strip_cells wide is a strip when
//    half of kStripMinLengthPerWidth * strip_cells of its gaps are at most strip_cells wide; a gap that is
//    wider everywhere is no strip.
void MarkStrips(const std::vector<std::uint8_t>& band, const std::vector<std::uint8_t>& barrier, int nx,
                int ny, double strip_cells, std::vector<std::uint8_t>* strip) {
  strip->assign(band.size(), 0);
  std::vector<std::uint8_t> floor(band.size());
  std::vector<std::uint8_t> narrow(band.size());  // 2: at most strip_cells wide, 1: at most 1.5 times that.
  std::vector<std::ptrdiff_t> last(static_cast<std::size_t>(nx + ny));  // Per line: a cell index, or -1.
  std::vector<int> run(static_cast<std::size_t>(nx + ny));              // Per line: cells since `last`.
  std::vector<int> strict(static_cast<std::size_t>(nx + ny));           // Per line: of them, narrow == 2.
  for (const auto& d : kAcross) {
    // Across and along the strip: d turned by 90 deg, (-d.y, d.x), or its opposite, as Lines takes it.
    const Lines across{nx, ny, d[0], d[1]};
    const int flip = d[1] > 0 ? -1 : 1;
    const Lines along{nx, ny, -d[1] * flip, d[0] * flip};
    const double step = std::hypot(d[0], d[1]);
    const int edge_r = std::max(1, static_cast<int>(std::ceil(0.5 * strip_cells / step - 1e-9)));
    DilateAlong(band, nx, ny, along.dx, along.dy, edge_r, &floor);
    // Gaps across: `run` cells without floor after a floor cell (`last`), closed by a floor cell; as wide as
    // the distance between the two floor cells less one cell (the hole rule's measure).
    std::fill(narrow.begin(), narrow.end(), 0);
    std::fill(last.begin(), last.end(), -1);
    std::fill(run.begin(), run.end(), 0);
    across.Sweep([&](int id, std::ptrdiff_t c) {
      const auto i = static_cast<std::size_t>(id);
      if (floor[static_cast<std::size_t>(c)] == 0) {
        ++run[i];
        if (barrier[static_cast<std::size_t>(c)] != 0) last[i] = -1;
        return;
      }
      const double width = (run[i] + 1) * step - 1.0;
      if (last[i] >= 0 && run[i] > 0 && width <= 1.5 * strip_cells + 1e-9) {
        const std::uint8_t mark = width <= strip_cells + 1e-9 ? 2 : 1;
        for (int j = 1; j <= run[i]; ++j) narrow[static_cast<std::size_t>(c - j * across.Step())] = mark;
      }
      last[i] = c;
      run[i] = 0;
    });
    // Strips: runs along the strip of `run` gap cells up to `last`, `strict` of them narrow == 2.
    const int min_run = static_cast<int>(std::ceil(kStripMinLengthPerWidth * strip_cells / step - 1e-9));
    std::fill(run.begin(), run.end(), 0);
    std::fill(strict.begin(), strict.end(), 0);
    const auto flush = [&](std::size_t i) {
      if (run[i] >= min_run && 2 * strict[i] >= min_run) {
        for (int j = 0; j < run[i]; ++j) (*strip)[static_cast<std::size_t>(last[i] - j * along.Step())] = 1;
      }
      run[i] = 0;
      strict[i] = 0;
    };
    along.Sweep([&](int id, std::ptrdiff_t c) {
      const auto i = static_cast<std::size_t>(id);
      const std::uint8_t n = narrow[static_cast<std::size_t>(c)];
      if (n == 0) {
        flush(i);
        return;
      }
      ++run[i];
      strict[i] += n == 2;
      last[i] = c;
    });
    for (std::size_t i = 0; i < run.size(); ++i) flush(i);
  }
}

// 2. Floor hole filling (see WorldLoadOptions::fill_hole_max_m and fill_strip_max_m), one pass: classifies
// the surfaces of `world`, fills the holes and strips found and returns how many voxels it filled, of which
// `*strips` (set) in strips only. Counts surfaces and seen-through holes into `report` (overwritten by each
// pass).
std::int64_t FillFloorHolesPass(World* world, const WorldLoadOptions& options, WorldLoadReport* report,
                                std::int64_t* strips) {
  *strips = 0;
  report->floor_surface_voxels = 0;
  report->overhead_surface_voxels = 0;
  report->holes_seen_through = 0;
  const double res = world->resolution_m();
  const Eigen::Vector3i& dims = world->dims();
  const int nx = dims.x(), ny = dims.y(), nz = dims.z();
  const int clearance = CeilVoxels(options.fill_clearance_m, res);
  const int gap_min = CeilVoxels(options.fill_gap_depth_m, res);
  const int gap_max = CeilVoxels(kGapSearchDepthM, res);
  const double hole_cells = options.fill_hole_max_m / res;
  const int radius = std::max(1, static_cast<int>(std::ceil(hole_cells)));
  auto column = [ny](int ix, int iy) { return static_cast<std::size_t>(ix) * ny + iy; };

  // Occupied runs [bottom, top] of every column, compressed (CSR).
  std::vector<std::int64_t> run_offset(static_cast<std::size_t>(nx) * ny + 1, 0);
  std::vector<std::array<std::int32_t, 2>> runs;
  for (int ix = 0; ix < nx; ++ix) {
    for (int iy = 0; iy < ny; ++iy) {
      for (int iz = 0; iz < nz; ++iz) {
        if (!world->IsOccupiedIndex({ix, iy, iz})) continue;
        const int bottom = iz;
        while (iz + 1 < nz && world->IsOccupiedIndex({ix, iy, iz + 1})) ++iz;
        runs.push_back({static_cast<std::int32_t>(bottom), static_cast<std::int32_t>(iz)});
      }
      run_offset[column(ix, iy) + 1] = static_cast<std::int64_t>(runs.size());
    }
  }
  // True if column (x, y) has an occupied voxel in levels [lo, hi].
  auto occupied_in = [&](int x, int y, int lo, int hi) {
    if (x < 0 || y < 0 || x >= nx || y >= ny || hi < lo) return false;
    const std::size_t c = column(x, y);
    for (std::int64_t i = run_offset[c]; i < run_offset[c + 1]; ++i) {
      const auto& r = runs[static_cast<std::size_t>(i)];
      if (r[0] <= hi && r[1] >= lo) return true;
    }
    return false;
  };
  // Classify the top of every run: a surface has `clearance` free voxels above it inside the map (a ceiling
  // at the top of the map is none). A surface is overhead when its own column is free for `clearance` below
  // its run and something was seen lower (clearance .. gap_max below the run) in its column or in a column
  // within `near` cells (0.2 m): a sparse scan may miss the floor right below a ceiling voxel, not all
  // around it. (So a floor rim within 0.2 m of an opening whose bottom was seen is overhead too: not filled.)
  const int near = std::max(1, static_cast<int>(std::lround(0.2 / res)));
  FloorLevels floor;
  floor.offset.assign(static_cast<std::size_t>(nx) * ny + 1, 0);
  std::vector<int> level_count(static_cast<std::size_t>(nz), 0);
  for (int ix = 0; ix < nx; ++ix) {
    for (int iy = 0; iy < ny; ++iy) {
      const std::size_t c = column(ix, iy);
      for (std::int64_t i = run_offset[c]; i < run_offset[c + 1]; ++i) {
        const int bottom = runs[static_cast<std::size_t>(i)][0];
        const int top = runs[static_cast<std::size_t>(i)][1];
        const int next_bottom = i + 1 < run_offset[c + 1] ? runs[static_cast<std::size_t>(i + 1)][0] : nz;
        if (next_bottom - top - 1 < clearance || top + clearance >= nz) continue;  // Not a surface.
        const int below_top = i > run_offset[c] ? runs[static_cast<std::size_t>(i - 1)][1] : -1;
        bool overhead = false;
        if (bottom - below_top - 1 >= clearance) {
          const int lo = bottom - gap_max, hi = bottom - 1 - clearance;
          for (int dx = -near; dx <= near && !overhead; ++dx) {
            for (int dy = -near; dy <= near && !overhead; ++dy)
              overhead = occupied_in(ix + dx, iy + dy, lo, hi);
          }
        }
        if (overhead) {
          ++report->overhead_surface_voxels;
          continue;
        }
        floor.levels.push_back(static_cast<std::int32_t>(top));
        ++level_count[static_cast<std::size_t>(top)];
        ++report->floor_surface_voxels;
      }
      floor.offset[c + 1] = static_cast<std::int64_t>(floor.levels.size());
    }
  }

  // Per level k, on the band mask B (floor at k - 1 .. k + 1):
  //  (a) a morphological closing of B with a disk of `close_r` cells (Serra, "Image Analysis and Mathematical
  //      Morphology", 1982) turns the sampled floor of a sparse scan into a surface: it fills gaps narrower
  //      than 2 * close_r cells and never grows past a straight or convex edge (a drop);
  //  (b) a cell outside the closed mask C is a hole when C, or an obstacle standing on level k (a wall),
  //      closes it in all kSectors directions within `radius` cells and the hole through it is at most
  //      fill_hole_max_m wide in every direction;
  //  (c) a cell outside B lies in a strip of B (MarkStrips(): at most fill_strip_max_m wide across, floor on
  //      both sides, however long; measured on B: the closing fills part of a narrow strip and would cut it
  //      into pieces too short to be strips).
  // Cells of C \ B must be closed in all directions too, or lie in a strip (the closing alone would round
  // the corners of a stairwell).
  // Either way the voxel at k must be free with `clearance` free voxels above it, the level k must be the
  // most common floor level around it, and nothing may be seen gap_min .. gap_max voxels below it.
  const int close_r =
      std::max(1, static_cast<int>(std::lround(std::min(0.2, 0.5 * options.fill_hole_max_m) / res)));
  const std::vector<SectorOffset> disk = DiskOffsets(radius);
  const std::vector<SectorOffset> close_disk = DiskOffsets(close_r);
  std::vector<std::uint8_t> band(static_cast<std::size_t>(nx) * ny);
  std::vector<std::uint8_t> dilated(band.size());
  std::vector<std::uint8_t> closed(band.size());
  std::vector<std::uint8_t> strip(band.size(), 0);
  const bool fill_strips = options.fill_strip_max_m > 0.0;
  const double strip_cells = options.fill_strip_max_m / res;
  // An obstacle stands on level k (occupied in k .. k + clearance).
  std::vector<std::uint8_t> wall(band.size());
  // A strip may not cross a wall, nor a column within `near` cells of one in which the scan saw something
  // 2 .. gap_max voxels below level k: below the band a floor may spread over, so the gap is an opening over
  // a lower surface (between two racks, beside a step or a pallet over the floor). Within `near`, as for
  // overhead surfaces: a sparse scan misses the floor right below.
  std::vector<std::uint8_t> seen_below(band.size());
  std::vector<std::uint8_t> barrier(band.size());
  std::vector<std::int32_t> sat(static_cast<std::size_t>(nx + 1) * (ny + 1));  // Summed-area table of C.
  auto sat_at = [&sat, ny](int x, int y) -> std::int32_t& {
    return sat[static_cast<std::size_t>(x) * (ny + 1) + y];
  };
  auto in_grid = [nx, ny](int x, int y) { return x >= 0 && y >= 0 && x < nx && y < ny; };
  std::vector<Eigen::Vector3i> fill;
  for (int k = 0; k + clearance < nz; ++k) {
    const int support = level_count[static_cast<std::size_t>(k)] +
                        (k > 0 ? level_count[static_cast<std::size_t>(k - 1)] : 0) +
                        level_count[static_cast<std::size_t>(k + 1)];
    // Only levels with a floor of some extent (0.5 m^2 of sampled floor in the band): not every shelf top.
    if (support < std::max(kSectors, static_cast<int>(0.5 / (res * res)))) continue;
    for (int ix = 0; ix < nx; ++ix) {
      for (int iy = 0; iy < ny; ++iy) {
        band[column(ix, iy)] = floor.Near(column(ix, iy), k) >= 0 ? 1 : 0;
        wall[column(ix, iy)] = occupied_in(ix, iy, k, k + clearance) ? 1 : 0;
        if (fill_strips) seen_below[column(ix, iy)] = occupied_in(ix, iy, k - gap_max, k - 2) ? 1 : 0;
      }
    }
    for (int ix = 0; ix < nx; ++ix) {  // Dilation.
      for (int iy = 0; iy < ny; ++iy) {
        std::uint8_t d = band[column(ix, iy)];
        for (std::size_t i = 0; i < close_disk.size() && d == 0; ++i) {
          const int x = ix + close_disk[i].dx, y = iy + close_disk[i].dy;
          d = in_grid(x, y) ? band[column(x, y)] : 0;
        }
        dilated[column(ix, iy)] = d;
      }
    }
    for (int ix = 0; ix < nx; ++ix) {  // Erosion of the dilation (outside the grid counts as set).
      for (int iy = 0; iy < ny; ++iy) {
        std::uint8_t e = dilated[column(ix, iy)];
        for (std::size_t i = 0; i < close_disk.size() && e != 0; ++i) {
          const int x = ix + close_disk[i].dx, y = iy + close_disk[i].dy;
          e = in_grid(x, y) ? dilated[column(x, y)] : 1;
        }
        closed[column(ix, iy)] = e;
      }
    }
    for (int ix = 0; ix < nx; ++ix) {
      for (int iy = 0; iy < ny; ++iy) {
        sat_at(ix + 1, iy + 1) =
            closed[column(ix, iy)] + sat_at(ix, iy + 1) + sat_at(ix + 1, iy) - sat_at(ix, iy);
      }
    }
    if (fill_strips) {
      DilateAlong(seen_below, nx, ny, 1, 0, near, &barrier);
      DilateAlong(barrier, nx, ny, 0, 1, near, &seen_below);
      for (std::size_t c = 0; c < barrier.size(); ++c)
        barrier[c] = wall[c] != 0 || seen_below[c] != 0 ? 1 : 0;
      MarkStrips(band, barrier, nx, ny, strip_cells, &strip);
    }
    for (int ix = 0; ix < nx; ++ix) {
      for (int iy = 0; iy < ny; ++iy) {
        if (band[column(ix, iy)] != 0) continue;
        const bool by_closing = closed[column(ix, iy)] != 0;
        const bool by_strip = strip[column(ix, iy)] != 0;
        if (!by_closing && !by_strip) {
          const int x0 = std::max(0, ix - radius), x1 = std::min(nx, ix + radius + 1);
          const int y0 = std::max(0, iy - radius), y1 = std::min(ny, iy + radius + 1);
          if (sat_at(x1, y1) - sat_at(x0, y1) - sat_at(x1, y0) + sat_at(x0, y0) < kSectors / 2) continue;
        }
        // The hole voxel and the clearance above it are free, inside the map.
        bool clear = true;
        for (int dz = 0; dz <= clearance && clear; ++dz) clear = !world->IsOccupiedIndex({ix, iy, k + dz});
        if (!clear) continue;
        // Nearest closed-surface cell per direction; level votes from the sampled floor (B) around.
        std::array<const SectorOffset*, kSectors> nearest{};  // Nearest closed cell per sector.
        std::array<int, 3> votes{0, 0, 0};                    // Floor levels k - 1, k, k + 1 seen around.
        int found = 0;
        int floor_sectors = 0;  // Sectors closed by floor (the others by a wall).
        for (const SectorOffset& o : disk) {
          const int x = ix + o.dx, y = iy + o.dy;
          if (!in_grid(x, y)) continue;
          if (band[column(x, y)] != 0 && votes[0] + votes[1] + votes[2] < kSectors) {
            ++votes[static_cast<std::size_t>(floor.Near(column(x, y), k) - k + 1)];
          }
          if (nearest[static_cast<std::size_t>(o.sector)] != nullptr) continue;
          // Floor, or an obstacle standing on the floor level (a wall): a hole between them is a floor hole.
          const bool is_floor = closed[column(x, y)] != 0;
          if (!is_floor && wall[column(x, y)] == 0) continue;
          nearest[static_cast<std::size_t>(o.sector)] = &o;
          floor_sectors += is_floor;
          if (++found == kSectors && votes[0] + votes[1] + votes[2] >= kSectors) break;
        }
        // Enclosed: floor or a wall in every direction (so a floor edge, a drop, is never grown).
        // At least half of them floor: a nook between walls whose floor nobody saw stays unknown.
        bool hole = found == kSectors && floor_sectors >= kSectors / 2;
        if (hole && !by_closing) {
          // Narrow: the gap between the nearest cells of opposite directions is at most hole_cells.
          for (int s = 0; s < kSectors / 2 && hole; ++s) {
            const SectorOffset& a = *nearest[static_cast<std::size_t>(s)];
            const SectorOffset& b = *nearest[static_cast<std::size_t>(s + kSectors / 2)];
            hole = std::hypot(a.dx - b.dx, a.dy - b.dy) - 1.0 <= hole_cells + 1e-9;
          }
        }
        if (!hole && !by_strip) continue;
        // The surface around is at this level (one fill per hole, at the most common level).
        if (votes[1] == 0 || votes[1] < votes[0] || votes[1] < votes[2]) continue;
        // Not a real gap: nothing seen gap_min..gap_max voxels below.
        bool seen_through = false;
        for (int d = gap_min; d <= gap_max && k - d >= 0 && !seen_through; ++d) {
          seen_through = world->IsOccupiedIndex({ix, iy, k - d});
        }
        if (seen_through) {
          ++report->holes_seen_through;
          continue;
        }
        fill.emplace_back(ix, iy, k);
        *strips += !hole;
      }
    }
  }
  for (const Eigen::Vector3i& v : fill) world->SetOccupied(v);
  return static_cast<std::int64_t>(fill.size());
}

// Passes of FillFloorHolesPass() until nothing changes (at most kMaxFillPasses): a sparse floor's holes have
// rough edges, which the cells filled by a pass smooth for the next one. A pass never fills a cell without
// floor within fill_hole_max_m in every direction or, in a strip, on both sides within 1.5 *
// fill_strip_max_m, so passes cannot grow the floor past an edge or across a wide gap.
void FillFloorHoles(World* world, const WorldLoadOptions& options, WorldLoadReport* report) {
  if (options.fill_hole_max_m <= 0.0) return;
  constexpr int kMaxFillPasses = 2;
  for (int pass = 0; pass < kMaxFillPasses; ++pass) {
    std::int64_t strips = 0;
    const std::int64_t filled = FillFloorHolesPass(world, options, report, &strips);
    report->voxels_filled_floor += filled;
    report->voxels_filled_strip += strips;
    if (filled == 0) break;
  }
}

}  // namespace

void CleanUpScannedWorld(World* world, const WorldLoadOptions& options, const PointCounts* counts,
                         WorldLoadReport* report) {
  const auto t0 = std::chrono::steady_clock::now();
  report->voxels_read = world->CountOccupied();
  RemoveUnsupported(world, options, counts, report);
  FillFloorHoles(world, options, report);
  report->cleanup_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (world->CountOccupied() == 0) {
    throw WorldError("world file '" + world->name() +
                     "' has no occupied voxel left after the support filter (" +
                     std::to_string(report->voxels_read) +
                     " read, all unsupported; lower WorldLoadOptions::min_support_neighbors or set "
                     "support_radius_m = 0)");
  }
}

}  // namespace cairn::sim::internal
