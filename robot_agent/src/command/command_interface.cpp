#include "cairn/agent/command/command_interface.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace cairn::agent {

std::string CheckGoal(const GoalCommand& goal) {
  if (goal.frame_id != "map") return "goal frame_id '" + goal.frame_id + "' is not supported (use 'map')";
  if (!std::isfinite(goal.x_m) || !std::isfinite(goal.y_m)) {
    char text[96];
    std::snprintf(text, sizeof(text), "goal (%g, %g) is not a finite point", goal.x_m, goal.y_m);
    return text;
  }
  if (std::isinf(goal.z_m)) {
    return "goal z_m = " + std::to_string(goal.z_m) +
           " must be a level's height (finite) or NaN (the robot's level)";
  }
  if (!std::isfinite(goal.tolerance_m) || goal.tolerance_m < 0 || goal.tolerance_m > 5) {
    return "goal tolerance_m = " + std::to_string(goal.tolerance_m) + " must be in [0, 5]";
  }
  return "";
}

namespace {

ModeControl* CheckedModes(ModeControl* modes) {
  if (modes == nullptr) throw std::invalid_argument("CommandInterface: modes is null");
  return modes;
}

}  // namespace

CommandInterface::CommandInterface(std::string robot_id, const ControlLockOptions& lock, ModeControl* modes,
                                   std::string goal_mode, Hooks hooks)
    : robot_id_(std::move(robot_id)),
      modes_(CheckedModes(modes)),
      goal_mode_(std::move(goal_mode)),
      hooks_(std::move(hooks)),
      lock_(robot_id_, lock),
      lock_keep_s_(lock.lock_keep_s) {
  std::string why;
  if (!lock.IsValid(&why)) throw std::invalid_argument("CommandInterface: " + why);
  if (!hooks_.conditions || !hooks_.send || !hooks_.plan_goal || !hooks_.start_goal ||
      !hooks_.start_explore || !hooks_.convoy || !hooks_.restart_component) {
    throw std::invalid_argument(
        "CommandInterface: every hook (conditions, send, plan_goal, start_goal, start_explore, convoy, "
        "restart_component) is required");
  }
}

bool CommandInterface::ReplayIfDuplicate(const CommandSender& sender, CommandKind kind, uint32_t request_id) {
  const CommandReply* cached =
      replies_.Find(CommandKey{sender.writer, static_cast<uint32_t>(kind), request_id});
  if (cached == nullptr) return false;
  spdlog::debug("robot {}: retry of request {} from {} ({}) answered from the cache", robot_id_, request_id,
                sender.base_id, sender.participant);
  hooks_.send(*cached);
  return true;
}

void CommandInterface::Respond(const CommandSender& sender, uint32_t request_id, CommandKind kind,
                               CommandResult result, const std::string& reason, uint32_t goal_id) {
  CommandReply r;
  r.base_id = sender.base_id;
  r.requester_participant = sender.participant;
  r.request_id = request_id;
  r.kind = kind;
  r.result = result;
  r.reason = reason;
  r.holder_id = lock_.holder_id();
  r.mode = modes_->mode();
  r.goal_id = goal_id;
  ValidActions valid = ValidNow();
  r.valid_modes = std::move(valid.modes);
  r.goal_acceptable = valid.goal_acceptable;
  if (result == CommandResult::kAccepted && kind != CommandKind::kControlRequest &&
      kind != CommandKind::kRestart && kind != CommandKind::kControlHandover &&
      kind != CommandKind::kControlDeny)
    ++mission_commands_;
  hooks_.send(r);
  replies_.Insert(CommandKey{sender.writer, static_cast<uint32_t>(kind), request_id}, std::move(r));
  // The behavior-tree state follows from the control loop (<= 20 ms), off the command path.
}

bool CommandInterface::DiscardUnlessHolder(const CommandSender& sender, uint32_t request_id,
                                           CommandKind kind) {
  if (lock_.IsHolder(sender.base_id)) return false;
  lock_.CountDiscarded();
  Respond(sender, request_id, kind, CommandResult::kDiscarded, lock_.NotHolderReason(sender.base_id));
  return true;
}

