// Copyright Cairn authors.
#include "cairn/sim/builtin_worlds.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "builtin_plant.h"

namespace cairn::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- Seeded value noise ---------------------------------------------------------------------------------
// Lattice values from a SplitMix64 hash of (i, j, seed, channel), blended with a smoothstep: smooth,
// deterministic on every platform, in [-1, 1].

std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

double LatticeValue(std::int64_t i, std::int64_t j, std::uint32_t seed, std::uint32_t channel) {
  const std::uint64_t h = SplitMix64(
      static_cast<std::uint64_t>(i) * 0x1F1F1F1Full ^
      SplitMix64(static_cast<std::uint64_t>(j) ^ (static_cast<std::uint64_t>(seed) << 32 | channel)));
  return static_cast<double>(h >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

double ValueNoise(double x_m, double y_m, double scale_m, std::uint32_t seed, std::uint32_t channel) {
  const double u = x_m / scale_m;
  const double v = y_m / scale_m;
  const double fu = std::floor(u);
  const double fv = std::floor(v);
  const auto i = static_cast<std::int64_t>(fu);
  const auto j = static_cast<std::int64_t>(fv);
  auto smooth = [](double t) { return t * t * (3.0 - 2.0 * t); };
  const double su = smooth(u - fu);
  const double sv = smooth(v - fv);
  const double a = LatticeValue(i, j, seed, channel);
  const double b = LatticeValue(i + 1, j, seed, channel);
  const double c = LatticeValue(i, j + 1, seed, channel);
  const double d = LatticeValue(i + 1, j + 1, seed, channel);
  return (a * (1 - su) + b * su) * (1 - sv) + (c * (1 - su) + d * su) * sv;
}

double DistanceToSegment(double x, double y, double ax, double ay, double bx, double by) {
  const double dx = bx - ax;
  const double dy = by - ay;
  const double len2 = dx * dx + dy * dy;
  const double t = len2 > 0 ? std::clamp(((x - ax) * dx + (y - ay) * dy) / len2, 0.0, 1.0) : 0.0;
  return std::hypot(x - (ax + t * dx), y - (ay + t * dy));
}

// ---- Column-based builder --------------------------------------------------------------------------------
// Both worlds are described per (x, y) column: a carved free column has a floor slab below the floor
// surface, optional solid steps, free space up to its ceiling and rock above; a column within the wall
// thickness of a free column is solid from the floor slab to the top of the grid; other columns are empty.

struct Column {
  bool free = false;       // Carved (walkable) column.
  double solid_top_m = 0;  // Top of the solid floor/steps, metres (>= floor surface).
  double ceiling_m = 1e9;  // Bottom of the rock above, metres (1e9: none).
};

World BuildFromColumns(const std::string& name, const Eigen::Vector3d& p_W_min, double res,
                       const Eigen::Vector3i& dims, double floor_bottom_m, double wall_thickness_m,
                       const std::function<Column(double, double)>& column_at) {
  World world(name, p_W_min, res, dims);
  const int nx = dims.x();
  const int ny = dims.y();
  const int nz = dims.z();
  std::vector<Column> columns(static_cast<std::size_t>(nx) * ny);
  for (int ix = 0; ix < nx; ++ix) {
    for (int iy = 0; iy < ny; ++iy) {
      const Eigen::Vector3d c = world.CenterOf({ix, iy, 0});
      columns[static_cast<std::size_t>(ix) * ny + iy] = column_at(c.x(), c.y());
    }
  }
  auto z_index = [&](double z_m) { return static_cast<int>(std::lround((z_m - p_W_min.z()) / res)); };
  const int iz_floor_bottom = std::clamp(z_index(floor_bottom_m), 0, nz);
  const int wall_cells = static_cast<int>(std::ceil(wall_thickness_m / res - 1e-9));
  for (int ix = 0; ix < nx; ++ix) {
    for (int iy = 0; iy < ny; ++iy) {
      const Column& col = columns[static_cast<std::size_t>(ix) * ny + iy];
      int iz_solid_end = 0;    // Voxels [iz_floor_bottom, iz_solid_end) are solid.
      int iz_rock_begin = nz;  // Voxels [iz_rock_begin, nz) are solid.
      if (col.free) {
        iz_solid_end = std::clamp(z_index(col.solid_top_m), 0, nz);
        iz_rock_begin = col.ceiling_m > 1e8 ? nz : std::clamp(z_index(col.ceiling_m), 0, nz);
      } else {
        bool near_free = false;
        for (int dx = -wall_cells; dx <= wall_cells && !near_free; ++dx) {
          for (int dy = -wall_cells; dy <= wall_cells && !near_free; ++dy) {
            const int jx = ix + dx;
            const int jy = iy + dy;
            if (jx < 0 || jy < 0 || jx >= nx || jy >= ny) continue;
            if (std::hypot(dx, dy) * res > wall_thickness_m + 1e-9) continue;
            near_free = columns[static_cast<std::size_t>(jx) * ny + jy].free;
          }
        }
        if (!near_free) continue;
        iz_solid_end = nz;  // Wall: solid from the floor slab to the top of the grid.
      }
      for (int iz = iz_floor_bottom; iz < iz_solid_end; ++iz) world.SetOccupied({ix, iy, iz});
      for (int iz = std::max(iz_rock_begin, iz_solid_end); iz < nz; ++iz) world.SetOccupied({ix, iy, iz});
    }
  }
  return world;
}

// ---- "tunnels" -------------------------------------------------------------------------------------------

struct Segment {
  double ax, ay, bx, by;
};

World MakeTunnels(std::uint32_t seed) {
  // Tunnel centre lines: main W-E tunnel into the room, an X junction at (30, 20) and two L bends.
  static const Segment kSegments[] = {
      {2.0, 20.0, 46.0, 20.0},   // Main tunnel, west end to the room.
      {30.0, 20.0, 30.0, 5.0},   // South branch.
      {30.0, 20.0, 30.0, 35.0},  // North branch.
      {30.0, 5.0, 55.0, 5.0},    // South branch bends east (L).
      {30.0, 35.0, 12.0, 35.0},  // North branch bends west (L).
  };
  constexpr double kHalfWidth = 1.5;  // Mean tunnel half width, metres.
  constexpr double kCeiling = 3.0;    // Mean tunnel height, metres.
  constexpr double kRoomCeiling = 3.5;
  auto column_at = [seed](double x, double y) {
    Column col;
    double d = 1e9;
    for (const Segment& s : kSegments) d = std::min(d, DistanceToSegment(x, y, s.ax, s.ay, s.bx, s.by));
    const double half_width =
        kHalfWidth + 0.22 * ValueNoise(x, y, 1.5, seed, 1) + 0.06 * ValueNoise(x, y, 0.35, seed, 2);
    const bool in_tunnel = d <= half_width;
    // Room x in [46, 56], y in [15, 25] with walls rough by up to 0.12 m.
    const double inside = std::min({x - 46.0, 56.0 - x, y - 15.0, 25.0 - y});
    const bool in_room = inside > 0.12 * (1.0 + ValueNoise(x, y, 0.8, seed, 3));
    if (!in_tunnel && !in_room) return col;
    col.free = true;
    col.solid_top_m = 0.0;
    col.ceiling_m = in_room ? kRoomCeiling : kCeiling + 0.25 * ValueNoise(x, y, 2.0, seed, 4);
    if (in_room && y >= 22.5) {
      if (x >= 52.5) {
        col.solid_top_m = 1.0;  // Platform.
      } else if (x >= 50.0) {
        col.solid_top_m = 0.2 * (std::floor((x - 50.0) / 0.5) + 1.0);  // Steps of 0.2 m rise, 0.5 m run.
      }
    }
    return col;
  };
  return BuildFromColumns("builtin:tunnels", Eigen::Vector3d(0.0, 0.0, -0.3), 0.1,
                          Eigen::Vector3i(600, 400, 41),
                          /*floor_bottom_m=*/-0.2, /*wall_thickness_m=*/0.3, column_at);
}

// ---- "narrow" -------------------------------------------------------------------------------------------

World MakeNarrow(std::uint32_t seed) {
  // Two 2 m wide tunnels along x (centre lines y = 5 and y = 15, x in [2, 32]) joined at their west end by a
  // 2 m wide tunnel at x = 2, each with a 2 x 2.5 m bay on its north wall at x in [19, 21]: a tunnel too
  // narrow for two robots to pass, and the one spot where one can stand aside (get-out-of-the-way).
  static const Segment kSegments[] = {
      {2.0, 5.0, 32.0, 5.0},
      {2.0, 15.0, 32.0, 15.0},
      {2.0, 5.0, 2.0, 15.0},
  };
  constexpr double kHalfWidth = 1.0;
  auto column_at = [seed](double x, double y) {
    Column col;
    double d = 1e9;
    for (const Segment& s : kSegments) {
      d = std::min(
          d, std::max(std::abs(x - std::clamp(x, s.ax, s.bx)), std::abs(y - std::clamp(y, s.ay, s.by))));
    }
    const bool in_tunnel = d <= kHalfWidth;
    const bool in_bay = x >= 19.0 && x <= 21.0 && ((y > 5.0 && y <= 8.5) || (y > 15.0 && y <= 18.5));
    if (!in_tunnel && !in_bay) return col;
    col.free = true;
    col.solid_top_m = 0.0;
    col.ceiling_m = 2.5 + 0.2 * ValueNoise(x, y, 2.0, seed, 4);
    return col;
  };
  return BuildFromColumns("builtin:narrow", Eigen::Vector3d(0.0, 0.0, -0.3), 0.1,
                          Eigen::Vector3i(340, 200, 33),
                          /*floor_bottom_m=*/-0.2, /*wall_thickness_m=*/0.3, column_at);
}

// ---- "arena" ---------------------------------------------------------------------------------------------

World MakeArena() {
  auto column_at = [](double x, double y) {
    Column col;
    if (x < 0.2 || y < 0.2 || x > 19.8 || y > 13.8) return col;  // Wall ring (built from the free columns).
    static const double kPillars[][2] = {{10.0, 7.0}, {5.0, 10.0}, {15.0, 4.0}};
    for (const auto& p : kPillars) {
      if (std::abs(x - p[0]) < 0.5 && std::abs(y - p[1]) < 0.5) return col;
    }
    col.free = true;
    col.solid_top_m = (x >= 3.0 && x < 6.0 && y >= 2.0 && y < 5.0) ? 0.1 : 0.0;
    return col;
  };
  return BuildFromColumns("builtin:arena", Eigen::Vector3d(0.0, 0.0, -0.2), 0.1,
                          Eigen::Vector3i(200, 140, 17),
                          /*floor_bottom_m=*/-0.2, /*wall_thickness_m=*/0.2, column_at);
}

// ---- "building" ------------------------------------------------------------------------------------------
// Two floors joined by a switchback stairwell, built from axis-aligned boxes (a voxel is occupied when its
// centre lies in a solid box and in no opening). Dimensions in the header's description.

struct Box {
  double x0, x1, y0, y1, z0, z1;
  bool Contains(const Eigen::Vector3d& p) const {
    return p.x() > x0 && p.x() < x1 && p.y() > y0 && p.y() < y1 && p.z() > z0 && p.z() < z1;
  }
};

World MakeBuilding() {
  constexpr double kFloor2 = 3.2;     // Floor surface of the upper floor, metres.
  constexpr double kRoof = 6.2;       // Bottom of the roof slab, metres.
  constexpr double kTop = 6.4;        // Top of the roof slab, metres.
  constexpr double kRise = 0.2;       // Step rise, metres.
  constexpr double kRun = 0.3;        // Step run (tread depth), metres.
  constexpr double kFlightX = 19.4;   // x where the lower flight starts and the upper flight ends.
  constexpr double kLandingX = 21.5;  // x where the mid landing starts.
  std::vector<Box> solid = {
      {0.0, 24.0, 0.0, 14.0, -0.2, 0.0},                   // floor 1 slab
      {0.0, kFlightX, 0.0, 14.0, kFloor2 - 0.2, kFloor2},  // floor 2 slab (open over the stairwell)
      {0.0, 24.0, 0.0, 14.0, kRoof, kTop},                 // roof
      {0.0, 0.2, 0.0, 14.0, -0.2, kTop},                   // outer walls
      {23.8, 24.0, 0.0, 14.0, -0.2, kTop},
      {0.0, 24.0, 0.0, 0.2, -0.2, kTop},
      {0.0, 24.0, 13.8, 14.0, -0.2, kTop},
      {18.0, 24.0, 0.0, 6.0, -0.2, kTop},  // service core around the stairwell
      {18.0, 24.0, 8.2, 14.0, -0.2, kTop},
      {0.0, 18.0, 5.8, 6.0, -0.2, kTop},  // corridor walls
      {0.0, 18.0, 8.2, 8.4, -0.2, kTop},
      {6.0, 6.2, 0.0, 5.8, -0.2, kTop},  // room partitions
      {6.0, 6.2, 8.4, 14.0, -0.2, kTop},
      {12.0, 12.2, 0.0, 5.8, -0.2, kTop},
      {12.0, 12.2, 8.4, 14.0, -0.2, kTop},
      {18.0, 18.2, 6.0, 8.2, -0.2, kTop},                            // stairwell wall with its entrances
      {kFlightX, kLandingX, 7.0, 7.2, 0.0, kFloor2 + 1.0},           // wall between the flights
      {kFlightX, kFlightX + 0.1, 6.0, 7.0, kFloor2, kFloor2 + 1.0},  // railing over the lower flight
      {kLandingX, 23.8, 6.0, 8.2, 1.6 - 0.2, 1.6},  // mid landing (1.6 m), free space below it
  };
  for (int k = 1; k <= 7; ++k) {
    // Lower flight (y in [6.0, 7.0]) rises along +x, filled to the floor; upper flight (y in [7.2, 8.2])
    // rises along -x from the mid landing, 0.4 m thick with free space below.
    solid.push_back({kFlightX + kRun * (k - 1), kFlightX + kRun * k, 6.0, 7.0, 0.0, kRise * k});
    solid.push_back(
        {kLandingX - kRun * k, kLandingX - kRun * (k - 1), 7.2, 8.2, 1.6 + kRise * k - 0.4, 1.6 + kRise * k});
  }
  std::vector<Box> open = {
      {18.0, 18.2, 6.4, 7.6, 0.0, 2.2},                // stairwell entrance, floor 1 (1.2 m)
      {18.0, 18.2, 6.8, 8.0, kFloor2, kFloor2 + 2.2},  // stairwell entrance, floor 2 (1.2 m)
  };
  for (const double floor : {0.0, kFloor2}) {
    for (const double door_x : {3.1, 9.1, 15.1}) {  // 1.0 m doorways into the six rooms of each floor
      open.push_back({door_x - 0.5, door_x + 0.5, 5.8, 6.0, floor, floor + 2.1});
      open.push_back({door_x - 0.5, door_x + 0.5, 8.2, 8.4, floor, floor + 2.1});
    }
  }
  World world("builtin:building", Eigen::Vector3d(0.0, 0.0, -0.3), 0.1, Eigen::Vector3i(240, 140, 68));
  const Eigen::Vector3i dims = world.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const Eigen::Vector3d c = world.CenterOf({ix, iy, iz});
        const auto in = [&c](const Box& b) { return b.Contains(c); };
        if (std::any_of(solid.begin(), solid.end(), in) && std::none_of(open.begin(), open.end(), in)) {
          world.SetOccupied({ix, iy, iz});
        }
      }
    }
  }
  return world;
}

