#include "cairn/agent/modes/mission_resumption.h"

#include <spdlog/spdlog.h>

#include <stdexcept>
#include <utility>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/core/range_check.h"

namespace cairn::agent {

MissionResumption::MissionResumption(std::string robot_id, const MissionOptions& options, Modes modes,
                                     RequestMode request_mode)
    : robot_id_(std::move(robot_id)),
      modes_(modes),
      request_mode_(std::move(request_mode)),
      keeper_(options) {
  if (!modes_.control || !modes_.waypoint || !modes_.explore || !modes_.convoy || !modes_.yield ||
      !modes_.navigation || !request_mode_)
    throw std::invalid_argument("MissionResumption: a mode, the mode tree or the navigation is missing");
}

MissionResumption::~MissionResumption() { Abandon(); }

void MissionResumption::Abandon() {
  if (resume_plan_.valid()) modes_.navigation->Abandon(std::move(resume_plan_));
}

std::optional<PausedMission> MissionResumption::Running(double now_s) const {
  const std::string mode = modes_.control->mode();
  PausedMission m;
  m.since_s = now_s;
  if (mode == modes_.waypoint->name() && modes_.waypoint->has_goal()) {
    m.kind = PausedMission::Kind::kWaypoint;
    m.goal = modes_.waypoint->goal();
    return m;
  }
  if (mode == modes_.explore->name() && modes_.explore->exploring()) {
    m.kind = PausedMission::Kind::kExplore;
    m.task = modes_.explore->status().task;
    m.task_id = modes_.explore->status().task_id;
    return m;
  }
  if (mode == modes_.convoy->name() && modes_.convoy->active()) {
    m.kind = PausedMission::Kind::kConvoy;
    m.convoy_ahead_ids = modes_.convoy->status().ahead_ids;
    return m;
  }
  return std::nullopt;
}

void MissionResumption::Pause(PausedMission mission, const std::string& reason,
                              std::uint64_t mission_commands) {
  mission.reason = reason;
  // Its place in the convoy is kept (the trail still extended) while it waits.
  if (mission.kind == PausedMission::Kind::kConvoy) modes_.convoy->Pause(mission.convoy_ahead_ids, reason);
  spdlog::warn("robot {}: mission paused ({}): {}; it resumes by itself{}", robot_id_, Name(mission), reason,
               mission.held
                   ? " when the yield ends"
                   : " when that clears (within " + core::Fixed(keeper_.options().resume_within_s, 0) +
                         " s, mission.resume_within_s)");
  Abandon();
  keeper_.Pause(std::move(mission));
  mission_commands_at_pause_ = mission_commands;
}

void MissionResumption::DropHeld() {
  if (keeper_.paused() && keeper_.paused()->held) keeper_.Take();
}

std::string MissionResumption::Name(const PausedMission& mission) {
  switch (mission.kind) {
    case PausedMission::Kind::kWaypoint:
      return "waypoint " + std::to_string(mission.goal.goal_id);
    case PausedMission::Kind::kExplore:
      return "explore " + std::to_string(mission.task_id);
    case PausedMission::Kind::kConvoy:
      return "convoy behind " +
             (mission.convoy_ahead_ids.empty() ? std::string("?") : mission.convoy_ahead_ids.front());
  }
  return "mission";
}

void MissionResumption::LeavePausedConvoy(const std::string& why) {
  if (modes_.convoy->status().state == ConvoyStatus::State::kPaused) modes_.convoy->Deactivate(why);
}

void MissionResumption::End(const PausedMission& mission, const std::string& reason) {
  switch (mission.kind) {
    case PausedMission::Kind::kWaypoint:
      modes_.waypoint->EndPaused(mission.goal.goal_id, reason);
      break;
    case PausedMission::Kind::kExplore:
      modes_.explore->EndPaused(mission.task_id, reason);
      break;
    case PausedMission::Kind::kConvoy:
      LeavePausedConvoy(reason);
      break;
  }
  note_ = reason;
  keeper_.Take();
}

void MissionResumption::Resumed(double now_s, const PausedMission& paused) {
  const double paused_s = now_s - paused.since_s;
  spdlog::info("robot {}: mission resumed ({}) after {:.1f} s paused ({})", robot_id_, Name(paused), paused_s,
               paused.reason);
  note_ = "resumed after " + core::Fixed(paused_s, 1) + " s paused: " + paused.reason;
  keeper_.Take();
}

void MissionResumption::Refused(const PausedMission& paused, const std::string& why) {
  if (IsTransientFailure(why)) {
    keeper_.SetReason(why);  // still paused, now for this
  } else {
    End(paused, "not resumed: " + why);
  }
}

void MissionResumption::StartPlannedGoal(double now_s, const PausedMission& paused) {
  if (nav::PlanRunning(resume_plan_)) return;
  const nav::GlobalPlan plan = resume_plan_.get();
  if (!plan.IsUsable()) {
    keeper_.SetReason("no path from here yet: " + plan.reason);  // the map may still be coming back
    return;
  }
  WaypointMode& waypoint = *modes_.waypoint;
  const GoalStart start = waypoint.Start(
      plan, paused.goal.x_m, paused.goal.y_m, paused.goal.tolerance_m, paused.goal.z_m, now_s,
      [this, &waypoint] { return request_mode_(waypoint.name()); }, paused.goal.goal_id);
  if (start.accepted) {
    Resumed(now_s, paused);
  } else {
    Refused(paused, start.reason);
  }
}

void MissionResumption::Step(double now_s, const core::BaseState& pose_M, const std::vector<Peer>& live_peers,
                             std::uint64_t mission_commands, const std::function<bool()>& goal_acceptable) {
  YieldMode& yield = *modes_.yield;
  if (yield.TakeFinished()) {
    spdlog::info("robot {}: {}", robot_id_, yield.status().reason);
    keeper_.Release(now_s);
  }
  if (!keeper_.paused()) {
    Abandon();
    return;
  }
  const PausedMission paused = *keeper_.paused();
  const std::string mode = modes_.control->mode();
  // An operator's command (a mode, a goal, an exploration, a stop, a release) ends it: they decided.
  if (mission_commands != mission_commands_at_pause_ ||
      (!paused.held && mode != ModeManager::kIdleMode && mode != yield.name())) {
    spdlog::info("robot {}: paused mission ({}) dropped: an operator's command came (mode {})", robot_id_,
                 Name(paused), mode);
    note_ = "dropped: an operator's command came";
    LeavePausedConvoy(note_);
    keeper_.Take();
    Abandon();
    return;
  }
  if (mode == yield.name()) return;  // out of a peer's way now: tried once the yield ends
  if (resume_plan_.valid()) return StartPlannedGoal(now_s, paused);
  switch (keeper_.Check(now_s)) {
    case MissionKeeper::Due::kNothing:
    case MissionKeeper::Due::kWait:
      return;
    case MissionKeeper::Due::kExpired:
      End(paused, "paused for " + core::Fixed(now_s - paused.since_s, 0) + " s (mission.resume_within_s " +
                      core::Fixed(keeper_.options().resume_within_s, 0) +
                      ") and not resumed: " + paused.reason);
      return;
    case MissionKeeper::Due::kTry:
      break;
  }
  keeper_.Tried(now_s);
  switch (paused.kind) {
    case PausedMission::Kind::kConvoy: {
      // Back in line behind the same robots, on the trail kept while it waited.
      ConvoyMode& convoy = *modes_.convoy;
      if (const std::string why = convoy.Start(robot_id_, paused.convoy_ahead_ids, now_s); !why.empty())
        return End(paused, "not resumed: " + why);
      convoy.SetPeers(live_peers, now_s);
      const ModeDecision d = request_mode_(convoy.name());
      if (d.accepted) return Resumed(now_s, paused);
      convoy.Pause(paused.convoy_ahead_ids, paused.reason);
      return Refused(paused, d.reason);
    }
    case PausedMission::Kind::kWaypoint:
      // Planned (off this thread) only once the tree would take a goal again: no search per retry meanwhile.
      if (goal_acceptable())
        resume_plan_ =
            modes_.navigation->PlanGoalAsync(pose_M, paused.goal.x_m, paused.goal.y_m, paused.goal.z_m);
      return;
    case PausedMission::Kind::kExplore: {
      ExploreMode& explore = *modes_.explore;
      const std::string why = explore.Start(
          paused.task, now_s, [this, &explore] { return request_mode_(explore.name()); }, paused.task_id);
      if (why.empty()) return Resumed(now_s, paused);
      return Refused(paused, why);
    }
  }
}

}  // namespace cairn::agent