void CommandInterface::OnControl(const ControlCommand& command, core::SteadyTime now) {
  const CommandSender& sender = command.sender;
  CommandKind kind = CommandKind::kControlRequest;
  switch (command.action) {
    case ControlAction::kRequest:
      break;
    case ControlAction::kRelease:
      kind = CommandKind::kControlRelease;
      break;
    case ControlAction::kHandover:
      kind = CommandKind::kControlHandover;
      break;
    case ControlAction::kDeny:
      kind = CommandKind::kControlDeny;
      break;
  }
  if (ReplayIfDuplicate(sender, kind, command.request_id)) return;
  if (!command.malformed.empty()) {
    spdlog::warn("robot {}: control command {} from {} refused: {}", robot_id_, command.request_id,
                 sender.base_id, command.malformed);
    return Respond(sender, command.request_id, kind, CommandResult::kDenied, "refused: " + command.malformed);
  }
  const uint32_t handovers_before = lock_.handovers();
  LockDecision d;
  switch (command.action) {
    case ControlAction::kRequest:
      d = lock_.Request(sender.base_id, sender.participant, now);
      break;
    case ControlAction::kRelease:
      d = lock_.Release(sender.base_id);
      break;
    case ControlAction::kHandover:
      d = lock_.Handover(sender.base_id, command.target_base_id);
      break;
    case ControlAction::kDeny:
      d = lock_.Deny(sender.base_id, command.target_base_id);
      break;
  }
  if (d.accepted) {
    const char* what = command.action == ControlAction::kRelease    ? "released"
                       : command.action == ControlAction::kHandover ? "handed over"
                       : command.action == ControlAction::kDeny     ? "request denied"
                                                                    : "granted";
    spdlog::info("robot {}: control {} by {} (participant {}){}", robot_id_, what, sender.base_id,
                 sender.participant,
                 lock_.handovers() != handovers_before ? ": " + lock_.handover_outcome() : "");
    // A release stops the robot (idle); a handover keeps its mode and goal where the tree still allows them.
    modes_->Recheck(hooks_.conditions());
  } else if (command.action == ControlAction::kRequest && lock_.pending_request() &&
             lock_.pending_request()->base_id == sender.base_id) {
    spdlog::info("robot {}: {} asks {} for the control lock", robot_id_, sender.base_id, lock_.holder_id());
  }
  Respond(sender, command.request_id, kind, d.accepted ? CommandResult::kAccepted : CommandResult::kDenied,
          d.reason);
}

void CommandInterface::OnMode(const ModeCommand& command) {
  const CommandSender& sender = command.sender;
  if (ReplayIfDuplicate(sender, CommandKind::kMode, command.request_id)) return;
  if (DiscardUnlessHolder(sender, command.request_id, CommandKind::kMode)) return;
  const ModeDecision d = modes_->Request(command.mode, hooks_.conditions());
  if (d.accepted) {
    lock_.NoteHolderCommand(sender.participant);  // an accepted command: this process speaks for the holder
    spdlog::info("robot {}: mode {} (by {})", robot_id_, d.mode, sender.base_id);
  }
  Respond(sender, command.request_id, CommandKind::kMode,
          d.accepted ? CommandResult::kAccepted : CommandResult::kDenied, d.reason);
}

void CommandInterface::OnRestart(const RestartCommand& command) {
  const CommandSender& sender = command.sender;
  if (ReplayIfDuplicate(sender, CommandKind::kRestart, command.request_id)) return;
  if (DiscardUnlessHolder(sender, command.request_id, CommandKind::kRestart)) return;
  // A peer's name is bounded and plain before it goes anywhere (a reason, a log line).
  const bool plain = !command.component.empty() && command.component.size() <= 64 &&
                     command.component.find_first_not_of("abcdefghijklmnopqrstuvwxyz_") == std::string::npos;
  const std::string refused = plain ? hooks_.restart_component(command.component, sender.base_id)
                                    : "component name of " + std::to_string(command.component.size()) +
                                          " characters is not [a-z_]{1,64}";
  if (refused.empty()) {
    lock_.NoteHolderCommand(sender.participant);
    spdlog::warn("robot {}: restart of {} asked by {}", robot_id_, command.component, sender.base_id);
  }
  Respond(sender, command.request_id, CommandKind::kRestart,
          refused.empty() ? CommandResult::kAccepted : CommandResult::kDenied,
          refused.empty() ? "restarting " + command.component : refused);
}

void CommandInterface::OnStop(const StopCommand& command) {
  const CommandSender& sender = command.sender;
  if (ReplayIfDuplicate(sender, CommandKind::kStop, command.request_id)) return;
  // An e-stop: honoured from any basestation, holder or not; the lock stays where it is.
  const std::string previous = modes_->mode();
  modes_->Stop("stopped by " + sender.base_id);
  ++stops_.count;
  stops_.by = sender.base_id;
  stops_.at = core::WallNow();
  spdlog::warn("robot {}: stopped by {} (participant {}) in mode {}", robot_id_, sender.base_id,
               sender.participant, previous);
  Respond(sender, command.request_id, CommandKind::kStop, CommandResult::kAccepted,
          "stopped (was " + previous + "): zero twist, mode idle");
}

