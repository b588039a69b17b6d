// Copyright Cairn authors.
//
// builtin:plant (a 90 x 60 m industrial building: racked hall, mezzanine and staircase, office wing, loading
// bay) and cairn_survey_pcd, the tool that writes a sparse survey scan of it: the layout the header promises,
// voxel by voxel; starts and places on free floor; the declared staircase in the voxels; the tool's PCD read
// back by LoadWorld with a drivable office corridor; bad flags refused with exit code 2.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <regex>
#include <string>
#include <vector>

#include "cairn/core/build_paths.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/survey_scan.h"
#include "cairn/sim/world.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

using testing::MakeTempDir;
using testing::ReadFile;

constexpr double kRobotRadiusM = 0.35;  // Largest wheeled robot the starts must fit.
constexpr double kPi = 3.14159265358979323846;

// The plant built once (seed 1) for the tests that only read it.
const World& Plant() {
  static const World* world = new World(MakeBuiltinWorld("plant", 1));
  return *world;
}

// Height of the top of the highest occupied voxel of the column at (x, y) with its centre below z_max_m (a
// multiple of the 0.1 m voxel edge), or NaN if there is none (metres, frame W).
double ColumnTop(const World& world, double x, double y, double z_max_m) {
  for (double z = z_max_m - 0.05; z > world.p_W_min().z(); z -= 0.1) {
    if (world.IsOccupied({x, y, z})) return std::floor(z * 10.0 + 1e-6) / 10.0 + 0.1;
  }
  return std::nan("");
}

// True if a disc of radius `radius_m` at (x, y) stands on floor at `z_m` (every sample has an occupied voxel
// right below z_m) with nothing in [z_m + 0.05, z_m + headroom_m].
bool OnFreeFloor(const World& world, double x, double y, double z_m, double radius_m, double headroom_m,
                 std::string* why) {
  for (double dx = -radius_m; dx <= radius_m + 1e-9; dx += 0.05) {
    for (double dy = -radius_m; dy <= radius_m + 1e-9; dy += 0.05) {
      if (std::hypot(dx, dy) > radius_m + 1e-9) continue;
      if (!world.IsOccupied({x + dx, y + dy, z_m - 0.05})) {
        *why = "no floor at offset (" + std::to_string(dx) + ", " + std::to_string(dy) + ")";
        return false;
      }
      for (double z = z_m + 0.05; z <= z_m + headroom_m; z += 0.1) {
        if (world.IsOccupied({x + dx, y + dy, z})) {
          *why = "occupied at offset (" + std::to_string(dx) + ", " + std::to_string(dy) + ", " +
                 std::to_string(z) + ")";
          return false;
        }
      }
    }
  }
  return true;
}

// Free voxels along x at height z from x0 to x1 (metres), counting the longest free run, metres.
double LongestFreeRunX(const World& world, double x0, double x1, double y, double z) {
  double best = 0.0, run = 0.0;
  for (double x = x0 + 0.05; x < x1; x += 0.1) {
    run = world.IsOccupied({x, y, z}) ? 0.0 : run + 0.1;
    best = std::max(best, run);
  }
  return best;
}

TEST(PlantTest, IsListedWithItsInfo) {
  const std::vector<std::string> names = BuiltinWorldNames();
  EXPECT_NE(std::find(names.begin(), names.end(), "plant"), names.end());
  const BuiltinWorldInfo& info = GetBuiltinWorldInfo("plant");
  EXPECT_EQ(info.name, "plant");
  EXPECT_FALSE(info.description.empty());
  EXPECT_DOUBLE_EQ(info.resolution_m, 0.1);
  EXPECT_DOUBLE_EQ(info.floor_z_m, 0.0);
  EXPECT_GE(info.suggested_starts.size(), 4u);
  for (std::size_t i = 0; i < info.suggested_starts.size(); ++i) {
    for (std::size_t j = i + 1; j < info.suggested_starts.size(); ++j) {
      const PlanarPose& a = info.suggested_starts[i];
      const PlanarPose& b = info.suggested_starts[j];
      EXPECT_GE(std::hypot(a.x_m - b.x_m, a.y_m - b.y_m), 2.0) << i << ", " << j;
    }
  }
  ASSERT_EQ(info.staircases.size(), 1u);
}

