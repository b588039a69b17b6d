#include "cairn/agent/communication/agent_dds.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <stdexcept>
#include <utility>

#include "cairn/core/dds.h"
#include "cairn/core/peer_input.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::agent {

namespace msgs = cairn_msgs;
using SampleInfo = eprosima::fastdds::dds::SampleInfo;

namespace {

CommandSender SenderOf(const std::string& base_id, const SampleInfo& info) {
  return CommandSender{base_id, core::ParticipantIdOf(info.publication_handle),
                       core::WriterIdOf(info.publication_handle)};
}

// A control request as the command interface takes it; an action out of range or a bad target id is named in
// `malformed`, not dropped.
ControlCommand ControlCommandFrom(const msgs::ControlRequest& m, CommandSender sender) {
  ControlCommand c{std::move(sender), m.request_id(), ControlAction::kRequest, "", ""};
  switch (m.action()) {
    case msgs::CONTROL_ACTION_REQUEST:
      break;
    case msgs::CONTROL_ACTION_RELEASE:
      c.action = ControlAction::kRelease;
      break;
    case msgs::CONTROL_ACTION_HANDOVER:
    case msgs::CONTROL_ACTION_DENY:
      c.action = m.action() == msgs::CONTROL_ACTION_DENY ? ControlAction::kDeny : ControlAction::kHandover;
      c.target_base_id = m.target_base_id();
      c.malformed = core::CheckId("target_base_id", m.target_base_id());
      break;
    default:
      c.malformed = "action " + std::to_string(static_cast<int>(m.action())) +
                    " is none of REQUEST, RELEASE, HANDOVER, DENY (0-3)";
  }
  return c;
}

// An exploration request as the explore mode takes it (the task is checked there: CheckExploreTask).
ExploreCommand ExploreCommandFrom(const msgs::ExploreRequest& m, CommandSender sender) {
  ExploreCommand c{std::move(sender), m.request_id(), m.frame_id(), {}};
  if (m.has_region()) {
    // Corners as sent (not sorted: CheckExploreTask refuses a box whose corners are swapped).
    c.task.region_M = Eigen::AlignedBox2d();
    c.task.region_M->min() << m.region_min_x_m(), m.region_min_y_m();
    c.task.region_M->max() << m.region_max_x_m(), m.region_max_y_m();
  }
  // NaN on the wire = no bound.
  if (!std::isnan(m.min_z_m())) c.task.min_z_m = m.min_z_m();
  if (!std::isnan(m.max_z_m())) c.task.max_z_m = m.max_z_m();
  c.task.home_after_silence_s = m.home_after_silence_s();
  return c;
}

msgs::CommandKind KindOf(CommandKind kind) {
  switch (kind) {
    case CommandKind::kControlRequest:
      return msgs::COMMAND_KIND_CONTROL_REQUEST;
    case CommandKind::kControlRelease:
      return msgs::COMMAND_KIND_CONTROL_RELEASE;
    case CommandKind::kMode:
      return msgs::COMMAND_KIND_MODE;
    case CommandKind::kWaypoint:
      return msgs::COMMAND_KIND_WAYPOINT;
    case CommandKind::kExplore:
      return msgs::COMMAND_KIND_EXPLORE;
    case CommandKind::kHome:
      return msgs::COMMAND_KIND_HOME;
    case CommandKind::kRestart:
      return msgs::COMMAND_KIND_RESTART;
    case CommandKind::kConvoy:
      return msgs::COMMAND_KIND_CONVOY;
    case CommandKind::kControlHandover:
      return msgs::COMMAND_KIND_CONTROL_HANDOVER;
    case CommandKind::kControlDeny:
      return msgs::COMMAND_KIND_CONTROL_DENY;
    case CommandKind::kStop:
      break;
  }
  return msgs::COMMAND_KIND_STOP;
}

msgs::CommandResult ResultOf(CommandResult result) {
  switch (result) {
    case CommandResult::kAccepted:
      return msgs::COMMAND_RESULT_ACCEPTED;
    case CommandResult::kDenied:
      return msgs::COMMAND_RESULT_DENIED;
    case CommandResult::kDiscarded:
      break;
  }
  return msgs::COMMAND_RESULT_DISCARDED;
}

}  // namespace

ExploreClaim ClaimFromMessage(const msgs::ExploreClaim& m, std::string* fault) {
  ExploreClaim c;
  c.robot_id = m.robot_id();
  c.task_id = m.task_id();
  c.active = m.active();
  c.has_target = m.has_target();
  c.target_M = {m.target_x_m(), m.target_y_m(), m.target_z_m()};
  c.held_s = m.held_s();
  c.lease_s = m.lease_s();
  fault->clear();
  if (m.coverage_cell_m() != 0.0) {
    nav::CoverageBitmap bitmap;
    bitmap.cell_m = m.coverage_cell_m();
    bitmap.origin_cell = {m.coverage_origin_ix(), m.coverage_origin_iy()};
    bitmap.nx = m.coverage_nx();
    bitmap.ny = m.coverage_ny();
    if (DecompressCoverageBits(m.coverage_zstd(), &bitmap, fault)) c.coverage = std::move(bitmap);
  }
  return c;
}

