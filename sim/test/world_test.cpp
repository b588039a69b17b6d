// Copyright Cairn authors.
#include "cairn/sim/world.h"

#include <gtest/gtest.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <set>

#include "cairn/sim/builtin_worlds.h"
#include "test_util.h"

namespace cairn::sim {
namespace {

using testing::MakeTempDir;
using testing::ReadFile;
using testing::WriteFile;

// Returns the message of the WorldError thrown by `f`, or "" if none was thrown.
template <typename F>
std::string WorldErrorOf(F&& f) {
  try {
    f();
  } catch (const WorldError& e) {
    return e.what();
  }
  return "";
}

TEST(WorldLoadOptionsTest, DefaultsAreValid) {
  std::string why;
  EXPECT_TRUE(WorldLoadOptions{}.IsValid(&why)) << why;
}

TEST(WorldLoadOptionsTest, InvalidFieldsAreNamed) {
  for (const double bad : {0.01, 2.5, std::nan("")}) {
    WorldLoadOptions options;
    options.pcd_resolution_m = bad;
    std::string why;
    EXPECT_FALSE(options.IsValid(&why));
    EXPECT_CONTAINS(why, "pcd_resolution_m");
    EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld("builtin:arena", options); }), "pcd_resolution_m");
  }
  WorldLoadOptions options;
  options.max_voxels = 0;
  std::string why;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_CONTAINS(why, "max_voxels = 0");
}

TEST(WorldTest, IndexHelpersAndOccupancy) {
  World world("test", Eigen::Vector3d(-1.0, 2.0, 0.0), 0.5, Eigen::Vector3i(4, 2, 3));
  EXPECT_EQ(world.name(), "test");
  EXPECT_EQ(world.num_voxels(), 24);
  EXPECT_TRUE(world.p_W_max().isApprox(Eigen::Vector3d(1.0, 3.0, 1.5)));
  EXPECT_TRUE(world.bounds().min().isApprox(Eigen::Vector3d(-1.0, 2.0, 0.0)));
  EXPECT_EQ(world.CountOccupied(), 0);

  const auto index = world.IndexOf(Eigen::Vector3d(0.2, 2.9, 1.4));
  ASSERT_TRUE(index.has_value());
  EXPECT_EQ(*index, Eigen::Vector3i(2, 1, 2));
  EXPECT_TRUE(world.CenterOf(*index).isApprox(Eigen::Vector3d(0.25, 2.75, 1.25)));
  EXPECT_FALSE(world.IndexOf(Eigen::Vector3d(1.0, 2.5, 0.5)).has_value());  // On the max face: outside.
  EXPECT_FALSE(world.IndexOf(Eigen::Vector3d(std::nan(""), 2.5, 0.5)).has_value());

  world.SetOccupied(*index);
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.4, 2.6, 1.1)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(-0.4, 2.6, 1.1)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(50.0, 2.6, 1.1)));  // Outside: free.
  EXPECT_TRUE(world.SetOccupiedAt(Eigen::Vector3d(-0.9, 2.1, 0.1)));
  EXPECT_FALSE(world.SetOccupiedAt(Eigen::Vector3d(-9.0, 2.1, 0.1)));
  EXPECT_EQ(world.CountOccupied(), 2);
  world.SetOccupied(*index, false);
  EXPECT_EQ(world.CountOccupied(), 1);
  EXPECT_THROW(world.SetOccupied(Eigen::Vector3i(4, 0, 0)), std::out_of_range);
}

TEST(WorldTest, RejectsBadGrids) {
  EXPECT_CONTAINS(WorldErrorOf([] { World("w", Eigen::Vector3d::Zero(), 0.0, Eigen::Vector3i(1, 1, 1)); }),
                  "resolution_m");
  EXPECT_CONTAINS(WorldErrorOf([] { World("w", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(0, 1, 1)); }),
                  "dims");
  EXPECT_CONTAINS(
      WorldErrorOf([] { World("w", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(1000, 1000, 1000)); }),
      "too large");
}

