// The command interface (Sriganesh et al. 2024, § Command Interface; lesson L3: exactly one operator commands
// a robot at a time). Receives every command as a plain struct (commands.h), applies the rules of who may
// command (the control lock; a stop from anyone), answers each command once (a retry is answered from the
// reply cache and applied once), and keeps track of the basestation processes that speak for the lock's
// holder. DDS-free: the agent's DDS adapter feeds it and sends its replies; tests drive it directly.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "cairn/agent/command/commands.h"
#include "cairn/agent/command/control_lock.h"
#include "cairn/agent/command/reply_cache.h"
#include "cairn/agent/modes/mode_control.h"
#include "cairn/core/peer_input.h"
#include "cairn/core/time.h"
#include "cairn/nav/global_planner.h"

namespace cairn::agent {

/// The last operator stop honoured (RobotState.stops, stopped_by, stopped_at).
struct StopRecord {
  uint32_t count = 0;  ///< stops honoured since start
  std::string by;      ///< base id of the last one
  core::WallStamp at;  ///< when it was received (wall clock)
};

/// The operator's valid actions now (lesson L4).
struct ValidActions {
  std::vector<std::string> modes;   ///< modes the tree would accept now
  bool goal_acceptable = false;     ///< a waypoint goal would be accepted now
  bool explore_acceptable = false;  ///< an exploration task would be accepted now
};

/// Applies operator commands. Not thread-safe: the agent calls it under its lock.
class CommandInterface {
 public:
  /// Replies kept for retries (a retry older than this many later commands runs again).
  static constexpr std::size_t kReplyCacheSize = 256;

  /// What the command interface acts on besides the lock and the modes. Every hook is required.
  struct Hooks {
    /// The mode tree's facts now (this interface's own, FillConditions(), included).
    std::function<ModeConditions()> conditions;
    /// Sends a reply to its sender.
    std::function<void(const CommandReply&)> send;
    /// Queues a checked goal for planning (off the caller's thread); OnGoalPlanned() follows with the plan.
    std::function<void(const GoalCommand&)> plan_goal;
    /// Drives the goal along `plan` (still from its holder): the outcome is the reply's.
    std::function<CommandOutcome(const GoalCommand&, const nav::GlobalPlan&)> start_goal;
    /// Starts the exploration task (checked) from its holder: the outcome is the reply's.
    std::function<CommandOutcome(const ExploreCommand&)> start_explore;
    /// Follows the robots ahead (convoy mode) or leaves the convoy, from its holder: the outcome is the
    /// reply's.
    std::function<CommandOutcome(const ConvoyCommand&)> convoy;
    /// Restarts one component (core::HealthMonitor::RequestRestart): "" when under way, else why not.
    std::function<std::string(const std::string& component, const std::string& by)> restart_component;
  };

  /// `modes` (not owned) outlives this. `goal_mode`: the mode a waypoint goal is driven in
  /// (WaypointMode::kName).
  /// @throws std::invalid_argument for a null `modes`, a missing hook or invalid lock options.
  CommandInterface(std::string robot_id, const ControlLockOptions& lock, ModeControl* modes,
                   std::string goal_mode, Hooks hooks);

  /// request-control / release: granted when free or held by the sender's base id; only the holder releases
  /// (the robot then stops: modes that need a holder end).
  void OnControl(const ControlCommand& command, core::SteadyTime now);
  /// mode R M: the holder's only; the tree decides.
  void OnMode(const ModeCommand& command);
  /// stop R: from anyone, holder or not; the lock stays where it is. Zero twist and idle at once.
  void OnStop(const StopCommand& command);
  /// restart R COMPONENT: the holder's only; the component restarts on the health monitor's thread (its
  /// outcome reaches operators as AgentHealth events); refused naming the components when there is no such
  /// one.
  void OnRestart(const RestartCommand& command);
  /// goto R X Y: the holder's only; checked (CheckGoal), refused at once when the goal's mode could not be
  /// entered now, else queued for planning (Hooks::plan_goal). A retry while it is planned is ignored: its
  /// reply comes when the plan is done.
  void OnGoal(const GoalCommand& command);
  /// The goal's plan is done: discarded when the lock moved meanwhile, else driven (Hooks::start_goal) and
  /// answered.
  void OnGoalPlanned(const GoalCommand& command, const nav::GlobalPlan& plan);
  /// home R [POINT]: the holder's only; a waypoint goal to `home_M` (the robot's start, frame M, with its
  /// ground height) or the point sent, then as OnGoal() (the reply's kind is kHome).
  void OnHome(const HomeCommand& command, const core::BaseState& home_M);
  /// explore R: the holder's only; checked (frame, CheckExploreTask), then started (Hooks::start_explore),
  /// which asks the mode tree.
  void OnExplore(const ExploreCommand& command);
  /// A convoy follower's request (convoy, convoy-stop, peel): the holder's only; a malformed one is refused
  /// naming the value; else Hooks::convoy, which asks the mode tree.
  void OnConvoy(const ConvoyCommand& command);
  /// The stick: the holder's only (others are counted as discarded), finite only; to the running mode.
  void OnTeleop(const TeleopCommand& command, core::SteadyTime now);

