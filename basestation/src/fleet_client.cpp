#include "cairn/base/fleet_client.h"

#include <algorithm>
#include <cmath>
#include <regex>

#include "cairn/core/dds.h"
#include "cairn/msgs/stamp.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::base {

namespace msgs = cairn_msgs;
using core::SteadyClock;

namespace {

const char* ResultName(msgs::CommandResult result) {
  switch (result) {
    case msgs::COMMAND_RESULT_ACCEPTED:
      return "accepted";
    case msgs::COMMAND_RESULT_DENIED:
      return "denied";
    case msgs::COMMAND_RESULT_DISCARDED:
      return "discarded";
  }
  return "error";
}

// Identifies one command to one robot, to match its acknowledgement.
std::string ResponseKey(const std::string& robot_id, msgs::CommandKind kind, uint32_t request_id) {
  return robot_id + "/" + std::to_string(kind) + "/" + std::to_string(request_id);
}

}  // namespace

class FleetClient::Impl {
 public:
  explicit Impl(const FleetClientOptions& options) : options_(options) {
    static const std::regex kIdPattern("[A-Za-z0-9_-]{1,64}");
    if (!std::regex_match(options.base_id, kIdPattern)) {
      throw std::invalid_argument("--base-id '" + options.base_id + "' must be 1-64 characters of A-Z a-z 0-9 _ -");
    }
    core::ParticipantOptions p;
    p.domain_id = options.domain_id;
    if (!options.dds_profiles_file.empty()) p.profiles_file = options.dds_profiles_file;
    p.name = "cairn_base/" + options.base_id;
    participant_ = std::make_unique<core::Participant>(p);
    participant_id_ = participant_->participant_id();
    info_writer_ =
        std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(*participant_, "cairn/agent_info", "cairn.latched");
    perception_ = std::make_unique<FleetPerception>(*participant_, options.base_id);
    control_writer_ = std::make_unique<core::Writer<msgs::ControlRequestPubSubType>>(
        *participant_, "cairn/control_request", "cairn.command");
    mode_writer_ = std::make_unique<core::Writer<msgs::ModeRequestPubSubType>>(*participant_, "cairn/mode_request",
                                                                              "cairn.command");
    goal_writer_ = std::make_unique<core::Writer<msgs::WaypointGoalPubSubType>>(
        *participant_, "cairn/waypoint_goal", "cairn.command");
    stop_writer_ = std::make_unique<core::Writer<msgs::StopRequestPubSubType>>(*participant_, "cairn/stop_request",
                                                                              "cairn.command");
    teleop_writer_ =
        std::make_unique<core::Writer<msgs::TeleopTwistPubSubType>>(*participant_, "cairn/teleop", "cairn.teleop");
    response_reader_ = std::make_unique<core::Reader<msgs::CommandResponsePubSubType>>(
        *participant_, "cairn/command_response", "cairn.command",
        [this](const msgs::CommandResponse& m, const auto&) { OnResponse(m); });
    state_reader_ = std::make_unique<core::Reader<msgs::RobotStatePubSubType>>(
        *participant_, "cairn/robot_state", "cairn.state", [this](const msgs::RobotState& m, const auto&) {
          Update(m.robot_id(), [&](RobotView& v) {
            v.state = m;
            v.platform = m.platform();
          });
        });
    path_request_writer_ = std::make_unique<core::Writer<msgs::PathRequestPubSubType>>(
        *participant_, "cairn/path_request", "cairn.command");
    path_response_reader_ = std::make_unique<core::Reader<msgs::PathResponsePubSubType>>(
        *participant_, "cairn/path_response", "cairn.command", [this](const msgs::PathResponse& m, const auto&) {
          // Answers to another process with this base id (same request ids) are not ours.
          if (m.requester_id() != options_.base_id || m.requester_participant() != participant_id_) return;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            path_responses_[m.request_id()] = m;
          }
          cv_.notify_all();
        });
    global_path_reader_ = std::make_unique<core::Reader<msgs::GlobalPathPubSubType>>(
        *participant_, "cairn/global_path", "cairn.latched",
        [this](const msgs::GlobalPath& m, const auto&) { Update(m.robot_id(), [&](RobotView& v) { v.global_path = m; }); });
    local_plan_reader_ = std::make_unique<core::Reader<msgs::LocalPlanPubSubType>>(
        *participant_, "cairn/local_plan", "cairn.state",
        [this](const msgs::LocalPlan& m, const auto&) { Update(m.robot_id(), [&](RobotView& v) { v.local_plan = m; }); });
    tree_reader_ = std::make_unique<core::Reader<msgs::BehaviorTreeStatePubSubType>>(
        *participant_, "cairn/bt_state", "cairn.latched",
        [this](const msgs::BehaviorTreeState& m, const auto&) {
          Update(m.robot_id(), [&](RobotView& v) { v.tree = m; });
        });
    info_reader_ = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
        *participant_, "cairn/agent_info", "cairn.latched",
        [this](const msgs::AgentInfo& m, const eprosima::fastdds::dds::SampleInfo& info) {
          if (m.kind() != msgs::AGENT_KIND_ROBOT) return;
          {
            std::lock_guard<std::mutex> lock(mutex_);
            robot_by_writer_[info.publication_handle] = m.agent_id();
            current_writer_[m.agent_id()] = info.publication_handle;
          }
          Update(m.agent_id(), [&](RobotView& v) {
            v.platform = m.platform();
            v.capabilities = m.capabilities();
          });
          perception_->OnRobotSeen(m.agent_id());
        },
        [this](const eprosima::fastdds::dds::LivelinessChangedStatus& status) { OnLiveliness(status); });

    msgs::AgentInfo info;
    info.agent_id(options.base_id);
    info.kind(msgs::AGENT_KIND_BASESTATION);
    info.platform("basestation");
    info.capabilities(options.capabilities);
    info.version("0.1.0");
    info.stamp(cairn::msgs::WallStampNow());
    info_writer_->Write(info);
  }

  ~Impl() {
    response_reader_.reset();
    path_response_reader_.reset();
    global_path_reader_.reset();
    local_plan_reader_.reset();
    state_reader_.reset();
    tree_reader_.reset();
    info_reader_.reset();
    perception_.reset();  // after info_reader_, whose callback uses it
  }

  // Applies `change` to the view of `robot_id` (creating it), marks it seen and wakes waiters.
  void Update(const std::string& robot_id, const std::function<void(RobotView&)>& change) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      RobotView& v = robots_[robot_id];
      v.robot_id = robot_id;
      change(v);
      v.last_seen = SteadyClock::now();
      v.lost = false;
      v.lost_reason.clear();
    }
    cv_.notify_all();
  }

  void OnLiveliness(const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
    if (!core::IsLivelinessLoss(status)) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      auto it = robot_by_writer_.find(status.last_publication_handle);
      if (it == robot_by_writer_.end()) return;
      const std::string robot_id = it->second;
      if (status.not_alive_count_change == 0) robot_by_writer_.erase(it);  // unmatched: that process is gone
      // An old process of a robot that has restarted (a new writer announces its id) does not make it lost.
      auto current = current_writer_.find(robot_id);
      if (current == current_writer_.end() || !(current->second == status.last_publication_handle)) return;
      auto robot = robots_.find(robot_id);
      if (robot == robots_.end()) return;
      robot->second.lost = true;
      robot->second.lost_reason = "liveliness lost";
    }
    cv_.notify_all();
  }

  void OnResponse(const msgs::CommandResponse& m) {
    // Replies to another process with this base id (it numbers its requests from 1 too) are not ours.
    if (m.base_id() != options_.base_id || m.requester_participant() != participant_id_) return;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      responses_[ResponseKey(m.robot_id(), m.kind(), m.request_id())] = m;
    }
    cv_.notify_all();
  }

  // Applies staleness to a copy of a view.
  RobotView WithStaleness(RobotView v, core::SteadyTime now) const {
    if (!v.lost && v.state && core::SecondsBetween(v.last_seen, now) > options_.lost_after_s) {
      v.lost = true;
      v.lost_reason = "no state for " + std::to_string(static_cast<int>(core::SecondsBetween(v.last_seen, now))) + " s";
    }
    return v;
  }

  // Sends with `send(request_id)` every command_retry_s until `answered()` holds (checked under mutex_) or
  // command_timeout_s passes. Returns false on timeout (and sets *reason). The lock is held on return.
  bool SendUntil(const std::string& robot_id, uint32_t request_id, const std::function<bool(uint32_t)>& send,
                 const std::function<bool()>& answered, std::unique_lock<std::mutex>* lock, std::string* reason) {
    const auto deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                   std::chrono::duration<double>(options_.command_timeout_s));
    const auto retry = std::chrono::duration_cast<SteadyClock::duration>(
        std::chrono::duration<double>(options_.command_retry_s));
    while (true) {
      lock->unlock();
      send(request_id);
      lock->lock();
      const auto resend_at = std::min(deadline, SteadyClock::now() + retry);
      if (cv_.wait_until(*lock, resend_at, answered)) return true;
      if (SteadyClock::now() >= deadline) {
        *reason = "robot " + robot_id + " did not acknowledge within " +
                  std::to_string(options_.command_timeout_s).substr(0, 4) + " s";
        return false;
      }
    }
  }

  // Sends a command until the robot answers or the timeout passes (robots de-duplicate).
  CommandOutcome Call(const std::string& robot_id, msgs::CommandKind kind,
                      const std::function<bool(uint32_t)>& send) {
    CommandOutcome outcome;
    outcome.request_id = next_request_id_++;
    if (!WaitForRobot(robot_id, options_.command_timeout_s)) {
      outcome.result = "error";
      outcome.reason = UnknownRobotReason(robot_id);
      return outcome;
    }
    const std::string key = ResponseKey(robot_id, kind, outcome.request_id);
    const auto start = SteadyClock::now();
    std::unique_lock<std::mutex> lock(mutex_);
    if (!SendUntil(robot_id, outcome.request_id, send, [&] { return responses_.count(key) > 0; }, &lock,
                   &outcome.reason)) {
      outcome.result = "timeout";
      return outcome;
    }
    const msgs::CommandResponse r = responses_[key];
    responses_.erase(key);
    outcome.round_trip_ms = std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
    outcome.ok = r.result() == msgs::COMMAND_RESULT_ACCEPTED;
    outcome.result = ResultName(r.result());
    outcome.reason = r.reason();
    outcome.holder_id = r.holder_id();
    outcome.mode = r.mode();
    outcome.goal_id = r.goal_id();
    return outcome;
  }

  bool WaitForRobot(const std::string& robot_id, double timeout_s) const {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [&] {
      auto it = robots_.find(robot_id);
      return it != robots_.end() && !WithStaleness(it->second, SteadyClock::now()).lost;
    });
  }

  std::string UnknownRobotReason(const std::string& robot_id) const {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = robots_.find(robot_id);
    if (it != robots_.end()) {
      return "robot " + robot_id + " is lost (" + WithStaleness(it->second, SteadyClock::now()).lost_reason + ")";
    }
    std::string known;
    for (const auto& [id, view] : robots_) known += (known.empty() ? "" : ", ") + id;
    return "unknown robot '" + robot_id + "' (known: " + (known.empty() ? "none" : known) + ")";
  }

  FleetClientOptions options_;
  std::string participant_id_;
  mutable std::mutex mutex_;
  mutable std::condition_variable cv_;
  std::map<std::string, RobotView> robots_;
  std::map<eprosima::fastrtps::rtps::InstanceHandle_t, std::string> robot_by_writer_;
  std::map<std::string, eprosima::fastrtps::rtps::InstanceHandle_t> current_writer_;  // newest agent-info writer
  std::map<std::string, msgs::CommandResponse> responses_;
  std::map<uint32_t, msgs::PathResponse> path_responses_;
  std::atomic<uint32_t> next_request_id_{1};
  std::atomic<uint64_t> teleop_sequence_{0};

  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Writer<msgs::AgentInfoPubSubType>> info_writer_;
  std::unique_ptr<FleetPerception> perception_;
  std::unique_ptr<core::Writer<msgs::ControlRequestPubSubType>> control_writer_;
  std::unique_ptr<core::Writer<msgs::ModeRequestPubSubType>> mode_writer_;
  std::unique_ptr<core::Writer<msgs::WaypointGoalPubSubType>> goal_writer_;
  std::unique_ptr<core::Writer<msgs::StopRequestPubSubType>> stop_writer_;
  std::unique_ptr<core::Writer<msgs::TeleopTwistPubSubType>> teleop_writer_;
  std::unique_ptr<core::Writer<msgs::PathRequestPubSubType>> path_request_writer_;
  std::unique_ptr<core::Reader<msgs::CommandResponsePubSubType>> response_reader_;
  std::unique_ptr<core::Reader<msgs::PathResponsePubSubType>> path_response_reader_;
  std::unique_ptr<core::Reader<msgs::GlobalPathPubSubType>> global_path_reader_;
  std::unique_ptr<core::Reader<msgs::LocalPlanPubSubType>> local_plan_reader_;
  std::unique_ptr<core::Reader<msgs::RobotStatePubSubType>> state_reader_;
  std::unique_ptr<core::Reader<msgs::BehaviorTreeStatePubSubType>> tree_reader_;
  std::unique_ptr<core::Reader<msgs::AgentInfoPubSubType>> info_reader_;
};

