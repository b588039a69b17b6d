// One robot's modes as the agent (RobotAgent) runs them, in one piece: the mode modules (idle, manual, smart
// joystick, waypoint, explore, convoy, yield) under the mode tree and the mux (ModeControl), the operator's
// mission across interruptions (MissionResumption) and getting out of each other's way, asked and asking
// (YieldCoordination); and the modes' part of a control cycle, in the agent's order.
//
// DDS-free: the caller gives the time (and the clock the modes stamp activations with), the tree's conditions
// and the peers. Not thread-safe (the agent calls it under its lock).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mission_resumption.h"
#include "cairn/agent/modes/mode_control.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/agent/team/explore_claims.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/agent/team/yield_coordination.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

class RobotModes {
 public:
  /// What the modes ask of the robot that composes them; every function is set.
  struct Hooks {
    /// The mode tree's facts now (holder, localization, health, the modes' tasks).
    std::function<ModeConditions()> conditions;
    /// Forgets the obstacles the robot remembers (a recovery's "clear the costmap").
    std::function<void()> clear_obstacle_memory;
    /// CommandInterface::mission_commands(): the operator commands so far (a new one drops a paused mission).
    std::function<std::uint64_t()> mission_commands;
    /// The traversability grid of the robot's platform (yields: the passage's width, the spots aside).
    YieldCoordination::GridSource grid;
    /// The robot's clock (ModeControl's): the real one in the agent, a simulated one in stepped runs.
    std::shared_ptr<const core::Clock> clock;
  };
  /// Goal and task ids: random (a restarted robot never repeats old ones) or from 1 (a deterministic run).
  enum class Ids { kRandom, kFromOne };

  /// Builds the modules from `options` (robot id, timeouts, the modes' options, the platform's step) on
  /// `navigation` (outlives this object), the waypoint and explore modes with the recovery tree of
  /// `tree_file` (a warning when the file has none), and loads the tree from `tree_file`.
  /// @throws as ModeControl, MissionResumption and YieldCoordination (the file, field or value named).
  RobotModes(const AgentOptions& options, const std::string& tree_file, nav::Navigation* navigation,
             Hooks hooks, Ids ids = Ids::kRandom);
  ~RobotModes();
  RobotModes(const RobotModes&) = delete;
  RobotModes& operator=(const RobotModes&) = delete;

  /// Asks the tree for `mode` under the conditions now (ModeControl::Request).
  ModeDecision Request(const std::string& mode);

  // The operator's missions, one path for every caller: the mode's task is set first, then the tree is asked
  // for the mode (the mode it replaces is deactivated).
  /// Drives `plan` to (x_m, y_m) (frame M, metres; tolerance and goal height as WaypointMode::Start) from
  /// `now_s` in waypoint mode.
  GoalStart StartGoal(const nav::GlobalPlan& plan, double x_m, double y_m, double tolerance_m, double z_m,
                      double now_s);
  /// Explores `task` from `now_s`: "" or why not.
  std::string StartExplore(const ExploreTask& task, double now_s);
  /// Follows the robots `ahead_ids` (nearest first, the leader last; `live_peers` heard now) in convoy mode:
  /// "" or why not. A robot already following only changes whom it follows.
  std::string StartConvoy(const std::vector<std::string>& ahead_ids, const std::vector<Peer>& live_peers,
                          double now_s);
  /// This robot as its peers see it at `pose_M`: navigation's body and path ahead, the mode, and its answer
  /// to a yield request (YieldStatus), if any.
  Peer AsPeer(const core::BaseState& pose_M) const;

  /// The top of a control cycle at `now_s`: the tree re-checks the current mode; when it is no longer
  /// allowed the robot goes idle, and a mission a transient condition stopped (IsTransientFailure) is paused.
  void Recheck(double now_s);
  /// The modes' part of a control cycle, after the pose: the peers and the team's claims and coverage to the
  /// modes, yields asked of blocking peers, the running mode's step (idle when its task ended), then the
  /// paused mission (MissionResumption::Step: a paused goal is planned again once GoalAcceptable()).
  /// `robot` is the robot as a yield sees it (its peers are those the modes get).
  void Step(const ModeInputs& in, const YieldCoordination::Robot& robot, const ExploreTeam& team);
  /// True when the tree would take a waypoint goal now (the conditions with a goal).
  bool GoalAcceptable();
  /// After the cycle's twist went to the platform: its status to the running mode (idle when that ended its
  /// task, e.g. a goal blocked in contact).
  void OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in);
  /// Stops the robot (mode idle, zero twist) because `why`, keeping the mission it ran to resume it.
  void StopKeepingMission(const std::string& why, double now_s);

  ModeControl& control() { return *control_; }
  const ModeControl& control() const { return *control_; }
  MissionResumption& missions() { return *missions_; }
  const MissionResumption& missions() const { return *missions_; }
  YieldCoordination& yielding() { return *yielding_; }
  const YieldCoordination& yielding() const { return *yielding_; }
  WaypointMode& waypoint() const { return *waypoint_; }
  ExploreMode& explore() const { return *explore_; }
  ConvoyMode& convoy() const { return *convoy_; }
  YieldMode& yield() const { return *yield_; }

 private:
  ModeRegistry MakeModules(const AgentOptions& options, const std::string& tree_file, Ids ids);

  const std::string robot_id_;
  nav::Navigation* const navigation_;
  const Hooks hooks_;
  WaypointMode* waypoint_ = nullptr;  // the modules are owned by control_
  ExploreMode* explore_ = nullptr;
  ConvoyMode* convoy_ = nullptr;
  YieldMode* yield_ = nullptr;
  std::unique_ptr<ModeControl> control_;
  std::unique_ptr<MissionResumption> missions_;
  std::unique_ptr<YieldCoordination> yielding_;
};

}  // namespace cairn::agent