TEST(PlantTest, BuildsQuicklyWithTheStatedGrid) {
  const auto t0 = std::chrono::steady_clock::now();
  const World world = MakeBuiltinWorld("plant", 3);
  const double build_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("FIGURE plant_build_s %.3f occupied %lld\n", build_s,
              static_cast<long long>(world.CountOccupied()));
  EXPECT_LT(build_s, 2.0);
  EXPECT_EQ(world.name(), "builtin:plant");
  EXPECT_DOUBLE_EQ(world.resolution_m(), 0.1);
  EXPECT_EQ(world.dims(), Eigen::Vector3i(900, 600, 64));
  EXPECT_TRUE(world.p_W_min().isApprox(Eigen::Vector3d(0.0, 0.0, -0.2)));
  EXPECT_TRUE(world.p_W_max().isApprox(Eigen::Vector3d(90.0, 60.0, 6.2)));
  const WorldLoadReport report = [] {
    WorldLoadReport r;
    LoadWorld("builtin:plant", {}, &r);
    return r;
  }();
  EXPECT_EQ(report.kind, "builtin");
}

TEST(PlantTest, SameSeedSameWorldOtherSeedOtherRackGaps) {
  const World a = MakeBuiltinWorld("plant", 7);
  const World b = MakeBuiltinWorld("plant", 7);
  const World c = MakeBuiltinWorld("plant", 8);
  std::int64_t differences_ab = 0, differences_ac = 0;
  const Eigen::Vector3i& dims = a.dims();
  for (int ix = 0; ix < dims.x(); ++ix) {
    for (int iy = 0; iy < dims.y(); ++iy) {
      for (int iz = 0; iz < dims.z(); ++iz) {
        const bool occupied = a.IsOccupiedIndex({ix, iy, iz});
        differences_ab += occupied != b.IsOccupiedIndex({ix, iy, iz});
        differences_ac += occupied != c.IsOccupiedIndex({ix, iy, iz});
      }
    }
  }
  EXPECT_EQ(differences_ab, 0);
  // Another seed moves the rack gaps: the racks' centre lines differ.
  int rack_differences = 0;
  for (int row = 0; row < 8; ++row) {
    for (double y = 4.05; y < 56.0; y += 0.1) {
      const Eigen::Vector3d p(16.5 + 4.0 * row, y, 1.0);
      rack_differences += a.IsOccupied(p) != c.IsOccupied(p);
    }
  }
  EXPECT_GT(rack_differences, 0);
  EXPECT_GT(differences_ac, 0);
}

TEST(PlantTest, StartsAndGoalAreOnFreeFloorWithHeadroomAndConnected) {
  const World& world = Plant();
  const BuiltinWorldInfo& info = GetBuiltinWorldInfo("plant");
  std::vector<PlanarPose> probes = info.suggested_starts;
  probes.push_back(info.far_goal);
  for (const std::uint32_t seed : {1u, 2u, 3u, 4u}) {
    const World w = MakeBuiltinWorld("plant", seed);
    for (const PlanarPose& p : probes) {
      std::string why;
      EXPECT_TRUE(OnFreeFloor(w, p.x_m, p.y_m, 0.0, kRobotRadiusM, 2.5, &why))
          << "seed " << seed << " at " << p.x_m << ", " << p.y_m << ": " << why;
      EXPECT_TRUE(w.IsOccupied({p.x_m, p.y_m, 6.05})) << "roof above " << p.x_m << ", " << p.y_m;
    }
  }
  // One connected region: every start and the goal reachable from the first start on traversable cells.
  nav::TraversabilityOptions options;
  options.robot_radius_m = kRobotRadiusM;
  const nav::TraversabilityGrid grid(world, options);
  std::vector<std::uint8_t> seen(static_cast<std::size_t>(grid.nx()) * grid.ny(), 0);
  int sx = 0, sy = 0;
  ASSERT_TRUE(grid.CellOf(probes[0].x_m, probes[0].y_m, &sx, &sy));
  std::deque<std::pair<int, int>> open = {{sx, sy}};
  seen[grid.Index(sx, sy)] = 1;
  while (!open.empty()) {
    const auto [ix, iy] = open.front();
    open.pop_front();
    for (int dx = -1; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        const int jx = ix + dx, jy = iy + dy;
        if (!grid.InGrid(jx, jy) || seen[grid.Index(jx, jy)] || !grid.IsTraversable(jx, jy)) continue;
        seen[grid.Index(jx, jy)] = 1;
        open.emplace_back(jx, jy);
      }
    }
  }
  for (const PlanarPose& p : probes) {
    int ix = 0, iy = 0;
    ASSERT_TRUE(grid.CellOf(p.x_m, p.y_m, &ix, &iy));
    EXPECT_TRUE(seen[grid.Index(ix, iy)]) << "not reachable: " << p.x_m << ", " << p.y_m;
  }
}

