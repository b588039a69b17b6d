#include "cairn/agent/command/control_lock.h"

#include <cmath>

namespace cairn::agent {

bool ControlLockOptions::IsValid(std::string* why) const {
  if (std::isnan(lock_keep_s) || lock_keep_s < 0.0) {
    *why = "lock_keep_s = " + std::to_string(lock_keep_s) + " must be >= 0 (or inf to keep forever)";
    return false;
  }
  return true;
}

ControlLock::ControlLock(std::string robot_id, ControlLockOptions options)
    : robot_id_(std::move(robot_id)), options_(options) {}

LockDecision ControlLock::Request(const std::string& base_id, const std::string& participant,
                                  core::SteadyTime /*now*/) {
  if (base_id.empty()) return {false, "a control request needs a basestation id", holder_};
  if (participant.empty()) return {false, "a control request needs a sending participant", holder_};
  if (holder_.empty() || holder_ == base_id) {
    holder_ = base_id;
    live_[participant] = base_id;  // it just spoke, so it is alive; its departure is reported like any other
    speaker_ = participant;
    return {true, "", holder_};
  }
  return {false, "robot " + robot_id_ + " is locked by basestation " + holder_, holder_};
}

LockDecision ControlLock::Release(const std::string& base_id) {
  if (holder_.empty()) return {false, "robot " + robot_id_ + " is not locked by anyone", holder_};
  if (holder_ != base_id) {
    return {false, "only the holder releases: robot " + robot_id_ + " is locked by basestation " + holder_,
            holder_};
  }
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
  if (holder_.empty() || holder_alive() || std::isinf(options_.lock_keep_s)) return false;
  if (core::SecondsBetween(lost_since_, now) < options_.lock_keep_s) return false;
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