TEST(BuiltinWorldTest, NamesAndInfo) {
  const std::vector<std::string> names = BuiltinWorldNames();
  EXPECT_EQ(names, (std::vector<std::string>{"tunnels", "narrow", "arena", "building", "plant"}));
  for (const std::string& name : names) {
    const BuiltinWorldInfo& info = GetBuiltinWorldInfo(name);
    EXPECT_EQ(info.name, name);
    ASSERT_GE(info.suggested_starts.size(), 3u) << name;
    for (std::size_t i = 0; i < info.suggested_starts.size(); ++i) {
      for (std::size_t j = i + 1; j < info.suggested_starts.size(); ++j) {
        const PlanarPose& a = info.suggested_starts[i];
        const PlanarPose& b = info.suggested_starts[j];
        EXPECT_GE(std::hypot(a.x_m - b.x_m, a.y_m - b.y_m), 2.0) << name << " starts " << i << ", " << j;
      }
    }
  }
}

// Every flight a built-in world declares is in its voxels: the floor before the first riser and each tread at
// its height (within half a voxel) across the inner part of the width, free space above each.
TEST(BuiltinWorldTest, DeclaredStaircasesMatchTheVoxels) {
  int flights = 0;
  for (const std::string& name : BuiltinWorldNames()) {
    const World world = MakeBuiltinWorld(name);
    const double res = world.resolution_m();
    for (const StaircaseFlight& f : GetBuiltinWorldInfo(name).staircases) {
      ++flights;
      ASSERT_GE(f.num_steps, 1) << name;
      const Eigen::Vector3d u(std::cos(f.yaw_rad), std::sin(f.yaw_rad), 0.0);
      const Eigen::Vector3d v(-u.y(), u.x(), 0.0);
      for (int k = 0; k <= f.num_steps; ++k) {
        for (double across : {-0.3, 0.0, 0.3}) {
          const Eigen::Vector3d p = f.p_W_first_riser + (k - 0.5) * f.run_m * u + across * f.width_m * v;
          const double top = f.p_W_first_riser.z() + k * f.rise_m;
          EXPECT_TRUE(world.IsOccupied({p.x(), p.y(), top - res}))
              << name << " tread " << k << " at " << across;
          EXPECT_FALSE(world.IsOccupied({p.x(), p.y(), top + res}))
              << name << " tread " << k << " at " << across;
          EXPECT_FALSE(world.IsOccupied({p.x(), p.y(), top + 0.3}))
              << name << " tread " << k << " at " << across;
        }
      }
    }
  }
  EXPECT_GE(flights, 1);  // builtin:tunnels has one.
}

TEST(BuiltinWorldTest, UnknownNameListsValidOnes) {
  const std::string message = WorldErrorOf([] { LoadWorld("builtin:caves"); });
  EXPECT_CONTAINS(message, "'builtin:caves'");
  EXPECT_CONTAINS(message, "valid names: tunnels, narrow, arena, building, plant");
}

TEST(BuiltinWorldTest, TunnelsLayout) {
  WorldLoadReport report;
  const World world = LoadWorld("builtin:tunnels", {}, &report);
  EXPECT_EQ(report.kind, "builtin");
  EXPECT_EQ(world.name(), "builtin:tunnels");
  EXPECT_DOUBLE_EQ(world.resolution_m(), 0.1);
  EXPECT_EQ(world.dims(), Eigen::Vector3i(600, 400, 41));
  EXPECT_TRUE(world.p_W_min().isApprox(Eigen::Vector3d(0.0, 0.0, -0.3)));
  EXPECT_TRUE(world.p_W_max().isApprox(Eigen::Vector3d(60.0, 40.0, 3.8)));
  const std::int64_t occupied = world.CountOccupied();
  EXPECT_GT(occupied, 500'000);
  EXPECT_LT(occupied, 2'000'000);

  const BuiltinWorldInfo& info = GetBuiltinWorldInfo("tunnels");
  std::vector<PlanarPose> probes = info.suggested_starts;
  probes.push_back(info.far_goal);
  for (const PlanarPose& p : probes) {
    // Floor under the pose, free body space above it, ceiling above that.
    EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(p.x_m, p.y_m, -0.05))) << p.x_m << ", " << p.y_m;
    for (double z = 0.05; z < 2.4; z += 0.1) {
      EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(p.x_m, p.y_m, z))) << p.x_m << ", " << p.y_m << ", " << z;
    }
    EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(p.x_m, p.y_m, 3.7))) << p.x_m << ", " << p.y_m;
  }
  // Rough walls 1.5 +- 0.3 m from the main tunnel's centre line (y = 20), at least 0.25 m thick.
  for (double x = 5.05; x < 25.0; x += 1.0) {
    double wall_y = 0.0;
    for (double y = 20.05; y < 23.0 && wall_y == 0.0; y += 0.1) {
      if (world.IsOccupied(Eigen::Vector3d(x, y, 1.0))) wall_y = y;
    }
    EXPECT_GT(wall_y, 21.15) << x;
    EXPECT_LT(wall_y, 21.85) << x;
    EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(x, wall_y + 0.2, 1.0))) << x;
  }
  // Room wall at x = 56.
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(55.5, 17.0, 1.0)));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(56.15, 17.0, 1.0)));
  // Staircase: third step (0.6 m) and platform (1.0 m) in the room.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(51.25, 24.0, 0.55)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(51.25, 24.0, 0.65)));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(54.0, 24.0, 0.95)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(54.0, 24.0, 1.05)));
}

