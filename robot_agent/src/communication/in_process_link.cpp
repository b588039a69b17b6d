#include "cairn/agent/communication/in_process_link.h"

#include <algorithm>
#include <stdexcept>

#include "cairn/agent/communication/agent_dds.h"
#include "cairn_msgs.h"

namespace cairn::agent {

// ---- InProcessLink ----------------------------------------------------------------------------------------

InProcessLink::InProcessLink(InProcessTeam* team, std::string robot_id)
    : team_(team), robot_id_(std::move(robot_id)) {}

InProcessLink::~InProcessLink() { team_->Leave(this); }

void InProcessLink::Listen(AgentDdsHandlers handlers) {
  if (ever_listened_) throw std::logic_error("InProcessLink::Listen called twice");
  RequireAllHandlers(handlers);
  handlers_ = std::move(handlers);
  listening_ = ever_listened_ = true;
}

bool InProcessLink::Publish(const cairn_msgs::AgentInfo&) { return Count(kState), true; }
bool InProcessLink::Publish(const cairn_msgs::RobotState&) { return Count(kState), true; }
bool InProcessLink::Publish(const cairn_msgs::AgentHealth&) { return Count(kState), true; }
bool InProcessLink::Publish(const cairn_msgs::RobotPose&) { return Count(kState), true; }
bool InProcessLink::Publish(const cairn_msgs::BehaviorTreeState&) { return Count(kTree), true; }
bool InProcessLink::Publish(const cairn_msgs::GlobalPath&) { return Count(kTree), true; }
bool InProcessLink::Publish(const cairn_msgs::LocalPlan&) { return Count(kState), true; }
bool InProcessLink::Publish(const cairn_msgs::MapUpdate&) { return Count(kMap), true; }
bool InProcessLink::Publish(const cairn_msgs::CompressedImage&) { return Count(kCamera), true; }
bool InProcessLink::Publish(const cairn_msgs::StaircaseDetection&) { return Count(kState), true; }

bool InProcessLink::Publish(const ExploreClaim& claim) {
  if (!ever_listened_) throw std::logic_error("InProcessLink::Publish(ExploreClaim) before Listen()");
  Count(kTeam);
  ++claims_sent_;
  if (claim.coverage) coverage_bytes_sent_ += CompressCoverageBits(*claim.coverage).size();
  if (!listening_to_claims_) {
    // From its first claim on it reads its peers' claims: the newest of each first (the latched topic).
    listening_to_claims_ = true;
    for (const auto& [id, last] : team_->last_claims_) {
      if (id != robot_id_ && team_->Hears(robot_id_, id) && listening()) listening()->explore_claim(last, "");
    }
  }
  team_->DeliverClaim(*this, claim);
  return true;
}

bool InProcessLink::Publish(const cairn_msgs::PeerState& state) {
  SendPeerState(PeerFromMessage(state));
  return true;
}

void InProcessLink::SendPeerState(const Peer& peer) {
  Count(kTeam);
  team_->DeliverPeerState(*this, peer);
}

void InProcessLink::ListenToPeers() {
  if (!ever_listened_) throw std::logic_error("InProcessLink::ListenToPeers() before Listen()");
  listening_to_peers_ = true;
}

bool InProcessLink::Send(const std::string& robot_id, const YieldCommand& request) {
  Count(kTeam);
  InProcessLink* to = team_->Find(robot_id);
  // Nobody reads it, or out of reach: lost, as on DDS.
  if (to == nullptr || to->listening() == nullptr || !team_->Hears(robot_id, robot_id_)) return true;
  YieldOrigin origin;
  origin.peer_robot = request.sender_id == robot_id_;  // its peer states come from this process
  to->listening()->yield(request, origin, "");
  return true;
}

std::vector<SentTraffic> InProcessLink::SentByClass() const {
  std::vector<SentTraffic> out;
  out.reserve(kTopicClasses);
  for (int c = 0; c < kTopicClasses; ++c) out.push_back({kTopicClassNames[c], 0, samples_[c]});
  return out;
}

std::uint64_t InProcessLink::samples(const std::string& topic_class) const {
  for (int c = 0; c < kTopicClasses; ++c) {
    if (topic_class == kTopicClassNames[c]) return samples_[c];
  }
  return 0;
}

// ---- InProcessTeam ----------------------------------------------------------------------------------------

std::shared_ptr<InProcessLink> InProcessTeam::Join(const std::string& robot_id) {
  if (robot_id.empty()) throw std::invalid_argument("InProcessTeam::Join: robot id is empty");
  if (Find(robot_id) != nullptr)
    throw std::invalid_argument("InProcessTeam::Join: robot id '" + robot_id + "' is already on the team");
  auto link = std::make_shared<InProcessLink>(this, robot_id);
  links_.push_back(link.get());
  return link;
}

InProcessLink* InProcessTeam::Find(const std::string& robot_id) const {
  for (InProcessLink* link : links_) {
    if (link->robot_id() == robot_id) return link;
  }
  return nullptr;
}

void InProcessTeam::SetHeard(const std::string& from_id, const std::string& to_id, bool heard) {
  if (heard) {
    unheard_.erase({from_id, to_id});
  } else {
    unheard_.insert({from_id, to_id});
  }
}

void InProcessTeam::Leave(InProcessLink* link) {
  links_.erase(std::remove(links_.begin(), links_.end(), link), links_.end());
}

void InProcessTeam::DeliverClaim(const InProcessLink& from, const ExploreClaim& claim) {
  last_claims_[from.robot_id()] = claim;
  for (InProcessLink* link : links_) {
    if (link != &from && link->listening_to_claims_ && link->listening() != nullptr &&
        Hears(link->robot_id(), from.robot_id()))
      link->listening()->explore_claim(claim, "");
  }
}

void InProcessTeam::DeliverPeerState(const InProcessLink& from, const Peer& peer) {
  for (InProcessLink* link : links_) {
    if (link != &from && link->listening_to_peers_ && link->listening() != nullptr &&
        Hears(link->robot_id(), from.robot_id()))
      link->listening()->peer_state(peer);
  }
}

// ---- InProcessBase ----------------------------------------------------------------------------------------

InProcessBase::InProcessBase(InProcessTeam* team, std::string base_id)
    : team_(team),
      base_id_(std::move(base_id)),
      participant_("in-process:" + base_id_),
      writer_("in-process:" + base_id_ + ":writer") {
  if (team_ == nullptr) throw std::invalid_argument("InProcessBase: team is null");
  for (InProcessLink* link : team_->links_) {
    if (link->listening() != nullptr) Reach(link->robot_id());
  }
}

const AgentDdsHandlers& InProcessBase::Reach(const std::string& robot_id) {
  InProcessLink* link = team_->Find(robot_id);
  if (link == nullptr) throw std::invalid_argument("InProcessBase: no robot '" + robot_id + "' on the team");
  if (link->listening() == nullptr)
    throw std::invalid_argument("InProcessBase: robot '" + robot_id + "' is not listening");
  if (std::find(announced_to_.begin(), announced_to_.end(), robot_id) == announced_to_.end()) {
    announced_to_.push_back(robot_id);
    link->listening()->base_announced({writer_, participant_, base_id_, /*has_joystick=*/false});
  }
  return *link->listening();
}

template <class Command>
std::uint32_t InProcessBase::SendCommand(const std::string& robot_id, Command command,
                                         std::function<void(const Command&)> AgentDdsHandlers::*handler) {
  const AgentDdsHandlers& to = Reach(robot_id);
  command.sender = Sender();
  command.request_id = Next();
  (to.*handler)(command);
  return command.request_id;
}

std::uint32_t InProcessBase::Send(const std::string& robot_id, ControlCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::control);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, ModeCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::mode);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, GoalCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::goal);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, ExploreCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::explore);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, ConvoyCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::convoy);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, HomeCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::home);
}
std::uint32_t InProcessBase::Send(const std::string& robot_id, StopCommand command) {
  return SendCommand(robot_id, std::move(command), &AgentDdsHandlers::stop);
}

void InProcessBase::Send(const std::string& robot_id, const YieldCommand& request) {
  const AgentDdsHandlers& to = Reach(robot_id);
  YieldOrigin origin;
  origin.announced_base = request.sender_id == base_id_;
  to.yield(request, origin, "");
}

std::optional<CommandReply> InProcessBase::Reply(const std::string& robot_id,
                                                 std::uint32_t request_id) const {
  const InProcessLink* link = team_->Find(robot_id);
  if (link == nullptr) return std::nullopt;
  for (const CommandReply& reply : link->replies()) {
    if (reply.base_id == base_id_ && reply.request_id == request_id) return reply;
  }
  return std::nullopt;
}

void InProcessBase::SetAlive(bool alive) {
  WriterLiveliness change;
  change.writer = writer_;
  change.lost = !alive;
  change.regained = alive;
  for (const std::string& robot_id : announced_to_) {
    const InProcessLink* link = team_->Find(robot_id);
    if (link != nullptr && link->listening() != nullptr) link->listening()->base_liveliness(change);
  }
}

}  // namespace cairn::agent
