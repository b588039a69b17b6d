// Robots and basestations in one process, for agents stepped on a simulated clock (RobotAgent::Stepped:
// scenario tests and benches): each robot's AgentLink is an InProcessLink joined to one InProcessTeam, which
// delivers what a robot sends its peers (explore claims, peer states, yield requests) at once, on the sending
// thread, as the DDS adapter hands messages on: a robot never hears itself, peers' states only after
// ListenToPeers(), peers' claims from its own first claim on (then the newest of each peer first, as the
// latched topic gives a late reader). An InProcessBase is an operator's basestation: it announces itself to
// every robot and sends commands as the console would, and reads their replies.
//
// What differs from DDS: no serialization (SentByClass counts samples, not bytes), no loss, no delay, one
// link for everyone (RobotsOnLink() is 1, the bulk share 1), no process leaves (a basestation out of range is
// InProcessBase::SetAlive(false)).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cairn/agent/communication/agent_link.h"

namespace cairn::agent {

class InProcessTeam;

/// One robot's link on an InProcessTeam (see the file comment). Not thread-safe: the team is stepped from one
/// thread (the agent's own lock still serialises its handlers).
class InProcessLink final : public AgentLink {
 public:
  /// Use InProcessTeam::Join().
  InProcessLink(InProcessTeam* team, std::string robot_id);
  ~InProcessLink() override;
  InProcessLink(const InProcessLink&) = delete;
  InProcessLink& operator=(const InProcessLink&) = delete;

  void Listen(AgentDdsHandlers handlers) override;
  void StopListening() override { listening_ = false; }
  std::vector<std::string> TakeGoneParticipants() override { return {}; }
  void Send(const CommandReply& reply) override {
    Count(kCommand);
    replies_.push_back(reply);
  }
  void Send(const PathAnswer& answer) override {
    Count(kCommand);
    path_answers_.push_back(answer);
  }
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
  bool Publish(const ExploreClaim& claim) override;
  bool Publish(const cairn_msgs::PeerState& state) override;
  void ListenToPeers() override;
  bool Send(const std::string& robot_id, const YieldCommand& request) override;
  ForgedSenders ForgedSendersSoFar() const override { return {}; }
  std::vector<SentTraffic> SentByClass() const override;
  int RobotsOnLink() const override { return 1; }
  int SetBulkShare(int /*robots*/) override { return 1; }
  void WaitForMapDelivery(std::chrono::milliseconds /*timeout*/) override {}

  /// A peer state this link's robot sends, for a robot that is not an agent stepped here (a test's or a
  /// bench's made-up peer): delivered as Publish(cairn_msgs::PeerState) delivers an agent's.
  void SendPeerState(const Peer& peer);

  const std::string& robot_id() const { return robot_id_; }
  /// The robot's replies so far, oldest first.
  const std::vector<CommandReply>& replies() const { return replies_; }
  /// The robot's answers to path queries so far, oldest first.
  const std::vector<PathAnswer>& path_answers() const { return path_answers_; }
  /// Explore claims sent so far, and the bytes of their compressed coverage (CompressCoverageBits: what they
  /// carry on the wire).
  int claims_sent() const { return claims_sent_; }
  std::size_t coverage_bytes_sent() const { return coverage_bytes_sent_; }
  /// Samples sent so far in topic class `topic_class` ("command", "state", "tree", "team", "map", "camera").
  std::uint64_t samples(const std::string& topic_class) const;

 private:
  friend class InProcessTeam;
  friend class InProcessBase;
  // The handlers, when listening (null otherwise).
  const AgentDdsHandlers* listening() const { return listening_ ? &handlers_ : nullptr; }
  // The topic classes in AgentLink::SentByClass's order, and the samples sent in each.
  enum TopicClass { kCommand, kState, kTree, kTeam, kMap, kCamera, kTopicClasses };
  static constexpr const char* kTopicClassNames[kTopicClasses] = {"command", "state", "tree",
                                                                  "team",    "map",   "camera"};
  void Count(TopicClass c) { ++samples_[c]; }

