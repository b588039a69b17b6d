#include "cairn/agent/communication/telemetry.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <set>
#include <stdexcept>
#include <utility>

#include "cairn/core/time.h"
#include "cairn/fleet/robot_status.h"
#include "cairn/msgs/robot_state.h"
#include "cairn/msgs/stamp.h"
#include "cairn_msgs.h"

namespace cairn::agent {

namespace msgs = cairn_msgs;

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

template <class T>
T* Required(T* pointer, const char* name) {
  if (pointer == nullptr) throw std::invalid_argument(std::string("Telemetry: ") + name + " is null");
  return pointer;
}

void SetExploration(const ExplorationStatus& ex, msgs::RobotState* state) {
  msgs::RobotState& m = *state;
  m.explore_state(ToString(ex.state));
  m.explore_reason(ex.reason);
  m.explore_task_id(ex.task_id);
  m.explored_m2(ex.explored_m2);
  m.frontier_clusters(static_cast<uint32_t>(ex.frontier_clusters));
  m.reachable_frontiers(static_cast<uint32_t>(ex.reachable_frontiers));
  m.explore_has_target(ex.has_target);
  m.explore_target_M().x_m(ex.target_M.x());
  m.explore_target_M().y_m(ex.target_M.y());
  m.explore_target_M().z_m(ex.target_z_m);
  m.explore_targets_reached(static_cast<uint32_t>(ex.targets_reached));
  m.explore_targets_failed(static_cast<uint32_t>(ex.targets_failed));
  m.explore_peers(static_cast<uint32_t>(ex.peers));
  m.explore_peer_seen_m2(ex.peer_seen_m2);
}

// The mission an interruption paused (it goes on under its id: --wait and the operator see it paused, not
// ended), else the last note about missions; the goal a restarted robot offers to resume.
void SetMission(const RobotStateInputs& in, msgs::RobotState* state) {
  msgs::RobotState& m = *state;
  if (in.paused_mission) {
    const PausedMission& p = *in.paused_mission;
    m.mission_state(fleet::mission_state::kPaused);
    m.mission_kind(ToString(p.kind));
    m.mission_reason(p.reason);
    m.mission_paused_s(in.mission_paused_s);
    if (p.kind == PausedMission::Kind::kWaypoint) {
      m.nav_status(msgs::NAV_STATUS_PAUSED);
      m.nav_reason("paused: " + p.reason);
      m.nav_goal_id(p.goal.goal_id);
      m.nav_goal_M().x_m(p.goal.x_m);
      m.nav_goal_M().y_m(p.goal.y_m);
    } else if (p.kind == PausedMission::Kind::kExplore) {
      m.explore_state(fleet::explore_state::kPaused);
      m.explore_reason("paused: " + p.reason);
      m.explore_task_id(p.task_id);
    } else {
      m.convoy_state(fleet::convoy_state::kPaused);
      m.convoy_ahead_ids(p.convoy_ahead_ids);
      m.convoy_reason("paused: " + p.reason);
    }
  } else {
    m.mission_reason(in.mission_note);
  }
  m.has_resumable_goal(in.resumable_goal_M.has_value());
  if (in.resumable_goal_M) {
    m.resumable_goal_M().x_m(in.resumable_goal_M->x());
    m.resumable_goal_M().y_m(in.resumable_goal_M->y());
    m.resumable_goal_M().z_m(in.resumable_goal_M->z());
  }
}

}  // namespace

Telemetry::Telemetry(const AgentOptions& options, AgentLink* link, const ModeControl* modes,
                     const WaypointMode* waypoint, const ExploreMode* explore, const ConvoyMode* convoy,
                     const nav::Navigation* navigation, CommandInterface* command)
    : robot_id_(options.robot_id),
      platform_(options.platform),
      nav_platform_(options.navigation.platform.name),
      limits_(options.navigation.platform.limits),
      footprint_radius_m_(options.navigation.platform.footprint_radius_m),
      link_(options.link),
      map_resolution_m_(options.perception.enabled ? options.perception.map.resolution_m : 0.0),
      agent_link_(Required(link, "link")),
      modes_(Required(modes, "modes")),
      waypoint_(Required(waypoint, "waypoint")),
      explore_(Required(explore, "explore")),
      convoy_(Required(convoy, "convoy")),
      navigation_(Required(navigation, "navigation")),
      command_(Required(command, "command")) {}

void Telemetry::PublishAgentInfo(const core::PlatformCapabilities& capabilities, const std::string& version) {
  msgs::AgentInfo info;
  info.agent_id(robot_id_);
  info.kind(msgs::AGENT_KIND_ROBOT);
  info.platform(platform_);
  info.capabilities(modes_->tree().known_modes());
  info.version(version);
  info.world(capabilities.description);
  info.max_speed_mps(limits_.max_speed_mps);
  info.max_reverse_speed_mps(limits_.max_reverse_speed_mps);
  info.max_yaw_rate_radps(limits_.max_yaw_rate_radps);
  info.footprint_radius_m(footprint_radius_m_);
  std::vector<std::string> sensors;
  if (capabilities.has_lidar) sensors.emplace_back("lidar");
  if (capabilities.has_camera) sensors.emplace_back("camera");
  info.sensors(sensors);
  info.map_resolution_m(map_resolution_m_);
  info.link(link_.link);
  info.link_kbps(core::StatedBudgetKbps(link_));
  info.stamp(cairn::msgs::WallStampNow());
  agent_link_->Publish(info);
}