void CommandInterface::OnHome(const HomeCommand& command, const core::BaseState& home_M) {
  GoalCommand goal;
  goal.sender = command.sender;
  goal.request_id = command.request_id;
  goal.frame_id = command.frame_id;
  goal.kind = CommandKind::kHome;
  if (command.has_point) {
    goal.x_m = command.x_m;
    goal.y_m = command.y_m;
    goal.z_m = command.z_m;
  } else {
    goal.x_m = home_M.x_m;
    goal.y_m = home_M.y_m;
    goal.z_m = home_M.z_m;  // the level it started on
  }
  OnGoal(goal);
}

void CommandInterface::OnGoal(const GoalCommand& command) {
  const CommandSender& sender = command.sender;
  const CommandKind kind = command.kind;
  if (ReplayIfDuplicate(sender, kind, command.request_id)) return;
  if (DiscardUnlessHolder(sender, command.request_id, kind)) return;
  auto deny = [&](const std::string& reason) {
    Respond(sender, command.request_id, kind, CommandResult::kDenied, reason);
  };
  if (const std::string problem = CheckGoal(command); !problem.empty()) return deny(problem);
  ModeConditions with_goal = hooks_.conditions();
  with_goal.has_waypoint_goal = true;
  // Refuse before planning when the mode could not be entered anyway (e.g. no fresh obstacle input).
  if (!modes_->IsValid(goal_mode_, with_goal)) {
    const ModeDecision probe = modes_->Request(goal_mode_, with_goal);  // refused: nothing switches
    return deny(probe.reason);
  }
  // Planned off this thread (a DDS thread, holding the agent lock); a retry of this request while it is
  // planned is ignored (its answer comes when the plan is done).
  const CommandKey key{sender.writer, static_cast<uint32_t>(kind), command.request_id};
  if (std::find(pending_goals_.begin(), pending_goals_.end(), key) != pending_goals_.end()) return;
  pending_goals_.push_back(key);
  hooks_.plan_goal(command);
}

void CommandInterface::RespondWithOutcome(const CommandSender& sender, uint32_t request_id, CommandKind kind,
                                          const CommandOutcome& outcome) {
  if (outcome.accepted) lock_.NoteHolderCommand(sender.participant);  // this process speaks for the holder
  Respond(sender, request_id, kind, outcome.accepted ? CommandResult::kAccepted : CommandResult::kDenied,
          outcome.reason, outcome.goal_id);
}

void CommandInterface::OnGoalPlanned(const GoalCommand& command, const nav::GlobalPlan& plan) {
  const CommandSender& sender = command.sender;
  const CommandKind kind = command.kind;
  const CommandKey key{sender.writer, static_cast<uint32_t>(kind), command.request_id};
  pending_goals_.erase(std::remove(pending_goals_.begin(), pending_goals_.end(), key), pending_goals_.end());
  if (DiscardUnlessHolder(sender, command.request_id, kind)) return;  // the lock moved while it was planned
  const CommandOutcome outcome = hooks_.start_goal(command, plan);
  RespondWithOutcome(sender, command.request_id, kind, outcome);
}

void CommandInterface::OnExplore(const ExploreCommand& command) {
  const CommandSender& sender = command.sender;
  const CommandKind kind = CommandKind::kExplore;
  if (ReplayIfDuplicate(sender, kind, command.request_id)) return;
  if (DiscardUnlessHolder(sender, command.request_id, kind)) return;
  std::string problem = command.frame_id != "map" ? "frame_id '" + command.frame_id + "' must be 'map'"
                                                  : CheckExploreTask(command.task);
  if (!problem.empty()) return Respond(sender, command.request_id, kind, CommandResult::kDenied, problem);
  const CommandOutcome outcome = hooks_.start_explore(command);
  RespondWithOutcome(sender, command.request_id, kind, outcome);
}

void CommandInterface::OnConvoy(const ConvoyCommand& command) {
  const CommandSender& sender = command.sender;
  const CommandKind kind = CommandKind::kConvoy;
  if (ReplayIfDuplicate(sender, kind, command.request_id)) return;
  if (DiscardUnlessHolder(sender, command.request_id, kind)) return;
  if (!command.malformed.empty()) {
    return Respond(sender, command.request_id, kind, CommandResult::kDenied, command.malformed);
  }
  const CommandOutcome outcome = hooks_.convoy(command);
  RespondWithOutcome(sender, command.request_id, kind, outcome);
}

