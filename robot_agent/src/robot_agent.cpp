#include "cairn/agent/robot_agent.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <map>
#include <optional>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include <spdlog/spdlog.h>

#include "cairn/agent/command_interface.h"
#include "cairn/agent/live_obstacles.h"
#include "cairn/agent/mode_control.h"
#include "cairn/agent/modes.h"
#include "cairn/agent/nav_map.h"
#include "cairn/agent/navigation.h"
#include "cairn/agent/perception_pipeline.h"
#include "cairn/agent/waypoint_mode.h"
#include "cairn/agent/waypoint_recovery.h"
#include "cairn/core/dds.h"
#include "cairn/core/shutdown.h"
#include "cairn/msgs/stamp.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/scan_obstacles.h"
#include "cairn/nav/traversability.h"
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
constexpr std::size_t kMaxPendingPathRequests = 32;

std::string Format(const char* fmt, double a, double b) {
  char text[128];
  std::snprintf(text, sizeof(text), fmt, a, b);
  return text;
}

}  // namespace

class RobotAgent::Impl {
 public:
  Impl(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform);
  ~Impl();
  void Run();

 private:
  using SampleInfo = eprosima::fastdds::dds::SampleInfo;

  // DDS callbacks (listener threads): each turns the message into the command interface's struct and applies it
  // under mutex_.
  void OnPathRequest(const msgs::PathRequest& msg, const SampleInfo& info);
  // Planning thread: the holder's goals first, then peers' path requests; never on a DDS thread.
  void PlanLoop();
  struct GoalJob {
    GoalCommand command;
    nav::GlobalPlanRequest request;
  };
  struct PathJob {
    msgs::PathRequest msg;
    std::string participant;
  };
  // With mutex_ held: drives a goal planned for the lock's holder (the command interface's start_goal).
  CommandOutcome StartGoal(const GoalCommand& goal, const nav::GlobalPlan& plan);
  void AnswerPathRequest(const PathJob& job);
  // A failed plan's reason for operators (an out-of-map goal names the navigation map's extent and its key).
  std::string PlanReason(const nav::GlobalPlan& plan) const;
  // A remote participant left or was dropped (participant discovery): it speaks for no holder any more.
  void OnParticipantGone(const std::string& participant);
  // The participants reported gone since the last call.
  std::vector<std::string> TakeGoneParticipants();

  // All below run with mutex_ held.
  // The mode tree's facts now.
  ModeConditions Conditions() const;
  // Writes a command interface reply as a CommandResponse.
  void SendReply(const CommandReply& reply);
  // The mode modules: idle, manual, smart joystick, waypoint (a new mode is one more here and its subtree).
  ModeRegistry MakeModes(const std::string& tree_file);
  static CommandSender SenderOf(const std::string& base_id, const SampleInfo& info) {
    return CommandSender{base_id, core::ParticipantIdOf(info.publication_handle),
                         core::WriterIdOf(info.publication_handle)};
  }
  void Step(SteadyTime now);
  void PublishState(SteadyTime now);
  void PublishTreeStateIfChanged();
  void PublishGlobalPathIfChanged();
  void PublishLocalPlan();
  // Sensor thread: reads lidar scans from the platform, makes the local planner's obstacles, hands the scan on.
  void SensorLoop();
  // Reads a scan if the platform has a new one: obstacles for the control loop, the scan for perception.
  bool ReadScan(double now_s);
  // Perception thread: maps, detects and publishes telemetry and camera frames, off the control loop.
  void PerceptionLoop();
  void PublishPerception(const PerceptionOutput& out);
  // Navigation map thread: applies the map's changed region to the planner's map at its period.
  void NavMapLoop();
  double NowS(SteadyTime t) const { return core::SecondsBetween(start_time_, t); }

  AgentOptions options_;
  SteadyTime start_time_ = SteadyClock::now();
  std::shared_ptr<core::PlatformIO> platform_;  // the robot: pose estimate, sensors, twist commands
  core::PlatformCapabilities capabilities_;
  core::BaseState start_M_;                     // pose estimate at start (the navigation map's centre)
  std::shared_ptr<nav::GlobalPlanner> planner_;  // thread-safe; also serves path requests
  core::BaseState pose_;          // latest pose estimate, map frame (control thread)
  bool pose_healthy_ = true;
  std::string pose_problem_;
  Navigation navigation_;
  WaypointMode* waypoint_ = nullptr;    // owned by modes_; holds the waypoint goal
  std::unique_ptr<ModeControl> modes_;  // the mode tree, the mode modules and the mux
  std::unique_ptr<CommandInterface> command_;  // the lock, the reply cache and the rules of who may command
  // Obstacles from live lidar points, made on the sensor thread, taken by the control loop.
  struct ObstacleSlot {
    std::vector<Eigen::Vector3f> points_B;
    core::BaseState pose_M;  // pose the points are expressed from
    double stamp_s = -1e9;
    bool fresh = false;
  };
  std::mutex obstacles_mutex_;
  ObstacleSlot live_obstacles_;
  std::unique_ptr<NavMap> nav_map_;  // used by the navigation map thread only
  // Planning jobs (jobs_mutex_), filled by DDS threads, emptied by the planning thread.
  std::mutex jobs_mutex_;
  std::condition_variable jobs_cv_;
  std::deque<GoalJob> goal_jobs_;
  std::deque<PathJob> path_jobs_;
  struct PathBudget {  // token bucket per requesting process
    double tokens = 0;
    SteadyTime last{};
    SteadyTime last_refusal{};
  };
  std::map<std::string, PathBudget> path_budgets_;
  std::uint64_t path_requests_refused_ = 0;
  std::mutex scan_mutex_;
  std::shared_ptr<core::LidarScan> latest_scan_;  // from the sensor thread to the perception thread
  // Sensor thread only (and the constructor, before it starts).
  LiveObstacles live_obstacle_sensor_;
  // Set by the recovery's "clear the local obstacle memory" (control thread), done by the sensor thread.
  std::atomic<bool> clear_obstacle_memory_{false};
  // Control-loop periods (control thread): the worst of the current and the previous 10 s window.
  struct PeriodWindow {
    SteadyTime last_start{};
    SteadyTime window_start{};
    double current_max_ms = 0.0;
    double previous_max_ms = 0.0;
    void Note(SteadyTime start) {
      if (last_start != SteadyTime{}) current_max_ms = std::max(current_max_ms, 1000 * core::SecondsBetween(last_start, start));
      last_start = start;
      if (window_start == SteadyTime{}) window_start = start;
      if (core::SecondsBetween(window_start, start) >= 10.0) {
        previous_max_ms = current_max_ms;
        current_max_ms = 0.0;
        window_start = start;
      }
    }
    double WorstMs() const { return std::max(current_max_ms, previous_max_ms); }
  } control_periods_;
  std::vector<Eigen::Vector3f> obstacle_points_B_;
  std::uint64_t published_path_revision_ = ~0ull;
  bool in_contact_ = false;
  std::string last_tree_signature_;
  std::unique_ptr<PerceptionPipeline> perception_;  // used by the perception thread only
  std::atomic<bool> map_snapshot_requested_{false};

