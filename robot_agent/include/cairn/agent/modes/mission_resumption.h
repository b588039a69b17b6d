// The operator's mission across interruptions, on the robot (modes/mission.h says what a paused mission is
// and why missions outlast interruptions): which mission runs now, keeping it when a transient condition or
// a yield interrupts it, trying it again when MissionKeeper says it is due (a paused goal planned again from
// where the robot is, off the control thread), and ending it — with the reason — when an operator's command
// comes, the retry is refused for good, or it stays paused past MissionOptions::resume_within_s.
//
// Not thread-safe: the agent's control thread, under its lock.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <future>
#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mission.h"
#include "cairn/agent/modes/mode_control.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/core/kinematics.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

class MissionResumption {
 public:
  /// The modes a mission runs in and the mode tree that switches them; all outlive this object.
  struct Modes {
    ModeControl* control = nullptr;
    WaypointMode* waypoint = nullptr;
    ExploreMode* explore = nullptr;
    ConvoyMode* convoy = nullptr;
    YieldMode* yield = nullptr;
    nav::Navigation* navigation = nullptr;
  };
  /// Asks the mode tree for `mode` under the robot's current conditions (ModeControl::Request).
  using RequestMode = std::function<ModeDecision(const std::string& mode)>;

  /// @throws std::invalid_argument for invalid `options` (MissionOptions::IsValid), or a null mode.
  MissionResumption(std::string robot_id, const MissionOptions& options, Modes modes,
                    RequestMode request_mode);
  ~MissionResumption();
  MissionResumption(const MissionResumption&) = delete;
  MissionResumption& operator=(const MissionResumption&) = delete;

  /// The operator's mission the robot runs now (a waypoint goal, an exploration or a place in a convoy), if
  /// any, stamped `now_s` (seconds, the agent's clock).
  std::optional<PausedMission> Running(double now_s) const;
  /// Keeps `mission`, interrupted because of `reason`; `mission_commands` is
  /// CommandInterface::mission_commands() now (a later operator's command drops it).
  void Pause(PausedMission mission, const std::string& reason, std::uint64_t mission_commands);
  /// A mission held for a yield that did not start after all: it never stopped, so it is not kept.
  void DropHeld();
  /// Once per control cycle, after the mode's step, at `now_s`: a yield that ended hands the mission back; a
  /// paused mission is dropped on an operator's command (`mission_commands` changed since the pause), tried
  /// again when due — a goal planned again from `pose_M` once `goal_acceptable()` (the tree would take one),
  /// a convoy place behind the same robots among `live_peers`, the exploration — and resumed under its old
  /// id, or ended with the reason.
  void Step(double now_s, const core::BaseState& pose_M, const std::vector<Peer>& live_peers,
            std::uint64_t mission_commands, const std::function<bool()>& goal_acceptable);
  /// Drops a goal still being planned again (the agent shuts down).
  void Abandon();

  const std::optional<PausedMission>& paused() const { return keeper_.paused(); }
  /// True while a paused goal is planned again on a worker (a caller on a simulated clock waits for it).
  bool planning() const {
    return resume_plan_.valid() &&
           resume_plan_.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
  }
  /// How the last pause ended ("resumed after 3.2 s paused: ...", "dropped: ...", "not resumed: ..."), for
  /// RobotState.mission_reason; "" before any.
  const std::string& note() const { return note_; }

  /// "waypoint 12", "explore 7", "convoy behind r1": the mission in log lines.
  static std::string Name(const PausedMission& mission);

 private:
  void End(const PausedMission& mission, const std::string& reason);
  void LeavePausedConvoy(const std::string& why);
  // A paused goal's new plan, when it has come: the goal goes on under its id, or the pause goes on.
  void StartPlannedGoal(double now_s, const PausedMission& paused);
  void Resumed(double now_s, const PausedMission& paused);
  void Refused(const PausedMission& paused, const std::string& why);

  const std::string robot_id_;
  const Modes modes_;
  const RequestMode request_mode_;
  MissionKeeper keeper_;
  std::uint64_t mission_commands_at_pause_ = 0;
  std::string note_;
  std::future<nav::GlobalPlan> resume_plan_;  // a paused goal, planned again from where the robot is
};

}  // namespace cairn::agent