class AgentDds::Impl {
 public:
  explicit Impl(const AgentDdsOptions& options) : options_(options) {
    core::ParticipantOptions p;
    p.domain_id = options.domain_id;
    if (!options.profiles_file.empty()) p.profiles_file = options.profiles_file;
    p.link = options.link;
    p.name = "cairn_agent/" + options.robot_id;
    p.security = options.security;
    p.on_participant_gone = [this](const std::string& participant, bool /*dropped*/) {
      {
        std::lock_guard<std::mutex> guard(senders_.mutex);
        senders_.bases_of_participant.erase(participant);
      }
      std::lock_guard<std::mutex> guard(gone_mutex_);
      gone_participants_.push_back(participant);
    };
    // One pair of bulk flow controllers per share of a shared radio (SetBulkShare picks one); Fast DDS cannot
    // change a controller's budget once the participant exists. Other links need only the whole budget.
    for (int share : kBulkShares) {
      if (share != 1 && !core::IsRadioLink(options.link)) continue;
      p.flow_controllers.push_back(
          {BulkController("cairn.map", share), options.map_budget_bits_per_s / share, 100});
      p.flow_controllers.push_back(
          {BulkController("cairn.camera", share), options.camera_budget_bits_per_s / share, 100});
    }
    participant_ = std::make_unique<core::Participant>(p);
    MakeWriters();
  }

  ~Impl() { StopListening(); }

  // Readers first so that no callback runs while the rest is torn down.
  void StopListening() {
    probe_reader_.reset();
    team_.yield_reader.reset();
    team_.commander_yield_reader.reset();
    team_.claim_reader.reset();
    team_.peer_reader.reset();
    map_sync_reader_.reset();
    path_request_reader_.reset();
    commands_ = CommandReaders{};
    info_reader_.reset();
  }

  // The topic this robot reads one kind of command on (its own under DDS Security: core::CommandTopicFor).
  std::string CommandTopic(const std::string& topic) const {
    return core::CommandTopicFor(topic, options_.robot_id, options_.security.enabled());
  }

  void MakeWriters() {
    core::Participant& p = *participant_;
    writers_.info =
        std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(p, "cairn/agent_info", "cairn.latched");
    writers_.state =
        std::make_unique<core::Writer<msgs::RobotStatePubSubType>>(p, "cairn/robot_state", "cairn.latched");
    writers_.pose =
        std::make_unique<core::Writer<msgs::RobotPosePubSubType>>(p, "cairn/robot_pose", "cairn.state");
    writers_.health =
        std::make_unique<core::Writer<msgs::AgentHealthPubSubType>>(p, "cairn/health", "cairn.latched");
    writers_.tree = std::make_unique<core::Writer<msgs::BehaviorTreeStatePubSubType>>(p, "cairn/bt_state",
                                                                                      "cairn.latched");
    writers_.response = std::make_unique<core::Writer<msgs::CommandResponsePubSubType>>(
        p, "cairn/command_response", "cairn.command");
    writers_.path_response = std::make_unique<core::Writer<msgs::PathResponsePubSubType>>(
        p, "cairn/path_response", "cairn.command");
    writers_.global_path =
        std::make_unique<core::Writer<msgs::GlobalPathPubSubType>>(p, "cairn/global_path", "cairn.latched");
    writers_.local_plan =
        std::make_unique<core::Writer<msgs::LocalPlanPubSubType>>(p, "cairn/local_plan", "cairn.state");
    MakeBulkWriters(1);
    writers_.staircase = std::make_unique<core::Writer<msgs::StaircaseDetectionPubSubType>>(
        p, "cairn/staircase", "cairn.latched");
    writers_.probe_reply = std::make_unique<core::Writer<msgs::PingPongPubSubType>>(
        p, "cairn/link_probe_reply", "cairn.command");
    team_.peer_writer =
        std::make_unique<core::Writer<msgs::PeerStatePubSubType>>(p, "cairn/peer_state", "cairn.state");
  }

  // The map and camera writers on the flow controllers of `share` (bulk_mutex_ held, or before any Publish).
  // What the old writers had sent stays counted.
  void MakeBulkWriters(int share) {
    if (bulk_.map)
      bulk_.retired_map = {bulk_.retired_map.first + bulk_.map->bytes_written(),
                           bulk_.retired_map.second + bulk_.map->samples_written()};
    if (bulk_.camera)
      bulk_.retired_camera = {bulk_.retired_camera.first + bulk_.camera->bytes_written(),
                              bulk_.retired_camera.second + bulk_.camera->samples_written()};
    bulk_.map.reset();
    bulk_.camera.reset();
    bulk_.map = std::make_unique<core::Writer<msgs::MapUpdatePubSubType>>(
        *participant_, "cairn/map_update", "cairn.map", BulkController("cairn.map", share));
    bulk_.camera = std::make_unique<core::Writer<msgs::CompressedImagePubSubType>>(
        *participant_, "cairn/camera", "cairn.camera", BulkController("cairn.camera", share));
    bulk_.share = share;
  }

  static std::string BulkController(const char* name, int share) {
    return share == 1 ? std::string(name) : std::string(name) + "/" + std::to_string(share);
  }

