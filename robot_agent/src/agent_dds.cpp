#include "cairn/agent/agent_dds.h"

#include <algorithm>
#include <mutex>
#include <stdexcept>

#include "cairn/core/dds.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::agent {

namespace msgs = cairn_msgs;
using SampleInfo = eprosima::fastdds::dds::SampleInfo;

namespace {

CommandSender SenderOf(const std::string& base_id, const SampleInfo& info) {
  return CommandSender{base_id, core::ParticipantIdOf(info.publication_handle),
                       core::WriterIdOf(info.publication_handle)};
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

AgentDdsHandlers Checked(AgentDdsHandlers h) {
  if (!h.control || !h.mode || !h.goal || !h.stop || !h.teleop || !h.base_announced || !h.base_liveliness ||
      !h.path_query || !h.map_sync) {
    throw std::invalid_argument("AgentDds: every handler is required");
  }
  return h;
}

}  // namespace

class AgentDds::Impl {
 public:
  explicit Impl(const AgentDdsOptions& options) : options_(options) {
    core::ParticipantOptions p;
    p.domain_id = options.domain_id;
    if (!options.profiles_file.empty()) p.profiles_file = options.profiles_file;
    p.link = options.link;
    p.name = "cairn_agent/" + options.robot_id;
    p.on_participant_gone = [this](const std::string& participant) {
      std::lock_guard<std::mutex> guard(gone_mutex_);
      gone_participants_.push_back(participant);
    };
    p.flow_controllers = {{"cairn.map", options.map_budget_bits_per_s, 100},
                          {"cairn.camera", options.camera_budget_bits_per_s, 100}};
    participant_ = std::make_unique<core::Participant>(p);
    MakeWriters();
  }

  ~Impl() {
    // Readers first so that no callback runs while the rest is torn down.
    map_sync_reader_.reset();
    path_request_reader_.reset();
    control_reader_.reset();
    mode_reader_.reset();
    goal_reader_.reset();
    stop_reader_.reset();
    teleop_reader_.reset();
    info_reader_.reset();
  }

  void MakeWriters() {
    core::Participant& p = *participant_;
    info_writer_ =
        std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(p, "cairn/agent_info", "cairn.latched");
    state_writer_ =
        std::make_unique<core::Writer<msgs::RobotStatePubSubType>>(p, "cairn/robot_state", "cairn.state");
    tree_writer_ = std::make_unique<core::Writer<msgs::BehaviorTreeStatePubSubType>>(p, "cairn/bt_state",
                                                                                     "cairn.latched");
    response_writer_ = std::make_unique<core::Writer<msgs::CommandResponsePubSubType>>(
        p, "cairn/command_response", "cairn.command");
    path_response_writer_ = std::make_unique<core::Writer<msgs::PathResponsePubSubType>>(
        p, "cairn/path_response", "cairn.command");
    global_path_writer_ =
        std::make_unique<core::Writer<msgs::GlobalPathPubSubType>>(p, "cairn/global_path", "cairn.latched");
    local_plan_writer_ =
        std::make_unique<core::Writer<msgs::LocalPlanPubSubType>>(p, "cairn/local_plan", "cairn.state");
    map_writer_ = std::make_unique<core::Writer<msgs::MapUpdatePubSubType>>(p, "cairn/map_update",
                                                                            "cairn.map", "cairn.map");
    camera_writer_ = std::make_unique<core::Writer<msgs::CompressedImagePubSubType>>(
        p, "cairn/camera", "cairn.camera", "cairn.camera");
    staircase_writer_ = std::make_unique<core::Writer<msgs::StaircaseDetectionPubSubType>>(
        p, "cairn/staircase", "cairn.latched");
  }

