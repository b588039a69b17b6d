// Copyright Cairn authors.
//
// Sparse, noisy scans as worlds: a degraded copy of the real scan geb079.bt (floor thinned to ~50
// points/m^2, walls and ceiling with holes, floor holes, two wells cut into the corridor floor, single stray
// points in open space) is written as a PCD and loaded at the default resolution; the clean-up must remove
// the strays, fill the small holes, leave the wells open and give nav a drivable corridor. A synthetic room
// checks that a ceiling and a pipe are never taken for floor. Seeded random numbers only.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "cairn/nav/platform.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/survey_scan.h"
#include "cairn/sim/world.h"
#include "sparse_corridor.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

using testing::MakeTempDir;

WorldLoadOptions NoCleanUp() {
  WorldLoadOptions o;
  o.support_radius_m = 0.0;
  o.fill_hole_max_m = 0.0;
  return o;
}

struct Box2 {
  double x0, x1, y0, y1;
  bool Contains(double x, double y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
};

// The degraded copy of geb079 (MakeSurveyScan with DegradedGeb079Options()) and what was done to it.
struct DegradedScan {
  std::vector<Eigen::Vector3f> points;
  std::vector<Eigen::Vector3d> strays;        // Single points in open space.
  std::vector<Eigen::Vector2d> hole_centres;  // Floor holes of kHoleRadius.
  double floor_points_per_m2 = 0.0;           // Measured on the corridor floor.
};

constexpr double kFloorDensity = 50.0;  // Points per m^2.
constexpr double kHoleRadius = 0.2;     // Floor holes of 0.4 m: smaller than a 0.6 m footprint.
// Well A: 0.5 m x 0.5 m, a floor seen 2 m below (a shaft): smaller than fill_hole_max_m, seen through.
const Box2 kWellA{8.0, 8.5, -1.2, -0.7};
// Well B: 1.2 m x 1.0 m, nothing seen below (a stairwell seen from above at a grazing angle): too large.
const Box2 kWellB{20.0, 21.2, -1.4, -0.4};

DegradedScan Degrade(const World& truth, std::uint32_t seed) {
  const SurveyScanOptions options = DegradedGeb079Options();
  EXPECT_EQ(options.floor_points_per_m2, kFloorDensity);
  EXPECT_EQ(options.hole_radius_m, kHoleRadius);
  SurveyScan scan = MakeSurveyScan(truth, options, seed);
  DegradedScan out;
  out.points = std::move(scan.points_W);
  out.strays = std::move(scan.strays_W);
  out.hole_centres = options.hole_centres_W;
  out.floor_points_per_m2 = scan.floor_points_per_m2;
  return out;
}

// Fraction of `centres` whose floor voxel (z = -0.05) is occupied in `world`.
double FloorCoverage(const World& world, const std::vector<Eigen::Vector2d>& centres) {
  int n = 0;
  for (const Eigen::Vector2d& c : centres) n += world.IsOccupied(Eigen::Vector3d(c.x(), c.y(), -0.05));
  return static_cast<double>(n) / centres.size();
}

// Floor a robot drives on: cells of the true scan's floor that its traversability grid calls traversable, in
// the corridor (x in [-4, 26], |y| < 1.6).
std::vector<Eigen::Vector2d> DrivenFloor(const World& truth) {
  const nav::TraversabilityGrid grid(truth);
  std::vector<Eigen::Vector2d> out;
  for (int ix = 0; ix < grid.nx(); ++ix) {
    for (int iy = 0; iy < grid.ny(); ++iy) {
      const Eigen::Vector2d c = grid.CellCenter(ix, iy);
      if (c.x() < -4.0 || c.x() > 26.0 || std::abs(c.y()) > 1.6 || !grid.IsTraversable(ix, iy)) continue;
      if (truth.IsOccupied(Eigen::Vector3d(c.x(), c.y(), -0.04)) ||
          truth.IsOccupied(Eigen::Vector3d(c.x(), c.y(), -0.12))) {
        out.push_back(c);
      }
    }
  }
  return out;
}

class DegradedGeb079Test : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!testing::FileExists(testing::Geb079Path())) return;
    truth_ = new World(LoadWorld(testing::Geb079Path(), NoCleanUp()));
    scan_ = new DegradedScan(Degrade(*truth_, 79));
    const std::string path = MakeTempDir() + "/geb079_degraded.pcd";
    WritePcd(path, scan_->points);
    report_ = new WorldLoadReport;
    world_ = new World(LoadWorld(path, {}, report_));  // Default options: 0.1 m, clean-up on.
    raw_ = new World(LoadWorld(path, NoCleanUp()));
    // The same scan, dense: one point at the centre of every voxel of the true scan, no stray.
    std::vector<Eigen::Vector3f> dense;
    const Eigen::Vector3i& dims = truth_->dims();
    for (int ix = 0; ix < dims.x(); ++ix) {
      for (int iy = 0; iy < dims.y(); ++iy) {
        for (int iz = 0; iz < dims.z(); ++iz) {
          if (truth_->IsOccupiedIndex({ix, iy, iz}))
            dense.emplace_back(truth_->CenterOf({ix, iy, iz}).cast<float>());
        }
      }
    }
    const std::string dense_path = MakeTempDir() + "/geb079_dense.pcd";
    WritePcd(dense_path, dense);
    dense_ = new World(LoadWorld(dense_path));
    std::printf("FIGURE degraded_geb079 points %zu floor_points_per_m2 %.1f strays %zu\n",
                scan_->points.size(), scan_->floor_points_per_m2, scan_->strays.size());
    std::printf("FIGURE degraded_geb079_load %s\n", report_->Summary().c_str());
  }
  static void TearDownTestSuite() {
    delete truth_;
    delete scan_;
    delete report_;
    delete world_;
    delete raw_;
    delete dense_;
  }
  void SetUp() override {
    if (truth_ == nullptr) GTEST_SKIP() << "real scan " << testing::Geb079Path() << " is absent";
  }
  static World* truth_;
  static DegradedScan* scan_;
  static WorldLoadReport* report_;
  static World* world_;
  static World* raw_;
  static World* dense_;
};
World* DegradedGeb079Test::truth_ = nullptr;
DegradedScan* DegradedGeb079Test::scan_ = nullptr;
WorldLoadReport* DegradedGeb079Test::report_ = nullptr;
World* DegradedGeb079Test::world_ = nullptr;
World* DegradedGeb079Test::raw_ = nullptr;
World* DegradedGeb079Test::dense_ = nullptr;