TEST(PlantTest, ShippedPlacesAreOnFreeFloorAtTheirLevel) {
  const std::string text = ReadFile(cairn::core::SourceDir() + "/config/places/plant.yaml");
  const std::regex line(R"((\w+): \{x_m: ([-0-9.]+), y_m: ([-0-9.]+), z_m: ([-0-9.]+)\})");
  int places = 0;
  for (auto it = std::sregex_iterator(text.begin(), text.end(), line); it != std::sregex_iterator(); ++it) {
    ++places;
    const std::smatch& m = *it;
    const double x = std::stod(m[2]), y = std::stod(m[3]), z = std::stod(m[4]);
    std::string why;
    EXPECT_TRUE(OnFreeFloor(Plant(), x, y, z, kRobotRadiusM, 1.5, &why)) << m[1] << ": " << why;
  }
  EXPECT_GE(places, 5);
}

TEST(PlantTest, LayoutAsDescribed) {
  const World& w = Plant();
  // Outer walls 0.3 m, roof slab [6.0, 6.2], floor slab [-0.2, 0].
  EXPECT_TRUE(w.IsOccupied({0.25, 10.0, 1.0}));
  EXPECT_FALSE(w.IsOccupied({0.35, 10.0, 1.0}));
  EXPECT_TRUE(w.IsOccupied({30.0, 10.0, 6.05}));
  EXPECT_FALSE(w.IsOccupied({30.0, 10.0, 5.95}));
  EXPECT_TRUE(w.IsOccupied({30.0, 10.0, -0.15}));
  // Racks: 1.0 m deep, 2.5 m tall, 3 m aisles (at y = 5 and 55 no seed puts a gap).
  EXPECT_DOUBLE_EQ(ColumnTop(w, 20.5, 5.0, 6.0), 2.5);
  EXPECT_NEAR(LongestFreeRunX(w, 16.0, 25.0, 5.0, 1.0), 3.0, 1e-6);
  for (double x = 16.05; x < 17.0; x += 0.1) EXPECT_TRUE(w.IsOccupied({x, 55.0, 1.0})) << x;
  EXPECT_FALSE(w.IsOccupied({16.5, 30.0, 1.0}));  // Cross aisle.
  // Office corridor 3 m wide between 0.2 m walls, from the hall to the east wall.
  for (double x = 50.5; x < 89.5; x += 1.0) {
    int free = 0;
    for (double y = 43.35; y < 46.7; y += 0.1) free += !w.IsOccupied({x, y, 2.5});
    EXPECT_EQ(free, 30) << x;
  }
  EXPECT_FALSE(w.IsOccupied({50.1, 45.0, 2.45}));  // The 3 m wide, 2.5 m high opening from the hall.
  EXPECT_TRUE(w.IsOccupied({50.1, 45.0, 2.55}));
  EXPECT_TRUE(w.IsOccupied({50.1, 43.4, 1.0}));
  EXPECT_FALSE(w.IsOccupied({89.65, 45.0, 1.0}));
  EXPECT_TRUE(w.IsOccupied({89.75, 45.0, 1.0}));
  // Doorways: 1.0 m, one 0.9 m (third south room), 2.1 m high.
  EXPECT_NEAR(LongestFreeRunX(w, 58.2, 66.0, 43.4, 1.0), 1.0, 1e-6);
  EXPECT_NEAR(LongestFreeRunX(w, 58.2, 66.0, 46.6, 1.0), 1.0, 1e-6);
  EXPECT_NEAR(LongestFreeRunX(w, 66.2, 74.0, 43.4, 1.0), 0.9, 1e-6);
  EXPECT_NEAR(LongestFreeRunX(w, 66.2, 74.0, 46.6, 1.0), 1.0, 1e-6);
  EXPECT_TRUE(w.IsOccupied({59.7, 43.4, 2.15}));
  // Mezzanine: top at 3.0, 0.2 m slab, 2.8 m headroom under it.
  EXPECT_DOUBLE_EQ(ColumnTop(w, 3.0, 50.0, 3.5), 3.0);
  EXPECT_FALSE(w.IsOccupied({3.0, 50.0, 2.75}));
  EXPECT_DOUBLE_EQ(ColumnTop(w, 3.0, 50.0, 2.8), 0.0);
  // The raised platform: a single 0.15 m step (its voxels reach 0.2) before a 1.8 m cabinet; floor in front.
  EXPECT_DOUBLE_EQ(ColumnTop(w, 62.0, 57.95, 5.0), 0.0);
  for (double y = 58.15; y < 59.1; y += 0.1) EXPECT_DOUBLE_EQ(ColumnTop(w, 62.0, y, 5.0), 0.2) << y;
  EXPECT_DOUBLE_EQ(ColumnTop(w, 62.0, 59.35, 5.0), 1.8);
  // Loading bay: opening to the hall, 4.5 m high.
  EXPECT_FALSE(w.IsOccupied({50.1, 13.0, 4.45}));
  EXPECT_TRUE(w.IsOccupied({50.1, 13.0, 4.55}));
  EXPECT_TRUE(w.IsOccupied({50.1, 20.0, 1.0}));
}

