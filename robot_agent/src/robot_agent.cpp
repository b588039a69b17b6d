#include "cairn/agent/robot_agent.h"

#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <thread>

#include <spdlog/spdlog.h>

#include "cairn/agent/control_lock.h"
#include "cairn/agent/mode_manager.h"
#include "cairn/agent/twist_mux.h"
#include "cairn/core/dds.h"
#include "cairn/core/shutdown.h"
#include "cairn/msgs/stamp.h"
#include "cairn/nav/astar.h"
#include "cairn/nav/path_tracker.h"
#include "cairn/nav/sampling.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/unicycle.h"
#include "cairn/sim/world.h"
#include "cairn_msgsPubSubTypes.h"

#ifndef CAIRN_CONFIG_DIR
#error "CAIRN_CONFIG_DIR must be defined by the build"
#endif

namespace cairn::agent {

namespace msgs = cairn_msgs;
using core::SteadyClock;
using core::SteadyTime;

namespace {

constexpr double kLoopPeriodS = 0.02;  // 50 Hz: mux staleness is acted on within 20 ms
constexpr const char* kVersion = "0.1.0";
constexpr std::size_t kResponseCacheSize = 256;

std::string Format(const char* fmt, double a, double b) {
  char text[128];
  std::snprintf(text, sizeof(text), fmt, a, b);
  return text;
}

}  // namespace

class RobotAgent::Impl {
 public:
  explicit Impl(const AgentOptions& options);
  ~Impl();
  void Run();

 private:
  // Waypoint goal being driven.
  struct Goal {
    uint32_t request_id = 0;
    double x_m = 0, y_m = 0, tolerance_m = 0;
    double best_distance_m = 0;
    SteadyTime best_time{};
    SteadyTime contact_since{};
    bool in_contact = false;
  };

  // DDS callbacks (listener threads); each takes mutex_.
  void OnControlRequest(const msgs::ControlRequest& msg);
  void OnModeRequest(const msgs::ModeRequest& msg);
  void OnWaypointGoal(const msgs::WaypointGoal& msg);
  void OnTeleop(const msgs::TeleopTwist& msg);
  void OnAgentInfo(const msgs::AgentInfo& msg, const eprosima::fastdds::dds::SampleInfo& info);
  void OnAgentLiveliness(const eprosima::fastdds::dds::LivelinessChangedStatus& status);

  // All below run with mutex_ held.
  bool ReplayIfDuplicate(const std::string& base_id, msgs::CommandKind kind, uint32_t request_id);
  void Respond(const std::string& base_id, uint32_t request_id, msgs::CommandKind kind, msgs::CommandResult result,
               const std::string& reason);
  ModeConditions Conditions() const;
  void ApplyMode(const ModeDecision& decision);
  void FinishGoal(msgs::NavStatus status, const std::string& reason);
  void Step(SteadyTime now);
  void PublishState(SteadyTime now);
  void PublishTreeStateIfChanged();

  AgentOptions options_;
  sim::World world_;
  std::unique_ptr<nav::TraversabilityGrid> grid_;
  sim::Unicycle platform_;
  ControlLock lock_;
  TwistMux mux_;
  ModeManager modes_;
  nav::PathTracker tracker_;
  std::optional<Goal> goal_;
  msgs::NavStatus nav_status_ = msgs::NAV_STATUS_NONE;
  std::string nav_reason_;
  uint32_t nav_goal_id_ = 0;
  double nav_goal_x_m_ = 0, nav_goal_y_m_ = 0, nav_distance_left_m_ = 0;
  bool in_contact_ = false;
  MuxOutput last_mux_;
  std::map<eprosima::fastrtps::rtps::InstanceHandle_t, std::string> base_by_writer_;
  std::deque<std::pair<std::string, msgs::CommandResponse>> responses_;
  std::string last_tree_signature_;

