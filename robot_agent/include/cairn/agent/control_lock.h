// The command interface's control lock (Sriganesh et al. 2024, § Command Interface; lesson L3: exactly one
// operator commands a robot at a time). Pure logic, no DDS: the agent feeds it requests and liveliness.
#pragma once

#include <cstdint>
#include <limits>
#include <string>

#include "cairn/core/time.h"

namespace cairn::agent {

/// Options of the control lock.
struct ControlLockOptions {
  /// How long the lock stays with a holder whose liveliness is lost before it is freed, in seconds.
  /// Range [0, inf]; inf (the default) keeps it forever, as in the paper.
  double lock_keep_s = std::numeric_limits<double>::infinity();

  /// @return false and sets `*why` (field, value, rule) when invalid.
  bool IsValid(std::string* why) const;
};

/// Outcome of a lock request or release.
struct LockDecision {
  bool accepted = false;
  std::string reason;     ///< why it was denied ("" when accepted)
  std::string holder_id;  ///< holder after the decision ("" = free)
};

/// Control lock keyed by basestation id. A request is granted when nobody holds the lock (or the requester
/// already does), otherwise denied naming the holder. Only the holder releases. While the holder's
/// liveliness is lost the lock is kept for `lock_keep_s`, then freed.
class ControlLock {
 public:
  ControlLock(std::string robot_id, ControlLockOptions options);

  LockDecision Request(const std::string& base_id, core::SteadyTime now);
  LockDecision Release(const std::string& base_id);

  /// True when `base_id` holds the lock (commands from anyone else are to be discarded).
  bool IsHolder(const std::string& base_id) const { return !holder_.empty() && holder_ == base_id; }

  /// Liveliness of basestation `base_id` was lost / regained (ignored unless it is the holder).
  void OnLivelinessLost(const std::string& base_id, core::SteadyTime now);
  void OnLivelinessRegained(const std::string& base_id);

  /// Frees the lock once the holder has been lost for longer than lock_keep_s. @return true if it freed it.
  bool Update(core::SteadyTime now);

  /// Counts one discarded command from a non-holder.
  void CountDiscarded() { ++discarded_; }

  const std::string& holder_id() const { return holder_; }
  bool holder_alive() const { return holder_alive_; }
  uint32_t discarded() const { return discarded_; }
  /// "locked by basestation opA" / "free" — for messages.
  std::string Describe() const;
  /// Reason given to a non-holder whose command was discarded.
  std::string NotHolderReason(const std::string& base_id) const;

 private:
  std::string robot_id_;
  ControlLockOptions options_;
  std::string holder_;
  bool holder_alive_ = true;
  core::SteadyTime lost_since_{};
  uint32_t discarded_ = 0;
};

}  // namespace cairn::agent
