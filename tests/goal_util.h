// Goals for multi-process tests in builtin:tunnels, picked on the agent's own kind of grid (tests that link
// cairn_sim and cairn_nav).
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdio>
#include <string>

#include "cairn/nav/astar.h"
#include "cairn/nav/sampling.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/world.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::testing_util {

/// A free goal of builtin:tunnels whose path from the robot's position in `start` is between min_m and max_m
/// long (metres), or the start itself with a test failure when there is none.
inline Eigen::Vector2d GoalAtPathLength(const cairn_msgs::RobotState& start, double min_m, double max_m) {
  static const sim::World world = sim::LoadWorld("builtin:tunnels");
  static const nav::TraversabilityGrid grid(world, nav::TraversabilityOptions{});
  const Eigen::Vector2d p_start(start.pose_MB().position().x_m(), start.pose_MB().position().y_m());
  for (const auto& c : nav::SampleFreeStarts(grid, 80, 1.0, 4321)) {
    const nav::PlanResult plan = nav::PlanPath(grid, p_start, c.head<2>(), nav::AStarOptions{});
    if (plan.status == nav::PlanResult::Status::kSuccess && plan.length_m >= min_m &&
        plan.length_m <= max_m) {
      return c.head<2>();
    }
  }
  ADD_FAILURE() << "no goal " << min_m << "-" << max_m << " m from the start";
  return p_start;
}

/// "goto ROBOT X Y" with centimetre precision.
inline std::string GotoCommand(const std::string& robot, const Eigen::Vector2d& goal) {
  char text[96];
  std::snprintf(text, sizeof(text), "goto %s %.2f %.2f", robot.c_str(), goal.x(), goal.y());
  return text;
}

}  // namespace cairn::testing_util
