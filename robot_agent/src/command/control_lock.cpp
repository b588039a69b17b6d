#include "cairn/agent/command/control_lock.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace cairn::agent {
namespace {

// Seconds as an operator reads them: "30 s", "2.5 s".
std::string SecondsText(double s) {
  std::ostringstream out;
  out << s << " s";
  return out.str();
}

}  // namespace

bool ControlLockOptions::IsValid(std::string* why) const {
  if (std::isnan(lock_keep_s) || lock_keep_s < 0.0) {
    *why = "lock_keep_s = " + std::to_string(lock_keep_s) + " must be >= 0 (or inf to keep forever)";
    return false;
  }
  if (!(handover_request_timeout_s > 0.0 && handover_request_timeout_s <= 3600.0)) {
    *why = "handover_request_timeout_s = " + std::to_string(handover_request_timeout_s) +
           " must be in (0, 3600] seconds";
    return false;
  }
  return true;
}

ControlLock::ControlLock(std::string robot_id, ControlLockOptions options)
    : robot_id_(std::move(robot_id)), options_(options) {}

LockDecision ControlLock::Request(const std::string& base_id, const std::string& participant,
                                  core::SteadyTime now) {
  if (base_id.empty()) return {false, "a control request needs a basestation id", holder_};
  if (participant.empty()) return {false, "a control request needs a sending participant", holder_};
  if (holder_.empty() || holder_ == base_id) {
    holder_ = base_id;
    live_[participant] = base_id;  // it just spoke, so it is alive; its departure is reported like any other
    speaker_ = participant;
    if (pending_ && pending_->base_id == base_id) pending_.reset();  // it has what it asked for
    return {true, "", holder_};
  }
  live_[participant] = base_id;
  const std::string locked = "robot " + robot_id_ + " is locked by basestation " + holder_;
  const double timeout_s = options_.handover_request_timeout_s;
  if (pending_ && pending_->base_id != base_id && PendingLeftS(now) > 0.0) {
    return {false,
            locked + "; basestation " + pending_->base_id + "'s request waits for its answer (" +
                SecondsText(std::ceil(PendingLeftS(now))) + " left): ask again after",
            holder_};
  }
  pending_ = PendingRequest{base_id, participant, now};  // a repeated request starts its wait again
  return {false,
          locked + ": asked " + holder_ + " to hand it over (grant " + robot_id_ + " " + base_id +
              " or deny " + robot_id_ + " " + base_id + " there, within " + SecondsText(timeout_s) + ")",
          holder_};
}

LockDecision ControlLock::Handover(const std::string& from, const std::string& to) {
  if (holder_.empty()) return {false, "robot " + robot_id_ + " is not locked by anyone", holder_};
  if (holder_ != from) {
    return {false, "only the holder hands over: robot " + robot_id_ + " is locked by basestation " + holder_,
            holder_};
  }
  if (to.empty() || to == from) {
    return {false, "target_base_id '" + to + "' must name another basestation", holder_};
  }
  const bool asked = pending_ && pending_->base_id == to;
  std::string participant = asked ? pending_->participant : "";
  if (participant.empty()) {
    const auto live = std::find_if(live_.begin(), live_.end(), [&](const auto& p) { return p.second == to; });
    if (live != live_.end()) participant = live->first;
  }
  if (participant.empty()) {
    return {false,
            "no live basestation " + to + " is known to robot " + robot_id_ + " (one announces itself " +
                "when it starts)",
            holder_};
  }
  holder_ = to;
  speaker_ = participant;
  live_[participant] = to;
  if (asked) {
    EndPending(from + " granted " + to + "'s request: " + to + " holds the lock");
  } else {
    if (pending_)
      EndPending(pending_->base_id + "'s request was dropped: " + from + " handed the lock to " + to);
    Record(from + " handed the lock over to " + to);
  }
  return {true, "", holder_};
}

