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

// 2. Floor hole filling (see WorldLoadOptions::fill_hole_max_m and fill_strip_max_m), one pass over `world`:
// classifies its surfaces, then fills the holes and strips of each floor level.
//
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
class FloorHolePass {
 public:
  // Counts surfaces and seen-through holes into `report` (overwritten by each pass).
  FloorHolePass(World* world, const WorldLoadOptions& options, WorldLoadReport* report)
      : world_(world),
        report_(report),
        nx_(world->dims().x()),
        ny_(world->dims().y()),
        nz_(world->dims().z()) {
    const double res = world->resolution_m();
    limits_.clearance = CeilVoxels(options.fill_clearance_m, res);
    limits_.gap_min = CeilVoxels(options.fill_gap_depth_m, res);
    limits_.gap_max = CeilVoxels(kGapSearchDepthM, res);
    limits_.hole_cells = options.fill_hole_max_m / res;
    limits_.radius = std::max(1, static_cast<int>(std::ceil(limits_.hole_cells)));
    limits_.near = std::max(1, static_cast<int>(std::lround(0.2 / res)));
    limits_.close_r =
        std::max(1, static_cast<int>(std::lround(std::min(0.2, 0.5 * options.fill_hole_max_m) / res)));
    limits_.fill_strips = options.fill_strip_max_m > 0.0;
    limits_.strip_cells = options.fill_strip_max_m / res;
    limits_.min_support = std::max(kSectors, static_cast<int>(0.5 / (res * res)));
  }

  // Fills what it finds; returns how many voxels it filled, of which `*strips` (set) in strips only.
  std::int64_t Run(std::int64_t* strips) {
    *strips = 0;
    report_->floor_surface_voxels = 0;
    report_->overhead_surface_voxels = 0;
    report_->holes_seen_through = 0;
    IndexRuns();
    ClassifySurfaces();
    disk_ = DiskOffsets(limits_.radius);
    close_disk_ = DiskOffsets(limits_.close_r);
    masks_.Resize(static_cast<std::size_t>(nx_) * ny_, static_cast<std::size_t>(nx_ + 1) * (ny_ + 1));
    std::vector<Eigen::Vector3i> fill;
    for (int k = 0; k + limits_.clearance < nz_; ++k) {
      if (!LevelHasFloor(k)) continue;
      BuildMasks(k);
      for (int ix = 0; ix < nx_; ++ix) {
        for (int iy = 0; iy < ny_; ++iy) {
          const CellFill verdict = Judge(ix, iy, k);
          if (verdict == CellFill::kNone) continue;
          fill.emplace_back(ix, iy, k);
          *strips += verdict == CellFill::kStrip;
        }
      }
    }
    for (const Eigen::Vector3i& v : fill) world_->SetOccupied(v);
    return static_cast<std::int64_t>(fill.size());
  }

 private:
  // Voxel counts and cell radii from the options, at the world's resolution.
  struct Limits {
    int clearance = 0;             // free voxels a surface needs above it
    int gap_min = 0, gap_max = 0;  // a hole with something seen this far below is a real gap
    double hole_cells = 0.0;       // widest hole filled, cells
    int radius = 0;                // cells searched around a hole cell
    int near = 0;                  // cells within which a sparse scan may miss the floor below (0.2 m)
    int close_r = 0;               // radius of the closing's disk, cells
    bool fill_strips = false;
    double strip_cells = 0.0;  // widest strip filled, cells
    int min_support = 0;       // sampled floor cells a level needs in its band (0.5 m^2)
  };
  // The masks of level k (one byte per column) and the summed-area table of the closed mask.
  struct LevelMasks {
    std::vector<std::uint8_t> band, dilated, closed, strip, wall, seen_below, barrier;
    std::vector<std::int32_t> sat;
    void Resize(std::size_t cells, std::size_t sat_cells) {
      for (auto* m : {&band, &dilated, &closed, &wall, &seen_below, &barrier}) m->assign(cells, 0);
      strip.assign(cells, 0);
      sat.assign(sat_cells, 0);
    }
  };
  enum class CellFill { kNone, kHole, kStrip };
  // The nearest closing cell (floor or wall) per direction sector around a cell, and the floor levels seen.
  struct SectorScan {
    std::array<const SectorOffset*, kSectors> nearest{};
    std::array<int, 3> votes{0, 0, 0};  // floor levels k - 1, k, k + 1 seen around
    int found = 0;
    int floor_sectors = 0;  // sectors closed by floor (the others by a wall)
  };

