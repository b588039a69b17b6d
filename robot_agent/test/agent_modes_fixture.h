// Shared by the tests of the pieces the agent composes around its modes (missions, yields), without DDS: one
// robot's modes as the agent composes them (RobotModes), with its navigation on a world's grid.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "../../nav/test/nav_test_util.h"
#include "cairn/agent/agent_options.h"
#include "cairn/agent/modes/robot_modes.h"
#include "cairn/agent/team/yield.h"
#include "cairn/core/build_paths.h"

namespace cairn::agent::mode_testing {

/// The wheeled platform's trajectory library, built once per process (about a second).
inline std::shared_ptr<const nav::TrajectoryLibrary> Library() {
  static auto library = [] {
    nav::TrajectoryLibraryOptions o;
    o.heading_range_rad = nav::GetPlatformProfile("wheeled").local_heading_range_rad;
    return std::make_shared<const nav::TrajectoryLibrary>(o);
  }();
  return library;
}

/// One wheeled robot `id`'s modes as the agent composes them (RobotModes: the shipped mode tree, the real
/// modules, missions and yields), in `world` (default: a 10 x 8 m yard) at `pose_M` (default (1, 4)), held by
/// opA; `localized` is a condition that comes and goes.
struct Robot {
  explicit Robot(std::shared_ptr<const sim::World> world = nullptr, std::string id = "r1",
                 core::BaseState pose = At(1.0, 4.0))
      : robot_id(std::move(id)),
        planner(std::make_shared<nav::GlobalPlanner>(
            world ? world : std::make_shared<const sim::World>(nav::testing::FlatWorld(10, 8)),
            std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")})),
        navigation(nav::NavigationOptions{}, planner, Library()),
        modes(Options(robot_id), TreeFile(), &navigation, Hooks(), RobotModes::Ids::kFromOne),
        control(modes.control()),
        missions(modes.missions()),
        waypoint(&modes.waypoint()),
        explore(&modes.explore()),
        convoy(&modes.convoy()),
        yield(&modes.yield()),
        pose_M(pose) {}

  static core::BaseState At(double x_m, double y_m) {
    core::BaseState s;
    s.x_m = x_m;
    s.y_m = y_m;
    return s;
  }
  static std::string TreeFile() { return cairn::core::SourceDir() + "/config/mode_tree.xml"; }

  static AgentOptions Options(const std::string& robot_id) {
    AgentOptions o;
    o.robot_id = robot_id;
    o.SetPlatform("wheeled");
    o.mission.resume_within_s = 10.0;
    o.mission.retry_every_s = 1.0;
    return o;
  }
  RobotModes::Hooks Hooks() {
    RobotModes::Hooks h;
    h.conditions = [this] { return Conditions(); };
    h.clear_obstacle_memory = [] {};
    h.mission_commands = [this] { return mission_commands; };
    h.grid = [this] { return planner->Grid("wheeled"); };
    h.clock = core::RealClock();
    return h;
  }
  ModeConditions Conditions() const {
    ModeConditions c;
    c.holder_id = "opA";
    c.holder_alive = true;
    c.localized = localized;
    c.local_planner_healthy = true;
    c.mapping_healthy = true;
    c.has_waypoint_goal = waypoint->has_goal();
    c.has_explore_task = explore->exploring();
    c.has_convoy_task = convoy->active();
    c.has_yield_task = yield->active();
    return c;
  }
  // The agent's handling of a lost condition: the tree re-checks, the mode goes idle, the mission pauses.
  void LoseLocalization(double now_s) {
    ASSERT_TRUE(missions.Running(now_s).has_value()) << "a mission runs in " << control.mode();
    localized = false;
    modes.Recheck(now_s);
    ASSERT_EQ(control.mode(), "idle");
    ASSERT_TRUE(missions.paused().has_value());
  }
  void Step(double now_s) {
    missions.Step(now_s, pose_M, {}, mission_commands, [this] { return localized; });
  }

  std::string robot_id;
  std::shared_ptr<nav::GlobalPlanner> planner;
  nav::Navigation navigation;
  RobotModes modes;
  ModeControl& control;
  MissionResumption& missions;
  WaypointMode* waypoint;
  ExploreMode* explore;
  ConvoyMode* convoy;
  YieldMode* yield;
  core::BaseState pose_M;
  bool localized = true;
  std::uint64_t mission_commands = 0;
};

}  // namespace cairn::agent::mode_testing