FleetClient::FleetClient(const FleetClientOptions& options) : impl_(std::make_unique<Impl>(options)) {}
FleetClient::~FleetClient() = default;

const std::string& FleetClient::base_id() const { return impl_->options_.base_id; }

const std::string& FleetClient::participant_id() const { return impl_->participant_id_; }

FleetPerception& FleetClient::perception() { return *impl_->perception_; }

std::vector<RobotView> FleetClient::Robots() const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  std::vector<RobotView> views;
  const auto now = SteadyClock::now();
  for (const auto& [id, view] : impl_->robots_) views.push_back(impl_->WithStaleness(view, now));
  return views;
}

std::optional<RobotView> FleetClient::Robot(const std::string& robot_id) const {
  std::lock_guard<std::mutex> lock(impl_->mutex_);
  auto it = impl_->robots_.find(robot_id);
  if (it == impl_->robots_.end()) return std::nullopt;
  return impl_->WithStaleness(it->second, SteadyClock::now());
}

bool FleetClient::WaitForRobot(const std::string& robot_id, double timeout_s) const {
  return impl_->WaitForRobot(robot_id, timeout_s);
}

std::optional<RobotView> FleetClient::WaitUntil(const std::string& robot_id, double timeout_s,
                                                const std::function<bool(const RobotView&)>& predicate) const {
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  const auto deadline =
      SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(timeout_s));
  std::optional<RobotView> match;
  auto check = [&] {
    auto it = impl_->robots_.find(robot_id);
    if (it == impl_->robots_.end()) return false;
    RobotView v = impl_->WithStaleness(it->second, SteadyClock::now());
    if (!predicate(v)) return false;
    match = std::move(v);
    return true;
  };
  // Staleness changes without an update, so re-check at least every 100 ms.
  while (!check()) {
    if (SteadyClock::now() >= deadline) return std::nullopt;
    impl_->cv_.wait_until(lock, std::min(deadline, SteadyClock::now() + std::chrono::milliseconds(100)));
  }
  return match;
}