// The declared flight is in the voxels: across its width, the column top steps from (k - 1) * rise to
// k * rise (within half a voxel) at each riser k, one step per riser, ending on the landing at 3.0 m.
TEST(PlantTest, DeclaredStaircaseMatchesTheVoxels) {
  const World& w = Plant();
  const StaircaseFlight& f = GetBuiltinWorldInfo("plant").staircases.front();
  EXPECT_NEAR(f.p_W_first_riser.x(), 11.68, 1e-9);
  EXPECT_NEAR(f.p_W_first_riser.y(), 45.0, 1e-9);
  EXPECT_DOUBLE_EQ(f.p_W_first_riser.z(), 0.0);
  EXPECT_NEAR(f.yaw_rad, kPi, 1e-12);
  EXPECT_EQ(f.num_steps, 17);
  EXPECT_NEAR(f.rise_m, 3.0 / 17, 1e-12);
  EXPECT_DOUBLE_EQ(f.run_m, 0.28);
  EXPECT_DOUBLE_EQ(f.width_m, 1.2);
  const double res = w.resolution_m();
  for (const double across : {-0.4, 0.0, 0.4}) {
    const double y = f.p_W_first_riser.y() + across;
    for (int k = 1; k <= f.num_steps; ++k) {
      const double riser_x = f.p_W_first_riser.x() - (k - 1) * f.run_m;  // Ascending along -x.
      const double below = ColumnTop(w, riser_x + res, y, 3.5);
      const double above = ColumnTop(w, riser_x - res, y, 3.5);
      EXPECT_NEAR(below, (k - 1) * f.rise_m, res / 2 + 1e-6) << "riser " << k << " at " << across;
      EXPECT_NEAR(above, k * f.rise_m, res / 2 + 1e-6) << "riser " << k << " at " << across;
    }
    // One rise per riser from the floor to the landing: no other step along the centre line.
    int rises = 0;
    double last = 0.0;
    for (double x = 13.05; x > 6.0; x -= 0.1) {
      const double top = ColumnTop(w, x, y, 3.5);
      rises += top > last + 1e-6;
      EXPECT_GE(top, last - 1e-6) << x;
      last = top;
    }
    EXPECT_EQ(rises, 17);  // Each 0.176 m rise shows as 0.1 or 0.2 m in 0.1 m voxels, never as none.
    EXPECT_DOUBLE_EQ(last, 3.0);
  }
  // Free space under the landing, the flight filled to the floor.
  EXPECT_FALSE(w.IsOccupied({6.6, 45.0, 1.5}));
  EXPECT_TRUE(w.IsOccupied({9.0, 45.0, 0.5}));
}

