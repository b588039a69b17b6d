#include "cairn/base/places.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "cairn/core/build_paths.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/world.h"

namespace cairn::base {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(Places, AddSaveLoadRemove) {
  const std::string path = ::testing::TempDir() + "/places_roundtrip.yaml";
  std::filesystem::remove(path);
  Places places = Places::Load(path);  // absent: empty
  EXPECT_TRUE(places.All().empty());
  places.Add({"junction", 30.0, 20.0, 0.0});
  places.Add({"stairs_top", 54.5, 23.8, 1.0});
  places.Save();
  const Places again = Places::Load(path);
  ASSERT_TRUE(again.Find("stairs_top"));
  EXPECT_DOUBLE_EQ(again.Find("stairs_top")->z_m, 1.0);
  EXPECT_EQ(again.Names(), (std::vector<std::string>{"junction", "stairs_top"}));
  places.Remove("junction");
  EXPECT_FALSE(places.Find("junction"));
}

TEST(Places, BadFilesAndNamesAreRefusedNamingTheField) {
  auto message = [](const std::string& path) -> std::string {
    try {
      Places::Load(path);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "(loaded)";
  };
  EXPECT_NE(message(Write("p1.yaml", "places:\n  room: {x_m: north, y_m: 1}\n"))
                .find("x_m = 'north' is not a number"),
            std::string::npos);
  EXPECT_NE(message(Write("p2.yaml", "places:\n  room: {x_m: 1}\n")).find("needs x_m and y_m"),
            std::string::npos);
  EXPECT_NE(
      message(Write("p3.yaml", "places:\n  room: {x_m: 1, y_m: 2, w_m: 3}\n")).find("unknown key 'w_m'"),
      std::string::npos);
  EXPECT_NE(message(Write("p4.yaml", "places:\n  9lives: {x_m: 1, y_m: 2}\n")).find("place name '9lives'"),
            std::string::npos);
  EXPECT_NE(message(Write("p5.yaml", "places: [\n")).find("not valid YAML"), std::string::npos);
  EXPECT_NE(
      message(Write("p6.yaml", "a: &a {x_m: 1, y_m: 2}\nplaces:\n  room: *a\n")).find("YAML alias '*a'"),
      std::string::npos);
  Places places;
  EXPECT_THROW(places.Add({"a", std::nan(""), 0, 0}), std::invalid_argument);
  EXPECT_THROW(places.Add({"has space", 0, 0, 0}), std::invalid_argument);
}

// The landmarks the demo ships are on free ground of their built-in world (a wheeled robot fits there).
TEST(Places, ShippedLandmarksAreOnFreeGround) {
  for (const std::string world : {"tunnels", "arena"}) {
    const Places places = Places::Load(cairn::core::SourceDir() + "/config/places/" + world + ".yaml");
    ASSERT_FALSE(places.All().empty()) << world;
    const sim::World w = sim::MakeBuiltinWorld(world);
    const nav::TraversabilityGrid grid(w, nav::TraversabilityOptions{});
    for (const Place& p : places.All()) {
      const auto ground = grid.GroundHeight(p.x_m, p.y_m);
      EXPECT_TRUE(grid.IsFootprintFree(p.x_m, p.y_m, 0.35)) << world << " " << p.name;
      ASSERT_TRUE(ground) << world << " " << p.name;
      EXPECT_NEAR(*ground, p.z_m, 0.15) << world << " " << p.name;
    }
  }
}

}  // namespace
}  // namespace cairn::base