  std::mutex mutex_;
  std::mutex gone_mutex_;                        // guards gone_participants_ only (taken on a DDS thread)
  std::vector<std::string> gone_participants_;  // reported by participant discovery, handled by the loop
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

namespace {

// The planner on the robot's own map (see NavMap), empty at start.
std::shared_ptr<nav::GlobalPlanner> MakePlanner(const AgentOptions& options, const core::BaseState& start_M) {
  // Serves its own (possibly re-configured) platform and the other built-in ones, for peers that ask.
  std::vector<nav::PlatformProfile> profiles = {options.navigation.platform};
  for (const auto& name : nav::PlatformNames()) {
    if (name != options.navigation.platform.name) profiles.push_back(nav::GetPlatformProfile(name));
  }
  return NavMap::MakePlanner(options.nav_map, options.perception.map.resolution_m, start_M, std::move(profiles));
}

std::shared_ptr<core::PlatformIO> Checked(std::shared_ptr<core::PlatformIO> platform) {
  if (!platform) throw std::invalid_argument("RobotAgent: platform is null");
  return platform;
}

core::BaseState StartPose(core::PlatformIO& platform) {
  platform.Update(0.0);
  const core::PoseEstimate pose = platform.ReadPose();
  if (!pose.T_MB.matrix().allFinite()) throw std::invalid_argument("the platform's start pose is not finite");
  return pose.PlanarState();
}

}  // namespace

std::string RobotAgent::Impl::PlanReason(const nav::GlobalPlan& plan) const {
  if (plan.result.status != nav::PlanResult::Status::kOutOfMap) return plan.reason;
  return plan.reason + " (the robot's navigation map spans its start +- " +
         Format("%.0f m: navigation.map_half_extent_m = %.0f)", options_.nav_map.half_extent_m,
                options_.nav_map.half_extent_m);
}

namespace {

std::string DefaultTreeFile() { return std::string(CAIRN_CONFIG_DIR) + "/mode_tree.xml"; }

}  // namespace

RobotAgent::Impl::Impl(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform)
    : options_(options),
      platform_(Checked(std::move(platform))),
      capabilities_(platform_->Capabilities()),
      start_M_(StartPose(*platform_)),
      planner_(MakePlanner(options, start_M_)),
      pose_(start_M_),
      navigation_(options.navigation, planner_,
                  std::make_shared<const nav::TrajectoryLibrary>(options.LibraryForPlatform())),
      live_obstacle_sensor_(options) {
  const std::string tree_file = options.mode_tree_file.empty() ? DefaultTreeFile() : options.mode_tree_file;
  modes_ = std::make_unique<ModeControl>(tree_file, MakeModes(tree_file), options.robot_id);
  command_ = std::make_unique<CommandInterface>(
      options.robot_id, options.lock, modes_.get(), waypoint_->name(),
      CommandInterface::Hooks{[this] { return Conditions(); }, [this](const CommandReply& r) { SendReply(r); },
                              [this](const GoalCommand& goal) {
                                {
                                  std::lock_guard<std::mutex> jobs_guard(jobs_mutex_);
                                  goal_jobs_.push_back(
                                      GoalJob{goal, navigation_.GoalRequest(pose_, goal.x_m, goal.y_m)});
                                }
                                jobs_cv_.notify_one();
                              },
                              [this](const GoalCommand& goal, const nav::GlobalPlan& plan) {
                                return StartGoal(goal, plan);
                              }});
  nav_map_ = std::make_unique<NavMap>(options.nav_map, options.perception.map.resolution_m, start_M_, planner_,
                                      options.navigation.platform.name);
  if (capabilities_.has_lidar) {
    // The first scan before the robot announces itself ready, so that it can take a goal at once.
    const SteadyTime deadline = SteadyClock::now() + std::chrono::seconds(5);
    while (!ReadScan(NowS(SteadyClock::now())) && SteadyClock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    std::lock_guard<std::mutex> guard(obstacles_mutex_);
    if (live_obstacles_.fresh) {
      live_obstacles_.fresh = false;
      navigation_.SetObstacles(live_obstacles_.points_B, live_obstacles_.pose_M, live_obstacles_.stamp_s);
    } else {
      spdlog::warn("robot {}: no lidar scan within 5 s of start; waypoint driving waits for one", options.robot_id);
    }
  }

  // DDS entities, in a checked chain; any failure throws and the destructors tear down what exists.
  core::ParticipantOptions p;
  p.domain_id = options.domain_id;
  if (!options.dds_profiles_file.empty()) p.profiles_file = options.dds_profiles_file;
  p.name = "cairn_agent/" + options.robot_id;
  p.on_participant_gone = [this](const std::string& participant) { OnParticipantGone(participant); };
  // Map telemetry budgets itself (PerceptionOptions::telemetry); the flow controller is a backstop 25 % above
  // it. Camera frames rely on theirs: a frame that cannot go out in time is replaced by the next.
  p.flow_controllers = {{"cairn.map", options.perception.telemetry.budget_bits_per_s * 1.25, 100},
                        {"cairn.camera", options.perception.camera_budget_bits_per_s, 100}};
  participant_ = std::make_unique<core::Participant>(p);
  info_writer_ = std::make_unique<core::Writer<msgs::AgentInfoPubSubType>>(*participant_, "cairn/agent_info",
                                                                           "cairn.latched");
  state_writer_ = std::make_unique<core::Writer<msgs::RobotStatePubSubType>>(*participant_, "cairn/robot_state",
                                                                             "cairn.state");
  tree_writer_ = std::make_unique<core::Writer<msgs::BehaviorTreeStatePubSubType>>(
      *participant_, "cairn/bt_state", "cairn.latched");
  response_writer_ = std::make_unique<core::Writer<msgs::CommandResponsePubSubType>>(
      *participant_, "cairn/command_response", "cairn.command");
  path_response_writer_ = std::make_unique<core::Writer<msgs::PathResponsePubSubType>>(
      *participant_, "cairn/path_response", "cairn.command");
  global_path_writer_ = std::make_unique<core::Writer<msgs::GlobalPathPubSubType>>(
      *participant_, "cairn/global_path", "cairn.latched");
  local_plan_writer_ = std::make_unique<core::Writer<msgs::LocalPlanPubSubType>>(*participant_, "cairn/local_plan",
                                                                                 "cairn.state");
  map_writer_ = std::make_unique<core::Writer<msgs::MapUpdatePubSubType>>(*participant_, "cairn/map_update",
                                                                           "cairn.map", "cairn.map");
  camera_writer_ = std::make_unique<core::Writer<msgs::CompressedImagePubSubType>>(*participant_, "cairn/camera",
                                                                                   "cairn.camera", "cairn.camera");
  staircase_writer_ = std::make_unique<core::Writer<msgs::StaircaseDetectionPubSubType>>(
      *participant_, "cairn/staircase", "cairn.latched");
  map_sync_reader_ = std::make_unique<core::Reader<msgs::MapSyncRequestPubSubType>>(
      *participant_, "cairn/map_sync_request", "cairn.command", [this](const msgs::MapSyncRequest& m, const auto&) {
        if (m.robot_id() != options_.robot_id) return;
        spdlog::info("robot {}: map snapshot requested by {}", options_.robot_id, m.requester_id());
        map_snapshot_requested_ = true;
      });
  path_request_reader_ = std::make_unique<core::Reader<msgs::PathRequestPubSubType>>(
      *participant_, "cairn/path_request", "cairn.command",
      [this](const msgs::PathRequest& m, const auto& info) { OnPathRequest(m, info); });
  info_reader_ = std::make_unique<core::Reader<msgs::AgentInfoPubSubType>>(
      *participant_, "cairn/agent_info", "cairn.latched",
      [this](const msgs::AgentInfo& m, const auto& info) {
        if (m.kind() != msgs::AGENT_KIND_BASESTATION) return;
        const auto& caps = m.capabilities();
        const BaseAnnouncement base{core::WriterIdOf(info.publication_handle),
                                    core::ParticipantIdOf(info.publication_handle), m.agent_id(),
                                    std::find(caps.begin(), caps.end(), "joystick") != caps.end()};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnBaseAnnounced(base);
      },
      [this](const eprosima::fastdds::dds::LivelinessChangedStatus& status) {
        WriterLiveliness change;
        change.writer = core::WriterIdOf(status.last_publication_handle);
        // Unmatched (the writer is gone for good): alive -1 while alive, or not_alive -1 after its lease lapsed.
        change.unmatched = (status.alive_count_change < 0 && status.not_alive_count_change == 0) ||
                           (status.alive_count_change == 0 && status.not_alive_count_change < 0);
        change.lost = core::IsLivelinessLoss(status);
        change.regained = status.alive_count_change > 0;
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnBaseLiveliness(change, SteadyClock::now());
      });
  control_reader_ = std::make_unique<core::Reader<msgs::ControlRequestPubSubType>>(
      *participant_, "cairn/control_request", "cairn.command",
      [this](const msgs::ControlRequest& m, const auto& info) {
        if (m.robot_id() != options_.robot_id) return;
        const ControlCommand c{SenderOf(m.base_id(), info), m.request_id(),
                               m.action() == msgs::CONTROL_ACTION_RELEASE};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnControl(c, SteadyClock::now());
      });
  mode_reader_ = std::make_unique<core::Reader<msgs::ModeRequestPubSubType>>(
      *participant_, "cairn/mode_request", "cairn.command",
      [this](const msgs::ModeRequest& m, const auto& info) {
        if (m.robot_id() != options_.robot_id) return;
        const ModeCommand c{SenderOf(m.base_id(), info), m.request_id(), m.mode()};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnMode(c);
      });
  goal_reader_ = std::make_unique<core::Reader<msgs::WaypointGoalPubSubType>>(
      *participant_, "cairn/waypoint_goal", "cairn.command",
      [this](const msgs::WaypointGoal& m, const auto& info) {
        if (m.robot_id() != options_.robot_id) return;
        const GoalCommand c{SenderOf(m.base_id(), info), m.request_id(), m.frame_id(), m.x_m(), m.y_m(),
                            m.tolerance_m()};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnGoal(c);
      });
  stop_reader_ = std::make_unique<core::Reader<msgs::StopRequestPubSubType>>(
      *participant_, "cairn/stop_request", "cairn.command",
      [this](const msgs::StopRequest& m, const auto& info) {
        if (m.robot_id() != options_.robot_id) return;
        const StopCommand c{SenderOf(m.base_id(), info), m.request_id()};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnStop(c);
      });
  teleop_reader_ = std::make_unique<core::Reader<msgs::TeleopTwistPubSubType>>(
      *participant_, "cairn/teleop", "cairn.teleop", [this](const msgs::TeleopTwist& m, const auto&) {
        if (m.robot_id() != options_.robot_id) return;
        const TeleopCommand c{m.base_id(), OperatorTwist{m.twist().linear_x_mps(), m.twist().linear_y_mps(),
                                                         m.twist().angular_z_radps()}};
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnTeleop(c, SteadyClock::now());
      });

  msgs::AgentInfo info;
  info.agent_id(options.robot_id);
  info.kind(msgs::AGENT_KIND_ROBOT);
  info.platform(options.platform);
  info.capabilities(modes_->tree().known_modes());
  info.version(kVersion);
  info.world(capabilities_.description);
  info.max_speed_mps(options.navigation.platform.limits.max_speed_mps);
  info.max_reverse_speed_mps(options.navigation.platform.limits.max_reverse_speed_mps);
  info.max_yaw_rate_radps(options.navigation.platform.limits.max_yaw_rate_radps);
  info.stamp(cairn::msgs::WallStampNow());
  info_writer_->Write(info);
  perception_ = std::make_unique<PerceptionPipeline>(options.perception, options.robot_id);
  PublishGlobalPathIfChanged();  // an empty path: late joiners see "no goal"
  spdlog::info("robot {} ({}) ready on platform {} ({}) at ({:.2f}, {:.2f}, yaw {:.2f}) in its map frame on DDS "
               "domain {}", options.robot_id, options.platform, capabilities_.driver, capabilities_.description,
               start_M_.x_m, start_M_.y_m, start_M_.yaw_rad, options.domain_id);
}

ModeRegistry RobotAgent::Impl::MakeModes(const std::string& tree_file) {
  auto recovery = std::make_unique<WaypointRecovery>(tree_file, &navigation_, WaypointRecovery::Hooks{[this] {
                                                       clear_obstacle_memory_ = true;
                                                       std::lock_guard<std::mutex> guard(obstacles_mutex_);
                                                       live_obstacles_.fresh = false;  // points from before
                                                     }});
  if (!recovery->enabled()) {
    spdlog::warn("robot {}: the mode tree file has no {} tree: a blocked waypoint goal fails without recovery",
                 options_.robot_id, WaypointRecovery::kTreeId);
  }
  WaypointModeOptions waypoint;
  waypoint.robot_id = options_.robot_id;
  waypoint.channel_timeout_s = options_.waypoint_timeout_s;
  waypoint.contact_timeout_s = options_.contact_timeout_s;
  std::random_device entropy;  // goal ids of a restarted robot do not repeat old ones
  waypoint.first_goal_id = std::uniform_int_distribution<uint32_t>(1, 1u << 30)(entropy);
  ModeRegistry modes;
  modes.Emplace<IdleMode>();
  modes.Emplace<ManualMode>(options_.teleop_timeout_s);
  modes.Emplace<SmartJoystickMode>(&navigation_, options_.waypoint_timeout_s, options_.teleop_timeout_s);
  waypoint_ = &modes.Emplace<WaypointMode>(waypoint, &navigation_, std::move(recovery));
  return modes;
}

RobotAgent::Impl::~Impl() {
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

ModeConditions RobotAgent::Impl::Conditions() const {
  ModeConditions c;
  command_->FillConditions(&c);  // holder, its liveliness, its joystick
  c.localized = pose_healthy_;
  c.localization_problem = pose_problem_;
  c.has_waypoint_goal = waypoint_->has_goal();
  c.local_planner_healthy = navigation_.LocalPlannerHealthy(NowS(SteadyClock::now()), &c.local_planner_problem);
  return c;
}

namespace {

msgs::NavStatus NavStatusOf(GoalStatus status) {
  switch (status) {
    case GoalStatus::kActive:
      return msgs::NAV_STATUS_ACTIVE;
    case GoalStatus::kArrived:
      return msgs::NAV_STATUS_ARRIVED;
    case GoalStatus::kFailed:
      return msgs::NAV_STATUS_FAILED;
    case GoalStatus::kNone:
      break;
  }
  return msgs::NAV_STATUS_NONE;
}

msgs::Point PointOf(double x, double y, double z) {
  msgs::Point p;
  p.x_m(x);
  p.y_m(y);
  p.z_m(z);
  return p;
}

msgs::Pose PoseOf(const Eigen::Isometry3d& T) {
  msgs::Pose pose;
  pose.position(PointOf(T.translation().x(), T.translation().y(), T.translation().z()));
  const Eigen::Quaterniond q(T.rotation());
  pose.orientation().x(q.x());
  pose.orientation().y(q.y());
  pose.orientation().z(q.z());
  pose.orientation().w(q.w());
  return pose;
}

// A planar pose (metres; yaw about +z, radians) as an IDL pose.
msgs::Pose PoseOf(double x_m, double y_m, double z_m, double yaw_rad) {
  msgs::Pose pose;
  pose.position(PointOf(x_m, y_m, z_m));
  pose.orientation().z(std::sin(yaw_rad / 2));
  pose.orientation().w(std::cos(yaw_rad / 2));
  return pose;
}

// A path (metres, frame map; z = ground height) as IDL points.
std::vector<msgs::Point> PathPoints(const std::vector<Eigen::Vector3d>& path_W) {
  std::vector<msgs::Point> points;
  points.reserve(path_W.size());
  for (const auto& p : path_W) points.push_back(PointOf(p.x(), p.y(), p.z()));
  return points;
}

}  // namespace

namespace {

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

}  // namespace

void RobotAgent::Impl::SendReply(const CommandReply& reply) {
  msgs::CommandResponse r;
  r.robot_id(options_.robot_id);
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
  response_writer_->Write(r);
}

CommandOutcome RobotAgent::Impl::StartGoal(const GoalCommand& goal, const nav::GlobalPlan& plan) {
  if (!plan.IsUsable()) return {false, "no path: " + PlanReason(plan), 0};  // the previous goal, if any, goes on
  const GoalStart start =
      waypoint_->Start(plan, goal.x_m, goal.y_m, goal.tolerance_m, NowS(SteadyClock::now()),
                       [this] { return modes_->Request(waypoint_->name(), Conditions()); });
  if (!start.accepted) return {false, start.reason, 0};
  spdlog::info("robot {}: waypoint {} to ({:.2f}, {:.2f}) from {} accepted, path {:.1f} m", options_.robot_id,
               start.goal_id, goal.x_m, goal.y_m, goal.sender.base_id, plan.result.length_m);
  PublishGlobalPathIfChanged();  // before the acknowledgement, so `path R` right after `goto` shows it
  return {true, Format("path %.1f m, ETA %.0f s", plan.result.length_m, navigation_.eta_s()), start.goal_id};
}

void RobotAgent::Impl::OnPathRequest(const msgs::PathRequest& msg, const SampleInfo& info) {
  if (msg.robot_id() != options_.robot_id) return;
  // No planning here (a DDS thread): the request waits for the planning thread, within a per-process rate.
  const std::string participant = core::ParticipantIdOf(info.publication_handle);
  std::string refusal;
  {
    std::lock_guard<std::mutex> jobs_guard(jobs_mutex_);
    const SteadyTime now = SteadyClock::now();
    PathBudget& budget = path_budgets_[participant];
    const double rate = options_.path_requests_per_s;
    budget.tokens = std::min(2 * rate, budget.tokens + rate * core::SecondsBetween(budget.last, now));
    budget.last = now;
    if (budget.tokens < 1.0) {
      ++path_requests_refused_;
      // One refusal a second per process says why; the rest of a flood is dropped unanswered.
      if (core::SecondsBetween(budget.last_refusal, now) < 1.0) return;
      budget.last_refusal = now;
      refusal = Format("rate limited: more than %.0f path requests/s (burst %.0f) from this process", rate,
                       2 * rate);
    } else if (path_jobs_.size() >= kMaxPendingPathRequests) {
      ++path_requests_refused_;
      refusal = "busy: " + std::to_string(kMaxPendingPathRequests) + " path requests are waiting";
    } else {
      budget.tokens -= 1.0;
      path_jobs_.push_back(PathJob{msg, participant});
    }
  }
  if (refusal.empty()) {
    jobs_cv_.notify_one();
    return;
  }
  msgs::PathResponse r;
  r.request_id(msg.request_id());
  r.requester_id(msg.requester_id());
  r.requester_participant(participant);
  r.robot_id(options_.robot_id);
  r.frame_id("map");
  r.success(false);
  r.status("kRateLimited");
  r.reason(refusal);
  path_response_writer_->Write(r);
}

void RobotAgent::Impl::AnswerPathRequest(const PathJob& job) {
  const msgs::PathRequest& msg = job.msg;
  // The planner is thread-safe: no agent lock here.
  msgs::PathResponse r;
  r.request_id(msg.request_id());
  r.requester_id(msg.requester_id());
  r.requester_participant(job.participant);
  r.robot_id(options_.robot_id);
  r.frame_id("map");
  if (msg.frame_id() != "map") {
    r.success(false);
    r.status("kInvalidFrame");
    r.reason("frame_id '" + msg.frame_id() + "' is not supported (use 'map')");
  } else {
    nav::GlobalPlanRequest request;
    request.start_W = {msg.start_M().x_m(), msg.start_M().y_m()};
    request.goal_W = {msg.goal_M().x_m(), msg.goal_M().y_m()};
    request.platform = msg.platform().empty() ? options_.navigation.platform.name : msg.platform();
    const nav::GlobalPlan plan = planner_->Plan(request);
    r.success(plan.IsUsable());
    r.status(plan.platform_known ? nav::ToString(plan.result.status) : "kUnknownPlatform");
    r.reason(plan.IsUsable() ? "" : PlanReason(plan));
    r.path_M(PathPoints(plan.result.path_W));
    r.length_m(plan.result.length_m);
    r.map_version(plan.map_version);
    r.planning_time_s(plan.total_time_s);
    spdlog::info("robot {}: path request {} from {} ({}): {}", options_.robot_id, msg.request_id(),
                 msg.requester_id(), request.platform, plan.IsUsable() ? "path" : plan.reason);
  }
  path_response_writer_->Write(r);
}

void RobotAgent::Impl::OnParticipantGone(const std::string& participant) {
  // Fast DDS's discovery thread: never wait for the agent lock here (the control loop holds it while it
  // writes samples). The control loop handles the departure within one period.
  std::lock_guard<std::mutex> guard(gone_mutex_);
  gone_participants_.push_back(participant);
}

std::vector<std::string> RobotAgent::Impl::TakeGoneParticipants() {
  std::vector<std::string> gone;
  std::lock_guard<std::mutex> guard(gone_mutex_);
  gone.swap(gone_participants_);
  return gone;
}

void RobotAgent::Impl::Step(SteadyTime now) {
  command_->Update(now);
  const ModeDecision recheck = modes_->Recheck(Conditions());
  if (!recheck.accepted) spdlog::warn("robot {}: {} -> idle", options_.robot_id, recheck.reason);

  const double now_s = NowS(now);
  // The robot as its platform reports it: pose estimate (SLAM), health.
  platform_->Update(now_s);
  const core::PoseEstimate estimate = platform_->ReadPose();
  pose_ = estimate.PlanarState();
  if (estimate.healthy != pose_healthy_) {
    if (estimate.healthy) {
      spdlog::info("robot {}: localization recovered", options_.robot_id);
    } else {
      spdlog::warn("robot {}: localization lost: {}", options_.robot_id, estimate.problem);
    }
  }
  pose_healthy_ = estimate.healthy;
  pose_problem_ = estimate.healthy ? "" : estimate.problem;
  const core::BaseState& s = pose_;
  {  // Obstacles from live lidar points, at the sensor's rate.
    std::lock_guard<std::mutex> guard(obstacles_mutex_);
    if (live_obstacles_.fresh) {
      live_obstacles_.fresh = false;
      navigation_.SetObstacles(live_obstacles_.points_B, live_obstacles_.pose_M, live_obstacles_.stamp_s);
    }
  }
  const ModeInputs inputs{now, now_s, s};
  if (modes_->Step(inputs)) modes_->GoIdle(Conditions());  // the mode's task ended (a goal arrived or failed)
  PublishGlobalPathIfChanged();

  const MuxOutput& command = modes_->Compute(now);
  platform_->CommandTwist(command.twist_B.linear_x_mps, command.twist_B.angular_z_radps, now_s);
  const core::PlatformStatus status = platform_->ReadStatus();
  in_contact_ = status.in_contact;
  if (modes_->OnPlatformStatus(status, inputs)) modes_->GoIdle(Conditions());  // e.g. a goal blocked in contact
}

void RobotAgent::Impl::PublishState(SteadyTime) {
  const core::BaseState& s = pose_;  // the SLAM estimate, in the map frame of the robot's map and paths
  msgs::RobotState m;
  m.robot_id(options_.robot_id);
  m.stamp(cairn::msgs::WallStampNow());
  m.platform(options_.platform);
  m.frame_id("map");
  m.pose_MB(PoseOf(s.x_m, s.y_m, s.z_m, s.yaw_rad));
  m.twist_B().linear_x_mps(s.v_mps);
  m.twist_B().angular_z_radps(s.w_radps);
  const MuxOutput& command = modes_->last_output();
  m.cmd_twist_B().linear_x_mps(command.twist_B.linear_x_mps);
  m.cmd_twist_B().angular_z_radps(command.twist_B.angular_z_radps);
  m.mode(modes_->mode());
  m.active_channel(command.active_channel);
  m.mux_reason(command.reason);
  const ControlLock& lock = command_->lock();
  m.holder_id(lock.holder_id());
  m.holder_alive(lock.holder_alive());
  m.holder_participant(lock.holder_participant());
  m.holder_participants(lock.holder_participants());
  m.discarded_commands(lock.discarded());
  const WaypointGoal& goal = waypoint_->goal();
  m.nav_status(NavStatusOf(goal.status));
  m.nav_reason(goal.reason);
  m.nav_goal_id(goal.goal_id);
  m.nav_goal_M().x_m(goal.x_m);
  m.nav_goal_M().y_m(goal.y_m);
  m.nav_distance_left_m(goal.distance_left_m);
  m.nav_eta_s(navigation_.eta_s());
  m.nav_replans(static_cast<uint32_t>(navigation_.replans()));
  m.local_planner_status(navigation_.local_status());
  m.in_contact(in_contact_);
  m.control_period_max_ms(control_periods_.WorstMs());
  const StopRecord& stops = command_->stops();
  m.stops(stops.count);
  m.stopped_by(stops.by);
  m.stopped_at().sec(stops.at.sec);
  m.stopped_at().nanosec(stops.at.nanosec);
  state_writer_->Write(m);
}

void RobotAgent::Impl::PublishTreeStateIfChanged() {
  const ValidActions valid_now = command_->ValidNow();
  const std::vector<std::string>& valid = valid_now.modes;
  const bool goal_acceptable = valid_now.goal_acceptable;
  const ModeManager& tree = modes_->tree();
  std::string signature = tree.mode() + "|" + tree.channel() + "|" + tree.last_refusal() + "|" +
                          (goal_acceptable ? "goal" : "");
  for (const auto& v : valid) signature += "|" + v;
  if (signature == last_tree_signature_) return;
  last_tree_signature_ = signature;
  // Node statuses come from the last Request/Recheck trace (Step's), which ValidModes does not overwrite.
  msgs::BehaviorTreeState t;
  t.robot_id(options_.robot_id);
  t.stamp(cairn::msgs::WallStampNow());
  t.mode(tree.mode());
  t.active_channel(tree.channel());
  t.last_refusal(tree.last_refusal());
  t.valid_modes(valid);
  t.goal_acceptable(goal_acceptable);
  t.tick_count(tree.tick_count());
  tree.tree().ForEachNode([&](const bt::TreeNode& node, int depth) {
    msgs::BtNodeState n;
    n.name(node.name());
    n.registration_id(node.registration_id());
    n.depth(static_cast<uint16_t>(depth));
    n.status(bt::ToString(tree.LastTickStatus(node)));
    t.nodes().push_back(n);
  });
  tree_writer_->Write(t);
}

void RobotAgent::Impl::PublishGlobalPathIfChanged() {
  if (navigation_.path_revision() == published_path_revision_) return;
  published_path_revision_ = navigation_.path_revision();
  const nav::GlobalPlan& plan = navigation_.global_plan();
  msgs::GlobalPath m;
  m.robot_id(options_.robot_id);
  m.stamp(cairn::msgs::WallStampNow());
  m.goal_id(waypoint_->has_goal() ? waypoint_->goal().goal_id : 0);
  m.platform(options_.navigation.platform.name);
  m.frame_id("map");
  if (waypoint_->has_goal()) {
    m.path_M(PathPoints(plan.result.path_W));
    m.length_m(plan.result.length_m);
  }
  m.map_version(plan.map_version);
  m.replans(static_cast<uint32_t>(navigation_.replans()));
  global_path_writer_->Write(m);
}

void RobotAgent::Impl::PublishLocalPlan() {
  if (!modes_->active().uses_local_planner()) return;
  const std::string& mode = modes_->mode();
  const nav::LocalPlanResult& r = navigation_.local_result();
  const core::BaseState& pose = navigation_.local_pose();
  msgs::LocalPlan m;
  m.robot_id(options_.robot_id);
  m.stamp(cairn::msgs::WallStampNow());
  m.mode(mode);
  const std::string& status = navigation_.local_status();
  m.status(status == "path" ? "path" : status.rfind("boxed in", 0) == 0 ? "boxed in" : "stopped");
  m.reason(status);
  m.free_paths(static_cast<uint32_t>(r.num_free_paths));
  m.total_paths(static_cast<uint32_t>(navigation_.library().num_paths()));
  m.pose_MB(PoseOf(pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad));
  for (const auto& p : r.path_B) m.chosen_path_B().push_back(PointOf(p.x(), p.y(), 0.0));
  // End points of free paths, thinned to one per 0.5 m cell, to keep the message small (~1 kB).
  std::set<std::pair<int, int>> cells;
  for (int id = 0; id < navigation_.library().num_paths(); ++id) {
    if (!r.IsFree(id)) continue;
    const Eigen::Vector2f end = navigation_.library().info(id).end_B;
    if (cells.emplace(static_cast<int>(std::floor(end.x() / 0.5f)), static_cast<int>(std::floor(end.y() / 0.5f)))
            .second) {
      m.free_path_ends_B().push_back(PointOf(end.x(), end.y(), 0.0));
    }
  }
  m.obstacle_points(static_cast<uint32_t>(r.num_points_used));
  m.cycle_time_ms(r.planning_time_s * 1000.0);
  local_plan_writer_->Write(m);
}

void RobotAgent::Impl::Run() {
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(kLoopPeriodS));
  const int state_every = std::max(1, static_cast<int>(std::lround(1.0 / (options_.state_rate_hz * kLoopPeriodS))));
  const int local_plan_every =
      std::max(1, static_cast<int>(std::lround(1.0 / (options_.local_plan_rate_hz * kLoopPeriodS))));
  // The lidar feeds navigation (live obstacles, the navigation map) even with perception's outputs disabled.
  std::thread sensor_thread;
  if (capabilities_.has_lidar) sensor_thread = std::thread([this] { SensorLoop(); });
  std::thread perception_thread([this] { PerceptionLoop(); });
  std::thread nav_map_thread([this] { NavMapLoop(); });
  std::thread plan_thread([this] { PlanLoop(); });
  // Joins the threads however Run() ends (an exception would otherwise terminate the process).
  struct JoinOnExit {
    std::thread* threads[4];
    ~JoinOnExit() {
      for (std::thread* t : threads) {
        if (t->joinable()) {
          core::RequestShutdown();
          t->join();
        }
      }
    }
  } join_on_exit{{&sensor_thread, &perception_thread, &nav_map_thread, &plan_thread}};
  SteadyTime next = SteadyClock::now();
  for (uint64_t cycle = 0; !core::ShutdownRequested(); ++cycle) {
    const SteadyTime wanted = SteadyClock::now();
    control_periods_.Note(wanted);
    if (const double late_s = core::SecondsBetween(next, wanted); late_s > 0.1) {
      spdlog::warn("robot {}: control loop woke {:.0f} ms late (the process was not scheduled)", options_.robot_id,
                   1000 * late_s);
    }
    {
      std::lock_guard<std::mutex> guard(mutex_);
      const SteadyTime now = SteadyClock::now();
      command_->OnParticipantsGone(TakeGoneParticipants(), now);
      Step(now);
      if (cycle % state_every == 0) PublishState(now);
      if (cycle % local_plan_every == 0) PublishLocalPlan();
      PublishTreeStateIfChanged();
      // A late cycle is a robot driving blind: say where the time went (waiting for the lock, or working).
      const double lock_wait_s = core::SecondsBetween(wanted, now);
      const double work_s = core::SecondsBetween(now, SteadyClock::now());
      if (lock_wait_s + work_s > 0.1) {
        spdlog::warn("robot {}: control cycle took {:.0f} ms ({:.0f} ms waiting for the agent lock, {:.0f} ms "
                     "working; period {:.0f} ms)",
                     options_.robot_id, 1000 * (lock_wait_s + work_s), 1000 * lock_wait_s, 1000 * work_s,
                     1000 * kLoopPeriodS);
      }
    }
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;  // overrun: do not try to catch up
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
  {
    std::lock_guard<std::mutex> guard(mutex_);
    modes_->Stop("agent shutting down");
    PublishState(SteadyClock::now());
  }
  for (std::thread* t : {&sensor_thread, &perception_thread, &nav_map_thread, &plan_thread}) {
    if (t->joinable()) t->join();
  }
  if (options_.perception.enabled) {
    // The last changes (within the budget), and a moment for the asynchronous writer to deliver them.
    PerceptionOutput last;
    last.map_messages = perception_->FlushMapTelemetry(NowS(SteadyClock::now()));
    PublishPerception(last);
    map_writer_->get()->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(1, 0));
  }
  if (!options_.map_save_path.empty()) {
    try {
      perception_->map()->SaveBt(options_.map_save_path);
      spdlog::info("robot {}: map saved to {}", options_.robot_id, options_.map_save_path);
    } catch (const std::exception& e) {
      spdlog::error("robot {}: cannot save the map: {}", options_.robot_id, e.what());
    }
  }
  const PerceptionStats& ps = perception_->stats();
  spdlog::info("robot {}: shutting down; perception: {} scans ({:.1f} ms map per inserted scan), {} staircase "
               "runs ({:.1f} ms each), {} camera frames; navigation map version {}",
               options_.robot_id, ps.scans, ps.scans_inserted ? ps.map_ms_total / ps.scans_inserted : 0.0,
               ps.staircase_runs, ps.staircase_runs ? ps.staircase_ms_total / ps.staircase_runs : 0.0,
               ps.camera_frames, planner_->map_version());
}

void RobotAgent::Impl::PublishPerception(const PerceptionOutput& out) {
  for (const perception::MapUpdate& update : out.map_messages) {
    msgs::MapUpdate m;
    m.robot_id(options_.robot_id);
    m.stamp(cairn::msgs::WallStampNow());
    m.kind(static_cast<uint8_t>(update.kind));
    m.seq(update.seq);
    m.base_seq(update.base_seq);
    m.snapshot_id(update.snapshot_id);
    m.chunk_index(update.chunk_index);
    m.chunk_count(update.chunk_count);
    m.resolution_m(update.resolution_m);
    m.encoding("cairn-coarse-zstd-v1");
    m.data(update.data);
    if (!map_writer_->Write(m)) {
      spdlog::warn("robot {}: map update seq {} not written (history full)", options_.robot_id, update.seq);
    }
  }
  for (const perception::StaircaseRegistry::Entry& entry : out.staircases) {
    const perception::Staircase& s = entry.staircase;
    msgs::StaircaseDetection m;
    m.robot_id(options_.robot_id);
    m.staircase_id(static_cast<uint32_t>(entry.id));
    m.stamp(cairn::msgs::WallStampNow());
    m.p_M_first_step(PointOf(s.p_W_first_step.x(), s.p_W_first_step.y(), s.p_W_first_step.z()));
    m.yaw_rad(s.yaw_rad);
    m.rise_m(s.rise_m);
    m.run_m(s.run_m);
    m.width_m(s.width_m);
    m.num_steps(static_cast<uint16_t>(s.num_steps));
    m.confidence(s.confidence);
    m.detections(static_cast<uint32_t>(entry.detections));
    staircase_writer_->Write(m);
    spdlog::info("robot {}: staircase {} at ({:.2f}, {:.2f}, {:.2f}) yaw {:.2f}: {} steps, rise {:.3f} m, run {:.3f} m, "
                 "width {:.2f} m ({} detections)", options_.robot_id, entry.id, s.p_W_first_step.x(),
                 s.p_W_first_step.y(), s.p_W_first_step.z(), s.yaw_rad, s.num_steps, s.rise_m, s.run_m, s.width_m,
                 entry.detections);
  }
  if (out.camera) {
    msgs::CompressedImage m;
    m.robot_id(options_.robot_id);
    m.stamp(cairn::msgs::WallStampNow());
    m.seq(out.camera->seq);
    m.frame_id("camera");
    m.format("jpeg");
    m.width_px(static_cast<uint16_t>(out.camera->width_px));
    m.height_px(static_cast<uint16_t>(out.camera->height_px));
    m.pose_MC(PoseOf(out.camera->T_W_C));
    m.data(out.camera->jpeg);
    camera_writer_->Write(m);  // keep-last 1: an unsent frame is replaced by this one (dropped, never queued)
  }
}

bool RobotAgent::Impl::ReadScan(double now_s) {
  auto scan = std::make_shared<core::LidarScan>();
  if (!platform_->ReadLidarScan(now_s, scan.get())) return false;
  core::BaseState pose_M;
  if (clear_obstacle_memory_.exchange(false)) live_obstacle_sensor_.Clear();
  live_obstacle_sensor_.AddScan(*scan, &obstacle_points_B_, &pose_M);
  {
    std::lock_guard<std::mutex> guard(obstacles_mutex_);
    live_obstacles_.points_B.swap(obstacle_points_B_);
    live_obstacles_.pose_M = pose_M;
    live_obstacles_.stamp_s = scan->stamp_s;
    live_obstacles_.fresh = true;
  }
  std::lock_guard<std::mutex> guard(scan_mutex_);
  latest_scan_ = std::move(scan);  // perception takes the newest; a slow mapper skips scans, never queues
  return true;
}

void RobotAgent::Impl::SensorLoop() {
  // Polls the platform at twice its lidar rate: a scan reaches the local planner within half a period of its
  // arrival, whatever the perception thread is busy with (mapping, stairs, camera).
  const double rate_hz = capabilities_.lidar_rate_hz > 0 ? capabilities_.lidar_rate_hz : 10.0;
  const auto period =
      std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(0.5 / rate_hz));
  SteadyTime next = SteadyClock::now();
  while (!core::ShutdownRequested()) {
    try {
      ReadScan(NowS(SteadyClock::now()));
    } catch (const std::exception& e) {
      // A sensor fault must never take the robot down: the local planner's input goes stale and the robot
      // stops (navigation.obstacle_timeout_s).
      spdlog::error("robot {}: lidar read failed: {}", options_.robot_id, e.what());
    }
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
}

void RobotAgent::Impl::PerceptionLoop() {
  const double rate_hz = capabilities_.lidar_rate_hz > 0 ? capabilities_.lidar_rate_hz : 10.0;
  const auto period =
      std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(0.5 / rate_hz));
  core::CameraImage image;
  SteadyTime next = SteadyClock::now();
  while (!core::ShutdownRequested()) {
    const double now_s = NowS(SteadyClock::now());
    try {
      std::shared_ptr<core::LidarScan> scan;
      {
        std::lock_guard<std::mutex> guard(scan_mutex_);
        scan.swap(latest_scan_);
      }
      if (map_snapshot_requested_.exchange(false)) perception_->RequestMapSnapshot();
      const bool has_image =
          capabilities_.has_camera && perception_->CameraDue(now_s) && platform_->ReadCameraImage(now_s, &image);
      PublishPerception(perception_->Tick(now_s, scan.get(), has_image ? &image : nullptr));
    } catch (const std::exception& e) {
      // Perception must never take the robot down.
      spdlog::error("robot {}: perception tick failed: {}", options_.robot_id, e.what());
    }
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;  // over budget: the next scan comes late, never a burst
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
}

void RobotAgent::Impl::PlanLoop() {
  while (!core::ShutdownRequested()) {
    std::optional<GoalJob> goal_job;
    std::optional<PathJob> path_job;
    {
      std::unique_lock<std::mutex> jobs_guard(jobs_mutex_);
      jobs_cv_.wait_for(jobs_guard, std::chrono::milliseconds(100),
                        [this] { return !goal_jobs_.empty() || !path_jobs_.empty(); });
      if (!goal_jobs_.empty()) {  // the holder's goals before peers' path requests
        goal_job = std::move(goal_jobs_.front());
        goal_jobs_.pop_front();
      } else if (!path_jobs_.empty()) {
        path_job = std::move(path_jobs_.front());
        path_jobs_.pop_front();
      }
    }
    try {
      if (goal_job) {
        const nav::GlobalPlan plan = planner_->Plan(goal_job->request);  // no agent lock while planning
        std::lock_guard<std::mutex> guard(mutex_);
        command_->OnGoalPlanned(goal_job->command, plan);
      } else if (path_job) {
        AnswerPathRequest(*path_job);
      }
    } catch (const std::exception& e) {
      spdlog::error("robot {}: planning failed: {}", options_.robot_id, e.what());
    }
  }
}

void RobotAgent::Impl::NavMapLoop() {
  const auto period = std::chrono::duration_cast<SteadyClock::duration>(
      std::chrono::duration<double>(options_.nav_map.update_period_s));
  SteadyTime next = SteadyClock::now() + period;
  while (!core::ShutdownRequested()) {
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - SteadyClock::now()));
    if (core::ShutdownRequested()) break;
    next += period;
    if (next < SteadyClock::now()) next = SteadyClock::now() + period;
    try {
      const std::vector<Eigen::Vector2i> tiles = perception_->TakeChangedTiles();
      if (tiles.empty()) continue;
      const NavMapUpdateStats stats = nav_map_->Update(*perception_->map(), tiles, perception_->change_tile_m(),
                                                        perception_->max_sensor_z_m());
      if (stats.applied) {
        spdlog::debug("robot {}: navigation map v{}: {} tiles in {:.1f} x {:.1f} m, {} occupied voxels, read {:.1f} "
                      "ms, traversability {:.1f} ms, publish {:.1f} ms",
                      options_.robot_id, stats.map_version, stats.tiles, stats.region_M.sizes().x(),
                      stats.region_M.sizes().y(), stats.occupied_voxels, stats.read_ms, stats.traversability_ms,
                      stats.publish_ms);
      }
    } catch (const std::exception& e) {
      spdlog::error("robot {}: navigation map update failed: {}", options_.robot_id, e.what());
    }
  }
}

RobotAgent::RobotAgent(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform)
    : impl_(std::make_unique<Impl>(options, std::move(platform))) {}
RobotAgent::~RobotAgent() = default;
void RobotAgent::Run() { impl_->Run(); }

}  // namespace cairn::agent