TEST_F(DegradedGeb079Test, CopyIsAsSparseAsTheSurvey) {
  EXPECT_NEAR(scan_->floor_points_per_m2, kFloorDensity, 5.0);
  EXPECT_DOUBLE_EQ(world_->resolution_m(), 0.1);
  EXPECT_EQ(report_->kind, "pcd");
  // At 0.1 m, 50 points/m^2 occupy 1 - exp(-0.5) ~ 39% of the floor voxels: most of the floor is holes.
  EXPECT_LT(FloorCoverage(*raw_, DrivenFloor(*truth_)), 0.6);
}

TEST_F(DegradedGeb079Test, StrayPointsAreRemoved) {
  int raw_kept = 0, kept = 0;
  for (const Eigen::Vector3d& p : scan_->strays) {
    raw_kept += raw_->IsOccupied(p);
    kept += world_->IsOccupied(p);
  }
  EXPECT_EQ(raw_kept, static_cast<int>(scan_->strays.size()));
  EXPECT_EQ(kept, 0);
  EXPECT_GE(report_->voxels_removed_unsupported, static_cast<std::int64_t>(scan_->strays.size()));
  // The support filter removes little else: the structure is kept.
  EXPECT_LT(report_->voxels_removed_unsupported, report_->voxels_read / 20);
}

