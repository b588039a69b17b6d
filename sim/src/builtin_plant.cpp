// Copyright Cairn authors.
//
// "builtin:plant": a single-storey industrial building of the size of the survey scans users load (90 x 60 m,
// 6 m high): a racked hall with a mezzanine and its staircase, an office wing, a loading bay. Built from
// axis-aligned boxes filled by voxel index ranges (the cost is the boxes' voxels, not boxes x grid). The
// layout and its coordinates are described in builtin_worlds.h.
#include "builtin_plant.h"

#include <algorithm>
#include <cmath>

namespace cairn::sim::internal {
namespace {

constexpr double kPi = 3.14159265358979323846;

// ---- Dimensions, metres, frame W (x east, y north, z up; floor surface z = 0) ----------------------------

// Grid: exactly the building's solid envelope, so nothing lies outside its outer walls, under its floor slab
// or above its roof (a survey made inside sees none of those faces).
constexpr double kResM = 0.1;
constexpr double kSizeXM = 90.0;
constexpr double kSizeYM = 60.0;
constexpr double kSlabBottomZM = -0.2;  // Floor slab z in [-0.2, 0].
constexpr double kRoofZM = 6.0;         // Roof slab z in [6.0, 6.2].
constexpr double kTopZM = 6.2;
constexpr double kOuterWallM = 0.3;
constexpr double kWallM = 0.2;        // Inner walls.
constexpr double kHallEastXM = 50.0;  // Wall between the hall and the east part, x in [50.0, 50.2].

// Racks: eight rows along y, 1.0 m deep, 2.5 m tall, 4 m apart (3 m aisles), y in [4, 56], cut by a 3 m
// cross aisle and, per half row, one seeded 2 m gap.
constexpr int kRackRows = 8;
constexpr double kRackX0M = 16.0;
constexpr double kRackPitchM = 4.0;
constexpr double kRackDepthM = 1.0;
constexpr double kRackHeightM = 2.5;
constexpr double kRackY0M = 4.0;
constexpr double kRackY1M = 56.0;
constexpr double kCrossAisleY0M = 28.5;
constexpr double kCrossAisleY1M = 31.5;
constexpr double kRackGapM = 2.0;

// Mezzanine along the west wall: slab x in [0.3, 6.0], y in [36, 59.7], top at 3.0 m, 0.2 m thick, free
// below (2.8 m headroom); 1.0 m balustrades on its open edges.
constexpr double kMezzanineZM = 3.0;
constexpr double kMezzanineSlabM = 0.2;
constexpr double kMezzanineEdgeXM = 6.0;
constexpr double kMezzanineY0M = 36.0;
constexpr double kRailHeightM = 1.0;
constexpr double kRailM = 0.1;

// Staircase: one straight flight rising along -x (towards the mezzanine), centred on y = 45, 1.2 m wide,
// 17 risers of 3.0 / 17 m (0.176 m) and 0.28 m run; 16 treads filled down to the floor, the 17th riser is the
// edge of a 1.2 m landing (x in [6.0, 7.2], free below) that joins the mezzanine.
constexpr double kStairYM = 45.0;
constexpr double kStairWidthM = 1.2;
constexpr int kStairRisers = 17;
constexpr double kStairRiseM = kMezzanineZM / kStairRisers;
constexpr double kStairRunM = 0.28;
constexpr double kLandingXM = 7.2;
constexpr double kFirstRiserXM = kLandingXM + (kStairRisers - 1) * kStairRunM;  // 11.68

// Office wing, x in [50.2, 89.7], y in [30.2, 59.7]: a 3 m corridor (y in [43.5, 46.5]) from the hall to the
// east wall; five rooms on each side (partitions at x = 58, 66, 74, 82), each behind a 1.0 m doorway at
// x = room start + 1.5, except the third south room's 0.9 m doorway (x in [67.2, 68.1]).
constexpr double kOfficeY0M = 30.0;  // Wall between the loading bay and the south rooms, y in [30.0, 30.2].
constexpr double kCorridorY0M = 43.5;
constexpr double kCorridorY1M = 46.5;
constexpr double kPartitionsXM[] = {58.0, 66.0, 74.0, 82.0};
constexpr double kDoorCentresXM[] = {51.7, 59.7, 67.7, 75.7, 83.7};
constexpr double kDoorHeightM = 2.1;
constexpr double kNarrowDoorX0M = 67.2;
constexpr double kNarrowDoorX1M = 68.1;

// Loading bay x in [50.2, 89.7], y in [0.3, 30.0]: a 6 m wide, 4.5 m high opening to the hall (y in [10,
// 16]); four closed dock doors in the south wall (3 m wide, 4 m high, recessed 0.1 m).
constexpr double kBayOpeningY0M = 10.0;
constexpr double kBayOpeningY1M = 16.0;
constexpr double kBayOpeningHeightM = 4.5;
constexpr double kDockDoorsXM[] = {60.0, 68.0, 76.0, 84.0};

// ---- Boxes, filled by index ranges -----------------------------------------------------------------------

struct Box {
  double x0, x1, y0, y1, z0, z1;  // Metres, frame W.
};

// Indices [begin, end) along one axis of the voxels whose centre lies in [lo_m, hi_m]; a centre on a face
// (within 1e-6 m) counts in, so a box reaching a voxel centre covers that voxel.
std::pair<int, int> CentresIn(double lo_m, double hi_m, double min_m, int n) {
  const int begin = static_cast<int>(std::ceil((lo_m - min_m) / kResM - 0.5 - 1e-6));
  const int end = static_cast<int>(std::floor((hi_m - min_m) / kResM - 0.5 + 1e-6)) + 1;
  return {std::clamp(begin, 0, n), std::clamp(end, 0, n)};
}

// Marks (or clears) every voxel of `world` whose centre lies in `box`.
void Fill(World* world, const Box& box, bool occupied = true) {
  const Eigen::Vector3d& p_min = world->p_W_min();
  const Eigen::Vector3i& dims = world->dims();
  const auto [x0, x1] = CentresIn(box.x0, box.x1, p_min.x(), dims.x());
  const auto [y0, y1] = CentresIn(box.y0, box.y1, p_min.y(), dims.y());
  const auto [z0, z1] = CentresIn(box.z0, box.z1, p_min.z(), dims.z());
  for (int ix = x0; ix < x1; ++ix) {
    for (int iy = y0; iy < y1; ++iy) {
      for (int iz = z0; iz < z1; ++iz) world->SetOccupied({ix, iy, iz}, occupied);
    }
  }
}

// ---- Seeded variations ------------------------------------------------------------------------------------

// A SplitMix64 stream (Steele et al., "Fast Splittable Pseudorandom Number Generators", OOPSLA 2014): the
// same numbers on every platform, unlike the std distributions.
class PlantRng {
 public:
  explicit PlantRng(std::uint32_t seed) : state_(0x504C414E54000000ull ^ seed) {}
  // Uniform in [0, 1).
  double Uniform01() {
    std::uint64_t z = (state_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return static_cast<double>((z ^ (z >> 31)) >> 11) * (1.0 / 9007199254740992.0);
  }
  // Uniform in [lo, hi], rounded to a multiple of 0.1 m (box faces on voxel faces: no centre ties).
  double Tenths(double lo, double hi) { return std::round(10.0 * (lo + (hi - lo) * Uniform01())) / 10.0; }
  // Uniform integer in [lo, hi].
  int Int(int lo, int hi) { return lo + std::min(hi - lo, static_cast<int>(Uniform01() * (hi - lo + 1))); }

 private:
  std::uint64_t state_;
};

// A machine near (cx, cy): a box of 1-2 m sides, 1-2 m high, its centre within 0.5 m of (cx, cy); it stays
// within 1.55 m of (cx, cy) in x and y.
void AddMachine(World* world, PlantRng* rng, double cx_m, double cy_m) {
  const double sx = rng->Tenths(1.0, 2.0);
  const double sy = rng->Tenths(1.0, 2.0);
  const double height = rng->Tenths(1.0, 2.0);
  const double x0 = rng->Tenths(cx_m - sx / 2 - 0.5, cx_m - sx / 2 + 0.5);
  const double y0 = rng->Tenths(cy_m - sy / 2 - 0.5, cy_m - sy / 2 + 0.5);
  Fill(world, {x0, x0 + sx, y0, y0 + sy, 0.0, height});
}

// ---- Parts
// --------------------------------------------------------------------------------------------------

// Floor slab, roof slab, outer walls and the full-height inner walls (hall/east part, bay/offices, corridor,
// room partitions) with their openings cut out.
void AddShellAndWalls(World* world) {
  Fill(world, {0.0, kSizeXM, 0.0, kSizeYM, kSlabBottomZM, 0.0});
  Fill(world, {0.0, kSizeXM, 0.0, kSizeYM, kRoofZM, kTopZM});
  Fill(world, {0.0, kOuterWallM, 0.0, kSizeYM, kSlabBottomZM, kTopZM});
  Fill(world, {kSizeXM - kOuterWallM, kSizeXM, 0.0, kSizeYM, kSlabBottomZM, kTopZM});
  Fill(world, {0.0, kSizeXM, 0.0, kOuterWallM, kSlabBottomZM, kTopZM});
  Fill(world, {0.0, kSizeXM, kSizeYM - kOuterWallM, kSizeYM, kSlabBottomZM, kTopZM});
  const double east_x0 = kHallEastXM + kWallM;
  const double inner_y1 = kSizeYM - kOuterWallM;
  Fill(world, {kHallEastXM, east_x0, 0.0, kSizeYM, 0.0, kRoofZM});
  Fill(world, {east_x0, kSizeXM, kOfficeY0M, kOfficeY0M + kWallM, 0.0, kRoofZM});
  Fill(world, {east_x0, kSizeXM, kCorridorY0M - kWallM, kCorridorY0M, 0.0, kRoofZM});
  Fill(world, {east_x0, kSizeXM, kCorridorY1M, kCorridorY1M + kWallM, 0.0, kRoofZM});
  for (const double x : kPartitionsXM) {
    Fill(world, {x, x + kWallM, kOfficeY0M, kCorridorY0M, 0.0, kRoofZM});
    Fill(world, {x, x + kWallM, kCorridorY1M, inner_y1, 0.0, kRoofZM});
  }
  constexpr bool kOpen = false;
  Fill(world, {kHallEastXM, east_x0, kCorridorY0M, kCorridorY1M, 0.0, 2.5}, kOpen);  // Hall to corridor.
  Fill(world, {kHallEastXM, east_x0, kBayOpeningY0M, kBayOpeningY1M, 0.0, kBayOpeningHeightM}, kOpen);
  for (const double c : kDoorCentresXM) {
    Fill(world, {c - 0.5, c + 0.5, kCorridorY1M, kCorridorY1M + kWallM, 0.0, kDoorHeightM}, kOpen);
    const bool narrow = c > kNarrowDoorX0M && c < kNarrowDoorX1M;
    Fill(world,
         {narrow ? kNarrowDoorX0M : c - 0.5, narrow ? kNarrowDoorX1M : c + 0.5, kCorridorY0M - kWallM,
          kCorridorY0M, 0.0, kDoorHeightM},
         kOpen);
  }
  for (const double c : kDockDoorsXM) {
    Fill(world, {c - 1.5, c + 1.5, kOuterWallM - 0.1, kOuterWallM, 0.0, 4.0}, kOpen);
  }
}

// Rack rows with the cross aisle and one seeded gap per half row; five machines in the open west part of the
// hall (slots clear of the mezzanine, the staircase and the hall's starts).
void AddHallContents(World* world, PlantRng* rng) {
  for (int row = 0; row < kRackRows; ++row) {
    const double x0 = kRackX0M + row * kRackPitchM;
    Fill(world, {x0, x0 + kRackDepthM, kRackY0M, kRackY1M, 0.0, kRackHeightM});
    Fill(world, {x0, x0 + kRackDepthM, kCrossAisleY0M, kCrossAisleY1M, 0.0, kRackHeightM}, false);
    const double south_gap = rng->Tenths(kRackY0M + 2.0, kCrossAisleY0M - 2.0 - kRackGapM);
    const double north_gap = rng->Tenths(kCrossAisleY1M + 2.5, kRackY1M - 2.0 - kRackGapM);
    for (const double y0 : {south_gap, north_gap}) {
      Fill(world, {x0, x0 + kRackDepthM, y0, y0 + kRackGapM, 0.0, kRackHeightM}, false);
    }
  }
  static const double kMachineSlots[][2] = {{4.0, 6.0}, {4.0, 16.0}, {4.0, 26.0}, {11.0, 8.0}, {11.0, 32.0}};
  for (const auto& slot : kMachineSlots) AddMachine(world, rng, slot[0], slot[1]);
}

// Mezzanine slab, its balustrades and columns, the landing and the flight.
void AddMezzanineAndStairs(World* world) {
  const double slab_z0 = kMezzanineZM - kMezzanineSlabM;
  const double rail_z1 = kMezzanineZM + kRailHeightM;
  const double inner_y1 = kSizeYM - kOuterWallM;
  const double stair_y0 = kStairYM - kStairWidthM / 2;
  const double stair_y1 = kStairYM + kStairWidthM / 2;
  Fill(world, {kOuterWallM, kMezzanineEdgeXM, kMezzanineY0M, inner_y1, slab_z0, kMezzanineZM});
  const double rail_x0 = kMezzanineEdgeXM - kRailM;
  Fill(world, {rail_x0, kMezzanineEdgeXM, kMezzanineY0M, stair_y0, kMezzanineZM, rail_z1});
  Fill(world, {rail_x0, kMezzanineEdgeXM, stair_y1, inner_y1, kMezzanineZM, rail_z1});
  Fill(world, {kOuterWallM, kMezzanineEdgeXM, kMezzanineY0M, kMezzanineY0M + kRailM, kMezzanineZM, rail_z1});
  for (const double y : {39.0, 51.0, 57.0}) {  // Columns under the slab's open edge, 0.4 m square.
    Fill(world, {kMezzanineEdgeXM - 0.6, kMezzanineEdgeXM - 0.2, y - 0.2, y + 0.2, 0.0, slab_z0});
  }
  // Landing, with balustrades on both sides (outside the flight's width).
  Fill(world, {kMezzanineEdgeXM, kLandingXM, stair_y0 - kRailM, stair_y1 + kRailM, slab_z0, kMezzanineZM});
  Fill(world, {kMezzanineEdgeXM, kLandingXM, stair_y0 - kRailM, stair_y0, kMezzanineZM, rail_z1});
  Fill(world, {kMezzanineEdgeXM, kLandingXM, stair_y1, stair_y1 + kRailM, kMezzanineZM, rail_z1});
  for (int k = 1; k < kStairRisers; ++k) {  // Tread k: between risers k and k + 1, filled to the floor.
    Fill(world, {kFirstRiserXM - k * kStairRunM, kFirstRiserXM - (k - 1) * kStairRunM, stair_y0, stair_y1,
                 0.0, k * kStairRiseM});
  }
}

// The raised platform and cabinet of the second north room; pallet stacks and machines in the loading bay.
void AddRoomAndBayContents(World* world, PlantRng* rng) {
  // Cabinet (2.0 x 0.6 m, 1.8 m tall) against the north wall, and in front of it a single 0.15 m step
  // (1.0 m deep, 2.0 m wide): a voxel counts when its centre is in a box, so at 0.1 m the step's top is the
  // voxel face at z = 0.2.
  const double wall_y = kSizeYM - kOuterWallM;
  Fill(world, {61.0, 63.0, wall_y - 0.6, wall_y, 0.0, 1.8});
  Fill(world, {61.0, 63.0, wall_y - 1.6, wall_y - 0.6, 0.0, 0.15});
  for (const double door_x : kDockDoorsXM) {  // 1-3 pallet stacks (1.2 x 1.0 m, 0.4-1.6 m) before each door.
    const int stacks = rng->Int(1, 3);
    for (int i = 0; i < stacks; ++i) {
      const double x0 = rng->Tenths(door_x - 0.9, door_x - 0.3);
      const double y0 = 2.0 + 1.8 * i;
      Fill(world, {x0, x0 + 1.2, y0, y0 + 1.0, 0.0, rng->Tenths(0.4, 1.6)});
    }
  }
  AddMachine(world, rng, 57.0, 23.0);
  AddMachine(world, rng, 79.0, 22.0);
}

}  // namespace

World MakePlant(std::uint32_t seed) {
  World world("builtin:plant", Eigen::Vector3d(0.0, 0.0, kSlabBottomZM), kResM,
              Eigen::Vector3i(static_cast<int>(std::lround(kSizeXM / kResM)),
                              static_cast<int>(std::lround(kSizeYM / kResM)),
                              static_cast<int>(std::lround((kTopZM - kSlabBottomZM) / kResM))));
  PlantRng rng(seed);
  AddShellAndWalls(&world);
  AddHallContents(&world, &rng);
  AddMezzanineAndStairs(&world);
  AddRoomAndBayContents(&world, &rng);
  return world;
}

BuiltinWorldInfo PlantInfo() {
  BuiltinWorldInfo info;
  info.name = "plant";
  info.description =
      "90 x 60 m industrial building, 6 m high under a roof slab: a 50 x 60 m hall with eight 2.5 m rows of "
      "racks (3 m aisles), a mezzanine at 3 m up a straight 17-riser staircase, an office wing (3 m "
      "corridor, "
      "ten rooms behind 1.0 m doorways, one 0.9 m), a loading bay, machines";
  info.resolution_m = kResM;
  info.floor_z_m = 0.0;
  info.suggested_starts = {
      {10.0, 20.0, 0.0},      // Hall, open west part.
      {30.5, 30.0, kPi / 2},  // Hall, cross aisle between rack rows 4 and 5.
      {47.5, 20.0, kPi / 2},  // Hall, east aisle.
      {56.0, 45.0, 0.0},      // Office corridor, west.
      {78.0, 45.0, kPi},      // Office corridor, east.
      {70.0, 20.0, 0.0},      // Loading bay.
  };
  info.far_goal = {86.0, 26.0, 0.0};  // North-east corner of the loading bay.
  info.staircases = {{Eigen::Vector3d(kFirstRiserXM, kStairYM, 0.0), kPi, kStairRiseM, kStairRunM,
                      kStairWidthM, kStairRisers}};
  return info;
}

}  // namespace cairn::sim::internal