void CommandInterface::OnTeleop(const TeleopCommand& command, core::SteadyTime now) {
  if (!lock_.IsHolder(command.base_id)) {
    lock_.CountDiscarded();
    return;
  }
  const OperatorTwist& t = command.twist_B;
  if (!std::isfinite(t.vx_mps) || !std::isfinite(t.vy_mps) || !std::isfinite(t.wz_radps)) {
    // At the teleop rate (20 Hz) a bad joystick would fill the log: one warning per 5 s, with the count.
    std::uint64_t suppressed = 0;
    if (teleop_warnings_.Allow("non-finite", now, &suppressed)) {
      spdlog::warn(
          "robot {}: teleop twist ({}, {}, {}) from {} dropped: not finite{}", robot_id_, t.vx_mps, t.vy_mps,
          t.wz_radps, command.base_id,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
    return;
  }
  // The running mode takes it (manual and smart joystick use it; the others ignore it).
  modes_->OnOperatorTwist(t, now);
}

void CommandInterface::OnBaseAnnounced(const BaseAnnouncement& announced) {
  BaseProcess& base = bases_[announced.writer];
  base.participant = announced.participant;
  base.base_id = announced.base_id;
  base.has_joystick = announced.has_joystick;
  lock_.OnParticipantAlive(base.base_id, base.participant);
}

void CommandInterface::OnBaseLiveliness(const WriterLiveliness& change, core::SteadyTime now) {
  auto it = bases_.find(change.writer);
  if (it == bases_.end()) return;
  const BaseProcess base = it->second;
  if (change.unmatched) bases_.erase(it);
  if (change.lost) {
    if (!change.unmatched) it->second.alive = false;
    LoseParticipant(base.participant, "its liveliness lapsed or it left", now);
  } else if (change.regained) {
    it->second.alive = true;
    lock_.OnParticipantAlive(base.base_id, base.participant);
  }
}

void CommandInterface::OnParticipantsGone(const std::vector<std::string>& participants,
                                          core::SteadyTime now) {
  for (const std::string& participant : participants) {
    for (auto it = bases_.begin(); it != bases_.end();) {
      it = it->second.participant == participant ? bases_.erase(it) : std::next(it);
    }
  }
  for (const std::string& participant : participants)
    LoseParticipant(participant, "it left the DDS domain", now);
}

void CommandInterface::LoseParticipant(const std::string& participant, const std::string& why,
                                       core::SteadyTime now) {
  const std::string holder = lock_.holder_id();
  const bool was_speaker = !holder.empty() && lock_.holder_participant() == participant;
  const uint32_t handovers_before = lock_.handovers();
  lock_.OnParticipantLost(participant, now);
  if (lock_.handovers() != handovers_before)
    spdlog::info("robot {}: {}", robot_id_, lock_.handover_outcome());
  if (was_speaker && !lock_.holder_alive()) {
    spdlog::warn(
        "robot {}: control holder {} lost: its last process {} is gone ({}); modes that need a live "
        "operator stop",
        robot_id_, holder, participant, why);
  } else if (was_speaker) {
    spdlog::info("robot {}: process {} of holder {} is gone ({}); {} speaks for it", robot_id_, participant,
                 holder, why, lock_.holder_participant());
  }
  modes_->Recheck(hooks_.conditions());
}

void CommandInterface::Update(core::SteadyTime now) {
  const uint32_t handovers_before = lock_.handovers();
  if (lock_.Update(now)) {
    spdlog::warn("robot {}: control lock freed after {} s without its holder", robot_id_, lock_keep_s_);
  }
  if (lock_.handovers() != handovers_before)
    spdlog::info("robot {}: {}", robot_id_, lock_.handover_outcome());
  for (const auto& [writer, base] : bases_) {
    if (base.alive) last_base_alive_ = now;
  }
}

double CommandInterface::SecondsSinceBaseHeard(core::SteadyTime now) const {
  return std::max(0.0, core::SecondsBetween(last_base_alive_, now));
}

void CommandInterface::FillConditions(ModeConditions* c) const {
  c->holder_id = lock_.holder_id();
  c->holder_alive = lock_.holder_alive();
  // A joystick is alive when a live process with the holder's id advertises one.
  c->joystick_alive = false;
  for (const auto& [writer, base] : bases_) {
    if (c->holder_alive && base.alive && base.base_id == c->holder_id && base.has_joystick)
      c->joystick_alive = true;
  }
}

ValidActions CommandInterface::ValidNow() {
  const ModeConditions conditions = hooks_.conditions();
  ModeConditions with_goal = conditions;
  with_goal.has_waypoint_goal = true;
  ValidActions valid;
  valid.goal_acceptable = modes_->IsValid(goal_mode_, with_goal);
  ModeConditions with_task = conditions;
  with_task.has_explore_task = true;
  valid.explore_acceptable = modes_->IsValid(ExploreMode::kName, with_task);
  valid.modes = modes_->ValidModes(conditions);
  return valid;
}

}  // namespace cairn::agent