LockDecision ControlLock::Deny(const std::string& from, const std::string& to) {
  if (holder_ != from) {
    return {false, "only the holder answers a request: robot " + robot_id_ + " is " + Describe(), holder_};
  }
  if (!pending_ || pending_->base_id != to) {
    return {false, "no request from basestation " + to + " waits for robot " + robot_id_ + "'s lock",
            holder_};
  }
  EndPending(from + " denied " + to + "'s request for the lock");
  return {true, "", holder_};
}

double ControlLock::PendingLeftS(core::SteadyTime now) const {
  if (!pending_) return 0.0;
  return std::max(0.0, options_.handover_request_timeout_s - core::SecondsBetween(pending_->asked_at, now));
}

void ControlLock::EndPending(const std::string& outcome) {
  pending_.reset();
  Record(outcome);
}

void ControlLock::Record(const std::string& outcome) {
  ++handovers_;
  handover_outcome_ = outcome;
}

LockDecision ControlLock::Release(const std::string& base_id) {
  if (holder_.empty()) return {false, "robot " + robot_id_ + " is not locked by anyone", holder_};
  if (holder_ != base_id) {
    return {false, "only the holder releases: robot " + robot_id_ + " is locked by basestation " + holder_,
            holder_};
  }
  if (pending_) EndPending(base_id + " released the lock while " + pending_->base_id + " waited: it is free");
  holder_.clear();
  speaker_.clear();
  return {true, "", holder_};
}

void ControlLock::NoteHolderCommand(const std::string& participant) {
  if (holder_.empty() || participant.empty()) return;
  live_[participant] = holder_;
  speaker_ = participant;
}

void ControlLock::OnParticipantAlive(const std::string& base_id, const std::string& participant) {
  if (participant.empty()) return;
  live_[participant] = base_id;
  if (!holder_.empty() && base_id == holder_ && speaker_.empty()) speaker_ = participant;
}

void ControlLock::OnParticipantLost(const std::string& participant, core::SteadyTime now) {
  live_.erase(participant);
  if (pending_ && pending_->participant == participant) {
    EndPending(pending_->base_id + "'s request was dropped: its basestation left");
  }
  if (holder_.empty() || participant != speaker_) return;
  // The speaker is gone: another live process with the holder's id takes over, else the holder is lost.
  speaker_.clear();
  for (const auto& [other, base_id] : live_) {
    if (base_id == holder_) {
      speaker_ = other;
      return;
    }
  }
  lost_since_ = now;
}

void ControlLock::Restore(const std::string& base_id, core::SteadyTime now) {
  pending_.reset();
  holder_ = base_id;
  speaker_.clear();
  lost_since_ = now;
  for (const auto& [participant, announced] : live_) {
    if (!holder_.empty() && announced == holder_) {
      speaker_ = participant;
      return;
    }
  }
}

uint32_t ControlLock::holder_participants() const {
  uint32_t n = 0;
  for (const auto& [participant, base_id] : live_) n += (!holder_.empty() && base_id == holder_) ? 1 : 0;
  return n;
}

bool ControlLock::Update(core::SteadyTime now) {
  if (pending_ && PendingLeftS(now) <= 0.0) {
    EndPending(pending_->base_id + "'s request expired: " + holder_ + " did not answer within " +
               SecondsText(options_.handover_request_timeout_s));
  }
  if (holder_.empty() || holder_alive() || std::isinf(options_.lock_keep_s)) return false;
  if (core::SecondsBetween(lost_since_, now) < options_.lock_keep_s) return false;
  if (pending_)
    EndPending(holder_ + "'s lock was freed (its holder lost): " + pending_->base_id + " may take it");
  holder_.clear();
  return true;
}

std::string ControlLock::Describe() const {
  if (holder_.empty()) return "free";
  return "locked by basestation " + holder_ + (holder_alive() ? "" : " (liveliness lost)");
}

std::string ControlLock::NotHolderReason(const std::string& base_id) const {
  if (holder_.empty()) {
    return "basestation " + base_id + " does not hold the control lock of robot " + robot_id_ +
           " (free: request-control first)";
  }
  return "basestation " + base_id + " does not hold the control lock: robot " + robot_id_ +
         " is locked by basestation " + holder_;
}

}  // namespace cairn::agent
