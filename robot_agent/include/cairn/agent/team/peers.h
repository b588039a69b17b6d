// The peer robots one robot hears (Sriganesh et al. 2024, § Advanced Multi-agent Coordination): every robot
// tells the others where it is, how big it is, where it is going, its mode and its answer to a yield request
// (cairn/peer_state, a few times a second); each keeps the newest word of each peer for a timeout, and its
// navigation keeps clear of their bodies (nav/peers.h: the geometry). Peers share the team's map frame M (the
// frame explore claims use).
#pragma once

#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "cairn/nav/peers.h"

namespace cairn::agent {

/// Options of peer awareness (config section `peers`).
struct PeerOptions {
  /// A robot tells its peers where it is this often, Hz, (0, 50].
  double rate_hz = 5.0;
  /// A peer not heard for this long is forgotten (it left, or its link did), seconds, (0, 60].
  double timeout_s = 1.0;
  /// How navigation keeps clear of the peers (margin, prediction, same level, avoid at all).
  nav::PeerAvoidanceOptions avoidance;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// A peer robot as it last described itself (cairn/peer_state), frame M: its body, and what it is doing.
struct Peer : nav::PeerBody {
  std::string mode;  ///< its mode ("idle", "manual", "waypoint", ...)
  /// Its answer to a yield request (get-out-of-the-way, yield.h): "" | "moving_aside" | "aside" |
  /// "returning" | "refused"; the robot it yields to (or refused), and why refused / where it stands aside.
  std::string yield_state;
  std::string yield_to_id;
  std::string yield_reason;
};

/// "" when `peer` is usable, else why not, naming the field and value (nav::CheckPeerBody, then the yield
/// answer: a state of the list above, a valid id, a reason of at most 512 bytes); a peer message is dropped
/// then.
std::string CheckPeer(const Peer& peer);

/// The peers one robot hears. Thread-safe: messages arrive on DDS threads, the control loop reads.
class PeerTracker {
 public:
  /// @throws std::invalid_argument for invalid `options` or an empty `own_id`.
  PeerTracker(std::string own_id, PeerOptions options);

  /// A peer's message arrived at `now_s` (seconds on this robot's clock: no clock sync). "" when kept, else
  /// why it was dropped (CheckPeer's reason); its own messages are ignored.
  std::string OnPeerState(const Peer& peer, double now_s);
  /// The peers heard within options().timeout_s of `now_s`, by id. Forgets the others.
  std::vector<Peer> Live(double now_s);
  const PeerOptions& options() const { return options_; }

 private:
  struct Heard {
    Peer peer;
    double at_s = 0.0;
  };
  std::string own_id_;
  PeerOptions options_;
  std::mutex mutex_;
  std::map<std::string, Heard> heard_;
};

}  // namespace cairn::agent
