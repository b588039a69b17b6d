#include "cairn/agent/modes/robot_modes.h"

#include <spdlog/spdlog.h>

#include <random>
#include <stdexcept>
#include <utility>

#include "cairn/agent/modes/mission.h"
#include "cairn/agent/modes/modes.h"
#include "cairn/agent/modes/waypoint_recovery.h"

namespace cairn::agent {

namespace {

RobotModes::Hooks Checked(RobotModes::Hooks hooks) {
  if (!hooks.conditions || !hooks.clear_obstacle_memory || !hooks.mission_commands || !hooks.grid ||
      !hooks.clock)
    throw std::invalid_argument("RobotModes: a hook is not set");
  return hooks;
}

}  // namespace

RobotModes::RobotModes(const AgentOptions& options, const std::string& tree_file, nav::Navigation* navigation,
                       Hooks hooks, Ids ids)
    : robot_id_(options.robot_id), navigation_(navigation), hooks_(Checked(std::move(hooks))) {
  if (navigation_ == nullptr) throw std::invalid_argument("RobotModes: navigation is null");
  control_ =
      std::make_unique<ModeControl>(tree_file, MakeModules(options, tree_file, ids), robot_id_, hooks_.clock);
  const MissionResumption::RequestMode request_mode = [this](const std::string& mode) {
    return Request(mode);
  };
  missions_ = std::make_unique<MissionResumption>(
      robot_id_, options.mission,
      MissionResumption::Modes{control_.get(), waypoint_, explore_, convoy_, yield_, navigation_},
      request_mode);
  yielding_ = std::make_unique<YieldCoordination>(
      robot_id_, options.yield, options.navigation.platform.footprint_radius_m, yield_, missions_.get(),
      navigation_, hooks_.grid, request_mode, hooks_.mission_commands);
}

RobotModes::~RobotModes() {
  if (missions_) missions_->Abandon();
}

ModeRegistry RobotModes::MakeModules(const AgentOptions& options, const std::string& tree_file, Ids ids) {
  auto recovery = [&] {
    return std::make_unique<WaypointRecovery>(tree_file, navigation_,
                                              WaypointRecovery::Hooks{hooks_.clear_obstacle_memory});
  };
  std::unique_ptr<WaypointRecovery> waypoint_recovery = recovery();
  if (!waypoint_recovery->enabled()) {
    spdlog::warn(
        "robot {}: the mode tree file has no {} tree: a blocked waypoint goal fails without recovery",
        robot_id_, WaypointRecovery::kTreeId);
  }
  std::random_device entropy;  // goal ids of a restarted robot do not repeat old ones
  auto first_id = [&] {
    return ids == Ids::kRandom ? std::uniform_int_distribution<uint32_t>(1, 1u << 30)(entropy) : 1u;
  };
  WaypointModeOptions waypoint;
  waypoint.robot_id = robot_id_;
  waypoint.channel_timeout_s = options.waypoint_timeout_s;
  waypoint.contact_timeout_s = options.contact_timeout_s;
  waypoint.first_goal_id = first_id();
  ExploreModeOptions explore = options.explore;
  explore.robot_id = robot_id_;
  explore.platform_max_step_m = options.navigation.platform.traversability.max_step_m;
  explore.channel_timeout_s = options.waypoint_timeout_s;
  explore.contact_timeout_s = options.contact_timeout_s;
  explore.first_task_id = first_id();
  ModeRegistry modules;
  modules.Emplace<IdleMode>();
  modules.Emplace<ManualMode>(options.teleop_timeout_s);
  modules.Emplace<SmartJoystickMode>(navigation_, options.waypoint_timeout_s, options.teleop_timeout_s);
  waypoint_ = &modules.Emplace<WaypointMode>(waypoint, navigation_, std::move(waypoint_recovery));
  explore_ = &modules.Emplace<ExploreMode>(explore, navigation_, recovery());
  convoy_ = &modules.Emplace<ConvoyMode>(options.convoy, options.waypoint_timeout_s, navigation_);
  yield_ = &modules.Emplace<YieldMode>(options.yield, options.waypoint_timeout_s, navigation_);
  return modules;
}

ModeDecision RobotModes::Request(const std::string& mode) {
  return control_->Request(mode, hooks_.conditions());
}

GoalStart RobotModes::StartGoal(const nav::GlobalPlan& plan, double x_m, double y_m, double tolerance_m,
                                double z_m, double now_s) {
  return waypoint_->Start(plan, x_m, y_m, tolerance_m, z_m, now_s,
                          [this] { return Request(waypoint_->name()); });
}

std::string RobotModes::StartExplore(const ExploreTask& task, double now_s) {
  return explore_->Start(task, now_s, [this] { return Request(explore_->name()); });
}

std::string RobotModes::StartConvoy(const std::vector<std::string>& ahead_ids,
                                    const std::vector<Peer>& live_peers, double now_s) {
  const bool was_following = convoy_->active() && control_->mode() == convoy_->name();
  std::string refused = convoy_->Start(robot_id_, ahead_ids, now_s);
  if (!refused.empty()) return refused;
  convoy_->SetPeers(live_peers, now_s);
  if (was_following) return "";
  const ModeDecision d = Request(convoy_->name());
  if (!d.accepted) convoy_->Deactivate(d.reason);
  return d.accepted ? "" : d.reason;
}

Peer RobotModes::AsPeer(const core::BaseState& pose_M) const {
  Peer self;
  static_cast<nav::PeerBody&>(self) = navigation_->AsPeer(robot_id_, pose_M);
  self.mode = control_->mode();
  const YieldStatus& yield = yield_->status();
  if (yield.state != YieldStatus::State::kNone) {
    self.yield_state = ToString(yield.state);
    self.yield_to_id = yield.peer_id;
    self.yield_reason = yield.reason;
  }
  return self;
}

void RobotModes::Recheck(double now_s) {
  std::optional<PausedMission> running = missions_->Running(now_s);
  const ModeDecision recheck = control_->Recheck(hooks_.conditions());
  if (recheck.accepted) return;
  spdlog::warn("robot {}: {} -> idle", robot_id_, recheck.reason);
  // A condition that clears by itself (a component restarting, localization lost) pauses the mission.
  if (running && IsTransientFailure(recheck.reason))
    missions_->Pause(std::move(*running), FailedCondition(recheck.reason), hooks_.mission_commands());
}

bool RobotModes::GoalAcceptable() {
  ModeConditions with_goal = hooks_.conditions();
  with_goal.has_waypoint_goal = true;
  return control_->IsValid(waypoint_->name(), with_goal);
}

void RobotModes::Step(const ModeInputs& in, const YieldCoordination::Robot& robot, const ExploreTeam& team) {
  // The team: what peers go for and have seen shapes the choice of frontier.
  explore_->SetPeerClaims(team.LiveClaims(in.now_s));
  explore_->SetTeamView(team.ExploringPeers(in.now_s), team.PeerSeenM2());
  convoy_->SetPeers(*robot.peers, in.now_s);  // the robot followed extends the trail
  yield_->SetPeers(*robot.peers, in.now_s);   // the robot let past goes by
  yielding_->AskPeers(robot);
  if (control_->Step(in)) control_->GoIdle(hooks_.conditions());  // the task ended (a goal arrived or failed)
  missions_->Step(in.now_s, in.pose_M, *robot.peers, hooks_.mission_commands(),
                  [this] { return GoalAcceptable(); });
}

void RobotModes::OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) {
  if (control_->OnPlatformStatus(status, in))
    control_->GoIdle(hooks_.conditions());  // e.g. blocked in contact
}

void RobotModes::StopKeepingMission(const std::string& why, double now_s) {
  std::optional<PausedMission> running = missions_->Running(now_s);
  try {
    control_->Stop(why);
  } catch (const std::exception& e) {
    spdlog::error("robot {}: cannot go idle: {}", robot_id_, e.what());
  }
  // After the mode has left: a convoy place is kept by the pause, not dropped by leaving the mode.
  if (running) missions_->Pause(std::move(*running), why, hooks_.mission_commands());
}

}  // namespace cairn::agent
