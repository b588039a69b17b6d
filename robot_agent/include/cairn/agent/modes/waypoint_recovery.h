// Recovery of a blocked waypoint goal, run as a behavior tree (the <BehaviorTree ID="WaypointRecovery"> of
// the mode tree file), Nav2-style: when navigation gives up on a goal ("blocked: no progress", "the map
// changed under the path and no new path exists", ...) the agent does not fail it at once but ticks this
// tree, whose shipped form tries in turn: clear the local obstacle memory, back up, rotate, wait 5 s, replan
// from where the robot is, and replan with reduced clearance, each followed by a new attempt at the goal.
// Every attempt is reported; only when all fail does the goal fail, with the reason of each attempt. Timeout
// and Delay in the tree count on the navigation clock (Step's now_s).
//
// The actions are the nodes registered by RegisterNodes() (BehaviorTree.CPP v4 node types, listed in the
// tree file's TreeNodesModel); their composition (order, Timeout, RetryUntilSuccessful, ...) is the tree's.
#pragma once

#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "cairn/bt/behavior_tree.h"
#include "cairn/core/kinematics.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

/// Runs the WaypointRecovery tree for one goal at a time. Not thread-safe (the agent's control thread).
class WaypointRecovery {
 public:
  /// ID of the recovery tree in the mode tree file.
  static constexpr const char* kTreeId = "WaypointRecovery";

  /// What the recovery acts on besides Navigation.
  struct Hooks {
    /// Forgets the obstacle points the agent accumulates from the lidar (its LiveObstacles window), so that
    /// only scans taken from now on count. May be empty (nothing beyond Navigation to clear).
    std::function<void()> clear_obstacle_memory;
  };

  /// Registers the recovery action nodes (ClearObstacleMemory, BackUp, Spin, FollowGoal) in `factory`.
  /// With a null `context` (a factory that only validates documents or writes the TreeNodesModel, e.g. the
  /// mode manager's) the types are known but building one throws std::logic_error: they act only in the
  /// WaypointRecovery tree.
  struct Context;
  static void RegisterNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& context);

  /// Loads tree kTreeId of `tree_file` on `navigation` (not owned, outlives this). A file without that
  /// tree disables recovery (enabled() false: a blocked goal fails at once). Throws bt::TreeError for an
  /// invalid file or tree.
  WaypointRecovery(const std::string& tree_file, nav::Navigation* navigation, Hooks hooks);
  ~WaypointRecovery();

  /// True if the file has a recovery tree.
  bool enabled() const { return !tree_.empty(); }
  /// True between Start() and the tick that ends the recovery (or Halt()).
  bool active() const;
  /// True while active() and an attempt waits for its plan from the planner's worker thread (the robot
  /// holds still). A simulated clock should wait in wall time then, not run ahead of the planner.
  bool planning() const;

  /// Starts recovering the goal (x_m, y_m) (metres, frame M; arrival radius tolerance_m) that navigation
  /// failed with `failure`, on the level nearest z_m (NaN: the robot's; see Navigation::SetGoal). Requires
  /// enabled().
  void Start(double x_m, double y_m, double tolerance_m, const std::string& failure,
             double z_m = std::numeric_limits<double>::quiet_NaN());
  /// Ticks the tree once with the robot's state (frame M) at `now_s` (seconds, the navigation clock), as
  /// Navigation::StepWaypoint does: the twist for the waypoint channel (frame B) while recovering; `arrived`
  /// when a retry reached the goal; `failed` when every attempt failed, `reason` naming each, e.g. "blocked:
  /// no progress ...; recovery failed: attempt 1 (clear the local obstacle memory): blocked: ...; attempt 2
  /// (back up 0.40 m): obstacle behind ...". An attempt whose goal navigation abandoned (NavigationStep::
  /// abandoned: unmapped space without progress, held by a peer) ends the recovery at once, `failed` and
  /// `abandoned`. Both false and no twist when not active().
  nav::NavigationStep Step(const core::BaseState& state, double now_s);
  /// Stops a running recovery (a new goal, a stop, a mode change): the actions are halted, nothing moves.
  void Halt();
  /// For operators while active(): what started the recovery and the attempts so far, e.g. "recovering
  /// after: blocked: no progress for 10.0 s (4.2 m left); attempt 1 (clear the local obstacle memory): ...".
  std::string Report() const;

 private:
  std::shared_ptr<Context> context_;
  bt::Tree tree_;
};

}  // namespace cairn::agent