TEST(BuiltinWorldTest, SeededAndDeterministic) {
  const World a = MakeBuiltinWorld("tunnels", 7);
  const World b = MakeBuiltinWorld("tunnels", 7);
  const World c = MakeBuiltinWorld("tunnels", 8);
  EXPECT_EQ(a.CountOccupied(), b.CountOccupied());
  int differences_ab = 0;
  int differences_ac = 0;
  for (double x = 0.05; x < 60.0; x += 0.1) {
    const Eigen::Vector3d p(x, 21.55, 1.0);
    differences_ab += a.IsOccupied(p) != b.IsOccupied(p);
    differences_ac += a.IsOccupied(p) != c.IsOccupied(p);
  }
  EXPECT_EQ(differences_ab, 0);
  EXPECT_GT(differences_ac, 0);  // Another seed roughens the walls differently.
}

TEST(BuiltinWorldTest, Arena) {
  const World world = LoadWorld("builtin:arena");
  EXPECT_EQ(world.dims(), Eigen::Vector3i(200, 140, 17));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.1, 7.0, 1.0)));    // West wall.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(10.45, 7.0, 1.0)));  // Pillar side.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(4.0, 3.0, 0.05)));   // Plate.
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(4.0, 3.0, 0.15)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(2.0, 7.0, 0.05)));  // Free above the floor.
}

class WorldFileTest : public ::testing::Test {
 protected:
  std::string dir_ = MakeTempDir();
};

TEST_F(WorldFileTest, BtRoundTrip) {
  const World arena = MakeBuiltinWorld("arena");
  const std::string path = dir_ + "/arena.bt";
  SaveWorldAsBt(arena, path);
  WorldLoadReport report;
  const World loaded = LoadWorld(path, {}, &report);
  EXPECT_EQ(report.kind, "bt");
  EXPECT_GT(report.leaves_occupied, 0);
  EXPECT_EQ(loaded.name(), path);
  EXPECT_DOUBLE_EQ(loaded.resolution_m(), 0.1);
  EXPECT_EQ(loaded.dims(), arena.dims());
  EXPECT_TRUE(loaded.p_W_min().isApprox(arena.p_W_min(), 1e-9));
  EXPECT_EQ(loaded.CountOccupied(), arena.CountOccupied());
  int mismatches = 0;
  for (int ix = 0; ix < arena.dims().x(); ++ix) {
    for (int iy = 0; iy < arena.dims().y(); ++iy) {
      for (int iz = 0; iz < arena.dims().z(); ++iz) {
        mismatches += arena.IsOccupiedIndex({ix, iy, iz}) != loaded.IsOccupiedIndex({ix, iy, iz});
      }
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST_F(WorldFileTest, MissingFile) {
  const std::string path = dir_ + "/nope.bt";
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(path); }), "'" + path + "' does not exist");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(dir_ + "/nope.pcd"); }), "does not exist");
}