CommandOutcome FleetClient::RequestControl(const std::string& robot_id) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_CONTROL_REQUEST, [&](uint32_t id) {
    msgs::ControlRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.action(msgs::CONTROL_ACTION_REQUEST);
    return impl_->control_writer_->Write(m);
  });
}

CommandOutcome FleetClient::ReleaseControl(const std::string& robot_id) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_CONTROL_RELEASE, [&](uint32_t id) {
    msgs::ControlRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.action(msgs::CONTROL_ACTION_RELEASE);
    return impl_->control_writer_->Write(m);
  });
}

CommandOutcome FleetClient::RequestMode(const std::string& robot_id, const std::string& mode) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_MODE, [&](uint32_t id) {
    msgs::ModeRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.mode(mode);
    return impl_->mode_writer_->Write(m);
  });
}

CommandOutcome FleetClient::SendWaypoint(const std::string& robot_id, double x_m, double y_m, double tolerance_m) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_WAYPOINT, [&](uint32_t id) {
    msgs::WaypointGoal m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    m.frame_id("map");
    m.x_m(x_m);
    m.y_m(y_m);
    m.tolerance_m(tolerance_m);
    return impl_->goal_writer_->Write(m);
  });
}

CommandOutcome FleetClient::Stop(const std::string& robot_id) {
  return impl_->Call(robot_id, msgs::COMMAND_KIND_STOP, [&](uint32_t id) {
    msgs::StopRequest m;
    m.robot_id(robot_id);
    m.base_id(base_id());
    m.request_id(id);
    return impl_->stop_writer_->Write(m);
  });
}

