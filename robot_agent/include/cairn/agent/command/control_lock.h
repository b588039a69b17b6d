// The command interface's control lock (Sriganesh et al. 2024, § Command Interface; lesson L3: exactly one
// operator commands a robot at a time). Pure logic, no DDS: the agent feeds it requests and liveliness.
//
// Two identities meet here:
//  - a basestation id ("opA") names an operator. The lock belongs to it, so a holder that crashes and comes
//    back with the same id finds its robots still locked to it (a robot is never orphaned by a restart);
//  - a participant id (the DDS participant's GUID prefix) names one process. Liveliness is per process: the
//    holder is alive while some live process speaks for it (one that announced the holder's id or sent a
//    command as the holder), so a short-lived second process with the same id (a one-shot CLI call) that
//    exits cannot make the holder look lost. The agent reports every process's departure (agent-info
//    liveliness, and participant discovery for processes that never announced themselves).
#pragma once

#include <cstdint>
#include <limits>
#include <map>
#include <optional>
#include <string>

#include "cairn/core/time.h"

namespace cairn::agent {

/// Options of the control lock.
struct ControlLockOptions {
  /// How long the lock stays with a holder that no live process speaks for before it is freed, in seconds.
  /// Range [0, inf]; inf (the default) keeps it forever, as in the paper.
  double lock_keep_s = std::numeric_limits<double>::infinity();
  /// How long a request for a lock another basestation holds waits for the holder's answer (hand it over or
  /// deny it), in seconds, (0, 3600]; then it expires and both are told.
  double handover_request_timeout_s = 30.0;

  /// @return false and sets `*why` (field, value, rule) when invalid.
  bool IsValid(std::string* why) const;
};

/// Outcome of a lock request or release.
struct LockDecision {
  bool accepted = false;
  std::string reason;     ///< why it was denied ("" when accepted)
  std::string holder_id;  ///< holder after the decision ("" = free)
};

/// A request for a lock another basestation holds, waiting for the holder's answer.
struct PendingRequest {
  std::string base_id;      ///< who asked
  std::string participant;  ///< the process that asked: it speaks for the lock once handed over
  core::SteadyTime asked_at{};
};

/// Control lock keyed by basestation id, with liveliness per participant (process).
///
/// A request is granted when nobody holds the lock (or the requester's id already does), otherwise denied
/// naming the holder and left pending: the holder hands the lock over to the requester (Handover) or denies
/// it (Deny) within handover_request_timeout_s, or the request expires (Update). One request waits at a
/// time; the holder may also hand the lock to any live basestation unasked. Only the holder's id releases.
/// The holder is alive while some participant "speaks for" it: the participant that last sent it a command,
/// or, when that one is lost, another live participant that announced the same id. With none left, the lock
/// is kept for `lock_keep_s`, then freed.
class ControlLock {
 public:
  ControlLock(std::string robot_id, ControlLockOptions options);

  /// Request from basestation `base_id` sent by participant `participant` (live: it just spoke; it then
  /// speaks for the holder until it is lost).
  LockDecision Request(const std::string& base_id, const std::string& participant, core::SteadyTime now);
  LockDecision Release(const std::string& base_id);
  /// The holder `from` gives the lock to `to` (a grant when `to`'s request waits, else unasked): accepted
  /// when `from` holds it and a live process speaks for `to` (it announced `to`, or it sent the pending
  /// request).
  LockDecision Handover(const std::string& from, const std::string& to);
  /// The holder `from` refuses the pending request of `to`.
  LockDecision Deny(const std::string& from, const std::string& to);

  /// True when `base_id` holds the lock (commands from anyone else are to be discarded).
  bool IsHolder(const std::string& base_id) const { return !holder_.empty() && holder_ == base_id; }

  /// The holder's command (mode, goal) sent through `participant` was accepted: that process is live and
  /// now speaks for the holder until it is lost. (A refused command changes nothing: a process is not made
  /// the holder's voice by a malformed or refused message.)
  void NoteHolderCommand(const std::string& participant);

  /// Participant `participant` announced basestation id `base_id` and is alive (its agent info arrived or
  /// its liveliness came back).
  void OnParticipantAlive(const std::string& base_id, const std::string& participant);
  /// Participant `participant`'s liveliness was lost (it exited, crashed, or its link dropped). The holder
  /// is lost only when no other live participant speaks for it.
  void OnParticipantLost(const std::string& participant, core::SteadyTime now);

  /// After a restart (the journal): `base_id` holds the lock again, lost until a process with that id
  /// announces itself (OnParticipantAlive) or commands. "" leaves the lock free.
  void Restore(const std::string& base_id, core::SteadyTime now);

  /// Frees the lock once the holder has been lost for longer than lock_keep_s, and expires a request older
  /// than handover_request_timeout_s. @return true if it freed the lock.
  bool Update(core::SteadyTime now);

  /// The request waiting for the holder's answer, if any.
  const std::optional<PendingRequest>& pending_request() const { return pending_; }
  /// Seconds until the pending request expires at `now` (0 with none).
  double PendingLeftS(core::SteadyTime now) const;
  /// Answers to requests and handovers so far: grants, unasked handovers, denials, expiries, drops.
  uint32_t handovers() const { return handovers_; }
  /// The last of them, for operators ("opA handed the lock over to opB", ...; "" before any).
  const std::string& handover_outcome() const { return handover_outcome_; }

  /// Counts one discarded command from a non-holder.
  void CountDiscarded() { ++discarded_; }

  const std::string& holder_id() const { return holder_; }
  bool holder_alive() const { return !holder_.empty() && !speaker_.empty(); }
  /// Participant speaking for the holder now ("" when none: lock free or holder lost).
  const std::string& holder_participant() const { return speaker_; }
  /// Live participants that announced the holder's id.
  uint32_t holder_participants() const;
  uint32_t discarded() const { return discarded_; }
  /// "locked by basestation opA" / "free" — for messages.
  std::string Describe() const;
  /// Reason given to a non-holder whose command was discarded.
  std::string NotHolderReason(const std::string& base_id) const;

 private:
  std::string robot_id_;
  ControlLockOptions options_;
  std::string holder_;
  std::string speaker_;  // participant speaking for holder_; "" = holder lost (or no holder)
  core::SteadyTime lost_since_{};
  std::map<std::string, std::string> live_;  // live participant -> the basestation id it announced
  uint32_t discarded_ = 0;
  std::optional<PendingRequest> pending_;
  uint32_t handovers_ = 0;
  std::string handover_outcome_;

  // Ends the pending request (if any) with `outcome`, counted in handovers_.
  void EndPending(const std::string& outcome);
  // Counts one answer or handover and keeps its text.
  void Record(const std::string& outcome);
};

}  // namespace cairn::agent