  std::mutex mutex_;
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Writer<msgs::AgentInfoPubSubType>> info_writer_;
  std::unique_ptr<core::Writer<msgs::RobotStatePubSubType>> state_writer_;
  std::unique_ptr<core::Writer<msgs::BehaviorTreeStatePubSubType>> tree_writer_;
  std::unique_ptr<core::Writer<msgs::CommandResponsePubSubType>> response_writer_;
  std::unique_ptr<core::Reader<msgs::ControlRequestPubSubType>> control_reader_;
  std::unique_ptr<core::Reader<msgs::ModeRequestPubSubType>> mode_reader_;
  std::unique_ptr<core::Reader<msgs::WaypointGoalPubSubType>> goal_reader_;
  std::unique_ptr<core::Reader<msgs::TeleopTwistPubSubType>> teleop_reader_;
  std::unique_ptr<core::Reader<msgs::AgentInfoPubSubType>> info_reader_;
};

namespace {

nav::TraversabilityOptions TraversabilityFrom(const AgentOptions& o) {
  nav::TraversabilityOptions t;
  t.robot_radius_m = o.robot_radius_m;
  t.robot_height_m = o.robot_height_m;
  t.max_step_m = o.max_step_m;
  return t;
}

nav::PathTrackerOptions TrackerFrom(const AgentOptions& o) {
  nav::PathTrackerOptions t;
  t.cruise_speed_mps = o.cruise_speed_mps;
  t.goal_tolerance_m = o.goal_tolerance_m;
  t.lookahead_m = o.lookahead_m;
  t.max_yaw_rate_radps = std::min(t.max_yaw_rate_radps, o.limits.max_yaw_rate_radps);
  return t;
}

std::string DefaultTreeFile() { return std::string(CAIRN_CONFIG_DIR) + "/mode_tree.xml"; }

}  // namespace

RobotAgent::Impl::Impl(const AgentOptions& options)
    : options_(options),
      world_(sim::LoadWorld(options.world, [&] {
        sim::WorldLoadOptions w;
        w.pcd_resolution_m = options.pcd_resolution_m;
        return w;
      }())),
      platform_(options.limits, options.footprint_radius_m),
      lock_(options.robot_id, options.lock),
      mux_({{"teleop", options.teleop_timeout_s}, {"waypoint", options.waypoint_timeout_s}}),
      modes_(options.mode_tree_file.empty() ? DefaultTreeFile() : options.mode_tree_file),
      tracker_(TrackerFrom(options)) {
  grid_ = std::make_unique<nav::TraversabilityGrid>(world_, TraversabilityFrom(options));

  // Start pose: given, or chosen deterministically from the robot id among free cells.
  sim::PlanarPose start;
  if (options.start_W) {
    start = *options.start_W;
    if (!grid_->IsFootprintFree(start.x_m, start.y_m, options.footprint_radius_m) ||
        !grid_->GroundHeight(start.x_m, start.y_m)) {
      throw std::invalid_argument("--start " + Format("%.2f,%.2f", start.x_m, start.y_m) +
                                  " is not free ground in world " + options.world +
                                  " (occupied, outside the map, or no floor there)");
    }
  } else if (options.start_slot) {
    const int k = *options.start_slot;
    if (options.world.rfind("builtin:", 0) == 0) {
      const auto& starts = sim::GetBuiltinWorldInfo(options.world.substr(8)).suggested_starts;
      start = starts[static_cast<std::size_t>(k) % starts.size()];
    } else {
      const auto starts = nav::SampleFreeStarts(*grid_, k + 1, 2.0, /*seed=*/7);
      if (static_cast<int>(starts.size()) <= k) {
        throw std::invalid_argument("--start slot:" + std::to_string(k) + ": world " + options.world + " has only " +
                                    std::to_string(starts.size()) + " free starts 2 m apart");
      }
      start = sim::PlanarPose{starts[k].x(), starts[k].y(), 0.0};
    }
  } else {
    const auto starts = nav::SampleFreeStarts(*grid_, 1, 1.0,
                                              static_cast<uint32_t>(std::hash<std::string>{}(options.robot_id)));
    if (starts.empty()) throw std::invalid_argument("world " + options.world + " has no free start cell");
    start = sim::PlanarPose{starts.front().x(), starts.front().y(), 0.0};
  }
  sim::UnicycleState state;
  state.x_m = start.x_m;
  state.y_m = start.y_m;
  state.yaw_rad = start.yaw_rad;
  state.z_m = grid_->GroundHeight(start.x_m, start.y_m).value_or(0.0);
  platform_.set_state(state);

  // DDS entities, in a checked chain; any failure throws and the destructors tear down what exists.
  core::ParticipantOptions p;
  p.domain_id = options.domain_id;
  if (!options.dds_profiles_file.empty()) p.profiles_file = options.dds_profiles_file;
  p.name = "cairn_agent/" + options.robot_id;
  participant_ = std::make_unique<core::Participant>(p);
  info_writer_ = std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(*participant_, "cairn/agent_info",
                                                                           "cairn.latched");
  state_writer_ = std::make_unique<core::Writer<msgs::RobotStatePubSubType>>(*participant_, "cairn/robot_state",
                                                                             "cairn.state");
  tree_writer_ = std::make_unique<core::Writer<msgs::BehaviorTreeStatePubSubType>>(
      *participant_, "cairn/bt_state", "cairn.latched");
  response_writer_ = std::make_unique<core::Writer<msgs::CommandResponsePubSubType>>(
      *participant_, "cairn/command_response", "cairn.command");
  info_reader_ = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
      *participant_, "cairn/agent_info", "cairn.latched",
      [this](const msgs::AgentInfo& m, const auto& info) { OnAgentInfo(m, info); },
      [this](const auto& status) { OnAgentLiveliness(status); });
  control_reader_ = std::make_unique<core::Reader<msgs::ControlRequestPubSubType>>(
      *participant_, "cairn/control_request", "cairn.command",
      [this](const msgs::ControlRequest& m, const auto&) { OnControlRequest(m); });
  mode_reader_ = std::make_unique<core::Reader<msgs::ModeRequestPubSubType>>(
      *participant_, "cairn/mode_request", "cairn.command",
      [this](const msgs::ModeRequest& m, const auto&) { OnModeRequest(m); });
  goal_reader_ = std::make_unique<core::Reader<msgs::WaypointGoalPubSubType>>(
      *participant_, "cairn/waypoint_goal", "cairn.command",
      [this](const msgs::WaypointGoal& m, const auto&) { OnWaypointGoal(m); });
  teleop_reader_ = std::make_unique<core::Reader<msgs::TeleopTwistPubSubType>>(
      *participant_, "cairn/teleop", "cairn.teleop", [this](const msgs::TeleopTwist& m, const auto&) { OnTeleop(m); });