TEST(SurveyScanOptionsTest, DefaultsAreValidAndBadFieldsNamed) {
  std::string why;
  EXPECT_TRUE(SurveyScanOptions{}.IsValid(&why)) << why;
  SurveyScanOptions o;
  o.wall_keep_fraction = 1.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "wall_keep_fraction = 1.5");
  o = {};
  o.missing_strips.push_back({Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), 0.0});
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_CONTAINS(why, "missing_strips[0].width_m = 0");
  EXPECT_THROW(MakeSurveyScan(Plant(), o, 1), WorldError);
}

// A survey from inside the plant: no floor point in a missing strip, none on the outer faces of the shell.
TEST(PlantSurveyTest, MissingStripsAndOnlyTheInsideSeen) {
  SurveyScanOptions o;
  o.floor_points_per_m2 = 40.0;
  o.wall_keep_fraction = 0.1;
  o.num_strays = 0;
  o.outside_is_solid = true;
  o.missing_strips.push_back({Eigen::Vector2d(52.0, 45.0), Eigen::Vector2d(88.0, 45.0), 0.4});
  const SurveyScan scan = MakeSurveyScan(Plant(), o, 5);
  int in_strip = 0, beside_strip = 0, outside = 0;
  for (const Eigen::Vector3f& p : scan.points_W) {
    outside +=
        p.z() >= 6.1f || p.z() < -0.1f || p.x() < 0.1f || p.x() >= 89.9f || p.y() < 0.1f || p.y() >= 59.9f;
    if (p.z() >= 0.0f || p.x() < 52.0f || p.x() > 88.0f) continue;  // Floor points of the corridor only.
    in_strip += std::abs(p.y() - 45.0f) <= 0.2f;
    beside_strip += std::abs(p.y() - 45.0f) > 0.3f && std::abs(p.y() - 45.0f) < 1.0f;
  }
  EXPECT_EQ(in_strip, 0);
  EXPECT_GT(beside_strip, 300);  // ~40 points/m^2 over 2 x 0.7 m x 36 m.
  EXPECT_EQ(outside, 0);
  o.outside_is_solid = false;
  const SurveyScan all_faces = MakeSurveyScan(Plant(), o, 5);
  int roof_top = 0;
  for (const Eigen::Vector3f& p : all_faces.points_W) roof_top += p.z() >= 6.1f;
  EXPECT_GT(roof_top, 1000);
}

// ---- cairn_survey_pcd
// ---------------------------------------------------------------------------------------

struct ToolRun {
  int exit_code = -1;
  std::string out;
  std::string err;
};

ToolRun RunTool(const std::string& args) {
  const std::string dir = MakeTempDir();
  const std::string command =
      std::string(CAIRN_SURVEY_PCD_BIN) + " " + args + " >" + dir + "/stdout 2>" + dir + "/stderr";
  const int status = std::system(command.c_str());
  ToolRun run;
  run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run.out = ReadFile(dir + "/stdout");
  run.err = ReadFile(dir + "/stderr");
  return run;
}