const std::vector<BuiltinWorldInfo>& Infos() {
  static const std::vector<BuiltinWorldInfo> kInfos = {
      {"tunnels",
       "60 x 40 m tunnels (3 m wide, 3 m high, rough walls), X junction, two L bends, 10 x 10 m room with a "
       "staircase to a 1 m platform",
       0.1,
       0.0,
       {{4.0, 20.0, 0.0}, {14.0, 20.0, 0.0}, {30.0, 12.0, kPi / 2}, {20.0, 35.0, 0.0}, {40.0, 5.0, kPi}},
       {50.0, 18.0, 0.0},
       // The room's staircase (see MakeTunnels): risers at x = 50, 50.5, .., 52, from y = 22.5 to the room
       // wall at y = 25 (rough by up to 0.24 m).
       {{Eigen::Vector3d(50.0, 23.75, 0.0), 0.0, 0.2, 0.5, 2.5, 5}}},
      {"narrow",
       "34 x 20 m: two 2 m wide, 30 m long tunnels (y = 5 and 15) joined at their west end, each with a 2 x "
       "2.5 m bay on its north wall at x = 19..21",
       0.1,
       0.0,
       {{4.0, 5.0, 0.0}, {4.0, 15.0, 0.0}, {26.0, 5.0, kPi}, {26.0, 15.0, kPi}},
       {30.0, 15.0, 0.0}},
      {"arena",
       "20 x 14 m walled yard without ceiling, three pillars and a 0.1 m plate",
       0.1,
       0.0,
       {{2.0, 7.0, 0.0}, {18.0, 7.0, kPi}, {10.0, 2.0, kPi / 2}},
       {17.0, 12.0, 0.0}},
      {"building",
       "24 x 14 m building, two floors (3.2 m apart) of a corridor and six rooms with 1.0 m doorways, joined "
       "by "
       "a switchback stairwell of 1.0 m wide flights (0.2 m rise, 0.3 m run)",
       0.1,
       0.0,
       {{2.0, 7.1, 0.0}, {6.0, 7.1, 0.0}, {10.0, 7.1, 0.0}, {14.0, 7.1, 0.0}},
       {15.1, 3.0, 0.0},
       // The stairwell (see MakeBuilding): the lower flight up +x to the mid landing (its edge the 8th
       // riser), the upper flight back along -x to floor 2 (its edge the 8th riser).
       {{Eigen::Vector3d(19.4, 6.5, 0.0), 0.0, 0.2, 0.3, 1.0, 8},
        {Eigen::Vector3d(21.5, 7.7, 1.6), kPi, 0.2, 0.3, 1.0, 8}}},
      internal::PlantInfo(),
  };
  return kInfos;
}

std::string ValidNames() {
  std::string names;
  for (const BuiltinWorldInfo& info : Infos()) names += (names.empty() ? "" : ", ") + info.name;
  return names;
}

}  // namespace

std::vector<std::string> BuiltinWorldNames() {
  std::vector<std::string> names;
  for (const BuiltinWorldInfo& info : Infos()) names.push_back(info.name);
  return names;
}

const BuiltinWorldInfo& GetBuiltinWorldInfo(const std::string& name) {
  for (const BuiltinWorldInfo& info : Infos()) {
    if (info.name == name) return info;
  }
  throw WorldError("unknown builtin world 'builtin:" + name + "'; valid names: " + ValidNames());
}

World MakeBuiltinWorld(const std::string& name, std::uint32_t seed) {
  GetBuiltinWorldInfo(name);  // Throws for unknown names.
  if (name == "tunnels") return MakeTunnels(seed);
  if (name == "building") return MakeBuilding();
  if (name == "narrow") return MakeNarrow(seed);
  if (name == "plant") return internal::MakePlant(seed);
  return MakeArena();
}

}  // namespace cairn::sim