TEST_F(DegradedGeb079Test, SmallFloorHolesAreFilled) {
  EXPECT_GT(report_->voxels_filled_floor, 0);
  EXPECT_EQ(FloorCoverage(*raw_, scan_->hole_centres), 0.0);
  for (const Eigen::Vector2d& c : scan_->hole_centres) {
    // Every voxel of the hole is floor again.
    for (double dx = -kHoleRadius + 0.05; dx < kHoleRadius; dx += 0.1) {
      for (double dy = -kHoleRadius + 0.05; dy < kHoleRadius; dy += 0.1) {
        EXPECT_TRUE(world_->IsOccupied(Eigen::Vector3d(c.x() + dx, c.y() + dy, -0.05)))
            << "hole at " << c.transpose() << " offset " << dx << ", " << dy;
      }
    }
    EXPECT_FALSE(world_->IsOccupied(Eigen::Vector3d(c.x(), c.y(), 0.05)));  // One voxel thick.
  }
  EXPECT_GT(FloorCoverage(*world_, DrivenFloor(*truth_)), 0.97);
}

TEST_F(DegradedGeb079Test, CorridorStartIsFreeGround) {
  const nav::TraversabilityGrid raw_grid(*raw_);
  const nav::TraversabilityGrid grid(*world_);
  const nav::TraversabilityGrid truth_grid(*truth_);
  const nav::TraversabilityGrid dense_grid(*dense_);
  std::printf(
      "FIGURE degraded_geb079_traversable_m2 raw %.1f cleaned %.1f dense_0.1m %.1f truth_0.08m %.1f\n",
      raw_grid.summary().cells_traversable * 0.01, grid.summary().cells_traversable * 0.01,
      dense_grid.summary().cells_traversable * 0.01, truth_grid.summary().cells_traversable * 0.08 * 0.08);
  // The reported failure: in the raw sparse world the corridor start is not free ground.
  EXPECT_FALSE(raw_grid.IsTraversableAt(-4.0, 0.0));
  EXPECT_EQ(raw_grid.summary().cells_traversable, 0);
  // Starts along the corridor centre line, where the true scan leaves at least 0.45 m of clearance (the robot
  // radius, 0.3 m, plus the 0.1 m voxels that may move an obstacle face closer): all are free ground.
  int starts = 0;
  for (double x = -4.0; x <= 26.0; x += 1.0) {
    int ix = 0, iy = 0;
    ASSERT_TRUE(truth_grid.CellOf(x, 0.0, &ix, &iy));
    if (truth_grid.ClearanceM(ix, iy) < 0.45) continue;
    if (std::abs(x - 0.5 * (kWellA.x0 + kWellA.x1)) < 1.0 ||
        std::abs(x - 0.5 * (kWellB.x0 + kWellB.x1)) < 1.2) {
      continue;  // The wells cut into the copy are holes the true scan does not have.
    }
    ++starts;
    EXPECT_TRUE(grid.IsTraversableAt(x, 0.0)) << x;
    EXPECT_TRUE(grid.IsFootprintFree(x, 0.0, 0.3)) << x;
    EXPECT_NEAR(grid.GroundHeight(x, 0.0).value_or(-9.0), 0.0, 0.1 + 1e-6) << x;
  }
  EXPECT_GE(starts, 20);
  // Nearly the area the same scan gives when it is dense (every voxel of the true scan as a point).
  EXPECT_GT(grid.summary().cells_traversable, 0.85 * dense_grid.summary().cells_traversable);
}

