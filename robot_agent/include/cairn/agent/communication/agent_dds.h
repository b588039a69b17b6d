// The agent's DDS adapter: one participant with the robot's readers and writers (topics and QoS profiles of
// config/dds_profiles.xml), nothing else. Incoming messages addressed to this robot become the plain structs
// of commands.h and go to the handlers; outgoing replies and telemetry are written as they are given. No
// robot logic lives here: who may command is the command interface's, what to publish the telemetry's.
//
// Topics (idl/cairn_msgs.idl): reads cairn/control_request, cairn/mode_request, cairn/waypoint_goal,
// cairn/explore_request, cairn/home_request, cairn/stop_request, cairn/restart_request (QoS cairn.command),
// cairn/teleop (cairn.teleop), cairn/base_info (cairn.latched, with liveliness), cairn/path_request,
// cairn/map_sync_request (cairn.command); writes cairn/command_response, cairn/path_response (cairn.command),
// cairn/agent_info, cairn/bt_state, cairn/global_path, cairn/staircase, cairn/robot_state, cairn/health
// (cairn.latched), cairn/robot_pose, cairn/local_plan (cairn.state), cairn/map_update (cairn.map, flow
// controller "cairn.map"), cairn/camera (cairn.camera, flow controller "cairn.camera"). Robots read one
// another on three topics only, each written or read from the moment the robot needs it, so that an idle
// fleet's discovery stays O(robots) (a reader matches every robot's writer; a discovery server relays a
// robot's endpoints only to the processes that match them): cairn/explore_claim (cairn.latched), written and
// read from the robot's first claim on; cairn/peer_state (cairn.state), written from the start and read once
// the robot first drives (ListenToPeers()); cairn/yield_request (cairn.command), read from the start (a
// parked robot may be asked to get out of the way) and written from the robot's first request (a
// basestation's `yield` writes it too; under DDS Security a basestation writes cairn/yield_request/<robot>,
// which only the robot's commanders may). It answers every basestation's link probe (cairn/link_probe ->
// cairn/link_probe_reply, cairn.command) on the spot.
#pragma once

#include <memory>
#include <string>

#include "cairn/agent/communication/agent_link.h"
#include "cairn/core/link_options.h"

namespace cairn_msgs {  // the message types the link's interface does not name already
class ExploreClaim;
class YieldRequest;
}  // namespace cairn_msgs

namespace cairn::agent {

/// How the adapter's participant is made.
struct AgentDdsOptions {
  std::string robot_id;                   ///< messages for other robots are ignored; replies carry it
  int domain_id = 0;                      ///< DDS domain, [0, 232]
  std::string profiles_file;              ///< Fast DDS XML profiles; "" = core::DefaultProfilesFile()
  core::LinkOptions link;                 ///< the network the participant talks on
  double map_budget_bits_per_s = 1e6;     ///< flow controller "cairn.map", > 0
  double camera_budget_bits_per_s = 1e6;  ///< flow controller "cairn.camera", > 0
  /// DDS Security (--secure DIR; identity = robot_id): commands (and operators' yield requests) are then
  /// read from the robot's own topics only (core::CommandTopicFor), which its permissions let only the
  /// basestations given it publish, and every message that names its sender (a base id, a robot id) is
  /// dropped, counted and logged when that sender is not the certificate it came under
  /// (core::GuidPrefixHoldsIdentity).
  core::SecurityOptions security;
};

/// The robot's DDS entities. Construction is a checked chain (participant, writers); Listen() adds the
/// readers. Any failure throws and what exists is torn down. Readers go first at destruction, so no handler
/// runs while the rest goes.
class AgentDds final : public AgentLink {
 public:
  /// Creates the participant and the writers. @throws core::DdsError naming the profile, topic or entity;
  /// std::invalid_argument for a bad domain id.
  explicit AgentDds(const AgentDdsOptions& options);
  /// Creates the readers: from now on the handlers are called (so everything they use must exist, and the
  /// writers replies go through already do). Call once. @throws std::invalid_argument for a missing handler,
  /// std::logic_error for a second call, core::DdsError as the constructor.
  void Listen(AgentDdsHandlers handlers) override;
  ~AgentDds() override;
  /// Deletes the readers: once it returns no handler runs (nor will), while the writers still send. Call
  /// before tearing down what the handlers use. Not thread-safe with Listen().
  void StopListening() override;
  AgentDds(const AgentDds&) = delete;
  AgentDds& operator=(const AgentDds&) = delete;

  /// Remote processes that left the domain or were dropped since the last call (participant discovery sees
  /// every process, announced or not). Collected on Fast DDS's discovery thread, which must never wait for
  /// the agent's lock; the control loop takes them.
  std::vector<std::string> TakeGoneParticipants() override;