void Telemetry::PublishState(const RobotStateInputs& in) {
  const core::BaseState& s = in.pose_M;  // the SLAM estimate, in the map frame of the robot's map and paths
  msgs::RobotState m;
  m.robot_id(robot_id_);
  m.stamp(cairn::msgs::WallStampNow());
  m.platform(platform_);
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
  m.control_requester_id(lock.pending_request() ? lock.pending_request()->base_id : "");
  m.control_request_left_s(in.control_request_left_s);
  m.handovers(lock.handovers());
  m.handover_outcome(lock.handover_outcome());
  const WaypointGoal& goal = waypoint_->goal();
  m.nav_status(NavStatusOf(goal.status));
  m.nav_reason(goal.reason);
  m.nav_goal_id(goal.goal_id);
  m.nav_goal_M().x_m(goal.x_m);
  m.nav_goal_M().y_m(goal.y_m);
  m.nav_distance_left_m(goal.distance_left_m);
  m.nav_eta_s(navigation_->eta_s());
  m.nav_replans(static_cast<uint32_t>(navigation_->replans()));
  m.local_planner_status(navigation_->local_status());
  m.in_contact(in.in_contact);
  m.control_period_max_ms(in.control_period_max_ms);
  const StopRecord& stops = command_->stops();
  m.stops(stops.count);
  m.stopped_by(stops.by);
  m.stopped_at().sec(stops.at.sec);
  m.stopped_at().nanosec(stops.at.nanosec);
  m.link_budget_kbps(core::StatedBudgetKbps(link_));
  SetExploration(explore_->status(), &m);
  const ConvoyStatus& convoy = convoy_->status();
  m.convoy_state(ToString(convoy.state));
  m.convoy_ahead_ids(convoy_->active() ? convoy.ahead_ids : std::vector<std::string>{});
  m.convoy_gap_m(convoy.gap_m);
  m.convoy_reason(convoy.reason);
  m.yield_state(ToString(in.yield.state));
  m.yield_peer_id(in.yield.peer_id);
  m.yield_reason(in.yield.reason);
  SetMission(in, &m);
  const cairn_msgs::RobotPose pose = cairn::msgs::PoseOf(m);
  // The whole state (~360 bytes, most of it unchanged from one cycle to the next) only when due. It goes
  // before the pose of the same cycle, so a reader that has the pose has (or is being repaired) the state it
  // joins.
  const double now_s = std::chrono::duration<double>(core::SteadyClock::now().time_since_epoch()).count();
  if (now_s >= next_link_usage_s_) whole_state_.Request();  // with the link usage, once a second
  if (whole_state_.Due(cairn::msgs::SlowPartOf(m), now_s)) {
    // Link usage once a second: ~200 bytes that would otherwise ride on every whole state.
    if (now_s >= next_link_usage_s_) {
      next_link_usage_s_ = now_s + 1.0;
      AddLinkUsage(now_s, &m);
    }
    agent_link_->Publish(m);
  }
  agent_link_->Publish(pose);
}

void Telemetry::AddLinkUsage(double now_s, msgs::RobotState* state) {
  for (const SentRate& rate : link_usage_.Update(now_s, agent_link_->SentByClass())) {
    msgs::LinkClassUsage usage;
    usage.topic_class(rate.total.topic_class);
    usage.sent_kbps(rate.sent_kbps);
    usage.sent_bytes(rate.total.bytes);
    usage.sent_samples(rate.total.samples);
    state->link_usage().push_back(usage);
  }
}

void Telemetry::PublishTreeStateIfChanged() {
  const ValidActions valid = command_->ValidNow();
  const ModeManager& tree = modes_->tree();
  std::string signature = tree.mode() + "|" + tree.channel() + "|" + tree.last_refusal() + "|" +
                          (valid.goal_acceptable ? "goal" : "") +
                          (valid.explore_acceptable ? "|explore" : "");
  for (const auto& v : valid.modes) signature += "|" + v;
  if (signature == last_tree_signature_) return;
  last_tree_signature_ = signature;
  // Node statuses come from the last Request/Recheck trace (Step's), which ValidModes does not overwrite.
  msgs::BehaviorTreeState t;
  t.robot_id(robot_id_);
  t.stamp(cairn::msgs::WallStampNow());
  t.mode(tree.mode());
  t.active_channel(tree.channel());
  t.last_refusal(tree.last_refusal());
  t.valid_modes(valid.modes);
  t.goal_acceptable(valid.goal_acceptable);
  t.explore_acceptable(valid.explore_acceptable);
  t.tick_count(tree.tick_count());
  tree.tree().ForEachNode([&](const bt::TreeNode& node, int depth) {
    msgs::BtNodeState n;
    n.name(node.name());
    n.registration_id(node.registration_id());
    n.depth(static_cast<uint16_t>(depth));
    n.status(bt::ToString(tree.LastTickStatus(node)));
    t.nodes().push_back(n);
  });
  agent_link_->Publish(t);
}