  /// A basestation process announced its base id (and whether it has a joystick).
  void OnBaseAnnounced(const BaseAnnouncement& base);
  /// An announced basestation's liveliness changed: a lost process no longer speaks for the holder.
  void OnBaseLiveliness(const WriterLiveliness& change, core::SteadyTime now);
  /// Processes that left the DDS domain (participant discovery): each is lost.
  void OnParticipantsGone(const std::vector<std::string>& participants, core::SteadyTime now);
  /// Frees the lock after lock_keep_s without its holder (logged). Call once per control cycle.
  void Update(core::SteadyTime now);

  /// Seconds since a basestation process was last known alive (its liveliness), at `now`; from the
  /// interface's creation while none ever was.
  double SecondsSinceBaseHeard(core::SteadyTime now) const;
  /// Fills the tree's facts this interface knows: holder, its liveliness, its joystick.
  void FillConditions(ModeConditions* conditions) const;
  /// Modes valid now and whether a goal would be accepted now.
  ValidActions ValidNow();

  const ControlLock& lock() const { return lock_; }
  /// After a restart: `base_id` (the journal's holder) holds the lock again (ControlLock::Restore).
  void RestoreHolder(const std::string& base_id, core::SteadyTime now) { lock_.Restore(base_id, now); }
  const StopRecord& stops() const { return stops_; }
  /// Accepted commands that change what the robot does (a mode, a goal, an exploration, home, a convoy, a
  /// stop, a release), counted from 0: a paused mission ends when one comes (MissionKeeper).
  std::uint64_t mission_commands() const { return mission_commands_; }

 private:
  // Answers a retry (same writer, kind and request id) from the cache. true when it was one.
  bool ReplayIfDuplicate(const CommandSender& sender, CommandKind kind, uint32_t request_id);
  void Respond(const CommandSender& sender, uint32_t request_id, CommandKind kind, CommandResult result,
               const std::string& reason, uint32_t goal_id = 0);
  // The answer to a command the holder's service took or refused (`outcome`); an accepted one notes that the
  // sender's process speaks for the holder.
  void RespondWithOutcome(const CommandSender& sender, uint32_t request_id, CommandKind kind,
                          const CommandOutcome& outcome);
  // The sender is not the holder: counted, answered "discarded" naming the holder. true then.
  bool DiscardUnlessHolder(const CommandSender& sender, uint32_t request_id, CommandKind kind);
  // The process `participant` is gone or silent; re-checks the mode (a holder without a live process stops
  // modes that need a live operator).
  void LoseParticipant(const std::string& participant, const std::string& why, core::SteadyTime now);

  // A basestation process known from its agent info.
  struct BaseProcess {
    std::string participant;
    std::string base_id;
    bool has_joystick = false;  // advertises the "joystick" capability
    bool alive = true;          // its agent-info writer's liveliness
  };

  std::string robot_id_;
  ModeControl* modes_;
  std::string goal_mode_;
  Hooks hooks_;
  ControlLock lock_;
  double lock_keep_s_;  // for the log line when the lock is freed
  ReplyCache<CommandReply> replies_{kReplyCacheSize};
  std::vector<CommandKey> pending_goals_;     // goals being planned
  std::map<std::string, BaseProcess> bases_;  // agent-info writer -> its process
  StopRecord stops_;
  std::uint64_t mission_commands_ = 0;
  core::WarningLimiter teleop_warnings_;                         // non-finite teleop twists
  core::SteadyTime last_base_alive_ = core::SteadyClock::now();  // Update() notes a live base process
};

}  // namespace cairn::agent