  // The explore-claim writer and reader, made when the robot first explores (team_mutex_ held): robots read
  // one another on this topic only, and only robots that explore, so that an idle fleet's discovery stays
  // O(robots) (every endpoint of every robot would otherwise go to every robot: bench/fleet_join.sh's ten
  // robots were seen 4.3 s after they started instead of 3 s).
  void MakeTeamEndpoints() {
    if (team_.claim_writer) return;
    core::Participant& p = *participant_;
    const std::string& robot = options_.robot_id;
    team_.claim_writer = std::make_unique<core::Writer<msgs::ExploreClaimPubSubType>>(
        p, "cairn/explore_claim", "cairn.latched");
    team_.claim_reader = std::make_unique<core::Reader<msgs::ExploreClaimPubSubType>>(
        p, "cairn/explore_claim", "cairn.latched",
        [this, robot](const msgs::ExploreClaim& m, const SampleInfo& info) {
          if (m.robot_id() == robot || !ValidPeerId("cairn/explore_claim", "robot id", m.robot_id()) ||
              !Certified("cairn/explore_claim", "robot id", m.robot_id(), info))
            return;
          std::string fault;
          const ExploreClaim c = ClaimFromMessage(m, &fault);
          handlers_.explore_claim(c, fault);
        });
  }

  std::pair<std::uint64_t, std::uint64_t> TeamSent() const {
    std::lock_guard<std::mutex> guard(team_mutex_);
    auto sent = team_.claim_writer ? std::make_pair(team_.claim_writer->bytes_written(),
                                                    team_.claim_writer->samples_written())
                                   : std::make_pair(std::uint64_t{0}, std::uint64_t{0});
    sent.first += team_.peer_writer->bytes_written();
    sent.second += team_.peer_writer->samples_written();
    if (team_.yield_writer) {
      sent.first += team_.yield_writer->bytes_written();
      sent.second += team_.yield_writer->samples_written();
    }
    return sent;
  }

  // The reader of the peers' states (team_mutex_ held), made when the robot first drives.
  void MakePeerReader() {
    if (team_.peer_reader) return;
    const std::string& robot = options_.robot_id;
    team_.peer_reader = std::make_unique<core::Reader<msgs::PeerStatePubSubType>>(
        *participant_, "cairn/peer_state", "cairn.state",
        [this, robot](const msgs::PeerState& m, const SampleInfo& info) {
          if (m.robot_id() == robot || !ValidPeerId("cairn/peer_state", "robot id", m.robot_id()) ||
              !ValidPeerId("cairn/peer_state", "mode", m.mode()) ||
              !Certified("cairn/peer_state", "robot id", m.robot_id(), info)) {
            return;
          }
          {
            std::lock_guard<std::mutex> guard(senders_.mutex);
            if (senders_.participant_of_robot.size() < kMaxSenders ||
                senders_.participant_of_robot.count(m.robot_id()) > 0)
              senders_.participant_of_robot[m.robot_id()] = core::ParticipantIdOf(info.publication_handle);
          }
          handlers_.peer_state(PeerFromMessage(m));
        });
  }