  msgs::AgentInfo info;
  info.agent_id(options.robot_id);
  info.kind(msgs::AGENT_KIND_ROBOT);
  info.platform(options.platform);
  info.capabilities(modes_.known_modes());
  info.version(kVersion);
  info.world(options.world);
  info.stamp(cairn::msgs::WallStampNow());
  info_writer_->Write(info);
  spdlog::info("robot {} ({}) ready in {} at ({:.2f}, {:.2f}, yaw {:.2f}) on DDS domain {}", options.robot_id,
               options.platform, options.world, state.x_m, state.y_m, state.yaw_rad, options.domain_id);
}

RobotAgent::Impl::~Impl() {
  // Readers first so that no callback runs while the rest is torn down.
  control_reader_.reset();
  mode_reader_.reset();
  goal_reader_.reset();
  teleop_reader_.reset();
  info_reader_.reset();
}

ModeConditions RobotAgent::Impl::Conditions() const {
  ModeConditions c;
  c.holder_id = lock_.holder_id();
  c.holder_alive = lock_.holder_alive();
  c.localized = true;  // the simulated platform knows its pose; SLAM health comes with perception
  c.has_waypoint_goal = goal_.has_value();
  return c;
}

void RobotAgent::Impl::ApplyMode(const ModeDecision& decision) {
  mux_.Select(decision.channel);
  if (decision.mode != "waypoint" && goal_) {
    FinishGoal(msgs::NAV_STATUS_FAILED, "cancelled: mode switched to " + decision.mode);
  }
}