  /// A command's reply, as a CommandResponse.
  void Send(const CommandReply& reply) override;
  /// A path query's answer, as a PathResponse.
  void Send(const PathAnswer& answer) override;
  /// Telemetry as built by the caller. Each returns false when Fast DDS refuses the sample (history full).
  /// The health message gets forged_senders and last_forged_sender (ForgedSendersSoFar()) here.
  bool Publish(const cairn_msgs::AgentInfo& info) override;
  bool Publish(const cairn_msgs::RobotState& state) override;
  bool Publish(const cairn_msgs::AgentHealth& health) override;
  bool Publish(const cairn_msgs::RobotPose& pose) override;
  bool Publish(const cairn_msgs::BehaviorTreeState& tree) override;
  bool Publish(const cairn_msgs::GlobalPath& path) override;
  bool Publish(const cairn_msgs::LocalPlan& plan) override;
  bool Publish(const cairn_msgs::MapUpdate& update) override;
  bool Publish(const cairn_msgs::CompressedImage& image) override;
  bool Publish(const cairn_msgs::StaircaseDetection& staircase) override;
  /// This robot's explore claim (its coverage compressed here). The first call makes the claim writer and the
  /// reader of peers' claims (their handler runs from then on); call it outside any lock a handler takes
  /// (Fast DDS delivers to this participant's own reader, with liveliness callbacks, on the calling thread).
  /// false when Fast DDS refuses the sample. @throws std::logic_error before Listen(), core::DdsError.
  bool Publish(const ExploreClaim& claim) override;
  /// This robot's state for its peers (class "team"): written only while a reader of the topic is matched
  /// (its own too, once it listens). false when Fast DDS refuses the sample.
  bool Publish(const cairn_msgs::PeerState& state) override;
  /// Makes the reader of the peers' states (idempotent): the peer_state handler runs from then on. Call it
  /// when the robot first drives, outside any lock a handler takes. @throws std::logic_error before Listen(),
  /// core::DdsError.
  void ListenToPeers() override;
  /// Asks robot `robot_id` to yield (cairn/yield_request, class "team"). The first call makes the writer;
  /// call it outside any lock a handler takes (Fast DDS delivers to this participant's own reader on the
  /// calling thread). false when Fast DDS refuses the sample. @throws core::DdsError.
  bool Send(const std::string& robot_id, const YieldCommand& request) override;
  /// Messages dropped so far because their sender id is not the certificate they came under. Thread-safe.
  ForgedSenders ForgedSendersSoFar() const override;
  /// What every writer has sent so far, grouped into the link's topic classes, in priority order: command
  /// (command and path answers, probe replies), state (robot state and pose, local plan, agent info,
  /// staircases), tree (behavior tree, global path), team (explore claims, peer states), map, camera.
  /// Thread-safe.
  std::vector<SentTraffic> SentByClass() const override;
  /// Robots sharing this robot's link now, itself included: the largest AgentInfo::robots_heard of the live
  /// basestations, at least 1. Robots never read one another (a fleet's discovery stays O(robots), not
  /// O(robots²)), so the basestations, which hear them all, tell them. Thread-safe.
  int RobotsOnLink() const override;
  /// A radio shared by `robots` robots: the map and camera writers move to flow controllers holding 1 / n of
  /// their budgets, n the smallest of 1, 2, 3, 4, 6, 8, 12, 16 at least `robots` (16 beyond). Replacing a
  /// writer drops its samples not yet sent (a basestation that misses map updates asks for a snapshot).
  /// Thread-safe. @return n; always 1 on a link other than radio (only a radio's controllers come in shares).
  int SetBulkShare(int robots) override;
  /// Waits up to `timeout` for the map updates written so far to be acknowledged (at shutdown).
  void WaitForMapDelivery(std::chrono::milliseconds timeout) override;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

/// A peer's claim as it came off cairn/explore_claim, with its coverage decompressed
/// (DecompressCoverageBits); `*fault` (not null) is "" or why its coverage could not be read, and then the
/// claim has none. The receiver still checks it (CheckExploreClaim). Also the fuzz harness's way in
/// (fuzz/peer_message_fuzz.cpp).
ExploreClaim ClaimFromMessage(const cairn_msgs::ExploreClaim& m, std::string* fault);

/// A yield request as it came off cairn/yield_request; `*fault` (not null) is "" or why it cannot be acted on
/// (an unknown action, named with its value). The receiver still checks it (CheckYieldCommand). Also the fuzz
/// harness's way in.
YieldCommand YieldFromMessage(const cairn_msgs::YieldRequest& m, std::string* fault);

/// A peer's state as it came off cairn/peer_state (the receiver checks it: CheckPeer). Also the fuzz
/// harness's way in.
Peer PeerFromMessage(const cairn_msgs::PeerState& m);

}  // namespace cairn::agent
