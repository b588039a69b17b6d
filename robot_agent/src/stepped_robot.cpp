#include "cairn/agent/stepped_robot.h"

#include <chrono>
#include <limits>
#include <stdexcept>

#include "cairn/agent/modes/waypoint_recovery.h"
#include "cairn/agent/services/planning_service.h"
#include "cairn/nav/frontier.h"

namespace cairn::agent {

namespace {

std::shared_ptr<core::PlatformIO> Checked(std::shared_ptr<core::PlatformIO> platform) {
  if (!platform) throw std::invalid_argument("SteppedRobot: platform is null");
  return platform;
}

core::BaseState StartPose(core::PlatformIO& platform) {
  platform.Update(0.0);
  return platform.ReadPose().PlanarState();
}

core::SteadyTime AsSteady(double now_s) {
  return core::SteadyTime{} +
         std::chrono::duration_cast<core::SteadyClock::duration>(std::chrono::duration<double>(now_s));
}

}  // namespace

SteppedRobot::SteppedRobot(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform,
                           const std::string& tree_file)
    : options_(options),
      platform_(Checked(std::move(platform))),
      team_(options.robot_id, options.explore.team),
      peers_(options.robot_id, options.peers) {
  const core::BaseState start_M = StartPose(*platform_);
  pose_M_ = start_M;
  // On a simulated clock a wall-clock budget would make the map depend on how busy the machine is: every
  // changed tile is read in the update it arrives with (the largest budget).
  options_.nav_map.update_budget_s = 10.0;
  PerceptionOptions perception = options_.perception;
  perception.camera_rate_hz = 0;
  perception_ = std::make_unique<PerceptionPipeline>(perception, options_.robot_id);
  planner_ = NavMap::MakePlanner(options_.nav_map, perception.map.resolution_m, start_M,
                                 {options_.navigation.platform});
  nav_map_ = std::make_unique<NavMap>(options_.nav_map, perception.map.resolution_m, start_M, planner_,
                                      options_.navigation.platform.name);
  navigation_ = std::make_unique<Navigation>(
      options_.navigation, planner_,
      std::make_shared<const nav::TrajectoryLibrary>(options_.LibraryForPlatform()));
  live_obstacles_ = std::make_unique<LiveObstacles>(options_.navigation, options_.obstacle_window_s,
                                                    platform_->Capabilities().lidar_min_elevation_rad);
  std::unique_ptr<WaypointRecovery> recovery;
  if (!tree_file.empty()) {
    recovery = std::make_unique<WaypointRecovery>(
        tree_file, navigation_.get(), WaypointRecovery::Hooks{[this] { live_obstacles_->Clear(); }});
  }
  ExploreModeOptions explore = options_.explore;
  explore.robot_id = options_.robot_id;
  explore.platform_max_step_m = options_.navigation.platform.traversability.max_step_m;
  explore_ = std::make_unique<ExploreMode>(explore, navigation_.get(), std::move(recovery));
  WaypointModeOptions waypoint;
  waypoint.robot_id = options_.robot_id;
  waypoint_ = std::make_unique<WaypointMode>(waypoint, navigation_.get(), nullptr);
  convoy_ = std::make_unique<ConvoyMode>(options_.convoy, waypoint.channel_timeout_s, navigation_.get());
  yield_ = std::make_unique<YieldMode>(options_.yield, waypoint.channel_timeout_s, navigation_.get());
  yield_asker_ = std::make_unique<YieldAsker>(options_.yield, options_.robot_id);
  active_ = explore_.get();
  next_map_update_s_ = options_.nav_map.update_period_s;
}

std::optional<ExploreClaim> SteppedRobot::ClaimToSend(double now_s) {
  return DueClaim(*explore_, team_, now_s, [this] {
    return std::optional<nav::CoverageBitmap>(
        nav::SeenCoverage(nav_map_->grid(), team_.options().coverage_cell_m));
  });
}

std::string SteppedRobot::mode() const {
  const bool busy = active_ == explore_.get()    ? explore_->exploring()
                    : active_ == waypoint_.get() ? waypoint_->has_goal()
                    : active_ == yield_.get()    ? yield_->active()
                                                 : convoy_->active();
  return busy ? active_->name() : std::string("idle");
}

PeerBody SteppedRobot::PeerState() const {
  PeerBody self = navigation_->AsPeer(options_.robot_id, pose_M_, mode());
  const YieldStatus& yield = yield_->status();
  if (yield.state != YieldStatus::State::kNone) {
    self.yield_state = ToString(yield.state);
    self.yield_to_id = yield.peer_id;
    self.yield_reason = yield.reason;
  }
  return self;
}

std::optional<std::pair<std::string, YieldCommand>> SteppedRobot::YieldRequestToSend() {
  auto request = std::move(yield_to_send_);
  yield_to_send_.reset();
  return request;
}

std::string SteppedRobot::OnYieldRequest(const YieldCommand& request, double now_s) {
  if (std::string why = CheckYieldCommand(request); !why.empty()) return why;
  const std::shared_ptr<const nav::TraversabilityGrid> grid =
      planner_->Grid(options_.navigation.platform.name);
  const double radius_m = options_.navigation.platform.footprint_radius_m;
  if (yield_->InTheWayOf(request)) {  // aside, but the route now runs by the spot: on to another one
    const YieldDecision moved =
        DecideYield(options_.yield, request,
                    YieldSituation{options_.robot_id, "idle", pose_M_, radius_m, grid.get(), {}, false, ""});
    return moved.accepted && yield_->MoveOn(request, moved.spot, now_s) ? "" : moved.refusal;
  }
  if (yield_->active()) return yield_->passing_id() == request.passing_id ? "" : "already yielding";
  const std::string now_mode = mode();
  const YieldSituation situation =
      WithPeerAndHistory(YieldSituation{options_.robot_id, now_mode, pose_M_, radius_m, grid.get(),
                                        yield_asker_->status(), false, ""},
                         request, peers_.Live(now_s), *yield_, now_s);
  const YieldDecision d = DecideYield(options_.yield, request, situation);
  if (d.ignore) return d.refusal;
  if (!d.accepted) {
    yield_->Refuse(request.passing_id, d.refusal, now_s);
    return d.refusal;
  }
  yield_resume_goal_.reset();
  if (now_mode == WaypointMode::kName) yield_resume_goal_ = waypoint_->goal();
  before_yield_ = active_;
  yield_->Start(request, d.spot, pose_M_, d.clearance_m, /*return_home=*/now_mode == "idle", now_s);
  if (active_ != yield_.get()) active_->Deactivate("getting out of the way");
  active_ = yield_.get();
  return "";
}

// As in the agent (ModeControl), the mode taking over starts first (its goal set), then the one it replaces
// is deactivated.
std::string SteppedRobot::Explore(const ExploreTask& task, double now_s) {
  const std::string why = explore_->Start(task, now_s, [] {
    return ModeDecision{true, ExploreMode::kName, ExploreMode::kChannel, ""};
  });
  if (!why.empty()) return why;
  if (active_ != explore_.get()) active_->Deactivate("exploring instead");
  active_ = explore_.get();
  return "";
}

std::string SteppedRobot::Goto(double x_m, double y_m, double now_s) {
  const nav::GlobalPlan plan = navigation_->PlanGoalAsync(pose_M_, x_m, y_m).get();
  if (!plan.IsUsable()) return GoalPlanReason(options_.robot_id, plan, {x_m, y_m});
  const GoalStart start =
      waypoint_->Start(plan, x_m, y_m, 0.0, std::numeric_limits<double>::quiet_NaN(), now_s, [] {
        return ModeDecision{true, WaypointMode::kName, WaypointMode::kChannel, ""};
      });
  if (!start.accepted) return start.reason;
  if (active_ != waypoint_.get()) active_->Deactivate("driving to a waypoint instead");
  active_ = waypoint_.get();
  return "";
}

std::string SteppedRobot::Follow(const std::vector<std::string>& ahead_ids, double now_s) {
  const std::string why = convoy_->Start(options_.robot_id, ahead_ids, now_s);
  if (!why.empty()) return why;
  if (active_ != convoy_.get()) active_->Deactivate("following in a convoy instead");
  active_ = convoy_.get();
  return "";
}

void SteppedRobot::Step(double now_s) {
  using WallClock = std::chrono::steady_clock;
  auto since = [](WallClock::time_point start) {
    return std::chrono::duration<double>(WallClock::now() - start).count();
  };
  auto start = WallClock::now();
  platform_->Update(now_s);
  const core::BaseState pose = platform_->ReadPose().PlanarState();
  pose_M_ = pose;
  const bool has_scan = platform_->ReadLidarScan(now_s, &scan_);
  timing_.platform_s += since(start);
  start = WallClock::now();
  if (has_scan) {
    core::BaseState at_scan;
    live_obstacles_->AddScan(scan_, &points_B_, &at_scan);
    navigation_->SetPeers(peers_.Live(now_s), peers_.options());  // peers are obstacles too
    navigation_->SetObstacles(points_B_, at_scan, now_s);
    perception_->Tick(now_s, &scan_, nullptr);
  }
  perception_->set_refresh_at_rest(explore_->exploring());
  timing_.perception_s += since(start);
  if (now_s >= next_map_update_s_) {
    start = WallClock::now();
    next_map_update_s_ += options_.nav_map.update_period_s;
    nav_map_->Update(*perception_->map(), perception_->TakeChangedTiles(), perception_->change_tile_m(),
                     perception_->max_sensor_z_m(), perception_->Staircases());
    timing_.nav_map_s += since(start);
    if (const auto search = explore_->frontier_search()) {
      start = WallClock::now();
      const std::shared_ptr<const nav::PeerCoverage> peers = team_.Coverage();
      nav::FrontierSet set =
          nav_map_->Frontiers({pose.x_m, pose.y_m, pose.z_m}, *search, explore_->every_level(), peers.get());
      frontier_search_s_ += since(start);
      ++frontier_searches_;
      explore_->OnFrontiers(std::move(set), now_s);
    }
  }
  start = WallClock::now();
  explore_->SetPeerClaims(team_.LiveClaims(now_s));
  explore_->SetTeamView(team_.ExploringPeers(now_s), team_.PeerSeenM2());
  const std::vector<PeerBody> live = peers_.Live(now_s);
  convoy_->SetPeers(live, now_s);
  yield_->SetPeers(live, now_s);
  // As the agent: a robot driving a goal asks a peer that blocks it in a narrow passage to yield.
  const std::string now_mode = mode();
  YieldAsk ask = yield_asker_->Update(AskInputs(
      options_.yield, now_mode, *navigation_, pose, options_.navigation.platform.footprint_radius_m, live,
      [this] { return planner_->Grid(options_.navigation.platform.name); }, now_s));
  navigation_->SetHold(ask.hold_reason, yield_asker_->status().peer_id);
  if (ask.request) yield_to_send_ = std::make_pair(ask.to_id, std::move(*ask.request));
  const ModeInputs in{AsSteady(now_s), now_s, pose};
  ModeOutput out = active_->Step(in);
  if (active_ == yield_.get() && yield_->TakeFinished()) {
    // Back to what the yield interrupted: the goal planned again from here, or idle where it stood.
    active_ = before_yield_ != nullptr ? before_yield_ : explore_.get();
    if (yield_resume_goal_) {
      const WaypointGoal goal = *yield_resume_goal_;
      yield_resume_goal_.reset();
      Goto(goal.x_m, goal.y_m, now_s);
    }
  }
  const Twist2 twist = out.twist_B.value_or(Twist2{0.0, 0.0});
  platform_->CommandTwist(twist.linear_x_mps, twist.angular_z_radps, now_s);
  const core::PlatformStatus status = platform_->ReadStatus();
  ever_in_contact_ = ever_in_contact_ || status.in_contact;
  active_->OnPlatformStatus(status, in);
  timing_.explore_s += since(start);
}

}  // namespace cairn::agent