void RobotAgent::Impl::FinishGoal(msgs::NavStatus status, const std::string& reason) {
  nav_status_ = status;
  nav_reason_ = reason;
  goal_.reset();
  if (status == msgs::NAV_STATUS_FAILED) spdlog::warn("robot {}: waypoint {} failed: {}", options_.robot_id,
                                                       nav_goal_id_, reason);
}

namespace {

// Identifies one command of one basestation, for de-duplicating retries.
std::string ResponseKey(const std::string& base_id, msgs::CommandKind kind, uint32_t request_id) {
  return base_id + "/" + std::to_string(kind) + "/" + std::to_string(request_id);
}

}  // namespace

bool RobotAgent::Impl::ReplayIfDuplicate(const std::string& base_id, msgs::CommandKind kind, uint32_t request_id) {
  const std::string key = ResponseKey(base_id, kind, request_id);
  for (const auto& [k, response] : responses_) {
    if (k == key) {
      response_writer_->Write(response);
      return true;
    }
  }
  return false;
}

void RobotAgent::Impl::Respond(const std::string& base_id, uint32_t request_id, msgs::CommandKind kind,
                               msgs::CommandResult result, const std::string& reason) {
  msgs::CommandResponse r;
  r.robot_id(options_.robot_id);
  r.base_id(base_id);
  r.request_id(request_id);
  r.kind(kind);
  r.result(result);
  r.reason(reason);
  r.holder_id(lock_.holder_id());
  r.mode(modes_.mode());
  response_writer_->Write(r);
  responses_.emplace_back(ResponseKey(base_id, kind, request_id), r);
  if (responses_.size() > kResponseCacheSize) responses_.pop_front();
  // The behavior-tree state follows from the control loop (<= 20 ms), off the command path.
}

void RobotAgent::Impl::OnControlRequest(const msgs::ControlRequest& msg) {
  if (msg.robot_id() != options_.robot_id) return;
  std::lock_guard<std::mutex> guard(mutex_);
  const bool release = msg.action() == msgs::CONTROL_ACTION_RELEASE;
  const auto kind = release ? msgs::COMMAND_KIND_CONTROL_RELEASE : msgs::COMMAND_KIND_CONTROL_REQUEST;
  if (ReplayIfDuplicate(msg.base_id(), kind, msg.request_id())) return;
  const LockDecision d = release ? lock_.Release(msg.base_id()) : lock_.Request(msg.base_id(), SteadyClock::now());
  if (d.accepted) {
    spdlog::info("robot {}: control {} by {}", options_.robot_id, release ? "released" : "granted", msg.base_id());
    const ModeDecision m = modes_.Recheck(Conditions());  // a release stops the robot (idle)
    if (!m.accepted) ApplyMode(m);
  }
  Respond(msg.base_id(), msg.request_id(), kind, d.accepted ? msgs::COMMAND_RESULT_ACCEPTED : msgs::COMMAND_RESULT_DENIED,
          d.reason);
}

void RobotAgent::Impl::OnModeRequest(const msgs::ModeRequest& msg) {
  if (msg.robot_id() != options_.robot_id) return;
  std::lock_guard<std::mutex> guard(mutex_);
  if (ReplayIfDuplicate(msg.base_id(), msgs::COMMAND_KIND_MODE, msg.request_id())) return;
  if (!lock_.IsHolder(msg.base_id())) {
    lock_.CountDiscarded();
    Respond(msg.base_id(), msg.request_id(), msgs::COMMAND_KIND_MODE, msgs::COMMAND_RESULT_DISCARDED,
            lock_.NotHolderReason(msg.base_id()));
    return;
  }
  const ModeDecision d = modes_.Request(msg.mode(), Conditions());
  if (d.accepted) {
    ApplyMode(d);
    spdlog::info("robot {}: mode {} (by {})", options_.robot_id, d.mode, msg.base_id());
  }
  Respond(msg.base_id(), msg.request_id(), msgs::COMMAND_KIND_MODE,
          d.accepted ? msgs::COMMAND_RESULT_ACCEPTED : msgs::COMMAND_RESULT_DENIED, d.reason);
}