TEST_F(WorldFileTest, GarbageAndTruncatedBt) {
  const std::string garbage = dir_ + "/garbage.bt";
  WriteFile(garbage, "this is not an octree\n\x01\x02\x03 at all");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(garbage); }),
                  "'" + garbage + "' is not an OctoMap binary (.bt) file: its first line is not");

  const std::string full = dir_ + "/full.bt";
  SaveWorldAsBt(MakeBuiltinWorld("arena"), full);
  const std::string bytes = ReadFile(full);
  const std::string truncated = dir_ + "/truncated.bt";
  WriteFile(truncated, bytes.substr(0, bytes.size() / 2));
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(truncated); }), "'" + truncated + "' is truncated");

  // Found by fuzzing (fuzz/corpus/bt_world/nested_inner_nodes.bt): inner nodes nested beyond the tree's 16
  // levels overflowed the stack in OctoMap's recursive reader; the stream is now walked before OctoMap sees
  // it.
  const std::string header = "# Octomap OcTree binary file\nid OcTree\nsize 100000\nres 0.1\ndata\n";
  const std::string deep = dir_ + "/deep.bt";
  WriteFile(deep, header + std::string(1 << 17, '\xFF'));
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(deep); }), "inner nodes below the finest depth");

  // A resolution of 1e30 (the header is text: "res 0.1") loaded and put the robot at (1.2e32, ...).
  std::string huge = bytes;
  const std::size_t res_at = huge.find("\nres ");
  ASSERT_NE(res_at, std::string::npos);
  const std::size_t res_end = huge.find('\n', res_at + 1);
  huge.replace(res_at, res_end - res_at, "\nres 1e30");
  const std::string huge_path = dir_ + "/huge.bt";
  WriteFile(huge_path, huge);
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(huge_path); }),
                  "OctoMap file '" + huge_path + "' has resolution 1e+30 m, outside [0.005, 5] m");

  const std::string garbage_ot = dir_ + "/garbage.ot";
  WriteFile(garbage_ot, "# Octomap OcTree file\nnonsense\n");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(garbage_ot); }),
                  "'" + garbage_ot + "' has an invalid header line 'nonsense'");
}

// An OctoMap full (.ot) file as OctoMap writes it loads to the same world as the .bt it came from.
TEST_F(WorldFileTest, OtWorldLoadsAsItsBt) {
  const std::string bt = dir_ + "/arena.bt";
  SaveWorldAsBt(MakeBuiltinWorld("arena"), bt);
  const std::string ot = dir_ + "/arena.ot";
  ASSERT_TRUE(octomap::OcTree(bt).write(ot));
  const World from_bt = LoadWorld(bt);
  const World from_ot = LoadWorld(ot);
  ASSERT_EQ(from_ot.dims(), from_bt.dims());
  EXPECT_TRUE(from_ot.p_W_min().isApprox(from_bt.p_W_min()));
  int mismatches = 0, occupied = 0;
  for (int ix = 0; ix < from_bt.dims().x(); ++ix) {
    for (int iy = 0; iy < from_bt.dims().y(); ++iy) {
      for (int iz = 0; iz < from_bt.dims().z(); ++iz) {
        mismatches += from_ot.IsOccupiedIndex({ix, iy, iz}) != from_bt.IsOccupiedIndex({ix, iy, iz});
        occupied += from_bt.IsOccupiedIndex({ix, iy, iz});
      }
    }
  }
  EXPECT_GT(occupied, 1000);
  EXPECT_EQ(mismatches, 0);
}