  // Each reader keeps only what is addressed to this robot and hands it on as a plain struct.
  void MakeReaders(AgentDdsHandlers handlers) {
    if (listening_) throw std::logic_error("AgentDds::Listen called twice");
    handlers_ = Checked(std::move(handlers));
    listening_ = true;
    core::Participant& p = *participant_;
    const std::string& robot = options_.robot_id;
    map_sync_reader_ = std::make_unique<core::Reader<msgs::MapSyncRequestPubSubType>>(
        p, "cairn/map_sync_request", "cairn.command",
        [this, robot](const msgs::MapSyncRequest& m, const auto&) {
          if (m.robot_id() == robot) handlers_.map_sync(m.requester_id());
        });
    path_request_reader_ = std::make_unique<core::Reader<msgs::PathRequestPubSubType>>(
        p, "cairn/path_request", "cairn.command",
        [this, robot](const msgs::PathRequest& m, const SampleInfo& info) {
          if (m.robot_id() != robot) return;
          handlers_.path_query(PathQuery{core::ParticipantIdOf(info.publication_handle),
                                         m.request_id(),
                                         m.requester_id(),
                                         m.frame_id(),
                                         {m.start_M().x_m(), m.start_M().y_m()},
                                         {m.goal_M().x_m(), m.goal_M().y_m()},
                                         m.platform()});
        });
    info_reader_ = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
        p, "cairn/agent_info", "cairn.latched",
        [this](const msgs::AgentInfo& m, const SampleInfo& info) {
          if (m.kind() != msgs::AGENT_KIND_BASESTATION) return;
          const auto& caps = m.capabilities();
          handlers_.base_announced(BaseAnnouncement{
              core::WriterIdOf(info.publication_handle), core::ParticipantIdOf(info.publication_handle),
              m.agent_id(), std::find(caps.begin(), caps.end(), "joystick") != caps.end()});
        },
        [this](const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
          WriterLiveliness change;
          change.writer = core::WriterIdOf(status.last_publication_handle);
          // Unmatched (gone for good): alive -1 while alive, or not_alive -1 after its lease lapsed.
          change.unmatched = (status.alive_count_change < 0 && status.not_alive_count_change == 0) ||
                             (status.alive_count_change == 0 && status.not_alive_count_change < 0);
          change.lost = core::IsLivelinessLoss(status);
          change.regained = status.alive_count_change > 0;
          handlers_.base_liveliness(change);
        });
    control_reader_ = std::make_unique<core::Reader<msgs::ControlRequestPubSubType>>(
        p, "cairn/control_request", "cairn.command",
        [this, robot](const msgs::ControlRequest& m, const SampleInfo& info) {
          if (m.robot_id() != robot) return;
          handlers_.control(ControlCommand{SenderOf(m.base_id(), info), m.request_id(),
                                           m.action() == msgs::CONTROL_ACTION_RELEASE});
        });
    mode_reader_ = std::make_unique<core::Reader<msgs::ModeRequestPubSubType>>(
        p, "cairn/mode_request", "cairn.command",
        [this, robot](const msgs::ModeRequest& m, const SampleInfo& info) {
          if (m.robot_id() != robot) return;
          handlers_.mode(ModeCommand{SenderOf(m.base_id(), info), m.request_id(), m.mode()});
        });
    goal_reader_ = std::make_unique<core::Reader<msgs::WaypointGoalPubSubType>>(
        p, "cairn/waypoint_goal", "cairn.command",
        [this, robot](const msgs::WaypointGoal& m, const SampleInfo& info) {
          if (m.robot_id() != robot) return;
          handlers_.goal(GoalCommand{SenderOf(m.base_id(), info), m.request_id(), m.frame_id(), m.x_m(),
                                     m.y_m(), m.tolerance_m(), m.z_m()});
        });
    stop_reader_ = std::make_unique<core::Reader<msgs::StopRequestPubSubType>>(
        p, "cairn/stop_request", "cairn.command",
        [this, robot](const msgs::StopRequest& m, const SampleInfo& info) {
          if (m.robot_id() != robot) return;
          handlers_.stop(StopCommand{SenderOf(m.base_id(), info), m.request_id()});
        });
    teleop_reader_ = std::make_unique<core::Reader<msgs::TeleopTwistPubSubType>>(
        p, "cairn/teleop", "cairn.teleop", [this, robot](const msgs::TeleopTwist& m, const SampleInfo&) {
          if (m.robot_id() != robot) return;
          const msgs::Twist& t = m.twist();
          handlers_.teleop(TeleopCommand{
              m.base_id(), OperatorTwist{t.linear_x_mps(), t.linear_y_mps(), t.angular_z_radps()}});
        });
  }