void Telemetry::PublishGlobalPathIfChanged() {
  if (navigation_->path_revision() == published_path_revision_) return;
  published_path_revision_ = navigation_->path_revision();
  const nav::GlobalPlan& plan = navigation_->global_plan();
  msgs::GlobalPath m;
  m.robot_id(robot_id_);
  m.stamp(cairn::msgs::WallStampNow());
  m.goal_id(waypoint_->has_goal() ? waypoint_->goal().goal_id : 0);
  m.platform(nav_platform_);
  m.frame_id("map");
  if (waypoint_->has_goal()) {
    m.path_M(PathPoints(plan.result.path_W));
    m.length_m(plan.result.length_m);
  }
  m.map_version(plan.map_version);
  m.replans(static_cast<uint32_t>(navigation_->replans()));
  agent_link_->Publish(m);
}

void Telemetry::PublishLocalPlan() {
  if (!modes_->active().uses_local_planner()) return;
  const nav::LocalPlanResult& r = navigation_->local_result();
  const core::BaseState& pose = navigation_->local_pose();
  msgs::LocalPlan m;
  m.robot_id(robot_id_);
  m.stamp(cairn::msgs::WallStampNow());
  m.mode(modes_->mode());
  const std::string& status = navigation_->local_status();
  m.status(status == "path" ? "path" : status.rfind("boxed in", 0) == 0 ? "boxed in" : "stopped");
  m.reason(status);
  m.free_paths(static_cast<uint32_t>(r.num_free_paths));
  m.total_paths(static_cast<uint32_t>(navigation_->library().num_paths()));
  m.pose_MB(PoseOf(pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad));
  for (const auto& p : r.path_B) m.chosen_path_B().push_back(PointOf(p.x(), p.y(), 0.0));
  // End points of free paths, thinned to one per 0.5 m cell, to keep the message small (~1 kB).
  std::set<std::pair<int, int>> cells;
  for (int id = 0; id < navigation_->library().num_paths(); ++id) {
    if (!r.IsFree(id)) continue;
    const Eigen::Vector2f end = navigation_->library().info(id).end_B;
    if (cells
            .emplace(static_cast<int>(std::floor(end.x() / 0.5f)),
                     static_cast<int>(std::floor(end.y() / 0.5f)))
            .second) {
      m.free_path_ends_B().push_back(PointOf(end.x(), end.y(), 0.0));
    }
  }
  m.obstacle_points(static_cast<uint32_t>(r.num_points_used));
  m.cycle_time_ms(r.planning_time_s * 1000.0);
  agent_link_->Publish(m);
}

void Telemetry::PublishPerception(const perception::PerceptionOutput& out) {
  for (const perception::MapUpdate& update : out.map_messages) {
    msgs::MapUpdate m;
    m.robot_id(robot_id_);
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
    if (!agent_link_->Publish(m)) {
      spdlog::warn("robot {}: map update seq {} not written (history full)", robot_id_, update.seq);
    }
  }
  for (const perception::StaircaseRegistry::Entry& entry : out.staircases) {
    const perception::Staircase& s = entry.staircase;
    msgs::StaircaseDetection m;
    m.robot_id(robot_id_);
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
    agent_link_->Publish(m);
    spdlog::info(
        "robot {}: staircase {} at ({:.2f}, {:.2f}, {:.2f}) yaw {:.2f}: {} steps, rise {:.3f} m, run {:.3f} "
        "m, "
        "width {:.2f} m ({} detections)",
        robot_id_, entry.id, s.p_W_first_step.x(), s.p_W_first_step.y(), s.p_W_first_step.z(), s.yaw_rad,
        s.num_steps, s.rise_m, s.run_m, s.width_m, entry.detections);
  }
  if (out.camera) {
    msgs::CompressedImage m;
    m.robot_id(robot_id_);
    m.stamp(cairn::msgs::WallStampNow());
    m.seq(out.camera->seq);
    m.frame_id("camera");
    m.format("jpeg");
    m.width_px(static_cast<uint16_t>(out.camera->width_px));
    m.height_px(static_cast<uint16_t>(out.camera->height_px));
    m.pose_MC(PoseOf(out.camera->T_W_C));
    m.data(out.camera->jpeg);
    agent_link_->Publish(m);  // keep-last 1: an unsent frame is replaced by this one (dropped, never queued)
  }
}

}  // namespace cairn::agent