  // False, with a warning at most every 5 s per topic, when a peer's message names a sender no CLI could
  // have (`field` `id`, e.g. a 100 kB base id, which would then ride in every state message as the holder's).
  bool ValidPeerId(const char* topic, const char* field, const std::string& id) {
    const std::string why = core::CheckId(field, id);
    if (why.empty()) return true;
    std::uint64_t suppressed = 0;
    if (peer_warnings_.Allow(topic, core::SteadyClock::now(), &suppressed)) {
      spdlog::warn(
          "robot {}: a message on {} dropped: {}{}", options_.robot_id, topic, why,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
    return false;
  }

  // Under DDS Security: true when the writer of `info` holds the certificate of `claimed`, the sender id the
  // message carries in `field`; else the message is dropped, counted (AgentHealth.forged_senders) and logged
  // (at most every 5 s per topic) naming the id claimed and the certificate's. Always true without security.
  bool Certified(const char* topic, const char* field, const std::string& claimed, const SampleInfo& info) {
    if (!options_.security.enabled()) return true;
    eprosima::fastrtps::rtps::GUID_t guid;
    eprosima::fastrtps::rtps::iHandle2GUID(guid, info.publication_handle);
    if (core::GuidPrefixHoldsIdentity(guid.guidPrefix, claimed)) return true;
    const std::string participant = core::ParticipantIdOf(guid);
    const std::string real = participant_->CertifiedIdOf(participant);
    const std::string what =
        std::string(topic) + ": " + field + " '" + claimed + "' sent under the certificate of " +
        (real.empty() ? "another identity" : "'" + real + "'") + " (participant " + participant + ")";
    {
      std::lock_guard<std::mutex> guard(senders_.forged_mutex);
      ++senders_.forged.count;
      senders_.forged.last = what;
    }
    std::uint64_t suppressed = 0;
    if (peer_warnings_.Allow(std::string("forged ") + topic, core::SteadyClock::now(), &suppressed)) {
      spdlog::warn(
          "robot {}: a forged message dropped: {}{}", options_.robot_id, what,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
    return false;
  }

  // Where a yield request on `topic` came from (`commander_topic`: this robot's own, under DDS Security).
  YieldOrigin OriginOf(const msgs::YieldRequest& m, const SampleInfo& info, bool commander_topic) {
    const std::string participant = core::ParticipantIdOf(info.publication_handle);
    YieldOrigin origin;
    origin.secure = options_.security.enabled();
    origin.commander_topic = commander_topic;
    std::lock_guard<std::mutex> guard(senders_.mutex);
    const auto bases = senders_.bases_of_participant.find(participant);
    origin.announced_base =
        bases != senders_.bases_of_participant.end() && bases->second.count(m.sender_id()) > 0;
    const auto robot = senders_.participant_of_robot.find(m.sender_id());
    origin.peer_robot = robot != senders_.participant_of_robot.end() && robot->second == participant;
    return origin;
  }

  // Each reader keeps only what is addressed to this robot and hands it on as a plain struct.
  void MakeReaders(AgentDdsHandlers handlers) {
    if (listening_) throw std::logic_error("AgentDds::Listen called twice");
    RequireAllHandlers(handlers);
    handlers_ = std::move(handlers);
    listening_ = true;
    core::Participant& p = *participant_;
    const std::string& robot = options_.robot_id;
    // Yield requests (get-out-of-the-way) from peer robots on the shared topic (a peer robot asks too, so it
    // is not a command topic) and, under DDS Security, from this robot's commanders on its own topic; who may
    // ask is the receiver's policy (CheckYieldSender), whether to yield its mode's (YieldOptions::modes).
    auto on_yield = [this, robot](const char* topic, bool commander_topic) {
      return [this, robot, topic, commander_topic](const msgs::YieldRequest& m, const SampleInfo& info) {
        if (m.robot_id() != robot || !ValidPeerId(topic, "sender id", m.sender_id()) ||
            !Certified(topic, "sender id", m.sender_id(), info))
          return;
        std::string fault;
        const YieldCommand c = YieldFromMessage(m, &fault);
        handlers_.yield(c, OriginOf(m, info, commander_topic), fault);
      };
    };
    team_.yield_reader = std::make_unique<core::Reader<msgs::YieldRequestPubSubType>>(
        p, "cairn/yield_request", "cairn.command", on_yield("cairn/yield_request", false));
    if (options_.security.enabled()) {
      team_.commander_yield_reader = std::make_unique<core::Reader<msgs::YieldRequestPubSubType>>(
          p, CommandTopic("cairn/yield_request"), "cairn.command",
          on_yield("cairn/yield_request/<robot>", true));
    }
    // A basestation's link probe, echoed at once: its round trip is the link's, not the control loop's.
    probe_reader_ = std::make_unique<core::Reader<msgs::PingPongPubSubType>>(
        p, "cairn/link_probe", "cairn.command",
        [this, robot](const msgs::PingPong& m, const SampleInfo& info) {
          if (!m.robot_id().empty() && m.robot_id() != robot) return;
          // Echoed: a body or id no basestation sends would make the robot an amplifier.
          if (!ValidPeerId("cairn/link_probe", "base id", m.base_id()) ||
              m.body().size() > kMaxProbeBodyBytes ||
              !Certified("cairn/link_probe", "base id", m.base_id(), info))
            return;
          msgs::PingPong reply;
          reply.request_id(m.request_id());
          reply.base_id(m.base_id());
          reply.robot_id(robot);
          reply.body(
              m.body());  // the probing process's identity: bases sharing an id tell their probes apart
          writers_.probe_reply->Write(reply);
        });
    map_sync_reader_ = std::make_unique<core::Reader<msgs::MapSyncRequestPubSubType>>(
        p, "cairn/map_sync_request", "cairn.command",
        [this, robot](const msgs::MapSyncRequest& m, const SampleInfo& info) {
          if (m.robot_id() != robot ||
              !ValidPeerId("cairn/map_sync_request", "requester id", m.requester_id()) ||
              !Certified("cairn/map_sync_request", "requester id", m.requester_id(), info)) {
            return;
          }
          handlers_.map_sync(m.requester_id());
        });
    path_request_reader_ = std::make_unique<core::Reader<msgs::PathRequestPubSubType>>(
        p, CommandTopic("cairn/path_request"), "cairn.command",
        [this, robot](const msgs::PathRequest& m, const SampleInfo& info) {
          // The requester id and the platform name ride into the answer and the log: bounded as ids are.
          if (m.robot_id() != robot || !ValidPeerId("cairn/path_request", "requester id", m.requester_id()) ||
              (!m.platform().empty() && !ValidPeerId("cairn/path_request", "platform", m.platform())) ||
              !Certified("cairn/path_request", "requester id", m.requester_id(), info)) {
            return;
          }
          handlers_.path_query(PathQuery{core::ParticipantIdOf(info.publication_handle),
                                         m.request_id(),
                                         m.requester_id(),
                                         m.frame_id(),
                                         {m.start_M().x_m(), m.start_M().y_m()},
                                         {m.goal_M().x_m(), m.goal_M().y_m()},
                                         m.platform()});
        });
    MakeBaseInfoReader();
    MakeCommandReaders();
  }

  // Basestations' announcements (who they are, which processes they run in, the robots they hear) and their
  // liveliness.
  void MakeBaseInfoReader() {
    // Basestations' announcements only: robots announce themselves on cairn/agent_info, which no robot reads.
    info_reader_ = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
        *participant_, "cairn/base_info", "cairn.latched",
        [this](const msgs::AgentInfo& m, const SampleInfo& info) {
          if (m.kind() != msgs::AGENT_KIND_BASESTATION ||
              !ValidPeerId("cairn/base_info", "base id", m.agent_id()) ||
              !Certified("cairn/base_info", "base id", m.agent_id(), info))
            return;
          const std::string writer = core::WriterIdOf(info.publication_handle);
          {
            std::lock_guard<std::mutex> guard(senders_.mutex);
            const std::string participant = core::ParticipantIdOf(info.publication_handle);
            if (senders_.bases_of_participant.size() < kMaxSenders ||
                senders_.bases_of_participant.count(participant) > 0)
              senders_.bases_of_participant[participant].insert(m.agent_id());
          }
          {
            std::lock_guard<std::mutex> guard(senders_.robots_heard_mutex);
            senders_.robots_heard_by_base[writer] = {m.robots_heard(), true};
          }
          const auto& caps = m.capabilities();
          handlers_.base_announced(
              BaseAnnouncement{writer, core::ParticipantIdOf(info.publication_handle), m.agent_id(),
                               std::find(caps.begin(), caps.end(), "joystick") != caps.end()});
        },
        [this](const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
          WriterLiveliness change;
          change.writer = core::WriterIdOf(status.last_publication_handle);
          // Unmatched (gone for good): alive -1 while alive, or not_alive -1 after its lease lapsed.
          change.unmatched = (status.alive_count_change < 0 && status.not_alive_count_change == 0) ||
                             (status.alive_count_change == 0 && status.not_alive_count_change < 0);
          change.lost = core::IsLivelinessLoss(status);
          change.regained = status.alive_count_change > 0;
          {
            std::lock_guard<std::mutex> guard(senders_.robots_heard_mutex);
            auto base = senders_.robots_heard_by_base.find(change.writer);
            if (base != senders_.robots_heard_by_base.end()) {
              if (change.unmatched) {
                senders_.robots_heard_by_base.erase(base);
              } else if (change.lost || change.regained) {
                base->second.second = change.regained && !change.lost;
              }
            }
          }
          handlers_.base_liveliness(change);
        });
  }

  // A reader of the command topic `name` (this robot's own under DDS Security, CommandTopic) that hands
  // `handle` each message addressed to this robot from a valid base id (certified under DDS Security).
  template <typename PubSub, typename Handle>
  std::unique_ptr<core::Reader<PubSub>> CommandReader(const char* name, const char* qos_class,
                                                      Handle handle) {
    using Msg = typename core::Reader<PubSub>::Msg;
    return std::make_unique<core::Reader<PubSub>>(
        *participant_, CommandTopic(name), qos_class,
        [this, name, handle = std::move(handle)](const Msg& m, const SampleInfo& info) {
          if (m.robot_id() != options_.robot_id) return;
          if (!ValidPeerId(name, "base id", m.base_id()) || !Certified(name, "base id", m.base_id(), info))
            return;
          handle(m, info);
        });
  }

  // The operators' commands, each handed on as a plain struct (malformed fields named, not dropped).
  void MakeCommandReaders() {
    commands_.control = CommandReader<msgs::ControlRequestPubSubType>(
        "cairn/control_request", "cairn.command",
        [this](const msgs::ControlRequest& m, const SampleInfo& info) {
          handlers_.control(ControlCommandFrom(m, SenderOf(m.base_id(), info)));
        });
    commands_.mode = CommandReader<msgs::ModeRequestPubSubType>(
        "cairn/mode_request", "cairn.command", [this](const msgs::ModeRequest& m, const SampleInfo& info) {
          handlers_.mode(ModeCommand{SenderOf(m.base_id(), info), m.request_id(), m.mode()});
        });
    commands_.goal = CommandReader<msgs::WaypointGoalPubSubType>(
        "cairn/waypoint_goal", "cairn.command", [this](const msgs::WaypointGoal& m, const SampleInfo& info) {
          handlers_.goal(GoalCommand{SenderOf(m.base_id(), info), m.request_id(), m.frame_id(), m.x_m(),
                                     m.y_m(), m.tolerance_m(), m.z_m()});
        });
    commands_.explore = CommandReader<msgs::ExploreRequestPubSubType>(
        "cairn/explore_request", "cairn.command",
        [this](const msgs::ExploreRequest& m, const SampleInfo& info) {
          handlers_.explore(ExploreCommandFrom(m, SenderOf(m.base_id(), info)));
        });
    commands_.home = CommandReader<msgs::HomeRequestPubSubType>(
        "cairn/home_request", "cairn.command", [this](const msgs::HomeRequest& m, const SampleInfo& info) {
          handlers_.home(HomeCommand{SenderOf(m.base_id(), info), m.request_id(), m.frame_id(), m.has_point(),
                                     m.x_m(), m.y_m(), m.z_m()});
        });
    commands_.convoy = CommandReader<msgs::ConvoyRequestPubSubType>(
        "cairn/convoy_request", "cairn.command",
        [this](const msgs::ConvoyRequest& m, const SampleInfo& info) {
          ConvoyCommand c{SenderOf(m.base_id(), info), m.request_id(), false, {}, ""};
          if (m.action() == msgs::CONVOY_ACTION_STOP) {
            c.stop = true;
          } else if (m.action() == msgs::CONVOY_ACTION_FOLLOW) {
            c.ahead_ids = m.ahead_ids();
          } else {
            c.malformed = "cairn/convoy_request: action = " + std::to_string(static_cast<int>(m.action())) +
                          " is not FOLLOW (0) or STOP (1)";
          }
          handlers_.convoy(c);
        });
    commands_.restart = CommandReader<msgs::RestartRequestPubSubType>(
        "cairn/restart_request", "cairn.command",
        [this](const msgs::RestartRequest& m, const SampleInfo& info) {
          handlers_.restart(RestartCommand{SenderOf(m.base_id(), info), m.request_id(), m.component_name()});
        });
    commands_.stop = CommandReader<msgs::StopRequestPubSubType>(
        "cairn/stop_request", "cairn.command", [this](const msgs::StopRequest& m, const SampleInfo& info) {
          handlers_.stop(StopCommand{SenderOf(m.base_id(), info), m.request_id()});
        });
    commands_.teleop = CommandReader<msgs::TeleopTwistPubSubType>(
        "cairn/teleop", "cairn.teleop", [this](const msgs::TeleopTwist& m, const SampleInfo&) {
          const msgs::Twist& t = m.twist();
          handlers_.teleop(TeleopCommand{
              m.base_id(), OperatorTwist{t.linear_x_mps(), t.linear_y_mps(), t.angular_z_radps()}});
        });
  }

  static constexpr std::size_t kMaxProbeBodyBytes = 256;
  static constexpr std::size_t kMaxSenders = 1024;  // processes and robots remembered (ids come from peers)
  AgentDdsOptions options_;
  AgentDdsHandlers handlers_;
  core::WarningLimiter peer_warnings_;
  bool listening_ = false;
  // Who is who among the senders this robot hears (taken on DDS threads, each map under its own mutex):
  // the base ids each process announced, the process each robot's peer states come from, the robots each
  // basestation hears, and the senders caught forging an id.
  struct Senders {
    std::mutex mutex;                                                   // guards the two maps below
    std::map<std::string, std::set<std::string>> bases_of_participant;  // process -> base ids it announced
    std::map<std::string, std::string> participant_of_robot;  // robot id -> process of its peer states
    std::mutex robots_heard_mutex;                            // guards robots_heard_by_base
    // A basestation's info writer -> (the robots it hears, alive).
    std::map<std::string, std::pair<int, bool>> robots_heard_by_base;
    std::mutex forged_mutex;  // guards forged
    ForgedSenders forged;
  };
  mutable Senders senders_;
  std::mutex gone_mutex_;  // guards gone_participants_ only (taken on a DDS thread)
  std::vector<std::string>
      gone_participants_;  // reported by participant discovery, taken by the control loop
  std::unique_ptr<core::Participant> participant_;
  // What this robot publishes about itself: its announcement, state, health, telemetry and answers.
  struct StateWriters {
    std::unique_ptr<core::Writer<msgs::AgentInfoPubSubType>> info;
    std::unique_ptr<core::Writer<msgs::RobotStatePubSubType>> state;
    std::unique_ptr<core::Writer<msgs::AgentHealthPubSubType>> health;
    std::unique_ptr<core::Writer<msgs::RobotPosePubSubType>> pose;
    std::unique_ptr<core::Writer<msgs::BehaviorTreeStatePubSubType>> tree;
    std::unique_ptr<core::Writer<msgs::CommandResponsePubSubType>> response;
    std::unique_ptr<core::Writer<msgs::PathResponsePubSubType>> path_response;
    std::unique_ptr<core::Writer<msgs::GlobalPathPubSubType>> global_path;
    std::unique_ptr<core::Writer<msgs::LocalPlanPubSubType>> local_plan;
    std::unique_ptr<core::Writer<msgs::StaircaseDetectionPubSubType>> staircase;
    std::unique_ptr<core::Writer<msgs::PingPongPubSubType>> probe_reply;
  } writers_;
  static constexpr int kBulkShares[] = {1, 2, 3, 4, 6, 8, 12, 16};
  mutable std::mutex bulk_mutex_;  // guards bulk_: its writers are replaced by SetBulkShare
  // The bulk topics (map updates, camera frames) on the flow controller of this robot's share of the link.
  struct BulkWriters {
    std::unique_ptr<core::Writer<msgs::MapUpdatePubSubType>> map;
    std::unique_ptr<core::Writer<msgs::CompressedImagePubSubType>> camera;
    int share = 1;
    std::pair<std::uint64_t, std::uint64_t> retired_map{0, 0}, retired_camera{0, 0};  // (bytes, samples)
  } bulk_;
  mutable std::mutex team_mutex_;  // guards team_'s endpoints made on first use (see below)
  // The team topics: explore claims (made by the first Publish(ExploreClaim)), peer states (the reader made
  // by ListenToPeers()) and yield requests (the writer made by Send()).
  struct TeamEndpoints {
    std::unique_ptr<core::Writer<msgs::ExploreClaimPubSubType>> claim_writer;
    std::unique_ptr<core::Reader<msgs::ExploreClaimPubSubType>> claim_reader;
    std::unique_ptr<core::Reader<msgs::PeerStatePubSubType>> peer_reader;
    std::unique_ptr<core::Writer<msgs::PeerStatePubSubType>> peer_writer;
    std::unique_ptr<core::Writer<msgs::YieldRequestPubSubType>> yield_writer;
    std::unique_ptr<core::Reader<msgs::YieldRequestPubSubType>> yield_reader;
    // This robot's commanders' yield requests (cairn/yield_request/<robot>, DDS Security only).
    std::unique_ptr<core::Reader<msgs::YieldRequestPubSubType>> commander_yield_reader;
  } team_;
  std::unique_ptr<core::Reader<msgs::PingPongPubSubType>> probe_reader_;
  std::unique_ptr<core::Reader<msgs::MapSyncRequestPubSubType>> map_sync_reader_;
  std::unique_ptr<core::Reader<msgs::PathRequestPubSubType>> path_request_reader_;
  // The operators' command topics (MakeCommandReaders).
  struct CommandReaders {
    std::unique_ptr<core::Reader<msgs::ControlRequestPubSubType>> control;
    std::unique_ptr<core::Reader<msgs::ModeRequestPubSubType>> mode;
    std::unique_ptr<core::Reader<msgs::WaypointGoalPubSubType>> goal;
    std::unique_ptr<core::Reader<msgs::ExploreRequestPubSubType>> explore;
    std::unique_ptr<core::Reader<msgs::ConvoyRequestPubSubType>> convoy;
    std::unique_ptr<core::Reader<msgs::HomeRequestPubSubType>> home;
    std::unique_ptr<core::Reader<msgs::StopRequestPubSubType>> stop;
    std::unique_ptr<core::Reader<msgs::RestartRequestPubSubType>> restart;
    std::unique_ptr<core::Reader<msgs::TeleopTwistPubSubType>> teleop;
  } commands_;
  std::unique_ptr<core::Reader<msgs::AgentInfoPubSubType>> info_reader_;
};

AgentDds::AgentDds(const AgentDdsOptions& options) : impl_(std::make_unique<Impl>(options)) {}

void AgentDds::Listen(AgentDdsHandlers handlers) { impl_->MakeReaders(std::move(handlers)); }

AgentDds::~AgentDds() = default;
void AgentDds::StopListening() { impl_->StopListening(); }

std::vector<std::string> AgentDds::TakeGoneParticipants() {
  std::vector<std::string> gone;
  std::lock_guard<std::mutex> guard(impl_->gone_mutex_);
  gone.swap(impl_->gone_participants_);
  return gone;
}

void AgentDds::Send(const CommandReply& reply) {
  msgs::CommandResponse r;
  r.robot_id(impl_->options_.robot_id);
  r.base_id(reply.base_id);
  r.request_id(reply.request_id);
  r.kind(KindOf(reply.kind));
  r.result(ResultOf(reply.result));
  r.reason(reply.reason);
  r.holder_id(reply.holder_id);
  r.mode(reply.mode);
  r.requester_participant(reply.requester_participant);
  r.goal_id(reply.goal_id);
  r.valid_modes(reply.valid_modes);
  r.goal_acceptable(reply.goal_acceptable);
  impl_->writers_.response->Write(r);
}

void AgentDds::Send(const PathAnswer& answer) {
  msgs::PathResponse r;
  r.request_id(answer.request_id);
  r.requester_id(answer.requester_id);
  r.requester_participant(answer.requester_participant);
  r.robot_id(impl_->options_.robot_id);
  r.frame_id("map");
  r.success(answer.success);
  r.status(answer.status);
  r.reason(answer.reason);
  for (const Eigen::Vector3d& p : answer.path_M) {
    msgs::Point point;
    point.x_m(p.x());
    point.y_m(p.y());
    point.z_m(p.z());
    r.path_M().push_back(point);
  }
  r.length_m(answer.length_m);
  r.map_version(answer.map_version);
  r.planning_time_s(answer.planning_time_s);
  impl_->writers_.path_response->Write(r);
}

bool AgentDds::Publish(const msgs::AgentInfo& info) { return impl_->writers_.info->Write(info); }
bool AgentDds::Publish(const msgs::RobotState& state) { return impl_->writers_.state->Write(state); }
bool AgentDds::Publish(const msgs::AgentHealth& health) {
  msgs::AgentHealth m = health;
  const ForgedSenders forged = ForgedSendersSoFar();
  m.forged_senders(forged.count);
  m.last_forged_sender(forged.last);
  return impl_->writers_.health->Write(m);
}

ForgedSenders AgentDds::ForgedSendersSoFar() const {
  std::lock_guard<std::mutex> guard(impl_->senders_.forged_mutex);
  return impl_->senders_.forged;
}
bool AgentDds::Publish(const msgs::RobotPose& pose) { return impl_->writers_.pose->Write(pose); }
bool AgentDds::Publish(const msgs::BehaviorTreeState& tree) { return impl_->writers_.tree->Write(tree); }
bool AgentDds::Publish(const msgs::GlobalPath& path) { return impl_->writers_.global_path->Write(path); }
bool AgentDds::Publish(const msgs::LocalPlan& plan) { return impl_->writers_.local_plan->Write(plan); }
bool AgentDds::Publish(const msgs::MapUpdate& update) {
  std::lock_guard<std::mutex> guard(impl_->bulk_mutex_);
  return impl_->bulk_.map->Write(update);
}
bool AgentDds::Publish(const msgs::CompressedImage& image) {
  std::lock_guard<std::mutex> guard(impl_->bulk_mutex_);
  return impl_->bulk_.camera->Write(image);
}

int AgentDds::SetBulkShare(int robots) {
  if (!core::IsRadioLink(impl_->options_.link)) return 1;  // only a radio's controllers come in shares
  int share = Impl::kBulkShares[0];
  for (int s : Impl::kBulkShares) {
    share = s;
    if (s >= robots) break;
  }
  std::lock_guard<std::mutex> guard(impl_->bulk_mutex_);
  if (share != impl_->bulk_.share) impl_->MakeBulkWriters(share);
  return share;
}
bool AgentDds::Publish(const msgs::StaircaseDetection& staircase) {
  return impl_->writers_.staircase->Write(staircase);
}

bool AgentDds::Publish(const ExploreClaim& claim) {
  msgs::ExploreClaim m;
  m.robot_id(impl_->options_.robot_id);
  m.task_id(claim.task_id);
  m.active(claim.active);
  m.has_target(claim.has_target);
  m.target_x_m(claim.target_M.x());
  m.target_y_m(claim.target_M.y());
  m.target_z_m(claim.target_M.z());
  m.held_s(claim.held_s);
  m.lease_s(claim.lease_s);
  if (claim.coverage) {
    const nav::CoverageBitmap& b = *claim.coverage;
    m.coverage_cell_m(b.cell_m);
    m.coverage_origin_ix(b.origin_cell.x());
    m.coverage_origin_iy(b.origin_cell.y());
    m.coverage_nx(b.nx);
    m.coverage_ny(b.ny);
    m.coverage_zstd(CompressCoverageBits(b));
  }
  std::lock_guard<std::mutex> guard(impl_->team_mutex_);
  if (!impl_->listening_) throw std::logic_error("AgentDds::Publish(ExploreClaim) before Listen()");
  impl_->MakeTeamEndpoints();
  return impl_->team_.claim_writer->Write(m);
}

bool AgentDds::Publish(const msgs::PeerState& state) {
  // No reader anywhere (every robot idle): nothing to send, and nothing counted as sent on the link.
  if (impl_->team_.peer_writer->matched() == 0) return true;
  return impl_->team_.peer_writer->Write(state);
}

void AgentDds::ListenToPeers() {
  std::lock_guard<std::mutex> guard(impl_->team_mutex_);
  if (!impl_->listening_) throw std::logic_error("AgentDds::ListenToPeers() before Listen()");
  impl_->MakePeerReader();
}

bool AgentDds::Send(const std::string& robot_id, const YieldCommand& request) {
  std::lock_guard<std::mutex> guard(impl_->team_mutex_);
  if (!impl_->team_.yield_writer) {
    impl_->team_.yield_writer = std::make_unique<core::Writer<msgs::YieldRequestPubSubType>>(
        *impl_->participant_, "cairn/yield_request", "cairn.command");
  }
  msgs::YieldRequest m;
  m.robot_id(robot_id);
  m.sender_id(request.sender_id);
  m.request_id(request.request_id);
  m.action(msgs::YIELD_ACTION_ASK);
  m.passing_id(request.passing_id);
  m.passing_radius_m(static_cast<float>(request.passing_radius_m));
  for (const Eigen::Vector2d& p : request.keep_clear_M) {
    msgs::PeerPathPoint q;
    q.x_m(static_cast<float>(p.x()));
    q.y_m(static_cast<float>(p.y()));
    m.keep_clear_M().push_back(q);
  }
  return impl_->team_.yield_writer->Write(m);
}

YieldCommand YieldFromMessage(const msgs::YieldRequest& m, std::string* fault) {
  YieldCommand c;
  c.sender_id = m.sender_id();
  c.request_id = m.request_id();
  c.passing_id = m.passing_id();
  c.passing_radius_m = m.passing_radius_m();
  for (const msgs::PeerPathPoint& q : m.keep_clear_M()) c.keep_clear_M.emplace_back(q.x_m(), q.y_m());
  *fault = m.action() == msgs::YIELD_ACTION_ASK
               ? ""
               : "cairn/yield_request from " + m.sender_id().substr(0, 64) +
                     ": action = " + std::to_string(static_cast<int>(m.action())) + " is not ASK (0)";
  return c;
}

Peer PeerFromMessage(const msgs::PeerState& m) {
  Peer peer;
  peer.robot_id = m.robot_id();
  peer.pose_M.x_m = m.x_MB_m();
  peer.pose_M.y_m = m.y_MB_m();
  peer.pose_M.z_m = m.z_MB_m();
  peer.pose_M.yaw_rad = m.yaw_MB_rad();
  peer.pose_M.v_mps = m.v_B_mps();
  peer.pose_M.w_radps = m.w_B_radps();
  peer.footprint_radius_m = m.footprint_radius_m();
  peer.mode = m.mode();
  peer.path_ahead_M.reserve(m.path_ahead_M().size());
  for (const msgs::PeerPathPoint& p : m.path_ahead_M())
    peer.path_ahead_M.emplace_back(p.x_m(), p.y_m(), p.z_m());
  peer.yield_state = m.yield_state();
  peer.yield_to_id = m.yield_to_id();
  peer.yield_reason = m.yield_reason();
  return peer;
}

std::vector<SentTraffic> AgentDds::SentByClass() const {
  const Impl& i = *impl_;
  auto sum = [](const char* topic_class,
                std::initializer_list<std::pair<std::uint64_t, std::uint64_t>> writers) {
    SentTraffic t{topic_class, 0, 0};
    for (const auto& [bytes, samples] : writers) {
      t.bytes += bytes;
      t.samples += samples;
    }
    return t;
  };
  auto of = [](const auto& writer) {
    return std::make_pair(writer->bytes_written(), writer->samples_written());
  };
  std::lock_guard<std::mutex> guard(i.bulk_mutex_);
  const auto& w = i.writers_;
  return {
      sum("command", {of(w.response), of(w.path_response), of(w.probe_reply)}),
      sum("state", {of(w.state), of(w.pose), of(w.local_plan), of(w.info), of(w.staircase), of(w.health)}),
      sum("tree", {of(w.tree), of(w.global_path)}),
      sum("team", {i.TeamSent()}),
      sum("map", {of(i.bulk_.map), i.bulk_.retired_map}),
      sum("camera", {of(i.bulk_.camera), i.bulk_.retired_camera})};
}

int AgentDds::RobotsOnLink() const {
  int robots = 1;
  std::lock_guard<std::mutex> guard(impl_->senders_.robots_heard_mutex);
  for (const auto& [writer, heard] : impl_->senders_.robots_heard_by_base) {
    if (heard.second) robots = std::max(robots, heard.first);
  }
  return robots;
}

void AgentDds::WaitForMapDelivery(std::chrono::milliseconds timeout) {
  std::lock_guard<std::mutex> guard(impl_->bulk_mutex_);
  impl_->bulk_.map->WaitForAcknowledgments(timeout);
}

}  // namespace cairn::agent