// .ot worlds went to OctoMap's reader unchecked: it recurses once per node and reads on past the end of the
// data. A 10 MB .ot of 2*10^6 nodes, each the only child of the one before, crashed cairn_agent --world
// (SIGSEGV, stack overflow). The stream is now walked before OctoMap sees it.
TEST_F(WorldFileTest, BadOtFiles) {
  const std::string bt = dir_ + "/arena.bt";
  SaveWorldAsBt(MakeBuiltinWorld("arena"), bt);
  const std::string ot = dir_ + "/arena.ot";
  ASSERT_TRUE(octomap::OcTree(bt).write(ot));
  const std::string bytes = ReadFile(ot);

  const std::string truncated = dir_ + "/truncated.ot";
  WriteFile(truncated, bytes.substr(0, bytes.size() / 2));
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(truncated); }), "'" + truncated + "' is truncated");

  const std::string trailing = dir_ + "/trailing.ot";
  WriteFile(trailing, bytes + "xyz");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(trailing); }), "3 bytes follow the end of the node data");

  std::string node(sizeof(float) + 1, '\0');
  const float log_odds = 2.0f;
  std::memcpy(node.data(), &log_odds, sizeof(float));
  node[sizeof(float)] = '\x01';  // one child: the next node
  const int kNodes = 2'000'000;
  std::string deep = "# Octomap OcTree file\nid OcTree\nsize " + std::to_string(kNodes) + "\nres 0.1\ndata\n";
  deep.reserve(deep.size() + node.size() * kNodes);
  for (int i = 0; i < kNodes; ++i) deep += node;
  const std::string deep_path = dir_ + "/deep.ot";
  WriteFile(deep_path, deep);
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(deep_path); }), "nodes below the finest depth 16");

  const std::string color = dir_ + "/color.ot";
  WriteFile(color,
            "# Octomap OcTree file\nid ColorOcTree\nsize 1\nres 0.1\ndata\n" + node.substr(0, 4) + '\0');
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(color); }),
                  "of type 'ColorOcTree'; only 'OcTree' is supported");

  const std::string bt_as_ot = dir_ + "/binary.ot";
  WriteFile(bt_as_ot, ReadFile(bt));
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(bt_as_ot); }),
                  "is an OctoMap binary (.bt) file, not a full (.ot) file");
}

TEST_F(WorldFileTest, EmptyBt) {
  const std::string path = dir_ + "/empty.bt";
  SaveWorldAsBt(World("empty", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(2, 2, 2)), path);
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(path); }), "'" + path + "' is an empty map");
}

TEST_F(WorldFileTest, TooLargeGrid) {
  const std::string bt = dir_ + "/arena.bt";
  SaveWorldAsBt(MakeBuiltinWorld("arena"), bt);
  WorldLoadOptions options;
  options.max_voxels = 1000;
  const std::string message = WorldErrorOf([&] { LoadWorld(bt, options); });
  EXPECT_CONTAINS(message, "too large");
  EXPECT_CONTAINS(message, "200 x 140 x 17");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld("builtin:arena", options); }), "too large");

  // Two points 40 m apart at 0.02 m: 2001^3 voxels, over the default 500 M limit.
  const std::string pcd = dir_ + "/far.pcd";
  WriteFile(pcd,
            "VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 2\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n0 0 0\n40 40 40\n");
  options = WorldLoadOptions{};
  options.pcd_resolution_m = 0.02;
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(pcd, options); }), "too large (limit 500000000 voxels");
}

TEST_F(WorldFileTest, UnknownExtension) {
  const std::string message = WorldErrorOf([&] { LoadWorld(dir_ + "/map.ply"); });
  EXPECT_CONTAINS(message, "map.ply' is not understood");
  EXPECT_CONTAINS(message, ".bt, .ot or .pcd");
}

std::string AsciiPcd(const std::vector<std::string>& rows) {
  std::string text = "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH " +
                     std::to_string(rows.size()) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
                     std::to_string(rows.size()) + "\nDATA ascii\n";
  for (const std::string& row : rows) text += row + "\n";
  return text;
}