bool FleetClient::PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                                double linear_y_mps) {
  msgs::TeleopTwist m;
  m.robot_id(robot_id);
  m.base_id(base_id());
  m.sequence_number(++impl_->teleop_sequence_);
  m.stamp(cairn::msgs::WallStampNow());
  m.twist().linear_x_mps(linear_x_mps);
  m.twist().linear_y_mps(linear_y_mps);
  m.twist().angular_z_radps(angular_z_radps);
  return impl_->teleop_writer_->Write(m);
}

PathAnswer FleetClient::RequestPath(const std::string& robot_id, const std::string& platform, double start_x_m,
                                    double start_y_m, double goal_x_m, double goal_y_m) {
  PathAnswer answer;
  const uint32_t request_id = impl_->next_request_id_++;
  if (!impl_->WaitForRobot(robot_id, impl_->options_.command_timeout_s)) {
    answer.result = "error";
    answer.reason = impl_->UnknownRobotReason(robot_id);
    return answer;
  }
  const auto start = SteadyClock::now();
  std::unique_lock<std::mutex> lock(impl_->mutex_);
  auto send = [&](uint32_t id) {
    msgs::PathRequest m;
    m.request_id(id);
    m.requester_id(base_id());
    m.robot_id(robot_id);
    m.platform(platform);
    m.frame_id("map");
    m.start_M().x_m(start_x_m);
    m.start_M().y_m(start_y_m);
    m.goal_M().x_m(goal_x_m);
    m.goal_M().y_m(goal_y_m);
    return impl_->path_request_writer_->Write(m);
  };
  if (!impl_->SendUntil(robot_id, request_id, send, [&] { return impl_->path_responses_.count(request_id) > 0; },
                        &lock, &answer.reason)) {
    answer.result = "timeout";
    return answer;
  }
  answer.response = impl_->path_responses_[request_id];
  impl_->path_responses_.erase(request_id);
  answer.round_trip_ms = std::chrono::duration<double, std::milli>(SteadyClock::now() - start).count();
  answer.ok = answer.response.success();
  answer.result = answer.ok ? "path" : "refused";
  answer.reason = answer.response.reason();
  return answer;
}

}  // namespace cairn::base