  AgentDdsOptions options_;
  AgentDdsHandlers handlers_;
  bool listening_ = false;
  std::mutex gone_mutex_;  // guards gone_participants_ only (taken on a DDS thread)
  std::vector<std::string>
      gone_participants_;  // reported by participant discovery, taken by the control loop
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Writer<msgs::AgentInfoPubSubType>> info_writer_;
  std::unique_ptr<core::Writer<msgs::RobotStatePubSubType>> state_writer_;
  std::unique_ptr<core::Writer<msgs::BehaviorTreeStatePubSubType>> tree_writer_;
  std::unique_ptr<core::Writer<msgs::CommandResponsePubSubType>> response_writer_;
  std::unique_ptr<core::Writer<msgs::PathResponsePubSubType>> path_response_writer_;
  std::unique_ptr<core::Writer<msgs::GlobalPathPubSubType>> global_path_writer_;
  std::unique_ptr<core::Writer<msgs::LocalPlanPubSubType>> local_plan_writer_;
  std::unique_ptr<core::Writer<msgs::MapUpdatePubSubType>> map_writer_;
  std::unique_ptr<core::Writer<msgs::CompressedImagePubSubType>> camera_writer_;
  std::unique_ptr<core::Writer<msgs::StaircaseDetectionPubSubType>> staircase_writer_;
  std::unique_ptr<core::Reader<msgs::MapSyncRequestPubSubType>> map_sync_reader_;
  std::unique_ptr<core::Reader<msgs::PathRequestPubSubType>> path_request_reader_;
  std::unique_ptr<core::Reader<msgs::ControlRequestPubSubType>> control_reader_;
  std::unique_ptr<core::Reader<msgs::ModeRequestPubSubType>> mode_reader_;
  std::unique_ptr<core::Reader<msgs::WaypointGoalPubSubType>> goal_reader_;
  std::unique_ptr<core::Reader<msgs::StopRequestPubSubType>> stop_reader_;
  std::unique_ptr<core::Reader<msgs::TeleopTwistPubSubType>> teleop_reader_;
  std::unique_ptr<core::Reader<msgs::AgentInfoPubSubType>> info_reader_;
};

AgentDds::AgentDds(const AgentDdsOptions& options) : impl_(std::make_unique<Impl>(options)) {}

void AgentDds::Listen(AgentDdsHandlers handlers) { impl_->MakeReaders(std::move(handlers)); }

AgentDds::~AgentDds() = default;

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
  impl_->response_writer_->Write(r);
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
  impl_->path_response_writer_->Write(r);
}

bool AgentDds::Publish(const msgs::AgentInfo& info) { return impl_->info_writer_->Write(info); }
bool AgentDds::Publish(const msgs::RobotState& state) { return impl_->state_writer_->Write(state); }
bool AgentDds::Publish(const msgs::BehaviorTreeState& tree) { return impl_->tree_writer_->Write(tree); }
bool AgentDds::Publish(const msgs::GlobalPath& path) { return impl_->global_path_writer_->Write(path); }
bool AgentDds::Publish(const msgs::LocalPlan& plan) { return impl_->local_plan_writer_->Write(plan); }
bool AgentDds::Publish(const msgs::MapUpdate& update) { return impl_->map_writer_->Write(update); }
bool AgentDds::Publish(const msgs::CompressedImage& image) { return impl_->camera_writer_->Write(image); }
bool AgentDds::Publish(const msgs::StaircaseDetection& staircase) {
  return impl_->staircase_writer_->Write(staircase);
}

void AgentDds::WaitForMapDelivery(std::chrono::milliseconds timeout) {
  const auto ms = timeout.count();
  impl_->map_writer_->get()->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(
      static_cast<int32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000000)));
}

}  // namespace cairn::agent