void RobotAgent::Impl::OnWaypointGoal(const msgs::WaypointGoal& msg) {
  if (msg.robot_id() != options_.robot_id) return;
  std::lock_guard<std::mutex> guard(mutex_);
  const auto kind = msgs::COMMAND_KIND_WAYPOINT;
  if (ReplayIfDuplicate(msg.base_id(), kind, msg.request_id())) return;
  if (!lock_.IsHolder(msg.base_id())) {
    lock_.CountDiscarded();
    Respond(msg.base_id(), msg.request_id(), kind, msgs::COMMAND_RESULT_DISCARDED, lock_.NotHolderReason(msg.base_id()));
    return;
  }
  auto deny = [&](const std::string& reason) {
    Respond(msg.base_id(), msg.request_id(), kind, msgs::COMMAND_RESULT_DENIED, reason);
  };
  if (msg.frame_id() != "map") return deny("goal frame_id '" + msg.frame_id() + "' is not supported (use 'map')");
  if (!std::isfinite(msg.x_m()) || !std::isfinite(msg.y_m())) {
    return deny("goal " + Format("(%g, %g)", msg.x_m(), msg.y_m()) + " is not a finite point");
  }
  if (!std::isfinite(msg.tolerance_m()) || msg.tolerance_m() < 0 || msg.tolerance_m() > 5) {
    return deny("goal tolerance_m = " + std::to_string(msg.tolerance_m()) + " must be in [0, 5]");
  }
  const auto& s = platform_.state();
  nav::AStarOptions astar;
  astar.start_footprint_radius_m = options_.footprint_radius_m;
  const nav::PlanResult plan =
      nav::PlanPath(*grid_, Eigen::Vector2d(s.x_m, s.y_m), Eigen::Vector2d(msg.x_m(), msg.y_m()), astar);
  if (plan.status != nav::PlanResult::Status::kSuccess) return deny("no path: " + plan.message);

  const std::optional<Goal> previous = goal_;
  Goal goal;
  goal.request_id = msg.request_id();
  goal.x_m = msg.x_m();
  goal.y_m = msg.y_m();
  goal.tolerance_m = msg.tolerance_m() > 0 ? msg.tolerance_m() : options_.goal_tolerance_m;
  goal.best_distance_m = plan.length_m;
  goal.best_time = SteadyClock::now();
  goal_ = goal;
  const ModeDecision d = modes_.Request("waypoint", Conditions());
  if (!d.accepted) {
    goal_ = previous;
    return deny(d.reason);
  }
  ApplyMode(d);  // a previous goal is simply superseded by this one
  auto tracker_options = TrackerFrom(options_);
  tracker_options.goal_tolerance_m = goal.tolerance_m;
  tracker_ = nav::PathTracker(tracker_options);
  tracker_.SetPath(plan.path_W);
  nav_status_ = msgs::NAV_STATUS_ACTIVE;
  nav_reason_.clear();
  nav_goal_id_ = msg.request_id();
  nav_goal_x_m_ = msg.x_m();
  nav_goal_y_m_ = msg.y_m();
  nav_distance_left_m_ = plan.length_m;
  spdlog::info("robot {}: waypoint {} to ({:.2f}, {:.2f}) accepted, path {:.1f} m", options_.robot_id,
               msg.request_id(), msg.x_m(), msg.y_m(), plan.length_m);
  Respond(msg.base_id(), msg.request_id(), kind, msgs::COMMAND_RESULT_ACCEPTED,
          Format("path %.1f m, %.0f waypoints", plan.length_m, static_cast<double>(plan.path_W.size())));
}

void RobotAgent::Impl::OnTeleop(const msgs::TeleopTwist& msg) {
  if (msg.robot_id() != options_.robot_id) return;
  std::lock_guard<std::mutex> guard(mutex_);
  if (!lock_.IsHolder(msg.base_id())) {
    lock_.CountDiscarded();
    return;
  }
  if (modes_.mode() != "manual") return;  // teleop drives only in manual mode
  const Twist2 twist{msg.twist().linear_x_mps(), msg.twist().angular_z_radps()};
  if (!mux_.Submit("teleop", twist, SteadyClock::now())) {
    spdlog::warn("robot {}: teleop twist ({}, {}) from {} dropped: not finite", options_.robot_id,
                 twist.linear_x_mps, twist.angular_z_radps, msg.base_id());
  }
}