TEST_F(DegradedGeb079Test, WellsAndFloorEdgesAreNotBridged) {
  for (const Box2& well : {kWellA, kWellB}) {
    int bridged = 0;
    for (double x = well.x0 + 0.05; x < well.x1; x += 0.1) {
      for (double y = well.y0 + 0.05; y < well.y1; y += 0.1) {
        bridged += world_->IsOccupied(Eigen::Vector3d(x, y, -0.05));
      }
    }
    EXPECT_EQ(bridged, 0) << "well at x " << well.x0;
  }
  EXPECT_GT(report_->holes_seen_through, 0);  // Well A: closed around, but its bottom was seen.
  // No filled floor voxel lies farther than half the largest hole plus a voxel (0.4 m) from the true floor:
  // filling never grows the floor past its edges (the offices seen only through their doors, the ends of the
  // corridor), it only closes holes (the true scan has holes up to ~0.6 m in the office floors).
  int grown = 0;
  const Eigen::Vector3i& dims = world_->dims();
  const int iz = world_->IndexOf(Eigen::Vector3d(0.0, 0.0, -0.05))->z();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      if (!world_->IsOccupiedIndex({ix, iy, iz}) || raw_->IsOccupiedIndex({ix, iy, iz})) continue;
      const Eigen::Vector3d c = world_->CenterOf({ix, iy, iz});
      bool near_floor = false;
      for (double dx = -0.4; dx <= 0.4 && !near_floor; dx += 0.04) {
        for (double dy = -0.4; dy <= 0.4 && !near_floor; dy += 0.04) {
          near_floor = truth_->IsOccupied(Eigen::Vector3d(c.x() + dx, c.y() + dy, -0.04)) ||
                       truth_->IsOccupied(Eigen::Vector3d(c.x() + dx, c.y() + dy, -0.12));
        }
      }
      grown += !near_floor;
    }
  }
  EXPECT_EQ(grown, 0);
}

// A 6 m x 4 m room at 0.1 m from a sparse scan: floor 50 points/m^2 with a 0.4 m hole under a pipe
// (0.2 m x 0.2 m, top at 1.7 m, along x) and a false ceiling at 2.5 m (50 points/m^2) below a roof at 3.5 m.
TEST(SparseRoomTest, CeilingAndPipeAreNeverFloor) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  std::poisson_distribution<int> per_cell(kFloorDensity * 0.1 * 0.1);
  std::vector<Eigen::Vector3f> points;
  for (double x = 0.0; x < 6.0; x += 0.1) {
    for (double y = 0.0; y < 4.0; y += 0.1) {
      const bool hole = std::hypot(x + 0.05 - 3.0, y + 0.05 - 2.0) < 0.2;
      for (double z : {-0.05, 2.45, 3.45}) {
        if (hole && z < 0) continue;
        for (int n = per_cell(rng); n > 0; --n) {
          points.emplace_back(x + 0.1 * u01(rng), y + 0.1 * u01(rng), z + 0.04 * (u01(rng) - 0.5));
        }
      }
      if (std::abs(y + 0.05 - 2.0) < 0.1) {  // The pipe: its underside and top, densely scanned.
        points.emplace_back(x + 0.05, y + 0.05, 1.55);
        points.emplace_back(x + 0.05, y + 0.05, 1.65);
      }
    }
  }
  const std::string path = MakeTempDir() + "/room.pcd";
  WritePcd(path, points);
  WorldLoadReport report;
  const World world = LoadWorld(path, {}, &report);
  std::printf("FIGURE sparse_room_load %s\n", report.Summary().c_str());
  EXPECT_GT(report.overhead_surface_voxels, 0);
  // Ceiling and pipe levels keep exactly the voxels their points fell in: no hole of theirs is filled.
  const World raw = LoadWorld(path, NoCleanUp());
  for (double z : {1.65, 2.45}) {
    int filled = 0;
    for (double x = 0.05; x < 6.0; x += 0.1) {
      for (double y = 0.05; y < 4.0; y += 0.1)
        filled += world.IsOccupied({x, y, z}) && !raw.IsOccupied({x, y, z});
    }
    EXPECT_EQ(filled, 0) << "z " << z;
  }
  // The hole under the pipe is filled at floor level; nav's ground is the floor everywhere inside.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(3.0, 2.0, -0.05)));
  nav::TraversabilityOptions o;
  o.free_above_map = false;
  const nav::TraversabilityGrid grid(world, o);
  int not_floor = 0;
  for (double x = 0.55; x < 5.5; x += 0.1) {
    for (double y = 0.55; y < 3.5; y += 0.1) {
      const std::optional<double> g = grid.GroundHeight(x, y);
      not_floor += !g || std::abs(*g) > 0.1;
    }
  }
  EXPECT_EQ(not_floor, 0);
  EXPECT_TRUE(grid.IsTraversableAt(3.0, 1.0));
}

