// What the agent needs of its communication: incoming commands, peer messages and base announcements to
// handlers; replies, telemetry and team messages out. AgentDds implements it over Fast DDS (the robot as it
// ships); InProcessLink (in_process_link.h) implements it in one process for robots stepped on a simulated
// clock (scenario tests, benches). The agent's logic sees only this interface, so both run the same wiring.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "cairn/agent/command/commands.h"
#include "cairn/agent/team/explore_claims.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/agent/team/yield_sender.h"

namespace cairn_msgs {
class AgentInfo;
class RobotPose;
class RobotState;
class AgentHealth;
class BehaviorTreeState;
class GlobalPath;
class LocalPlan;
class MapUpdate;
class CompressedImage;
class StaircaseDetection;
class PeerState;
}  // namespace cairn_msgs

namespace cairn::agent {

/// Messages dropped because the sender id they carry is not the certificate they came under (DDS Security
/// only; AgentHealth.forged_senders).
struct ForgedSenders {
  std::uint64_t count = 0;
  std::string last;  ///< the newest: topic, the id claimed and the certificate's id
};

/// What the agent has sent in one topic class (AgentLink::SentByClass), cumulative since it started.
struct SentTraffic {
  std::string
      topic_class;  ///< "command" | "state" | "tree" | "team" | "map" | "camera" (cairn_msgs::LinkClassUsage)
  std::uint64_t bytes = 0;  ///< serialized samples (CDR with encapsulation), bytes
  std::uint64_t samples = 0;
};

/// Where incoming messages go. Called on the link's threads, possibly concurrently: each handler does its own
/// locking. Every handler is required.
struct AgentDdsHandlers {
  std::function<void(const ControlCommand&)> control;
  std::function<void(const ModeCommand&)> mode;
  std::function<void(const GoalCommand&)> goal;
  std::function<void(const ExploreCommand&)> explore;
  std::function<void(const ConvoyCommand&)> convoy;
  std::function<void(const HomeCommand&)> home;
  std::function<void(const StopCommand&)> stop;
  std::function<void(const RestartCommand&)> restart;
  std::function<void(const TeleopCommand&)> teleop;
  std::function<void(const BaseAnnouncement&)> base_announced;   ///< agent info of a basestation
  std::function<void(const WriterLiveliness&)> base_liveliness;  ///< its agent-info writer's liveliness
  std::function<void(const PathQuery&)> path_query;
  std::function<void(const std::string& requester_id)> map_sync;  ///< a map snapshot is asked for
  /// A peer robot's explore claim (its own are not handed on); `fault` is "" or why its coverage could not be
  /// read (the field and value; the claim is then handed on without coverage and must be dropped).
  std::function<void(const ExploreClaim& claim, const std::string& fault)> explore_claim;
  /// A peer robot's state (cairn/peer_state; its own are not handed on), after ListenToPeers(). Not checked
  /// here: the receiver checks it (CheckPeerBody).
  std::function<void(const Peer& peer)> peer_state;
  /// A yield request for this robot (cairn/yield_request, from a peer robot or a basestation); `fault` is ""
  /// or why it cannot be read (an unknown action, named with its value; it must then be refused, not acted
  /// on). Not checked otherwise: the receiver checks it (CheckYieldCommand).
  std::function<void(const YieldCommand& request, const YieldOrigin& origin, const std::string& fault)> yield;
};

/// Throws std::invalid_argument naming the first handler of `handlers` that is empty.
void RequireAllHandlers(const AgentDdsHandlers& handlers);

/// One robot's communication (see the file comment). Methods are thread-safe unless they say otherwise.
class AgentLink {
 public:
  virtual ~AgentLink() = default;

  /// Starts handing incoming messages to `handlers` (everything they use must exist by then). Call once.
  /// @throws std::invalid_argument for a missing handler, std::logic_error for a second call.
  virtual void Listen(AgentDdsHandlers handlers) = 0;
  /// Stops handing messages on: once it returns no handler runs (nor will), while sending still works. Call
  /// before tearing down what the handlers use. Not thread-safe with Listen().
  virtual void StopListening() = 0;
  /// Remote processes that left or were dropped since the last call.
  virtual std::vector<std::string> TakeGoneParticipants() = 0;

  /// A command's reply.
  virtual void Send(const CommandReply& reply) = 0;
  /// A path query's answer.
  virtual void Send(const PathAnswer& answer) = 0;
  /// Telemetry as built by the caller. Each returns false when the sample is refused (history full).
  virtual bool Publish(const cairn_msgs::AgentInfo& info) = 0;
  virtual bool Publish(const cairn_msgs::RobotState& state) = 0;
  virtual bool Publish(const cairn_msgs::AgentHealth& health) = 0;
  virtual bool Publish(const cairn_msgs::RobotPose& pose) = 0;
  virtual bool Publish(const cairn_msgs::BehaviorTreeState& tree) = 0;
  virtual bool Publish(const cairn_msgs::GlobalPath& path) = 0;
  virtual bool Publish(const cairn_msgs::LocalPlan& plan) = 0;
  virtual bool Publish(const cairn_msgs::MapUpdate& update) = 0;
  virtual bool Publish(const cairn_msgs::CompressedImage& image) = 0;
  virtual bool Publish(const cairn_msgs::StaircaseDetection& staircase) = 0;
  /// This robot's explore claim, for its peers. Call outside any lock a handler takes (a link may deliver to
  /// its own readers on the calling thread). @throws std::logic_error before Listen().
  virtual bool Publish(const ExploreClaim& claim) = 0;
  /// This robot's state for its peers.
  virtual bool Publish(const cairn_msgs::PeerState& state) = 0;
  /// Starts handing the peers' states to the peer_state handler (idempotent). Call outside any lock a
  /// handler takes. @throws std::logic_error before Listen().
  virtual void ListenToPeers() = 0;
  /// Asks robot `robot_id` to yield. Call outside any lock a handler takes.
  virtual bool Send(const std::string& robot_id, const YieldCommand& request) = 0;
  /// Messages dropped so far because their sender id is not the certificate they came under.
  virtual ForgedSenders ForgedSendersSoFar() const = 0;
  /// What has been sent so far, grouped into the link's topic classes, in priority order (command, state,
  /// tree, team, map, camera).
  virtual std::vector<SentTraffic> SentByClass() const = 0;
  /// Robots sharing this robot's link now, itself included, at least 1.
  virtual int RobotsOnLink() const = 0;
  /// A radio shared by `robots` robots: bulk traffic (map, camera) at 1 / n of its budget. @return n.
  virtual int SetBulkShare(int robots) = 0;
  /// Waits up to `timeout` for the map updates written so far to be acknowledged (at shutdown).
  virtual void WaitForMapDelivery(std::chrono::milliseconds timeout) = 0;
};

}  // namespace cairn::agent
