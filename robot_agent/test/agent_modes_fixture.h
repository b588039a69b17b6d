// Shared by the tests of the pieces the agent composes around its modes (missions, yields), without DDS: one
// robot's real mode modules under the shipped mode tree, with its navigation on a world's grid.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>

#include "../../nav/test/nav_test_util.h"
#include "cairn/agent/modes/mission_resumption.h"
#include "cairn/agent/modes/modes.h"
#include "cairn/agent/team/yield.h"

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

/// One wheeled robot `id`'s modes, the shipped mode tree and the mission it runs, in `world` (default: a
/// 10 x 8 m yard) at `pose_M` (default (1, 4)), held by opA; `localized` is a condition that comes and goes.
struct Robot {
  explicit Robot(std::shared_ptr<const sim::World> world = nullptr, std::string id = "r1",
                 core::BaseState pose = At(1.0, 4.0))
      : robot_id(std::move(id)),
        planner(std::make_shared<nav::GlobalPlanner>(
            world ? world : std::make_shared<const sim::World>(nav::testing::FlatWorld(10, 8)),
            std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")})),
        navigation(NavigationOptions{}, planner, Library()),
        control(TreeFile(), Registry(), robot_id),
        missions(robot_id, Options(), {&control, waypoint, explore, convoy, yield, &navigation},
                 [this](const std::string& mode) { return control.Request(mode, Conditions()); }),
        pose_M(pose) {}

  static core::BaseState At(double x_m, double y_m) {
    core::BaseState s;
    s.x_m = x_m;
    s.y_m = y_m;
    return s;
  }
  static std::string TreeFile() { return std::string(CAIRN_SOURCE_DIR) + "/config/mode_tree.xml"; }

  static MissionOptions Options() {
    MissionOptions o;
    o.resume_within_s = 10.0;
    o.retry_every_s = 1.0;
    return o;
  }
  ModeRegistry Registry() {
    ModeRegistry r;
    r.Emplace<IdleMode>();
    r.Emplace<ManualMode>(0.5);
    r.Emplace<SmartJoystickMode>(&navigation, 0.5, 0.5);
    WaypointModeOptions w;
    w.robot_id = robot_id;
    w.first_goal_id = 40;
    waypoint = &r.Emplace<WaypointMode>(w, &navigation, nullptr);
    ExploreModeOptions e;
    e.robot_id = robot_id;
    e.first_task_id = 70;
    explore = &r.Emplace<ExploreMode>(e, &navigation, nullptr);
    convoy = &r.Emplace<ConvoyMode>(ConvoyOptions{}, 0.5, &navigation);
    yield = &r.Emplace<YieldMode>(YieldOptions{}, 0.5, &navigation);
    return r;
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
    std::optional<PausedMission> running = missions.Running(now_s);
    ASSERT_TRUE(running.has_value()) << "a mission runs in " << control.mode();
    localized = false;
    const ModeDecision d = control.Recheck(Conditions());
    ASSERT_FALSE(d.accepted);
    ASSERT_EQ(control.mode(), "idle");
    missions.Pause(std::move(*running), "IsLocalized: no pose estimate", mission_commands);
  }
  void Step(double now_s) {
    missions.Step(now_s, pose_M, {}, mission_commands, [this] { return localized; });
  }

  std::string robot_id;
  std::shared_ptr<nav::GlobalPlanner> planner;
  Navigation navigation;
  WaypointMode* waypoint = nullptr;
  ExploreMode* explore = nullptr;
  ConvoyMode* convoy = nullptr;
  YieldMode* yield = nullptr;
  ModeControl control;
  MissionResumption missions;
  core::BaseState pose_M;
  bool localized = true;
  std::uint64_t mission_commands = 0;
};

}  // namespace cairn::agent::mode_testing