// A 3 m x 15 m corridor from a sparse survey scan (20 or 60 floor points/m^2, +-2 cm, nothing 0.02 m to 2.5 m
// above the floor but the walls) whose floor has a strip of missing returns 9 m long and 0.3 to 0.5 m wide
// near the south wall, loaded with the default options: the strip is floor (seen floor on both sides of it, a
// gap no wider than a sampling gap), no voxel appears in the corridor above the floor, and the floor around
// and over the strip is free ground for nav's traversability (the grid the simulated platform judges its body
// with). 20 points/m^2 is the density of the real survey of an industrial building on which a robot was held
// in contact beside such a strip.
struct StripCase {
  double strip_width_m;
  double floor_points_per_m2;
};

class SparseCorridorTest : public ::testing::TestWithParam<StripCase> {};

TEST_P(SparseCorridorTest, StripOfMissingFloorReturnsIsFloorAndNoObstacle) {
  testing::SparseCorridorOptions o;
  o.strip_width_m = GetParam().strip_width_m;
  o.floor_points_per_m2 = GetParam().floor_points_per_m2;
  const testing::SparseCorridorScan scan = testing::MakeSparseCorridorScan(o, 44);
  const std::string path = MakeTempDir() + "/corridor.pcd";
  WritePcd(path, scan.points_W);
  WorldLoadReport report;
  const World world = LoadWorld(path, {}, &report);
  std::printf("FIGURE sparse_corridor_strip_%.1f_m_%.0f_per_m2_load %s\n", o.strip_width_m,
              o.floor_points_per_m2, report.Summary().c_str());
  ASSERT_DOUBLE_EQ(world.resolution_m(), 0.1);
  // Nothing occupied in the corridor (a voxel away from the walls) from 0.1 m to 2 m above the floor.
  int invented = 0;
  for (double x = 0.15; x < o.length_m - 0.1; x += 0.1) {
    for (double y = 0.15; y < o.width_m - 0.1; y += 0.1) {
      for (double z = 0.15; z < 2.0; z += 0.1) invented += world.IsOccupied({x, y, z});
    }
  }
  EXPECT_EQ(invented, 0);
  // Every column of the strip has its floor voxel (the floor's points fall in [-0.1, 0.1)).
  int strip_columns = 0, no_floor = 0;
  for (double x = scan.strip_W.min().x() + 0.05; x < scan.strip_W.max().x(); x += 0.1) {
    for (double y = scan.strip_W.min().y() + 0.05; y < scan.strip_W.max().y(); y += 0.1) {
      ++strip_columns;
      no_floor += !world.IsOccupied({x, y, -0.05}) && !world.IsOccupied({x, y, 0.05});
    }
  }
  EXPECT_GE(strip_columns, 3 * 90);
  EXPECT_EQ(no_floor, 0) << "of " << strip_columns << " strip columns";
  EXPECT_GT(report.voxels_filled_strip, 0);  // Too long for a hole: filled as a strip.
  // Free ground for a 0.3 m body wherever the walls leave it room (0.45 m: the radius plus the voxel that
  // may bring a wall face closer), over the strip and beside it.
  nav::TraversabilityOptions t = nav::GetPlatformProfile("wheeled").traversability;
  const nav::TraversabilityGrid grid(world, t);
  int blocked = 0, checked = 0;
  for (double x = 0.5; x <= o.length_m - 0.5; x += 0.1) {
    for (double y = 0.45; y <= o.width_m - 0.45; y += 0.1) {
      ++checked;
      const bool free =
          grid.IsFootprintFree(x, y, 0.3) && std::abs(grid.GroundHeight(x, y).value_or(-9.0)) <= 0.1;
      if (!free && blocked++ < 5) ADD_FAILURE() << "no free ground for the body at " << x << ", " << y;
    }
  }
  EXPECT_EQ(blocked, 0) << "of " << checked << " body positions";
}

INSTANTIATE_TEST_SUITE_P(StripWidthsAndDensities, SparseCorridorTest,
                         ::testing::Values(StripCase{0.3, 60.0}, StripCase{0.4, 60.0}, StripCase{0.5, 60.0},
                                           StripCase{0.4, 20.0}, StripCase{0.5, 20.0}));

}  // namespace
}  // namespace cairn::sim