TEST_F(WorldFileTest, PcdVoxelizedAndNonFiniteDropped) {
  const std::string path = dir_ + "/cloud.pcd";
  WriteFile(path, AsciiPcd({"0.05 0.05 0.05", "0.06 0.04 0.02", "1.05 0.55 0.25", "nan 1 1", "2 inf 0",
                            "0.95 0.05 0.05"}));
  WorldLoadReport report;
  WorldLoadOptions options;
  options.pcd_resolution_m = 0.1;
  options.support_radius_m = 0.0;  // Voxelization only: these lone points would be unsupported.
  options.fill_hole_max_m = 0.0;
  const World world = LoadWorld(path, options, &report);
  EXPECT_EQ(report.kind, "pcd");
  EXPECT_EQ(report.points_total, 6);
  EXPECT_EQ(report.points_dropped_non_finite, 2);
  EXPECT_EQ(world.CountOccupied(), 3);  // The first two points share a voxel.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.05, 0.05, 0.05)));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(1.05, 0.55, 0.25)));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.95, 0.05, 0.05)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(0.5, 0.3, 0.1)));
  EXPECT_NEAR(world.p_W_min().x(), 0.0, 1e-9);
  EXPECT_GE(world.p_W_max().x(), 1.1 - 1e-9);
}

TEST_F(WorldFileTest, PcdSupportFilterKeepsRepeatedHitsAndDropsLonePoints) {
  const std::string path = dir_ + "/support.pcd";
  std::vector<std::string> rows;
  rows.reserve(5);
  for (int i = 0; i < 5; ++i) rows.push_back("0." + std::to_string(i + 1) + "5 0.05 0.05");  // A short row.
  rows.emplace_back("3.05 3.05 1.05");                                                       // A lone point.
  for (int i = 0; i < 3; ++i) rows.emplace_back("1.52 2.53 0.54");  // Three hits of one lone voxel.
  WriteFile(path, AsciiPcd(rows));
  WorldLoadReport report;
  const World world = LoadWorld(path, {}, &report);
  EXPECT_EQ(report.voxels_read, 7);
  EXPECT_EQ(report.voxels_removed_unsupported, 1);
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(3.05, 3.05, 1.05)));
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(1.55, 2.55, 0.55)));  // pcd_min_points_per_voxel = 3.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.15, 0.05, 0.05)));
  EXPECT_CONTAINS(report.Summary(), "1 unsupported voxels removed");

  const std::string lone = dir_ + "/lone.pcd";
  WriteFile(lone, AsciiPcd({"0 0 0", "5 5 5"}));
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(lone); }), "no occupied voxel left after the support filter");
}

TEST(WorldLoadOptionsTest, CleanUpFieldsAreChecked) {
  auto why_of = [](const WorldLoadOptions& o) {
    std::string why;
    EXPECT_FALSE(o.IsValid(&why));
    return why;
  };
  WorldLoadOptions o;
  o.support_radius_m = 3.0;
  EXPECT_CONTAINS(why_of(o), "support_radius_m = 3 must be 0 (off) or in [0.01, 1] m");
  o = {};
  o.min_support_neighbors = 0;
  EXPECT_CONTAINS(why_of(o), "min_support_neighbors = 0");
  o = {};
  o.pcd_min_points_per_voxel = 0;
  EXPECT_CONTAINS(why_of(o), "pcd_min_points_per_voxel = 0");
  o = {};
  o.fill_hole_max_m = std::nan("");
  EXPECT_CONTAINS(why_of(o), "fill_hole_max_m = nan");
  o = {};
  o.fill_strip_max_m = 0.01;
  EXPECT_CONTAINS(why_of(o), "fill_strip_max_m = 0.01 must be 0 (off) or in [0.05, 3] m");
  o = {};
  o.fill_clearance_m = 0.0;
  EXPECT_CONTAINS(why_of(o), "fill_clearance_m = 0");
  o = {};
  o.fill_gap_depth_m = 9.0;
  EXPECT_CONTAINS(why_of(o), "fill_gap_depth_m = 9");
}

TEST_F(WorldFileTest, PcdErrors) {
  const std::string all_nan = dir_ + "/nan.pcd";
  WriteFile(all_nan, AsciiPcd({"nan nan nan", "inf 0 0"}));
  const std::string message = WorldErrorOf([&] { LoadWorld(all_nan); });
  EXPECT_CONTAINS(message, "'" + all_nan + "' is an empty map: no finite point");
  EXPECT_CONTAINS(message, "2 dropped as NaN/inf");

  const std::string garbage = dir_ + "/garbage.pcd";
  WriteFile(garbage, "hello, I am not a point cloud\n");
  EXPECT_CONTAINS(WorldErrorOf([&] { LoadWorld(garbage); }), "'" + garbage + "' is not a valid PCD file");
}

