// The journal: what a restarted robot reads back, and what it refuses, naming the field.
#include "cairn/agent/journal.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <thread>

namespace cairn::agent {
namespace {

namespace fs = std::filesystem;

std::string FreshDir(const std::string& name) {
  const fs::path dir = fs::path(::testing::TempDir()) / name;
  fs::remove_all(dir);
  return dir.lexically_normal().string();
}

JournalEntry Driving() {
  JournalEntry e;
  e.robot_id = "r1";
  e.holder_id = "opA";
  e.mode = "waypoint";
  e.has_goal = true;
  e.goal_id = 77;
  e.goal_x_m = 12.5;
  e.goal_y_m = -3.0;
  e.goal_tolerance_m = 0.4;  // z NaN: the robot's level
  e.x_m = 1.0;
  e.y_m = 2.0;
  e.z_m = 0.1;
  e.yaw_rad = 0.5;
  return e;
}

bool WaitForWrites(const JournalWriter& writer, int count) {
  for (int i = 0; i < 200 && writer.writes() < count; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return writer.writes() >= count;
}

TEST(Journal, WhatIsWrittenIsReadBackWithItsMapSnapshot) {
  const std::string dir = FreshDir("journal_roundtrip");
  EXPECT_FALSE(ReadJournal(dir, "r1").has_value());  // no journal yet: a fresh start
  int snapshots = 0;
  {
    JournalWriter writer(dir, 0.05, [&](const std::string& path) {
      std::ofstream(path) << "snapshot";  // stands in for the map's SaveBt
      ++snapshots;
    });
    writer.Submit(Driving());
    ASSERT_TRUE(WaitForWrites(writer, 1));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // a snapshot is due, then referred to
  }
  EXPECT_GE(snapshots, 1);
  const std::optional<JournalEntry> read = ReadJournal(dir, "r1");
  ASSERT_TRUE(read.has_value());
  EXPECT_TRUE(read->SameStateAs([] {
    JournalEntry e = Driving();
    e.map_file = "map.bt";
    return e;
  }()));
  EXPECT_TRUE(std::isnan(read->goal_z_m));
  EXPECT_DOUBLE_EQ(read->x_m, 1.0);
  EXPECT_DOUBLE_EQ(read->yaw_rad, 0.5);
  EXPECT_FALSE(fs::exists(JournalFile(dir) + ".tmp"));  // replaced whole, never half written
}

TEST(Journal, AnUnchangedStateAndASmallMoveAreNotWrittenAgain) {
  const std::string dir = FreshDir("journal_changes");
  JournalWriter writer(dir, 1.0, nullptr);
  JournalEntry e = Driving();
  writer.Submit(e);
  ASSERT_TRUE(WaitForWrites(writer, 1));
  e.x_m += 0.05;  // a small move: not worth a write yet
  writer.Submit(e);
  std::this_thread::sleep_for(std::chrono::milliseconds(400));
  EXPECT_EQ(writer.writes(), 1);
  e.x_m += 0.5;  // a real move
  writer.Submit(e);
  ASSERT_TRUE(WaitForWrites(writer, 2));
  e.mode = "idle";  // a change of state
  e.has_goal = false;
  writer.Submit(e);
  ASSERT_TRUE(WaitForWrites(writer, 3));
  EXPECT_EQ(ReadJournal(dir, "r1")->mode, "idle");
}

TEST(Journal, ABadJournalIsRefusedNamingTheFieldAndTheValue) {
  const std::string dir = FreshDir("journal_bad");
  fs::create_directories(dir);
  const auto refused = [&](const std::string& text, const std::string& robot) -> std::string {
    std::ofstream(JournalFile(dir)) << text;
    try {
      ReadJournal(dir, robot);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "accepted";
  };
  const std::string good =
      R"({"version":1,"robot_id":"r1","holder_id":"opA","mode":"idle","pose_M":{"x_m":1,"y_m":2,"z_m":0,"yaw_rad":0},"goal":null,"map_file":""})";
  EXPECT_EQ(refused(good, "r1"), "accepted");
  EXPECT_NE(refused(good, "r2").find("robot 'r1''s, not r2's"), std::string::npos);
  EXPECT_NE(refused("{not json", "r1").find(JournalFile(dir)), std::string::npos);
  std::string bad = good;
  bad.replace(bad.find("\"x_m\":1"), 7, "\"x_m\":1e300");
  EXPECT_NE(refused(bad, "r1").find("pose_M.x_m"), std::string::npos);
  bad = good;
  bad.replace(bad.find("\"opA\""), 5, "\"op A\"");
  EXPECT_NE(refused(bad, "r1").find("holder_id 'op A'"), std::string::npos);
  bad = good;
  bad.replace(bad.find("\"map_file\":\"\""), 13, "\"map_file\":\"map.bt\"");
  EXPECT_NE(refused(bad, "r1").find("map_file 'map.bt' does not exist"), std::string::npos);
  bad = good;
  bad.replace(bad.find("\"goal\":null"), 11,
              "\"goal\":{\"goal_id\":3,\"x_m\":\"far\",\"y_m\":0,\"tolerance_m\":0}");
  EXPECT_NE(refused(bad, "r1").find("goal.x_m"), std::string::npos);
  EXPECT_NE(refused(R"({"version":2})", "r1").find("version 2"), std::string::npos);
}

}  // namespace
}  // namespace cairn::agent
