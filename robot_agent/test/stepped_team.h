// Wheeled robots in a built-in world, each one's autonomy stepped in process on a simulated clock
// (SteppedRobot), for the team tests (convoy, get out of the way).
#pragma once

#include <chrono>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cairn/agent/stepped_robot.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent::team_testing {

struct SteppedTeam {
  std::vector<std::shared_ptr<sim::SimulatedPlatform>> platforms;  // ground truth: TrueState()
  std::vector<std::unique_ptr<SteppedRobot>> robots;
};

/// Robots `starts` (id, start pose in frame W = M) in `world`, with peers.margin_m `peer_margin_m` (metres).
inline SteppedTeam MakeSteppedTeam(const std::string& world,
                                   const std::vector<std::pair<std::string, core::PlanarPose>>& starts,
                                   double peer_margin_m = PeerOptions{}.margin_m) {
  SteppedTeam team;
  for (const auto& [id, start] : starts) {
    AgentOptions options;
    options.robot_id = id;
    options.SetPlatform("wheeled");
    options.peers.margin_m = peer_margin_m;
    sim::SimulatedPlatformOptions sim_options;
    sim_options.world = world;
    sim_options.start_W = start;
    sim::ApplyPlatformProfile(options.navigation.platform, &sim_options);
    team.platforms.push_back(std::make_shared<sim::SimulatedPlatform>(sim_options));
    team.robots.push_back(std::make_unique<SteppedRobot>(options, team.platforms.back(), ""));
  }
  return team;
}

/// One control cycle of every robot at `now_s`, each waiting (wall time) for the plan its next step needs.
inline void StepAll(const std::vector<std::unique_ptr<SteppedRobot>>& robots, double now_s) {
  for (const auto& robot : robots) {
    robot->Step(now_s);
    while (robot->planning()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
}

}  // namespace cairn::agent::team_testing
