#include "cairn/agent/agent_options.h"

#include <gtest/gtest.h>

#include <fstream>

#include "cairn/core/build_paths.h"
#include "cairn/core/config.h"
#include "cairn/nav/platform.h"

namespace cairn::agent {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(AgentOptions, DefaultsAndShippedConfigAreValid) {
  AgentOptions options;
  options.robot_id = "r1";
  std::string why;
  EXPECT_TRUE(options.IsValid(&why)) << why;
  options.LoadConfigFile(cairn::core::SourceDir() + "/config/agent.yaml");
  EXPECT_TRUE(std::isinf(options.lock.lock_keep_s));
  EXPECT_DOUBLE_EQ(options.teleop_timeout_s, 0.5);
}

TEST(AgentOptions, ConfigErrorsNameFileFieldAndValue) {
  AgentOptions options;
  options.robot_id = "r1";
  try {
    options.LoadConfigFile(Write("bad1.yaml", "mux:\n  teleop_timeout_s: -2\n"));
    FAIL();
  } catch (const core::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("mux.teleop_timeout_s = -2 must be in (0, 60]"), std::string::npos)
        << e.what();
  }
  try {
    options.LoadConfigFile(Write("bad2.yaml", "navigation:\n  cruise_speed: 1\n"));
    FAIL();
  } catch (const core::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("navigation.cruise_speed is not a known setting"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(options.LoadConfigFile(Write("bad3.yaml", "command_interface:\n  lock_keep_s: soon\n")),
               core::ConfigError);
  try {
    AgentOptions fresh;
    fresh.robot_id = "r1";
    fresh.LoadConfigFile(Write("bad4.yaml", "health:\n  restart_backoff_s: 5\n  restart_backoff_max_s: 2\n"));
    FAIL();
  } catch (const core::ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("health.restart_backoff_max_s = 2"), std::string::npos) << e.what();
  }
}

TEST(AgentOptions, NavigationConfigErrorsNameTheField) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"controller:\n  horizon_steps: 0\n", "horizon_steps = 0"},
      {"controller:\n  dt_s: -0.1\n", "dt_s = -0.1"},
      {"local_planner:\n  voxel_size_m: 5\n", "voxel_size_m = 5"},
      {"local_planner:\n  collision_margin_m: -1\n", "local_planner.collision_margin_m = -1"},
      {"navigation:\n  carrot_distance_m: 0\n", "navigation.carrot_distance_m = 0"},
      {"navigation:\n  cruise_speed_mps: 9\n", "cruise_speed_mps = 9"},
      {"navigation:\n  unmapped_goal_max_replans: 0\n", "navigation.unmapped_goal_max_replans = 0"},
      {"navigation:\n  unmapped_goal_timeout_s: -5\n", "navigation.unmapped_goal_timeout_s = -5"},
      {"navigation:\n  max_hold_s: 0\n", "navigation.max_hold_s = 0"},
      {"traversability:\n  max_step_m: -0.1\n", "max_step_m = -0.1"},
      {"local_planner:\n  speed: 1\n", "local_planner.speed is not a known setting"},
      {"explore:\n  settle_s: -1\n", "explore.settle_s = -1"},
      {"explore:\n  complete_settle_s: 40\n", "explore.complete_settle_s = 40"},
      {"explore:\n  min_gain_m2: -3\n", "FrontierOptions::min_gain_m2 = -3"},
      {"explore:\n  switch_utility_ratio: 0.5\n", "ExplorerOptions::switch_utility_ratio = 0.5"},
      {"explore:\n  radius: 5\n", "explore.radius is not a known setting"},
      {"explore:\n  levels: upstairs\n", "explore.levels = 'upstairs' must be auto, main or all"},
  };
  for (const auto& [yaml, expected] : cases) {
    AgentOptions options;
    options.robot_id = "r1";
    try {
      options.LoadConfigFile(Write("nav_bad.yaml", yaml));
      ADD_FAILURE() << "accepted: " << yaml;
    } catch (const core::ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << yaml << " -> " << e.what();
    }
  }
}

TEST(AgentOptions, PlatformProfilesSetLimitsAndStairs) {
  AgentOptions options;
  options.robot_id = "r1";
  options.SetPlatform("legged");
  std::string why;
  EXPECT_TRUE(options.IsValid(&why)) << why;
  EXPECT_GE(options.navigation.platform.traversability.max_step_m, 0.2);
  EXPECT_DOUBLE_EQ(options.LibraryForPlatform().heading_range_rad,
                   options.navigation.platform.local_heading_range_rad);
  // The shipped config keeps the profile's platform values (it only comments them).
  options.LoadConfigFile(cairn::core::SourceDir() + "/config/agent.yaml");
  EXPECT_GE(options.navigation.platform.traversability.max_step_m, 0.2);
  EXPECT_DOUBLE_EQ(options.navigation.platform.limits.max_speed_mps, 0.6);
  EXPECT_THROW(options.SetPlatform("hovercraft"), std::invalid_argument);
}