// Crafted headers: each is refused before PCL reads (or allocates) anything, naming the field and
// its value.
TEST_F(WorldFileTest, PcdHeadersThatLieAreRefusedNamingTheField) {
  const auto header = [](const std::string& type, const std::string& points, const std::string& data) {
    return "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE " + type + "\nCOUNT 1 1 1\nWIDTH " + points +
           "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + points + "\nDATA " + data + "\n";
  };
  const auto error_of = [this](const std::string& name, const std::string& text) {
    const std::string path = dir_ + "/" + name + ".pcd";
    WriteFile(path, text);
    return WorldErrorOf([&] { LoadWorld(path); });
  };
  // 2e9 points in a ~200-byte binary file: PCL sized the cloud first (23.5 GB).
  EXPECT_CONTAINS(
      error_of("huge", header("F F F", "2000000000", "binary") + std::string(24, '\0')),
      "the header declares 2000000000 points of 12 bytes (24 GB) but the file holds 24 bytes after it");
  // The same through binary_compressed: 8 bytes of sizes, the uncompressed one matching POINTS.
  std::string sizes(8, '\0');
  const std::uint32_t compressed = 16, uncompressed = 1200000000;
  std::memcpy(&sizes[0], &compressed, 4);
  std::memcpy(&sizes[4], &uncompressed, 4);
  EXPECT_CONTAINS(
      error_of("lzf", header("F F F", "100000000", "binary_compressed") + sizes + std::string(16, 'a')),
      "declares 100000000 points of 12 bytes (1.2 GB, at least 13.6 MB compressed)");
  std::memcpy(&sizes[4], &compressed, 4);
  EXPECT_CONTAINS(error_of("lzf_size", header("F F F", "1", "binary_compressed") + sizes),
                  "binary_compressed data of 16 bytes uncompressed, but POINTS 1 of 12 bytes make 12 bytes");
  EXPECT_CONTAINS(
      error_of("ascii", header("F F F", "1000", "ascii") + "0 0 0\n"),
      "declares 1000 points of 3 values (6000 bytes of text at least) but the file holds 6 bytes");
  EXPECT_CONTAINS(error_of("type_q", header("Q F F", "1", "ascii") + "0 0 0\n"),
                  "TYPE 'Q' of field 'x' is not I, U or F");
  EXPECT_CONTAINS(error_of("negative", header("F F F", "-5", "ascii") + "0 0 0\n"),
                  "WIDTH '-5' is not a whole number >= 0");
  std::string lying_points = header("F F F", "1", "ascii") + "0 0 0\n";
  lying_points.replace(lying_points.find("POINTS 1"), 8, "POINTS -5");
  EXPECT_CONTAINS(error_of("negative_points", lying_points), "POINTS '-5' is not a whole number >= 0");
  std::string mismatch = header("F F F", "2", "ascii") + "0 0 0\n1 1 1\n";
  mismatch.replace(mismatch.find("POINTS 2"), 8, "POINTS 3");
  EXPECT_CONTAINS(error_of("mismatch", mismatch), "POINTS 3 is not WIDTH x HEIGHT = 2 x 1");
  std::string half_float = header("F F F", "1", "ascii") + "0 0 0\n";
  half_float.replace(half_float.find("SIZE 4 4 4"), 10, "SIZE 2 4 4");
  EXPECT_CONTAINS(error_of("half", half_float), "field 'x' is TYPE F with SIZE 2");
  std::string short_type = header("F F", "1", "ascii") + "0 0 0\n";
  EXPECT_CONTAINS(error_of("short_type", short_type), "TYPE has 2 values for 3 FIELDS");
  // Found by fuzzing: binary data whose first bytes spell a header keyword. PCL's reader reads on past the
  // DATA line and took "FIELDS_..." as new fields (a heap use-after-free inside PCL 1.13).
  std::string fields_data(600, '\x3f');
  fields_data.replace(0, 8, "FIELDS_\xc0");
  EXPECT_CONTAINS(error_of("fields_after_data", header("F F F", "50", "binary") + fields_data),
                  "the data after the DATA line starts with 'FIELDS_?");
  EXPECT_CONTAINS(error_of("fields_after_data", header("F F F", "50", "binary") + fields_data),
                  "which PCL would read as a FIELDS header line");
  // Found by fuzzing: a key given twice. PCL sized the cloud from the first POINTS (48 GB); the check read
  // the last.
  EXPECT_CONTAINS(error_of("points_twice", "POINTS 2000000000\n" + header("F F F", "1", "ascii") + "0 0 0\n"),
                  "POINTS appears twice in the header");
  // Found by fuzzing: a lone carriage return before the header ended PCL's header there (SEGV inside PCL).
  EXPECT_CONTAINS(error_of("cr_first", "\r\n" + header("F F F", "1", "ascii") + "0 0 0\n"),
                  "line 1 is blank (spaces or a carriage return) before the DATA line");
  std::string comment_then_width = header("F F F", "1", "ascii") + "# a comment\nWIDTH 7\n0 0 0\n";
  EXPECT_CONTAINS(error_of("width_after_data", comment_then_width), "starts with 'WIDTH'");
  // A valid binary file still loads.
  std::string data(12, '\0');
  const float p[3] = {0.05f, 0.05f, 0.05f};
  std::memcpy(&data[0], p, 12);
  WorldLoadOptions raw;
  raw.support_radius_m = 0.0;
  raw.fill_hole_max_m = 0.0;
  const std::string good = dir_ + "/good.pcd";
  WriteFile(good, header("F F F", "1", "binary") + data);
  EXPECT_EQ(LoadWorld(good, raw).CountOccupied(), 1);
}

