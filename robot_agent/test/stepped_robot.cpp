#include "stepped_robot.h"

#include <chrono>
#include <limits>
#include <stdexcept>

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

std::string TreeFileOrDefault(const std::string& tree_file) {
  return tree_file.empty() ? std::string(CAIRN_CONFIG_DIR) + "/mode_tree.xml" : tree_file;
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
  perception::PerceptionOptions perception = options_.perception;
  perception.camera_rate_hz = 0;
  perception_ = std::make_unique<perception::PerceptionPipeline>(perception, options_.robot_id);
  planner_ = NavMap::MakePlanner(options_.nav_map, perception.map.resolution_m, start_M,
                                 {options_.navigation.platform});
  nav_map_ = std::make_unique<NavMap>(options_.nav_map, perception.map.resolution_m, start_M, planner_,
                                      options_.navigation.platform.name);
  navigation_ = std::make_unique<Navigation>(
      options_.navigation, planner_,
      std::make_shared<const nav::TrajectoryLibrary>(options_.LibraryForPlatform()));
  live_obstacles_ = std::make_unique<LiveObstacles>(options_.navigation, options_.obstacle_window_s,
                                                    platform_->Capabilities().lidar_min_elevation_rad);
  RobotModes::Hooks hooks;
  hooks.conditions = [this] { return Conditions(); };
  hooks.clear_obstacle_memory = [this] { live_obstacles_->Clear(); };
  hooks.mission_commands = [this] { return mission_commands_; };
  hooks.grid = [this] { return planner_->Grid(options_.navigation.platform.name); };
  hooks.clock = clock_;
  modes_ = std::make_unique<RobotModes>(options_, TreeFileOrDefault(tree_file), navigation_.get(),
                                        std::move(hooks), RobotModes::Ids::kFromOne);
  next_map_update_s_ = options_.nav_map.update_period_s;
  // The sensors read once at time 0, as a running agent has them before an operator commands it (the mode
  // tree takes a mission only with obstacle input).
  StepPerception(0.0);
}

ModeConditions SteppedRobot::Conditions() const {
  ModeConditions c;
  c.holder_id = "operator";
  c.holder_alive = true;
  c.localized = localized_;
  c.has_waypoint_goal = modes_->waypoint().has_goal();
  c.local_planner_healthy = navigation_->ObstacleSensingAlive(now_s_, &c.local_planner_problem);
  c.mapping_healthy = true;
  c.has_explore_task = modes_->explore().exploring();
  c.has_convoy_task = modes_->convoy().active();
  c.has_yield_task = modes_->yield().active();
  return c;
}

std::optional<ExploreClaim> SteppedRobot::ClaimToSend(double now_s) {
  return DueClaim(modes_->explore(), team_, now_s, [this] {
    return std::optional<nav::CoverageBitmap>(
        nav::SeenCoverage(nav_map_->grid(), team_.options().coverage_cell_m));
  });
}

std::string SteppedRobot::OnYieldRequest(const YieldCommand& request, double now_s) {
  YieldOrigin origin;
  origin.peer_robot = true;  // handed in from the robot that sent it, whose states this robot hears
  const std::vector<PeerBody> live = peers_.Live(now_s);
  modes_->yielding().OnRequest(request, origin, "", {now_s, mode(), pose_M_, &live, true});
  const YieldMode& yield = modes_->yield();
  if (yield.active() && yield.passing_id() == request.passing_id) return "";
  return yield.status().reason.empty() ? "not accepted" : yield.status().reason;
}

// As the agent's command interface: the mode taking over starts first (its goal set), then the mode tree
// switches to it and the one it replaces is deactivated.
std::string SteppedRobot::Explore(const ExploreTask& task, double now_s) {
  ++mission_commands_;
  return modes_->StartExplore(task, now_s);
}

std::string SteppedRobot::Goto(double x_m, double y_m, double now_s) {
  ++mission_commands_;
  const nav::GlobalPlan plan = navigation_->PlanGoalAsync(pose_M_, x_m, y_m).get();
  if (!plan.IsUsable()) return GoalPlanReason(options_.robot_id, plan, {x_m, y_m});
  const GoalStart start =
      modes_->StartGoal(plan, x_m, y_m, 0.0, std::numeric_limits<double>::quiet_NaN(), now_s);
  return start.accepted ? "" : start.reason;
}

std::string SteppedRobot::Follow(const std::vector<std::string>& ahead_ids, double now_s) {
  ++mission_commands_;
  return modes_->StartConvoy(ahead_ids, peers_.Live(now_s), now_s);
}

void SteppedRobot::StepPerception(double now_s) {
  using WallClock = std::chrono::steady_clock;
  auto since = [](WallClock::time_point start) {
    return std::chrono::duration<double>(WallClock::now() - start).count();
  };
  auto start = WallClock::now();
  platform_->Update(now_s);
  const core::PoseEstimate estimate = platform_->ReadPose();
  pose_M_ = estimate.PlanarState();
  localized_ = estimate.healthy;
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
  ExploreMode& explore = modes_->explore();
  perception_->set_refresh_at_rest(modes_->waypoint().has_goal() || explore.exploring());
  timing_.perception_s += since(start);
  if (now_s < next_map_update_s_) return;
  start = WallClock::now();
  next_map_update_s_ += options_.nav_map.update_period_s;
  nav_map_->Update(*perception_->map(), perception_->TakeChangedTiles(), perception_->change_tile_m(),
                   perception_->max_sensor_z_m(), perception_->Staircases());
  timing_.nav_map_s += since(start);
  if (const auto search = explore.frontier_search()) {
    start = WallClock::now();
    const std::shared_ptr<const nav::PeerCoverage> peers = team_.Coverage();
    nav::FrontierSet set = nav_map_->Frontiers({pose_M_.x_m, pose_M_.y_m, pose_M_.z_m}, *search,
                                               explore.every_level(), peers.get());
    frontier_search_s_ += since(start);
    ++frontier_searches_;
    explore.OnFrontiers(std::move(set), now_s);
  }
}

void SteppedRobot::Step(double now_s) {
  clock_->SetSeconds(now_s);
  now_s_ = now_s;
  StepPerception(now_s);
  const auto start = std::chrono::steady_clock::now();
  // The agent's control cycle, as RobotAgent runs it: re-check, the modes' step, the mux, the driver.
  modes_->Recheck(now_s);
  const ModeInputs in{clock_->Now(), now_s, pose_M_};
  const std::vector<PeerBody> live = peers_.Live(now_s);
  modes_->Step(in, {now_s, mode(), pose_M_, &live, true}, team_);
  const Twist2 twist = modes_->control().Compute(in.now).twist_B;
  platform_->CommandTwist(twist.linear_x_mps, twist.angular_z_radps, now_s);
  const core::PlatformStatus status = platform_->ReadStatus();
  ever_in_contact_ = ever_in_contact_ || status.in_contact;
  modes_->OnPlatformStatus(status, in);
  timing_.explore_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace cairn::agent