  std::size_t Column(int ix, int iy) const { return static_cast<std::size_t>(ix) * ny_ + iy; }
  bool InGrid(int x, int y) const { return x >= 0 && y >= 0 && x < nx_ && y < ny_; }
  std::int32_t& Sat(int x, int y) { return masks_.sat[static_cast<std::size_t>(x) * (ny_ + 1) + y]; }

  // Occupied runs [bottom, top] of every column, compressed (CSR).
  void IndexRuns() {
    run_offset_.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
    runs_.clear();
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        for (int iz = 0; iz < nz_; ++iz) {
          if (!world_->IsOccupiedIndex({ix, iy, iz})) continue;
          const int bottom = iz;
          while (iz + 1 < nz_ && world_->IsOccupiedIndex({ix, iy, iz + 1})) ++iz;
          runs_.push_back({static_cast<std::int32_t>(bottom), static_cast<std::int32_t>(iz)});
        }
        run_offset_[Column(ix, iy) + 1] = static_cast<std::int64_t>(runs_.size());
      }
    }
  }

  // True if column (x, y) has an occupied voxel in levels [lo, hi].
  bool OccupiedIn(int x, int y, int lo, int hi) const {
    if (!InGrid(x, y) || hi < lo) return false;
    const std::size_t c = Column(x, y);
    for (std::int64_t i = run_offset_[c]; i < run_offset_[c + 1]; ++i) {
      const auto& r = runs_[static_cast<std::size_t>(i)];
      if (r[0] <= hi && r[1] >= lo) return true;
    }
    return false;
  }

  // Classifies the top of every run: a surface has `clearance` free voxels above it inside the map (a ceiling
  // at the top of the map is none). A surface is overhead when its own column is free for `clearance` below
  // its run and something was seen lower (clearance .. gap_max below the run) in its column or in a column
  // within `near` cells (0.2 m): a sparse scan may miss the floor right below a ceiling voxel, not all
  // around it. (So a floor rim within 0.2 m of an opening whose bottom was seen is overhead too: not filled.)
  void ClassifySurfaces() {
    floor_ = FloorLevels{};
    floor_.offset.assign(static_cast<std::size_t>(nx_) * ny_ + 1, 0);
    level_count_.assign(static_cast<std::size_t>(nz_), 0);
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        const std::size_t c = Column(ix, iy);
        for (std::int64_t i = run_offset_[c]; i < run_offset_[c + 1]; ++i) {
          const int bottom = runs_[static_cast<std::size_t>(i)][0];
          const int top = runs_[static_cast<std::size_t>(i)][1];
          const int next_bottom =
              i + 1 < run_offset_[c + 1] ? runs_[static_cast<std::size_t>(i + 1)][0] : nz_;
          if (next_bottom - top - 1 < limits_.clearance || top + limits_.clearance >= nz_) continue;
          const int below_top = i > run_offset_[c] ? runs_[static_cast<std::size_t>(i - 1)][1] : -1;
          if (bottom - below_top - 1 >= limits_.clearance && SeenBelowNear(ix, iy, bottom)) {
            ++report_->overhead_surface_voxels;
            continue;
          }
          floor_.levels.push_back(static_cast<std::int32_t>(top));
          ++level_count_[static_cast<std::size_t>(top)];
          ++report_->floor_surface_voxels;
        }
        floor_.offset[c + 1] = static_cast<std::int64_t>(floor_.levels.size());
      }
    }
  }

  // Something was seen clearance .. gap_max below a run starting at `bottom`, in column (ix, iy) or within
  // `near` cells of it.
  bool SeenBelowNear(int ix, int iy, int bottom) const {
    const int lo = bottom - limits_.gap_max, hi = bottom - 1 - limits_.clearance;
    for (int dx = -limits_.near; dx <= limits_.near; ++dx) {
      for (int dy = -limits_.near; dy <= limits_.near; ++dy) {
        if (OccupiedIn(ix + dx, iy + dy, lo, hi)) return true;
      }
    }
    return false;
  }

  // Only levels with a floor of some extent (0.5 m^2 of sampled floor in the band): not every shelf top.
  bool LevelHasFloor(int k) const {
    const int support = level_count_[static_cast<std::size_t>(k)] +
                        (k > 0 ? level_count_[static_cast<std::size_t>(k - 1)] : 0) +
                        level_count_[static_cast<std::size_t>(k) + 1];
    return support >= limits_.min_support;
  }

  // The band, walls (an obstacle standing on level k: occupied in k .. k + clearance), its closing and the
  // closing's summed-area table, and the strips of level k.
  void BuildMasks(int k) {
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        const std::size_t c = Column(ix, iy);
        masks_.band[c] = floor_.Near(c, k) >= 0 ? 1 : 0;
        masks_.wall[c] = OccupiedIn(ix, iy, k, k + limits_.clearance) ? 1 : 0;
        if (limits_.fill_strips)
          masks_.seen_below[c] = OccupiedIn(ix, iy, k - limits_.gap_max, k - 2) ? 1 : 0;
      }
    }
    CloseBand();
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        Sat(ix + 1, iy + 1) = masks_.closed[Column(ix, iy)] + Sat(ix, iy + 1) + Sat(ix + 1, iy) - Sat(ix, iy);
      }
    }
    if (limits_.fill_strips) {
      // A strip may not cross a wall, nor a column within `near` cells of one in which the scan saw something
      // 2 .. gap_max voxels below level k: below the band a floor may spread over, so the gap is an opening
      // over a lower surface (between two racks, beside a step or a pallet over the floor). Within `near`, as
      // for overhead surfaces: a sparse scan misses the floor right below.
      DilateAlong(masks_.seen_below, nx_, ny_, 1, 0, limits_.near, &masks_.barrier);
      DilateAlong(masks_.barrier, nx_, ny_, 0, 1, limits_.near, &masks_.seen_below);
      for (std::size_t c = 0; c < masks_.barrier.size(); ++c) {
        masks_.barrier[c] = masks_.wall[c] != 0 || masks_.seen_below[c] != 0 ? 1 : 0;
      }
      MarkStrips(masks_.band, masks_.barrier, nx_, ny_, limits_.strip_cells, &masks_.strip);
    }
  }

  // closed = the band dilated, then eroded (outside the grid counts as set), by the closing's disk.
  void CloseBand() {
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        std::uint8_t d = masks_.band[Column(ix, iy)];
        for (std::size_t i = 0; i < close_disk_.size() && d == 0; ++i) {
          const int x = ix + close_disk_[i].dx, y = iy + close_disk_[i].dy;
          d = InGrid(x, y) ? masks_.band[Column(x, y)] : 0;
        }
        masks_.dilated[Column(ix, iy)] = d;
      }
    }
    for (int ix = 0; ix < nx_; ++ix) {
      for (int iy = 0; iy < ny_; ++iy) {
        std::uint8_t e = masks_.dilated[Column(ix, iy)];
        for (std::size_t i = 0; i < close_disk_.size() && e != 0; ++i) {
          const int x = ix + close_disk_[i].dx, y = iy + close_disk_[i].dy;
          e = InGrid(x, y) ? masks_.dilated[Column(x, y)] : 1;
        }
        masks_.closed[Column(ix, iy)] = e;
      }
    }
  }

  // Whether the free cell (ix, iy) of level k is filled, and as what (rules (a) to (c) above).
  CellFill Judge(int ix, int iy, int k) {
    const std::size_t c = Column(ix, iy);
    if (masks_.band[c] != 0) return CellFill::kNone;
    const bool by_closing = masks_.closed[c] != 0;
    const bool by_strip = masks_.strip[c] != 0;
    if (!by_closing && !by_strip) {
      const int r = limits_.radius;
      const int x0 = std::max(0, ix - r), x1 = std::min(nx_, ix + r + 1);
      const int y0 = std::max(0, iy - r), y1 = std::min(ny_, iy + r + 1);
      if (Sat(x1, y1) - Sat(x0, y1) - Sat(x1, y0) + Sat(x0, y0) < kSectors / 2) return CellFill::kNone;
    }
    // The hole voxel and the clearance above it are free, inside the map.
    for (int dz = 0; dz <= limits_.clearance; ++dz) {
      if (world_->IsOccupiedIndex({ix, iy, k + dz})) return CellFill::kNone;
    }
    const SectorScan scan = ScanSectors(ix, iy, k);
    // Enclosed: floor or a wall in every direction (so a floor edge, a drop, is never grown). At least half
    // of them floor: a nook between walls whose floor nobody saw stays unknown.
    bool hole = scan.found == kSectors && scan.floor_sectors >= kSectors / 2;
    if (hole && !by_closing) hole = Narrow(scan);
    if (!hole && !by_strip) return CellFill::kNone;
    // The surface around is at this level (one fill per hole, at the most common level).
    const auto& votes = scan.votes;
    if (votes[1] == 0 || votes[1] < votes[0] || votes[1] < votes[2]) return CellFill::kNone;
    // Not a real gap: nothing seen gap_min..gap_max voxels below.
    for (int d = limits_.gap_min; d <= limits_.gap_max && k - d >= 0; ++d) {
      if (world_->IsOccupiedIndex({ix, iy, k - d})) {
        ++report_->holes_seen_through;
        return CellFill::kNone;
      }
    }
    return hole ? CellFill::kHole : CellFill::kStrip;
  }

  // The nearest closed-surface cell per direction; level votes from the sampled floor (B) around.
  SectorScan ScanSectors(int ix, int iy, int k) const {
    SectorScan scan;
    for (const SectorOffset& o : disk_) {
      const int x = ix + o.dx, y = iy + o.dy;
      if (!InGrid(x, y)) continue;
      const std::size_t c = Column(x, y);
      if (masks_.band[c] != 0 && scan.votes[0] + scan.votes[1] + scan.votes[2] < kSectors) {
        const int vote = floor_.Near(c, k) - k + 1;  // 0: below, 1: this level, 2: above
        ++scan.votes[static_cast<std::size_t>(vote)];
      }
      if (scan.nearest[static_cast<std::size_t>(o.sector)] != nullptr) continue;
      // Floor, or an obstacle standing on the floor level (a wall): a hole between them is a floor hole.
      const bool is_floor = masks_.closed[c] != 0;
      if (!is_floor && masks_.wall[c] == 0) continue;
      scan.nearest[static_cast<std::size_t>(o.sector)] = &o;
      scan.floor_sectors += is_floor;
      if (++scan.found == kSectors && scan.votes[0] + scan.votes[1] + scan.votes[2] >= kSectors) break;
    }
    return scan;
  }

  // Narrow: the gap between the nearest cells of opposite directions is at most hole_cells.
  bool Narrow(const SectorScan& scan) const {
    for (int s = 0; s < kSectors / 2; ++s) {
      const SectorOffset& a = *scan.nearest[static_cast<std::size_t>(s)];
      const SectorOffset& b = *scan.nearest[static_cast<std::size_t>(s) + kSectors / 2];
      if (std::hypot(a.dx - b.dx, a.dy - b.dy) - 1.0 > limits_.hole_cells + 1e-9) return false;
    }
    return true;
  }

  World* world_;
  WorldLoadReport* report_;
  const int nx_, ny_, nz_;
  Limits limits_;
  std::vector<std::int64_t> run_offset_;
  std::vector<std::array<std::int32_t, 2>> runs_;
  FloorLevels floor_;
  std::vector<int> level_count_;  // floor surfaces per level
  std::vector<SectorOffset> disk_, close_disk_;
  LevelMasks masks_;
};

// Passes of FloorHolePass until nothing changes (at most kMaxFillPasses): a sparse floor's holes have
// rough edges, which the cells filled by a pass smooth for the next one. A pass never fills a cell without
// floor within fill_hole_max_m in every direction or, in a strip, on both sides within 1.5 *
// fill_strip_max_m, so passes cannot grow the floor past an edge or across a wide gap.
void FillFloorHoles(World* world, const WorldLoadOptions& options, WorldLoadReport* report) {
  if (options.fill_hole_max_m <= 0.0) return;
  constexpr int kMaxFillPasses = 2;
  for (int pass = 0; pass < kMaxFillPasses; ++pass) {
    std::int64_t strips = 0;
    const std::int64_t filled = FloorHolePass(world, options, report).Run(&strips);
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
