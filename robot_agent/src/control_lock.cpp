#include "cairn/agent/control_lock.h"

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

LockDecision ControlLock::Request(const std::string& base_id, core::SteadyTime /*now*/) {
  if (base_id.empty()) return {false, "a control request needs a basestation id", holder_};
  if (holder_.empty() || holder_ == base_id) {
    holder_ = base_id;
    holder_alive_ = true;
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
  holder_alive_ = true;
  return {true, "", holder_};
}

void ControlLock::OnLivelinessLost(const std::string& base_id, core::SteadyTime now) {
  if (!IsHolder(base_id) || !holder_alive_) return;
  holder_alive_ = false;
  lost_since_ = now;
}

void ControlLock::OnLivelinessRegained(const std::string& base_id) {
  if (IsHolder(base_id)) holder_alive_ = true;
}

bool ControlLock::Update(core::SteadyTime now) {
  if (holder_.empty() || holder_alive_ || std::isinf(options_.lock_keep_s)) return false;
  if (core::SecondsBetween(lost_since_, now) < options_.lock_keep_s) return false;
  holder_.clear();
  holder_alive_ = true;
  return true;
}

std::string ControlLock::Describe() const {
  if (holder_.empty()) return "free";
  return "locked by basestation " + holder_ + (holder_alive_ ? "" : " (liveliness lost)");
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
