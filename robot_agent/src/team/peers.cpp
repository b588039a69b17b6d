#include "cairn/agent/team/peers.h"

#include <stdexcept>
#include <utility>

#include "cairn/core/peer_input.h"
#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::agent {

bool PeerOptions::IsValid(std::string* why) const {
  std::string msg;
  if (!core::InRange("peers.rate_hz", rate_hz, 0, 50, true, &msg) ||
      !core::InRange("peers.timeout_s", timeout_s, 0, 60, true, &msg)) {
    if (why != nullptr) *why = msg;
    return false;
  }
  return avoidance.IsValid(why);
}

namespace {

// "" when a peer's answer to a yield request is usable, else why not (the field and value).
std::string CheckYieldAnswer(const Peer& peer) {
  // A peer tells only its answer as the robot asked to yield (none, giving way or refused).
  if (peer.yield_state != fleet::yield_state::kNone && !fleet::GivesWay(peer.yield_state) &&
      peer.yield_state != fleet::yield_state::kRefused) {
    return "yield_state = \"" + peer.yield_state.substr(0, 40) +
           "\" is not \"\", moving_aside, aside, returning or refused";
  }
  if (!peer.yield_to_id.empty()) {
    if (std::string why = core::CheckId("yield_to_id", peer.yield_to_id); !why.empty()) return why;
  }
  if (peer.yield_reason.size() > 512) {
    return "yield_reason is " + std::to_string(peer.yield_reason.size()) + " bytes (at most 512)";
  }
  return "";
}

}  // namespace

std::string CheckPeer(const Peer& peer) {
  std::string fault = nav::CheckPeerBody(peer);
  if (fault.empty()) fault = CheckYieldAnswer(peer);
  return fault.empty() ? fault : "peer state from \"" + peer.robot_id + "\": " + fault;
}

PeerTracker::PeerTracker(std::string own_id, PeerOptions options)
    : own_id_(std::move(own_id)), options_(options) {
  if (own_id_.empty()) throw std::invalid_argument("PeerTracker: own_id is empty");
  if (std::string why; !options_.IsValid(&why)) throw std::invalid_argument("PeerTracker: " + why);
}

std::string PeerTracker::OnPeerState(const Peer& peer, double now_s) {
  if (std::string why = CheckPeer(peer); !why.empty()) return why;
  if (peer.robot_id == own_id_) return "";
  std::lock_guard<std::mutex> guard(mutex_);
  heard_[peer.robot_id] = Heard{peer, now_s};
  return "";
}

std::vector<Peer> PeerTracker::Live(double now_s) {
  std::vector<Peer> live;
  std::lock_guard<std::mutex> guard(mutex_);
  for (auto it = heard_.begin(); it != heard_.end();) {
    if (now_s - it->second.at_s > options_.timeout_s) {
      it = heard_.erase(it);
    } else {
      live.push_back(it->second.peer);
      ++it;
    }
  }
  return live;
}

}  // namespace cairn::agent