void RobotAgent::Impl::OnAgentInfo(const msgs::AgentInfo& msg, const eprosima::fastdds::dds::SampleInfo& info) {
  if (msg.kind() != msgs::AGENT_KIND_BASESTATION) return;
  std::lock_guard<std::mutex> guard(mutex_);
  base_by_writer_[info.publication_handle] = msg.agent_id();
  lock_.OnLivelinessRegained(msg.agent_id());
}

void RobotAgent::Impl::OnAgentLiveliness(const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
  std::lock_guard<std::mutex> guard(mutex_);
  auto it = base_by_writer_.find(status.last_publication_handle);
  if (it == base_by_writer_.end()) return;
  if (core::IsLivelinessLoss(status)) {
    if (lock_.IsHolder(it->second)) {
      spdlog::warn("robot {}: liveliness of control holder {} lost: stopping", options_.robot_id, it->second);
    }
    lock_.OnLivelinessLost(it->second, SteadyClock::now());
    const ModeDecision m = modes_.Recheck(Conditions());
    if (!m.accepted) ApplyMode(m);
  } else if (status.alive_count_change > 0) {
    lock_.OnLivelinessRegained(it->second);
  }
}

void RobotAgent::Impl::Step(SteadyTime now) {
  if (lock_.Update(now)) {
    spdlog::warn("robot {}: control lock freed after {} s without its holder", options_.robot_id,
                 options_.lock.lock_keep_s);
  }
  const ModeDecision recheck = modes_.Recheck(Conditions());
  if (!recheck.accepted) {
    spdlog::warn("robot {}: {} -> idle", options_.robot_id, recheck.reason);
    ApplyMode(recheck);
  }

  const auto& s = platform_.state();
  if (goal_ && modes_.mode() == "waypoint") {
    const nav::TrackerCommand cmd = tracker_.Compute(s.x_m, s.y_m, s.yaw_rad);
    nav_distance_left_m_ = cmd.distance_left_m;
    if (cmd.arrived) {
      spdlog::info("robot {}: waypoint {} arrived ({:.2f} m from the goal)", options_.robot_id, goal_->request_id,
                   std::hypot(s.x_m - goal_->x_m, s.y_m - goal_->y_m));
      FinishGoal(msgs::NAV_STATUS_ARRIVED, "");
      ApplyMode(modes_.Request("idle", Conditions()));
    } else {
      mux_.Submit("waypoint", Twist2{cmd.vx_mps, cmd.wz_radps}, now);
      if (cmd.distance_left_m < goal_->best_distance_m - 0.05) {
        goal_->best_distance_m = cmd.distance_left_m;
        goal_->best_time = now;
      } else if (core::SecondsBetween(goal_->best_time, now) > options_.blocked_timeout_s) {
        FinishGoal(msgs::NAV_STATUS_FAILED,
                   Format("blocked: no progress for %.0f s (%.1f m left)", options_.blocked_timeout_s,
                          cmd.distance_left_m));
        ApplyMode(modes_.Request("idle", Conditions()));
      }
    }
  }

  last_mux_ = mux_.Compute(now);
  const sim::UnicycleStepResult step =
      platform_.Step(last_mux_.twist_B.linear_x_mps, last_mux_.twist_B.angular_z_radps, kLoopPeriodS, *grid_);
  in_contact_ = step.contact;
  if (goal_) {
    if (!step.contact) {
      goal_->in_contact = false;
    } else if (!goal_->in_contact) {
      goal_->in_contact = true;
      goal_->contact_since = now;
    } else if (core::SecondsBetween(goal_->contact_since, now) > options_.contact_timeout_s) {
      FinishGoal(msgs::NAV_STATUS_FAILED, Format("blocked: in contact with occupied space at (%.2f, %.2f)",
                                                 platform_.state().x_m, platform_.state().y_m));
      ApplyMode(modes_.Request("idle", Conditions()));
    }
  }
}

