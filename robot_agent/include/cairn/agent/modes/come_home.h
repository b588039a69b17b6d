// Coming home on silence: an exploring robot that has heard no basestation for its task's
// home_after_silence_s ends the exploration and drives back to where it started by itself (the paper's robots
// return when the link is lost for good, so that their maps come back into range). The way back is planned
// on the planner's worker thread; once found it becomes a waypoint goal like an operator's.
//
// Not thread-safe: the agent's control thread, under its lock.
#pragma once

#include <functional>
#include <future>
#include <string>

#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/core/kinematics.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

class ComeHome {
 public:
  /// `start_M`: where the robot started, frame M (its level by z_m).
  ComeHome(std::string robot_id, const core::BaseState& start_M);

  /// Once per control cycle. While `explore` explores and `silence_s` (seconds since a basestation was last
  /// heard) exceeds its task's home_after_silence_s (> 0): ends the exploration (saying why) and plans the
  /// way back from `pose_M` on `navigation`. When that plan is found, `start_goal` drives it (a waypoint goal
  /// to the start); a plan that is not usable, or a goal refused, is logged and the robot stays where it is.
  void Step(
      double silence_s, const core::BaseState& pose_M, ExploreMode& explore, nav::Navigation& navigation,
      const std::function<GoalStart(const nav::GlobalPlan& plan, const core::BaseState& goal_M)>& start_goal);

  /// Drops a way back still being planned (the agent shuts down).
  void Abandon(nav::Navigation& navigation);

 private:
  const std::string robot_id_;
  const core::BaseState start_M_;
  std::future<nav::GlobalPlan> plan_;  // the way back, being planned
};

}  // namespace cairn::agent
