#include "cairn/agent/services/trajectory_library_cache.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace cairn::agent {
namespace {

namespace fs = std::filesystem;

// A small library: quick to build, the same code path as the agent's.
nav::TrajectoryLibraryOptions SmallOptions() {
  nav::TrajectoryLibraryOptions o;
  o.num_groups = 3;
  o.paths_per_group = 9;
  o.num_headings = 12;
  return o;
}

class LibraryCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/cairn_library_cache_XXXXXX";
    ASSERT_NE(mkdtemp(pattern), nullptr);
    root_ = pattern;
  }
  void TearDown() override { fs::remove_all(root_); }
  std::string root_;
};

TEST_F(LibraryCacheTest, BuildsAndCachesThenLoadsTheSameLibrary) {
  const std::string dir = root_ + "/cache";  // created on the first write
  const CachedLibrary first = LoadOrBuildTrajectoryLibrary(SmallOptions(), dir);
  ASSERT_NE(first.library, nullptr);
  EXPECT_FALSE(first.loaded);
  EXPECT_FALSE(first.cache_failed);
  const std::string file = dir + "/" + TrajectoryLibraryCacheFile(SmallOptions());
  EXPECT_NE(first.how.find("cached in " + file), std::string::npos) << first.how;
  ASSERT_TRUE(fs::exists(file));
  EXPECT_EQ(fs::directory_iterator(dir)->path().string(), file);  // no temporary file left

  const CachedLibrary second = LoadOrBuildTrajectoryLibrary(SmallOptions(), dir);
  ASSERT_NE(second.library, nullptr);
  EXPECT_TRUE(second.loaded);
  EXPECT_EQ(second.how.rfind("loaded from " + file, 0), 0u) << second.how;
  EXPECT_EQ(second.library->Serialize(), first.library->Serialize());

  // Other options: another file, built.
  nav::TrajectoryLibraryOptions other = SmallOptions();
  other.collision_radius_m = 0.4;
  EXPECT_NE(TrajectoryLibraryCacheFile(other), TrajectoryLibraryCacheFile(SmallOptions()));
  EXPECT_FALSE(LoadOrBuildTrajectoryLibrary(other, dir).loaded);
}

TEST_F(LibraryCacheTest, ADamagedFileIsRefusedNamingWhyAndReplaced) {
  const std::string dir = root_;
  const std::string file = dir + "/" + TrajectoryLibraryCacheFile(SmallOptions());
  const std::string good = [&] {
    LoadOrBuildTrajectoryLibrary(SmallOptions(), dir);
    std::ifstream in(file, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  auto write = [&](const std::string& bytes) {
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
  };
  struct Case {
    std::string bytes, needle;
  };
  std::string flipped = good;
  flipped[flipped.size() / 2] = static_cast<char>(flipped[flipped.size() / 2] ^ 0x5a);
  const Case cases[] = {
      {"", "not a zstd frame"},
      {"a text file\n", "not a zstd frame"},
      {good.substr(0, good.size() / 2), "zstd: "},
      {flipped, "zstd: "},  // the frame's checksum (or its block structure) catches it
  };
  for (const Case& c : cases) {
    write(c.bytes);
    const CachedLibrary cached = LoadOrBuildTrajectoryLibrary(SmallOptions(), dir);
    ASSERT_NE(cached.library, nullptr);
    EXPECT_FALSE(cached.loaded);
    EXPECT_TRUE(cached.cache_failed);
    EXPECT_NE(cached.how.find(file + " was refused (" + c.needle), std::string::npos) << cached.how;
    EXPECT_NE(cached.how.find("and replaced"), std::string::npos) << cached.how;
    EXPECT_TRUE(LoadOrBuildTrajectoryLibrary(SmallOptions(), dir).loaded);  // the replacement loads
  }
}

TEST_F(LibraryCacheTest, NoFolderOrAnUnwritableOneOnlyCostsTheBuild) {
  const CachedLibrary off = LoadOrBuildTrajectoryLibrary(SmallOptions(), "");
  ASSERT_NE(off.library, nullptr);
  EXPECT_FALSE(off.cache_failed);
  EXPECT_NE(off.how.find("not cached: no cache folder"), std::string::npos) << off.how;

  std::ofstream(root_ + "/a_file") << "x";
  const std::string under_a_file = root_ + "/a_file/cache";
  const CachedLibrary unwritable = LoadOrBuildTrajectoryLibrary(SmallOptions(), under_a_file);
  ASSERT_NE(unwritable.library, nullptr);
  EXPECT_TRUE(unwritable.cache_failed);
  EXPECT_NE(unwritable.how.find("not cached (local_planner.library_cache_dir '" + under_a_file +
                                "'): cannot create the folder"),
            std::string::npos)
      << unwritable.how;
}

TEST(LibraryCacheDir, ConfiguredThenXdgThenHomeAndOff) {
  EXPECT_EQ(TrajectoryLibraryCacheDir("off"), "");
  EXPECT_EQ(TrajectoryLibraryCacheDir("/var/cache/robot"), "/var/cache/robot");
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const std::string saved_xdg = xdg ? xdg : "", saved_home = home ? home : "";
  setenv("XDG_CACHE_HOME", "/x/cache", 1);
  setenv("HOME", "/home/op", 1);
  EXPECT_EQ(TrajectoryLibraryCacheDir(""), "/x/cache/cairn");
  unsetenv("XDG_CACHE_HOME");
  EXPECT_EQ(TrajectoryLibraryCacheDir(""), "/home/op/.cache/cairn");
  unsetenv("HOME");
  EXPECT_EQ(TrajectoryLibraryCacheDir(""), "");
  if (xdg) setenv("XDG_CACHE_HOME", saved_xdg.c_str(), 1);
  if (home) setenv("HOME", saved_home.c_str(), 1);
}

}  // namespace
}  // namespace cairn::agent
