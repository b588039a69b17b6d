// One robot exploring on SteppedRobot (stepped_robot.h), the second wiring of the agent's components that the
// scenario tests used before the agent itself could be stepped (RobotAgent::Stepped). Kept for one scenario
// only: a legged robot exploring both floors of builtin:building. The shipping agent, stepped over the same
// world, stops on the landing between the flights with the upper flight's frontiers seen but unreachable
// (2026-11-27; docs/AGENT.md "What still runs on SteppedRobot"): until that is found and mended this scenario
// checks the climb on the wiring that makes it, and the agent's own run is in explore_test.cpp.
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "explore_team.h"
#include "stepped_robot.h"

namespace cairn::agent::explore_team {

/// RunTeam for one robot (o.starts[0]) on SteppedRobot: no peers, no kill; coverage scored as RunTeam does.
inline TeamRun RunOneSteppedRobot(const TeamOptions& o) {
  constexpr double kDt = 0.02;
  const auto wall_start = std::chrono::steady_clock::now();
  TeamRun run;
  AgentOptions options;
  options.robot_id = "r1";
  options.SetPlatform(o.platform);
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = o.world;
  sim_options.start_W = o.starts.at(0);
  sim::ApplyPlatformProfile(options.navigation.platform, &sim_options);
  auto platform = std::make_shared<sim::SimulatedPlatform>(sim_options);
  SteppedRobot robot(options, platform, "");
  robot.Explore(o.task, 0.0);
  nav::TraversabilityOptions floor_options = options.navigation.platform.traversability;
  floor_options.robot_radius_m = options.navigation.platform.footprint_radius_m;
  double t = 0.0;
  while (robot.explore().exploring() && t < o.timeout_s) {
    t += kDt;
    robot.Step(t);
    while (robot.planning()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    run.highest_z_m = std::max(run.highest_z_m, platform->TrueState().z_m);
  }
  run.end_s = t;
  const auto truth = std::make_shared<const nav::TraversabilityGrid>(*platform->world(), floor_options);
  run.coverage = Coverage(*truth, {&robot.nav_map().grid()}, o.starts[0].x_m, o.starts[0].y_m);
  const auto truth_levels = std::make_shared<const nav::MultiLevelGrid>(platform->world(), floor_options);
  for (const auto& [z0, z1] : o.level_bands) {
    run.level_coverage.push_back(CoverageOnLevels(*truth_levels, {&robot.nav_map().levels()},
                                                  {o.starts[0].x_m, o.starts[0].y_m, 0.0}, z0, z1));
  }
  run.contact = robot.ever_in_contact();
  run.statuses.push_back(robot.explore().status());
  run.driven_m.push_back(platform->distance_travelled_m());
  run.end_speed_mps = std::abs(platform->TrueState().v_mps);
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return run;
}

}  // namespace cairn::agent::explore_team
