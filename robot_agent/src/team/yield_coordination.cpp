#include "cairn/agent/team/yield_coordination.h"

#include <spdlog/spdlog.h>

#include <stdexcept>
#include <utility>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/core/peer_input.h"

namespace cairn::agent {

YieldCoordination::YieldCoordination(std::string robot_id, const YieldOptions& options, double radius_m,
                                     YieldMode* yield, MissionResumption* missions,
                                     nav::Navigation* navigation, GridSource grid,
                                     MissionResumption::RequestMode request_mode,
                                     std::function<std::uint64_t()> mission_commands)
    : robot_id_(std::move(robot_id)),
      options_(options),
      radius_m_(radius_m),
      yield_(yield),
      missions_(missions),
      navigation_(navigation),
      grid_(std::move(grid)),
      request_mode_(std::move(request_mode)),
      mission_commands_(std::move(mission_commands)),
      asker_(options, robot_id_) {
  if (!yield_ || !missions_ || !navigation_ || !grid_ || !request_mode_ || !mission_commands_)
    throw std::invalid_argument(
        "YieldCoordination: the yield mode, missions, navigation or a source is missing");
}

bool YieldCoordination::AlreadyRefused(const YieldCommand& c, const std::string& why) const {
  const YieldStatus& status = yield_->status();
  return status.state == YieldStatus::State::kRefused && status.peer_id == c.passing_id &&
         status.reason == why;
}

void YieldCoordination::Refuse(const YieldCommand& c, const std::string& why, double now_s) {
  const bool repeated = AlreadyRefused(c, why);
  yield_->Refuse(c.passing_id, why, now_s);
  if (!repeated)
    spdlog::warn("robot {}: yield for {} (asked by {}) refused: {}", robot_id_, c.passing_id, c.sender_id,
                 why);
}

void YieldCoordination::OnRequest(const YieldCommand& c, const YieldOrigin& origin, const std::string& fault,
                                  const Robot& robot) {
  const double now_s = robot.now_s;
  if (const std::string why = fault.empty() ? CheckYieldCommand(c) : fault; !why.empty()) {
    spdlog::warn("robot {}: {}; refused", robot_id_, why);
    // Shown to the peer only under a valid id (a bad one would spoil this robot's own peer state).
    if (core::CheckId("passing_id", c.passing_id).empty()) yield_->Refuse(c.passing_id, why, now_s);
    return;
  }
  if (c.passing_id == robot_id_) return;
  if (!robot.listening_to_peers) {
    // Its peers are not read yet: the caller starts reading them, and the request is decided once they could
    // be heard (DecideWaitingRequest).
    if (!unheard_)
      spdlog::info("robot {}: yield for {} (asked by {}): listening to peers first", robot_id_, c.passing_id,
                   c.sender_id);
    unheard_ = std::make_pair(c, origin);
    unheard_at_s_ = now_s;
    return;
  }
  if (const std::string why = CheckYieldSender(robot_id_, c, origin, *robot.peers); !why.empty()) {
    const bool repeated = AlreadyRefused(c, why);
    if (!yield_->active()) yield_->Refuse(c.passing_id, why, now_s);
    if (!repeated) spdlog::warn("robot {}: {}", robot_id_, why);
    return;
  }
  const std::shared_ptr<const nav::TraversabilityGrid> grid = grid_();
  if (yield_->InTheWayOf(c)) {
    // Aside, but the passing robot's route now runs by the spot: on to another one.
    const YieldDecision moved = DecideYield(options_, c,
                                            YieldSituation{robot_id_, ModeManager::kIdleMode, robot.pose_M,
                                                           radius_m_, grid.get(), YieldStatus{}, false, ""});
    if (moved.accepted && yield_->MoveOn(c, moved.spot, now_s))
      spdlog::info("robot {}: {}", robot_id_, yield_->status().reason);
    return;
  }
  if (yield_->active()) {
    if (yield_->passing_id() != c.passing_id) {
      spdlog::info("robot {}: yield for {} (asked by {}) refused: already yielding to {}", robot_id_,
                   c.passing_id, c.sender_id, yield_->passing_id());
    }
    return;  // a repeat of the request being served
  }
  const YieldSituation situation = WithPeerAndHistory(
      YieldSituation{robot_id_, robot.mode, robot.pose_M, radius_m_, grid.get(), asker_.status(), false, ""},
      c, *robot.peers, *yield_, now_s);
  const YieldDecision decision = DecideYield(options_, c, situation);
  if (decision.ignore) return;  // it gets out of this robot's way itself
  if (!decision.accepted) return Refuse(c, decision.refusal, now_s);
  // Its mission waits for the yield's end (held: no retry, no expiry meanwhile).
  if (std::optional<PausedMission> running = missions_->Running(now_s)) {
    running->held = true;
    missions_->Pause(std::move(*running), "yielding to " + c.passing_id, mission_commands_());
  }
  yield_->Start(c, decision.spot, robot.pose_M, decision.clearance_m,
                /*return_home=*/robot.mode == ModeManager::kIdleMode, now_s);
  const ModeDecision d = request_mode_(yield_->name());
  if (!d.accepted) {
    yield_->Deactivate(d.reason);
    missions_->DropHeld();  // it never stopped
    return Refuse(c, d.reason, now_s);
  }
  spdlog::info("robot {}: yielding to {} (asked by {}, was {}): {}", robot_id_, c.passing_id, c.sender_id,
               robot.mode, yield_->status().reason);
}

void YieldCoordination::DecideWaitingRequest(const Robot& robot) {
  if (!unheard_ || !robot.listening_to_peers || robot.now_s - unheard_at_s_ < kHearingS) return;
  const auto [request, origin] = std::move(*unheard_);
  unheard_.reset();
  OnRequest(request, origin, "", robot);
}

void YieldCoordination::AskPeers(const Robot& robot) {
  YieldAsk ask = asker_.Update(AskInputs(options_, robot.mode, *navigation_, robot.pose_M, radius_m_,
                                         *robot.peers, grid_, robot.now_s));
  navigation_->SetHold(ask.hold_reason, asker_.status().peer_id);
  if (ask.request) to_send_ = std::make_pair(ask.to_id, std::move(*ask.request));
  const YieldStatus& status = asker_.status();
  const std::string logged = std::string(ToString(status.state)) + status.peer_id;
  if (logged == asking_logged_) return;
  asking_logged_ = logged;
  if (status.state == YieldStatus::State::kBlocked) {
    spdlog::warn("robot {}: {}", robot_id_, status.reason);
  } else if (status.state != YieldStatus::State::kNone) {
    spdlog::info("robot {}: {}", robot_id_, status.reason);
  }
}

std::optional<std::pair<std::string, YieldCommand>> YieldCoordination::TakeRequestToSend() {
  std::optional<std::pair<std::string, YieldCommand>> out = std::move(to_send_);
  to_send_.reset();
  return out;
}

}  // namespace cairn::agent