void RobotAgent::Impl::PublishState(SteadyTime) {
  const auto& s = platform_.state();
  msgs::RobotState m;
  m.robot_id(options_.robot_id);
  m.stamp(cairn::msgs::WallStampNow());
  m.platform(options_.platform);
  m.frame_id("map");
  msgs::Pose pose;
  pose.position().x_m(s.x_m);
  pose.position().y_m(s.y_m);
  pose.position().z_m(s.z_m);
  pose.orientation().z(std::sin(s.yaw_rad / 2));
  pose.orientation().w(std::cos(s.yaw_rad / 2));
  m.pose_MB(pose);
  m.twist_B().linear_x_mps(s.v_mps);
  m.twist_B().angular_z_radps(s.w_radps);
  m.cmd_twist_B().linear_x_mps(last_mux_.twist_B.linear_x_mps);
  m.cmd_twist_B().angular_z_radps(last_mux_.twist_B.angular_z_radps);
  m.mode(modes_.mode());
  m.active_channel(last_mux_.active_channel);
  m.mux_reason(last_mux_.reason);
  m.holder_id(lock_.holder_id());
  m.holder_alive(lock_.holder_alive());
  m.discarded_commands(lock_.discarded());
  m.nav_status(nav_status_);
  m.nav_reason(nav_reason_);
  m.nav_goal_id(nav_goal_id_);
  m.nav_goal_M().x_m(nav_goal_x_m_);
  m.nav_goal_M().y_m(nav_goal_y_m_);
  m.nav_distance_left_m(nav_distance_left_m_);
  m.in_contact(in_contact_);
  state_writer_->Write(m);
}

void RobotAgent::Impl::PublishTreeStateIfChanged() {
  const ModeConditions conditions = Conditions();
  const std::vector<std::string> valid = modes_.ValidModes(conditions);
  std::string signature = modes_.mode() + "|" + modes_.channel() + "|" + modes_.last_refusal();
  for (const auto& v : valid) signature += "|" + v;
  if (signature == last_tree_signature_) return;
  last_tree_signature_ = signature;
  // Node statuses come from the last Request/Recheck trace (Step's), which ValidModes does not overwrite.
  msgs::BehaviorTreeState t;
  t.robot_id(options_.robot_id);
  t.stamp(cairn::msgs::WallStampNow());
  t.mode(modes_.mode());
  t.active_channel(modes_.channel());
  t.last_refusal(modes_.last_refusal());
  t.valid_modes(valid);
  t.tick_count(modes_.tick_count());
  modes_.tree().ForEachNode([&](const bt::TreeNode& node, int depth) {
    msgs::BtNodeState n;
    n.name(node.name());
    n.registration_id(node.registration_id());
    n.depth(static_cast<uint16_t>(depth));
    n.status(bt::ToString(modes_.LastTickStatus(node)));
    t.nodes().push_back(n);
  });
  tree_writer_->Write(t);
}

void RobotAgent::Impl::Run() {
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(kLoopPeriodS));
  const int state_every = std::max(1, static_cast<int>(std::lround(1.0 / (options_.state_rate_hz * kLoopPeriodS))));
  SteadyTime next = SteadyClock::now();
  for (uint64_t cycle = 0; !core::ShutdownRequested(); ++cycle) {
    {
      std::lock_guard<std::mutex> guard(mutex_);
      const SteadyTime now = SteadyClock::now();
      Step(now);
      if (cycle % state_every == 0) PublishState(now);
      PublishTreeStateIfChanged();
    }
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;  // overrun: do not try to catch up
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
  std::lock_guard<std::mutex> guard(mutex_);
  ApplyMode(modes_.Request("idle", Conditions()));
  PublishState(SteadyClock::now());
  spdlog::info("robot {}: shutting down", options_.robot_id);
}

RobotAgent::RobotAgent(const AgentOptions& options) : impl_(std::make_unique<Impl>(options)) {}
RobotAgent::~RobotAgent() = default;
void RobotAgent::Run() { impl_->Run(); }

}  // namespace cairn::agent