TEST(SurveyPcdToolTest, DefaultScanOfThePlantLoadsWithADrivableCorridor) {
  const std::string path = MakeTempDir() + "/plant.pcd";
  const auto t0 = std::chrono::steady_clock::now();
  const ToolRun run = RunTool("--world builtin:plant --out " + path);
  const double tool_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_CONTAINS(run.out, "points");
  EXPECT_CONTAINS(run.out, "extent x [");
  std::printf("FIGURE survey_pcd_tool_s %.2f: %s", tool_s, run.out.c_str());

  WorldLoadReport report;
  const auto t1 = std::chrono::steady_clock::now();
  const World world = LoadWorld(path, {}, &report);
  const double load_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
  std::printf("FIGURE plant_survey_load_s %.2f %s\n", load_s, report.Summary().c_str());
  EXPECT_EQ(report.kind, "pcd");
  EXPECT_GE(report.points_total, 200'000);
  EXPECT_GE(report.points_total, 250'000);  // The defaults aim at the 250-300 k points of a real survey.
  EXPECT_LE(report.points_total, 300'000);

  // The office corridor (y in [43.5, 46.5]) is drivable along its centre line, from the hall to the east
  // wall, for the default robot.
  const nav::TraversabilityGrid grid(world);
  int cells = 0, traversable = 0;
  for (double x = 52.05; x < 88.0; x += 0.1) {
    ++cells;
    traversable += grid.IsTraversableAt(x, 45.0);
  }
  std::printf("FIGURE plant_survey_corridor_traversable %d of %d\n", traversable, cells);
  EXPECT_GE(traversable, cells * 95 / 100);
  for (const PlanarPose& start : GetBuiltinWorldInfo("plant").suggested_starts) {
    if (start.y_m > 43.5 && start.y_m < 46.5 && start.x_m > 50.2) {
      EXPECT_TRUE(grid.IsTraversableAt(start.x_m, start.y_m)) << start.x_m << ", " << start.y_m;
    }
  }
}

TEST(SurveyPcdToolTest, SameSeedSameFileAndStripsApplied) {
  const std::string dir = MakeTempDir();
  const std::string args =
      "--world builtin:plant --floor-points-per-m2 5 --wall-keep-fraction 0.02 --strays 10 "
      "--missing-strip 52,45,88,45,0.6 --seed 4 --out ";
  ASSERT_EQ(RunTool(args + dir + "/a.pcd").exit_code, 0);
  ASSERT_EQ(RunTool(args + dir + "/b.pcd").exit_code, 0);
  const std::string a = ReadFile(dir + "/a.pcd");
  EXPECT_GT(a.size(), 1000u);
  EXPECT_TRUE(a == ReadFile(dir + "/b.pcd"));
  const ToolRun run = RunTool(args + dir + "/c.pcd --missing-strip 10,5,10,25,0.5");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_CONTAINS(run.out, "2 missing strips");
}

TEST(SurveyPcdToolTest, BadInputIsRefusedWithExitCode2NamingTheFlag) {
  const std::string out = " --out " + MakeTempDir() + "/x.pcd";
  const struct {
    std::string args;
    std::string message;
  } cases[] = {
      {"--world builtin:plant --floor-points-per-m2 0" + out, "--floor-points-per-m2 0"},
      {"--world builtin:plant --floor-points-per-m2 abc" + out, "--floor-points-per-m2"},
      {"--world builtin:plant --wall-keep-fraction 1.5" + out, "--wall-keep-fraction 1.5"},
      {"--world builtin:plant --strays -3" + out, "--strays -3"},
      {"--world builtin:plant --seed -1" + out, "--seed '-1'"},
      {"--world builtin:plant --missing-strip 1,2,3" + out, "--missing-strip '1,2,3'"},
      {"--world builtin:plant --missing-strip 1,2,3,4,0" + out, "--missing-strip '1,2,3,4,0'"},
      {"--world builtin:factory" + out, "--world 'builtin:factory'"},
      {"--world builtin:plant --out /nonexistent-folder/x.pcd", "--out '/nonexistent-folder/x.pcd'"},
      {"--world builtin:plant --out " + MakeTempDir() + "/x.ply", "must end in .pcd"},
      {"--out x.pcd", "--world"},
  };
  for (const auto& c : cases) {
    const ToolRun run = RunTool(c.args);
    EXPECT_EQ(run.exit_code, 2) << c.args;
    EXPECT_CONTAINS(run.err, c.message);
  }
  const ToolRun help = RunTool("--help");
  EXPECT_EQ(help.exit_code, 0);
  EXPECT_CONTAINS(help.out, "--missing-strip");
}

}  // namespace
}  // namespace cairn::sim