// explore.levels: a legged robot (it climbs a stair rise) explores every level of its map by default, a
// wheeled one its main level; the config names either.
TEST(AgentOptions, ExploreLevelsFollowThePlatformUnlessTheConfigNamesThem) {
  ExploreModeOptions explore;
  explore.platform_max_step_m = nav::GetPlatformProfile("legged").traversability.max_step_m;
  EXPECT_TRUE(explore.EveryLevel());
  explore.platform_max_step_m = nav::GetPlatformProfile("wheeled").traversability.max_step_m;
  EXPECT_FALSE(explore.EveryLevel());
  AgentOptions options;
  options.robot_id = "r1";
  options.LoadConfigFile(Write("levels.yaml", "explore:\n  levels: all\n"));
  EXPECT_EQ(options.explore.levels, ExploreModeOptions::Levels::kAll);
  options.LoadConfigFile(Write("levels.yaml", "explore:\n  levels: main\n"));
  EXPECT_EQ(options.explore.levels, ExploreModeOptions::Levels::kMain);
  options.explore.platform_max_step_m = 0.3;
  EXPECT_FALSE(options.explore.EveryLevel());
  options.explore.platform_max_step_m = -1;
  std::string why;
  EXPECT_FALSE(options.explore.IsValid(&why));
  EXPECT_NE(why.find("explore.platform_max_step_m = -1"), std::string::npos) << why;
}

TEST(AgentOptions, IdsAndPlatformsAreChecked) {
  AgentOptions options;
  std::string why;
  options.robot_id = "";
  EXPECT_FALSE(options.IsValid(&why));
  options.robot_id = "r 1";
  EXPECT_FALSE(options.IsValid(&why));
  options.robot_id = "r1";
  options.platform = "tracked";
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_NE(why.find("tracked"), std::string::npos);
}

TEST(StartPose, ParsesAndRejects) {
  const core::PlanarPose p = ParseStartPose("1.5,-2");
  EXPECT_DOUBLE_EQ(p.x_m, 1.5);
  EXPECT_DOUBLE_EQ(p.y_m, -2.0);
  EXPECT_DOUBLE_EQ(ParseStartPose("1,2,0.5").yaw_rad, 0.5);
  for (const char* bad : {"", "1", "1,2,3,4", "a,b", "1,nan", "1,2,", "1,inf"}) {
    EXPECT_THROW(ParseStartPose(bad), std::invalid_argument) << bad;
  }
  AgentOptions options;
  ParseStart("slot:2", &options);
  EXPECT_EQ(options.start_slot, 2);
  EXPECT_FALSE(options.start_W.has_value());
  for (const char* bad : {"slot:", "slot:-1", "slot:100", "slot:x"}) {
    EXPECT_THROW(ParseStart(bad, &options), std::invalid_argument) << bad;
  }
}

// A radio link holds the robot's bulk traffic to shares of its budget; other links leave the config alone.
TEST(AgentOptions, ARadioLinkLowersMapAndCameraBudgetsToTheirSharesOnly) {
  AgentOptions options;
  options.robot_id = "r1";
  options.perception.telemetry.budget_bits_per_s = 100000;
  options.perception.camera_budget_bits_per_s = 4000000;
  options.link = core::LinkOptions{"lan", "10.77.0.0/24", "", 0, ""};
  EXPECT_EQ(options.ApplyLinkBudget(), "");
  EXPECT_EQ(options.perception.camera_budget_bits_per_s, 4000000);
  options.link = core::LinkOptions{"radio", "10.77.0.0/24", "", 1000, ""};
  EXPECT_EQ(options.ApplyLinkBudget(), "camera 4000000 -> 150000 bit/s");  // map: 100 kbit/s is under 25 %
  EXPECT_DOUBLE_EQ(options.perception.telemetry.budget_bits_per_s, 100000);
  EXPECT_DOUBLE_EQ(options.perception.camera_budget_bits_per_s, 150000);
  options.link.link_kbps = 200;
  EXPECT_EQ(options.ApplyLinkBudget(), "map telemetry 100000 -> 50000 bit/s, camera 150000 -> 30000 bit/s");
  std::string why;
  EXPECT_TRUE(options.IsValid(&why)) << why;
}

// A radio too slow for one map message is refused naming --link-kbps, unless perception (the map) is off.
TEST(AgentOptions, ARadioTooSlowForOneMapMessageIsRefusedNamingTheFlagUnlessPerceptionIsOff) {
  AgentOptions options;
  options.robot_id = "r1";
  options.link = core::LinkOptions{"radio", "10.77.0.0/24", "", 8, ""};
  try {
    options.ApplyLinkBudget();
    FAIL() << "8 kbit/s accepted for map telemetry";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--link-kbps 8"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("perception.enabled"), std::string::npos) << e.what();
  }
  AgentOptions light;
  light.robot_id = "r1";
  light.perception.enabled = false;
  light.link = options.link;
  EXPECT_EQ(light.ApplyLinkBudget(), "");
  std::string why;
  EXPECT_TRUE(light.IsValid(&why)) << why;
}

}  // namespace
}  // namespace cairn::agent