TEST(Geb079Test, LoadsRealScan) {
  CAIRN_SKIP_WITHOUT_GEB079();
  WorldLoadReport report;
  const World world = LoadWorld(testing::Geb079Path(), {}, &report);
  EXPECT_EQ(report.kind, "bt");
  std::printf("FIGURE geb079_load %s\n", report.Summary().c_str());
  EXPECT_EQ(report.leaves_occupied, 143729);
  EXPECT_DOUBLE_EQ(world.resolution_m(), 0.08);
  EXPECT_TRUE(world.bounds().min().isApprox(Eigen::Vector3d(-8.0, -7.52, -0.32), 1e-6));
  EXPECT_TRUE(world.bounds().max().isApprox(Eigen::Vector3d(30.96, 7.44, 2.8), 1e-6));
  EXPECT_EQ(world.dims(), Eigen::Vector3i(487, 187, 39));
  // 137745 single-voxel leaves + 5983 leaves of 2^3 voxels + 1 leaf of 4^3 voxels.
  EXPECT_EQ(report.voxels_read, 185673);
  // The clean-up (default options) changes little on this dense scan: a few dozen isolated voxels, and
  // holes up to 0.6 m in the floors seen only sparsely (offices seen through their doors), with the strips up
  // to 0.6 m across between floor seen on both sides (gaps between the fans of floor seen through a door) and
  // the holes those strips close: 6041 voxels (170 in strips; 5713 with strip filling off).
  EXPECT_LT(report.voxels_removed_unsupported, 100);
  EXPECT_LT(report.voxels_filled_floor, 8000);
  EXPECT_LT(report.voxels_filled_strip, 500);
  EXPECT_EQ(world.CountOccupied(), 185673 - report.voxels_removed_unsupported + report.voxels_filled_floor);
  WorldLoadOptions raw;
  raw.support_radius_m = 0.0;
  raw.fill_hole_max_m = 0.0;
  EXPECT_EQ(LoadWorld(testing::Geb079Path(), raw).CountOccupied(), 185673);
  // The corridor floor near the origin is occupied; the corridor above it is free.
  EXPECT_TRUE(world.IsOccupied(Eigen::Vector3d(0.0, 0.0, -0.04)) ||
              world.IsOccupied(Eigen::Vector3d(0.0, 0.0, -0.12)));
  EXPECT_FALSE(world.IsOccupied(Eigen::Vector3d(0.0, 0.0, 1.0)));
}

}  // namespace
}  // namespace cairn::sim