  InProcessTeam* team_;
  std::string robot_id_;
  AgentDdsHandlers handlers_;
  bool listening_ = false;
  bool ever_listened_ = false;
  bool listening_to_peers_ = false;
  bool listening_to_claims_ = false;  // from its first claim on
  std::vector<CommandReply> replies_;
  std::vector<PathAnswer> path_answers_;
  std::array<std::uint64_t, kTopicClasses> samples_{};
  int claims_sent_ = 0;
  std::size_t coverage_bytes_sent_ = 0;
};

/// The robots and basestations of one process (see the file comment). Outlives its links and bases. Not
/// thread-safe.
class InProcessTeam {
 public:
  InProcessTeam() = default;
  InProcessTeam(const InProcessTeam&) = delete;
  InProcessTeam& operator=(const InProcessTeam&) = delete;

  /// A link for robot `robot_id` (give it to RobotAgent::Stepped). @throws std::invalid_argument for an
  /// empty id or one already on the team.
  std::shared_ptr<InProcessLink> Join(const std::string& robot_id);
  /// The link of robot `robot_id`, or null.
  InProcessLink* Find(const std::string& robot_id) const;
  /// Radio reach: robot `to_id` hears what robot `from_id` sends its peers (states, claims, yield requests)
  /// only while `heard` (at first everyone hears everyone). Ids need not have joined yet.
  void SetHeard(const std::string& from_id, const std::string& to_id, bool heard);
  bool Hears(const std::string& to_id, const std::string& from_id) const {
    return unheard_.count({from_id, to_id}) == 0;
  }

 private:
  friend class InProcessLink;
  friend class InProcessBase;
  void Leave(InProcessLink* link);
  void DeliverClaim(const InProcessLink& from, const ExploreClaim& claim);
  void DeliverPeerState(const InProcessLink& from, const Peer& peer);

  std::vector<InProcessLink*> links_;
  std::map<std::string, ExploreClaim> last_claims_;        // the newest of each robot (the latched topic)
  std::set<std::pair<std::string, std::string>> unheard_;  // (from, to) pairs out of reach
};

/// An operator's basestation on an InProcessTeam: announced (alive) to every robot on the team when made and
/// to robots that listen later when it sends them something; sends commands as the console does (its base id,
/// its own process and writer, request ids counting from 1) and reads their replies.
class InProcessBase {
 public:
  InProcessBase(InProcessTeam* team, std::string base_id);
  const std::string& base_id() const { return base_id_; }

  /// Sends `command` to robot `robot_id` (sender and request id filled in here) and returns its request id.
  /// @throws std::invalid_argument naming a robot not on the team or not listening.
  std::uint32_t Send(const std::string& robot_id, ControlCommand command);
  std::uint32_t Send(const std::string& robot_id, ModeCommand command);
  std::uint32_t Send(const std::string& robot_id, GoalCommand command);
  std::uint32_t Send(const std::string& robot_id, ExploreCommand command);
  std::uint32_t Send(const std::string& robot_id, ConvoyCommand command);
  std::uint32_t Send(const std::string& robot_id, HomeCommand command);
  std::uint32_t Send(const std::string& robot_id, StopCommand command);
  /// Asks robot `robot_id` to yield (a basestation's `yield`).
  void Send(const std::string& robot_id, const YieldCommand& request);
  /// The reply of robot `robot_id` to request `request_id`, if it came.
  std::optional<CommandReply> Reply(const std::string& robot_id, std::uint32_t request_id) const;
  /// The basestation goes out of range: its liveliness is lost at every robot (`lost` true), or comes back.
  void SetAlive(bool alive);

 private:
  // The robot's handlers, the base announced to it first.
  const AgentDdsHandlers& Reach(const std::string& robot_id);
  template <class Command>
  std::uint32_t SendCommand(const std::string& robot_id, Command command,
                            std::function<void(const Command&)> AgentDdsHandlers::*handler);
  CommandSender Sender() const { return {base_id_, participant_, writer_}; }
  std::uint32_t Next() { return ++last_request_id_; }

  InProcessTeam* team_;
  std::string base_id_;
  std::string participant_;  // its process's id, unique on the team
  std::string writer_;       // its agent-info and command writers' id
  std::uint32_t last_request_id_ = 0;
  std::vector<std::string> announced_to_;
};

}  // namespace cairn::agent
