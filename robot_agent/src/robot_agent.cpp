// RobotAgent: the composition of one robot's components (docs/AGENT.md): the mode tree running the mode
// modules through the mux (ModeControl), the command interface, navigation and its planning service,
// perception, the telemetry and the DDS adapter. They run as core::Components (agent_components.h) watched by
// a core::HealthMonitor, which restarts one that throws or stalls alone: the control cycle (Run, 50 Hz; its
// parts command_interface, mode_tree, mux, navigation, telemetry), and the threads of platform (sensor),
// perception (perception, navigation map) and planning. One lock (mutex_) serialises the control loop, the
// DDS handlers and the planning thread's goal answers; the components themselves are not thread-safe unless
// they say so.
#include "cairn/agent/robot_agent.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <future>
#include <map>
#include <mutex>
#include <thread>

#include "cairn/agent/agent_components.h"
#include "cairn/agent/command/command_interface.h"
#include "cairn/agent/communication/agent_dds.h"
#include "cairn/agent/communication/health_report.h"
#include "cairn/agent/communication/telemetry.h"
#include "cairn/agent/journal.h"
#include "cairn/agent/modes/come_home.h"
#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mission.h"
#include "cairn/agent/modes/mission_resumption.h"
#include "cairn/agent/modes/mode_control.h"
#include "cairn/agent/modes/robot_modes.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/agent/services/perception_service.h"
#include "cairn/agent/services/planning_service.h"
#include "cairn/agent/services/trajectory_library_cache.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/agent/team/yield_coordination.h"
#include "cairn/agent/team/yield_sender.h"
#include "cairn/core/build_paths.h"
#include "cairn/core/health_monitor.h"
#include "cairn/core/peer_input.h"
#include "cairn/core/range_check.h"
#include "cairn/core/shutdown.h"
#include "cairn/nav/navigation.h"
#include "cairn_msgs.h"

namespace cairn::agent {

using core::SteadyClock;
using core::SteadyTime;

namespace {

constexpr double kLoopPeriodS = 0.02;  // 50 Hz: mux staleness is acted on within 20 ms
constexpr const char* kVersion = "0.1.0";

std::string DefaultTreeFile() { return core::ConfigDir() + "/mode_tree.xml"; }

// The planner on the robot's own map (see NavMap), empty at start.
std::shared_ptr<nav::GlobalPlanner> MakePlanner(const AgentOptions& options, const core::BaseState& start_M) {
  // Serves its own (possibly re-configured) platform and the other built-in ones, for peers that ask.
  std::vector<nav::PlatformProfile> profiles = {options.navigation.platform};
  for (const auto& name : nav::PlatformNames()) {
    if (name != options.navigation.platform.name) profiles.push_back(nav::GetPlatformProfile(name));
  }
  return NavMap::MakePlanner(options.nav_map, options.perception.map.resolution_m, start_M,
                             std::move(profiles));
}

std::shared_ptr<AgentLink> MakeDds(const AgentOptions& options) {
  AgentDdsOptions dds;
  dds.robot_id = options.robot_id;
  dds.domain_id = options.domain_id;
  dds.profiles_file = options.dds_profiles_file;
  dds.link = options.link;
  dds.security = options.security;
  // Map telemetry budgets itself (PerceptionOptions::telemetry); the flow controller is a backstop 25 % above
  // it. Camera frames rely on theirs: a frame that cannot go out in time is replaced by the next.
  dds.map_budget_bits_per_s = options.perception.telemetry.budget_bits_per_s * 1.25;
  dds.camera_budget_bits_per_s = options.perception.camera_budget_bits_per_s;
  return std::make_shared<AgentDds>(dds);
}

// The local planner's library, from the cache when it has it (trajectory_library_cache.h).
std::shared_ptr<const nav::TrajectoryLibrary> LocalPlannerLibrary(const AgentOptions& options) {
  CachedLibrary cached = LoadOrBuildTrajectoryLibrary(options.LibraryForPlatform(),
                                                      TrajectoryLibraryCacheDir(options.library_cache_dir));
  if (cached.cache_failed) {
    spdlog::warn("robot {}: local planner library {}", options.robot_id, cached.how);
  } else {
    spdlog::info("robot {}: local planner library {}", options.robot_id, cached.how);
  }
  return std::move(cached.library);
}

// A stepped agent's options: every changed tile is read in the navigation map update it arrives with (the
// largest budget), since on a simulated clock a wall-clock budget would make the map depend on how busy the
// machine is.
AgentOptions Hosted(AgentOptions options, bool stepped) {
  if (stepped) options.nav_map.update_budget_s = 10.0;
  return options;
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

// Control-loop periods (control thread): the worst of the current and the previous 10 s window.
struct PeriodWindow {
  SteadyTime last_start{};
  SteadyTime window_start{};
  double current_max_ms = 0.0;
  double previous_max_ms = 0.0;
  void Note(SteadyTime start) {
    if (last_start != SteadyTime{}) {
      current_max_ms = std::max(current_max_ms, 1000 * core::SecondsBetween(last_start, start));
    }
    last_start = start;
    if (window_start == SteadyTime{}) window_start = start;
    if (core::SecondsBetween(window_start, start) >= 10.0) {
      previous_max_ms = current_max_ms;
      current_max_ms = 0.0;
      window_start = start;
    }
  }
  double WorstMs() const { return std::max(current_max_ms, previous_max_ms); }
};

}  // namespace

class RobotAgent::Impl {
 public:
  // Where the agent runs: both null for the shipping agent (DDS, the machine's clock, Run()); both set for a
  // stepped one (RobotAgent::Stepped).
  struct Hosting {
    std::shared_ptr<AgentLink> link;
    std::shared_ptr<core::SimulatedClock> clock;
  };
  Impl(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform, Hosting hosting);
  ~Impl() {
    if (link_) link_->StopListening();  // no handler runs while the rest goes (the handlers use link_ too)
    if (parts_.monitor) parts_.monitor->StopAll();  // the component threads end before what they use
    ExitIfWorkStillRuns();
    link_.reset();
    come_home_.Abandon(navigation_);
    if (modes_) modes_->missions().Abandon();
  }
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  void Run(const std::function<void()>& on_started);
  // A stepped agent's cycle with its clock at `clock_s` (RobotAgent::Step).
  void StepOnce(double clock_s);
  bool planning() const { return modes_->explore().planning() || modes_->missions().planning(); }
  bool stepped() const { return time_.lockstep.has_value(); }
  const RobotModes& modes() const { return *modes_; }
  const nav::Navigation& navigation() const { return navigation_; }
  const NavMap& nav_map() const { return perception_->nav_map(); }
  bool restart_requested() const { return health_.restart_requested.load(); }
  // What of the threaded components' work did not stop when asked ("" = nothing). Their transitions' thread
  // (the health monitor's, or after StopAll() any).
  std::string WorkStillRunning() const {
    std::string running;
    for (core::Component* c : {static_cast<core::Component*>(parts_.platform.get()),
                               static_cast<core::Component*>(parts_.perception.get()),
                               static_cast<core::Component*>(parts_.planning.get())}) {
      if (c == nullptr) continue;
      if (const std::string r = c->StillRunning(); !r.empty())
        running += (running.empty() ? "" : "; ") + c->name() + ": " + r;
    }
    return running;
  }
  // A loop that did not stop still uses what the agent is about to free (its map, planner, DDS writers): the
  // process ends here instead, as at a crash (the journal has the last safe state).
  void ExitIfWorkStillRuns() const {
    const std::string running = WorkStillRunning();
    if (running.empty()) return;
    spdlog::error("robot {}: {}; leaving the process without tearing down", options_.robot_id, running);
    spdlog::default_logger()->flush();
    std::_Exit(health_.restart_requested ? RobotAgent::kRestartExitStatus : 0);
  }

 private:
  // The command interface's hooks into the modes, the planning service and the DDS adapter.
  CommandInterface::Hooks CommandHooks();
  // The DDS adapter's handlers: each applies a message to its component under mutex_.
  AgentDdsHandlers DdsHandlers();
  // With mutex_ held: drives a goal planned for the lock's holder (the command interface's start_goal).
  CommandOutcome StartGoal(const GoalCommand& goal, const nav::GlobalPlan& plan);
  // With mutex_ held: the mode tree's facts now.
  ModeConditions Conditions() const;
  // Control cycles between two publications of the state, the local plan and the peer state.
  struct CycleRates {
    int state = 1;
    int local_plan = 1;
    int peer_state = 1;
  };
  // The cycle rates of the options (state, local plan, peer state).
  CycleRates Rates() const {
    auto cycles_per = [](double rate_hz) {
      return std::max(1, static_cast<int>(std::lround(1.0 / (rate_hz * kLoopPeriodS))));
    };
    return {cycles_per(options_.state_rate_hz), cycles_per(options_.local_plan_rate_hz),
            cycles_per(options_.peers.rate_hz)};
  }
  // What a control cycle hands out, sent once the agent lock is released: Fast DDS hands a sample to this
  // participant's own readers on the writing thread, and their callbacks take the agent lock.
  struct CycleOutbox {
    std::optional<ExploreClaim> claim;
    std::optional<std::pair<std::string, YieldCommand>> yield_request;  // to the robot named first
    bool listen_to_peers = false;                                       // start reading the peers' states
  };
  // With mutex_ held: control cycle `cycle` (Step), woken at `wanted`, and what is due after it: the journal,
  // the state, the local plan, the peer state, the tree's state, a yield request that waited for the peers.
  CycleOutbox LockedCycle(uint64_t cycle, SteadyTime wanted, const CycleRates& every);
  // Without mutex_: sends what the cycle handed out, and starts reading the peers when asked.
  void SendOutbox(CycleOutbox out);
  // After the control loop: the last health and state, the claim let go, the components stopped and the map
  // flushed and saved, the pose sent meanwhile.
  void Leave();
  // With mutex_ held: one control cycle (mode re-check, pose, obstacles, the running mode, the mux, the
  // driver).
  void Step(SteadyTime now);
  // With mutex_ held: the robot as its platform reports it: pose estimate (SLAM), health. A platform call
  // that throws takes the platform component down (its restart re-reads the sensors) and returns false.
  bool ReadPose(double now_s);
  // With mutex_ held, as the navigation component: live obstacles and peers, the explore mode's frontiers and
  // team, yields asked of peers, the running mode's step, the paused mission, coming home, the claim due.
  void StepNavigation(SteadyTime now, const ModeInputs& inputs);
  // With mutex_ held: a part of the driving chain is down; the robot leaves its mode, its mission paused.
  void LeaveModeForADownChain(double now_s);
  // On a radio link: the robots on it share its bulk budget (map telemetry, camera), so a robot's share is
  // 1 / n of what one robot alone would send (AgentOptions::ApplyLinkBudget). Control thread, once a second.
  void ShareRadioLink();
  // With mutex_ held: this robot's pose, footprint, mode and the next metres of its path, for its peers.
  void PublishPeerState();
  // A convoy follower's request (CommandInterface::Hooks::convoy): follow the robots ahead, or leave the
  // convoy.
  CommandOutcome OnConvoy(const ConvoyCommand& c);
  // With mutex_ held: the robot as a yield, asked or asking, sees it at `now_s` with `live_peers` (which
  // outlive the answer).
  YieldCoordination::Robot ForYield(double now_s, const std::vector<Peer>& live_peers) const {
    return {now_s, modes_->control().mode(), reading_.pose_M, &live_peers, team_.listening_to_peers};
  }
  // With mutex_ held: what the robot state reports now.
  RobotStateInputs StateInputs() const {
    // As the robot asked while it yields (or last yielded: how it ended), else as the robot asking.
    const YieldStatus& own = modes_->yield().status();
    const YieldStatus& asking = modes_->yielding().asking();
    const bool own_first = own.state != YieldStatus::State::kNone ||
                           (asking.state == YieldStatus::State::kNone && !own.reason.empty());
    RobotStateInputs in;
    in.pose_M = reading_.pose_M;
    in.in_contact = reading_.in_contact;
    in.control_period_max_ms = loop_.periods.WorstMs();
    in.resumable_goal_M = resume_.goal_M;
    in.yield = own_first ? own : asking;
    in.paused_mission = modes_->missions().paused();
    if (in.paused_mission)
      in.mission_paused_s = std::max(0.0, NowS(time_.clock->Now()) - in.paused_mission->since_s);
    in.mission_note = modes_->missions().note();
    in.control_request_left_s = command_->lock().PendingLeftS(time_.clock->Now());
    return in;
  }
  void SendClaim(const ExploreClaim& claim) {
    if (!link_->Publish(claim))
      spdlog::warn("robot {}: explore claim not sent (DDS history full)", options_.robot_id);
  }
  double NowS(SteadyTime t) const { return core::SecondsBetween(time_.start, t); }

  AgentOptions options_;
  // A stepped agent's clock and when its loops are due next.
  struct Lockstep {
    std::shared_ptr<core::SimulatedClock> clock;
    std::uint64_t cycle = 0;
    double next_perception_s = 0.0;
    double next_nav_map_s = 0.0;
  };
  // What the agent's logic reads the time from (the modes, the command interface, missions, claims,
  // perception): the machine's clock, on which Run() also paces the control loop, or a stepped agent's (then
  // lockstep is set; none: the agent runs its own threads).
  struct Timing {
    explicit Timing(const std::shared_ptr<core::SimulatedClock>& stepped)
        : clock(stepped ? std::shared_ptr<const core::Clock>(stepped) : core::RealClock()),
          start(clock->Now()),
          lockstep(stepped ? std::optional<Lockstep>(Lockstep{stepped}) : std::nullopt) {}
    std::shared_ptr<const core::Clock> clock;
    SteadyTime start;
    std::optional<Lockstep> lockstep;
  } time_;
  // The communication (DDS, or a stepped agent's link). The DDS participant and writers come first, so that
  // discovery runs while the rest is built (~0.5 s: the trajectory library, the navigation grids); the
  // readers come last (Listen). Destroyed first (~Impl).
  std::shared_ptr<AgentLink> link_;
  // The robot: pose estimate, sensors, twist commands; what it can do; its pose estimate at start (the
  // navigation map's centre).
  struct Platform {
    explicit Platform(std::shared_ptr<core::PlatformIO> platform)
        : io(Checked(std::move(platform))), capabilities(io->Capabilities()), start_M(StartPose(*io)) {}
    std::shared_ptr<core::PlatformIO> io;
    core::PlatformCapabilities capabilities;
    core::BaseState start_M;
  } platform_;
  std::shared_ptr<nav::GlobalPlanner> planner_;  // thread-safe: goals and peers' path queries
  // What the platform said at the last control cycle (control thread).
  struct PlatformReading {
    explicit PlatformReading(const core::BaseState& start_M) : pose_M(start_M) {}
    core::BaseState pose_M;  // latest pose estimate, map frame
    bool pose_healthy = true;
    std::string pose_problem;
    bool in_contact = false;
  } reading_;
  // How the control loop keeps time and shares the link (control thread; late_cycles read by any).
  struct LoopRecord {
    PeriodWindow periods;
    std::atomic<std::uint64_t> late_cycles{0};  // Run(): cycles started over half a period late
    int robots_on_link = 1;                     // ShareRadioLink()
  } loop_;
  nav::Navigation navigation_;
  std::unique_ptr<PerceptionService> perception_;  // sensor, perception and navigation map threads
  // What this robot knows of its peers and owes them.
  struct Team {
    explicit Team(const AgentOptions& o) : explore(o.robot_id, o.explore.team), peers(o.robot_id, o.peers) {}
    ExploreTeam explore;                 // peers' explore claims and coverage (thread-safe)
    PeerTracker peers;                   // peers' poses, footprints and paths (thread-safe)
    core::WarningLimiter peer_warnings;  // a bad peer state is named once per 5 s per robot
    // Run(): the link's ListenToPeers() done, once the robot first left idle or was asked to yield.
    std::atomic<bool> listening_to_peers{false};
    std::optional<ExploreClaim> claim_to_send;  // Step()'s, sent by Run() outside the agent lock
  } team_;
  // An exploring robot that hears no basestation drives back to its start.
  ComeHome come_home_{options_.robot_id, platform_.start_M};
  // The mode tree, the mode modules and the mux; the operator's mission across interruptions; yields.
  std::unique_ptr<RobotModes> modes_;
  std::unique_ptr<CommandInterface> command_;  // the lock, the reply cache and the rules of who may command
  std::unique_ptr<PlanningService> planning_;  // the planning thread: goals, then peers' path queries
  std::unique_ptr<Telemetry> telemetry_;
  // A restarted robot's past: its old goal (--resume), offered until it leaves idle; the journal (--journal),
  // the last known safe state on disk.
  struct Resumption {
    std::optional<Eigen::Vector3d> goal_M;
    std::unique_ptr<JournalWriter> journal;
  } resume_;
  std::mutex mutex_;

  // The components (agent_components.h) and their health monitor; made last, stopped first (~Impl).
  struct Components {
    explicit Components(FaultInjector faults_in) : faults(std::move(faults_in)) {}
    FaultInjector faults;
    std::unique_ptr<PlatformComponent> platform;
    std::unique_ptr<PerceptionComponent> perception;
    std::unique_ptr<PlanningComponent> planning;
    std::unique_ptr<ControlLoopComponent> command, mode_tree, mux, navigation, telemetry;
    std::unique_ptr<core::HealthMonitor> monitor;
  } parts_;
  struct Health {
    explicit Health(const AgentOptions& o) : report(o.robot_id, core::IsRadioLink(o.link) ? 10.0 : 2.0) {}
    // What the basestations are told of the components (cairn/health): at once after an event, else every
    // 2 s (10 s on a radio link).
    HealthReport report;
    // A component's work did not stop and the agent is supervised: Run() ends for a restart of the process.
    std::atomic<bool> restart_requested{false};
  } health_{options_};

  // In the constructor: the planning service, its answers going to the command interface and the link.
  std::unique_ptr<PlanningService> MakePlanningService();
  // In the constructor: the first scan before the robot announces itself ready, so that it can take a goal at
  // once (a stepped agent reads its sensors once, at time 0).
  void ReadFirstScan();
  // In the constructor: the components and their monitor (not started).
  void MakeComponents();
  // The monitor's event: logged there; published at once.
  void OnHealthEvent(const core::HealthEvent& event);
  // Control thread, outside the agent lock: the health message when due (an event, or its period).
  void PublishHealthIfDue(SteadyTime now);
  // With mutex_ held, at the top of a control cycle: a control-loop part restarted since the last cycle has
  // its state reset.
  void ResetRestartedParts();

  // With mutex_ held: what the journal keeps now.
  JournalEntry JournalNow() const;
  // With mutex_ held, in the constructor: a robot restarted from its journal (--resume) comes up idle with
  // its lock's holder (lost until that basestation announces itself), its map, and its old goal offered.
  void Resume(const JournalEntry& entry);
};

RobotAgent::Impl::Impl(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform,
                       Hosting hosting)
    : options_(Hosted(options, hosting.clock != nullptr)),
      time_(hosting.clock),
      link_(hosting.link ? std::move(hosting.link) : MakeDds(options_)),
      platform_(std::move(platform)),
      planner_(MakePlanner(options_, platform_.start_M)),
      reading_(platform_.start_M),
      navigation_(options_.navigation, planner_, LocalPlannerLibrary(options_)),
      team_(options_),
      parts_(FaultInjector(
          [&] {
            std::vector<FaultInjection> faults;
            for (const std::string& f : options_.inject_faults) faults.push_back(ParseFaultInjection(f));
            return faults;
          }(),
          time_.start)) {
  perception_ = std::make_unique<PerceptionService>(
      options_, platform_.io, platform_.start_M, planner_, time_.clock, time_.start,
      [this](const perception::PerceptionOutput& out) { telemetry_->PublishPerception(out); });
  const std::string tree_file = options_.mode_tree_file.empty() ? DefaultTreeFile() : options_.mode_tree_file;
  RobotModes::Hooks hooks;
  hooks.conditions = [this] { return Conditions(); };
  hooks.clear_obstacle_memory = [this] { perception_->ClearObstacleMemory(); };
  hooks.mission_commands = [this] { return command_->mission_commands(); };
  hooks.grid = [this] { return planner_->Grid(options_.navigation.platform.name); };
  hooks.clock = time_.clock;
  modes_ =
      std::make_unique<RobotModes>(options_, tree_file, &navigation_, std::move(hooks),
                                   time_.lockstep ? RobotModes::Ids::kFromOne : RobotModes::Ids::kRandom);
  command_ = std::make_unique<CommandInterface>(options_.robot_id, options_.lock, &modes_->control(),
                                                modes_->waypoint().name(), CommandHooks());
  planning_ = MakePlanningService();
  ReadFirstScan();
  telemetry_ =
      std::make_unique<Telemetry>(options_, link_.get(), &modes_->control(), &modes_->waypoint(),
                                  &modes_->explore(), &modes_->convoy(), &navigation_, command_.get());
  if (options_.resumed) Resume(*options_.resumed);
  if (!options_.journal_dir.empty()) {
    std::function<void(const std::string&)> save_map;
    if (options_.perception.enabled) {
      save_map = [this](const std::string& path) { perception_->SaveMapSnapshot(path); };
    }
    resume_.journal =
        std::make_unique<JournalWriter>(options_.journal_dir, options_.journal_map_every_s, save_map);
    std::lock_guard<std::mutex> guard(mutex_);
    resume_.journal->Submit(JournalNow());
  }
  MakeComponents();
  if (time_.lockstep) parts_.monitor->StartAll();  // the control cycle's parts only: no thread of its own
  link_->Listen(DdsHandlers());
  telemetry_->PublishAgentInfo(platform_.capabilities, kVersion);
  telemetry_->PublishGlobalPathIfChanged();  // an empty path: late joiners see "no goal"
  spdlog::info("robot {} ({}) ready on platform {} ({}) at ({:.2f}, {:.2f}, yaw {:.2f}) in its map frame {}",
               options_.robot_id, options_.platform, platform_.capabilities.driver,
               platform_.capabilities.description, platform_.start_M.x_m, platform_.start_M.y_m,
               platform_.start_M.yaw_rad,
               time_.lockstep ? std::string("(stepped on a simulated clock, in process)")
                              : "on DDS domain " + std::to_string(options_.domain_id));
}

std::unique_ptr<PlanningService> RobotAgent::Impl::MakePlanningService() {
  PlanningServiceOptions planning;
  planning.robot_id = options_.robot_id;
  planning.platform = options_.navigation.platform.name;
  planning.path_queries_per_s = options_.path_requests_per_s;
  planning.map_max_extent_m = options_.nav_map.max_extent_m;
  return std::make_unique<PlanningService>(
      planning, planner_,
      PlanningService::Hooks{[this](const GoalCommand& goal, const nav::GlobalPlan& plan) {
                               std::lock_guard<std::mutex> guard(mutex_);
                               command_->OnGoalPlanned(goal, plan);
                             },
                             [this](const PathAnswer& answer) { link_->Send(answer); },
                             [this](const Eigen::Vector2d& goal_M) { return perception_->CoverGoal(goal_M); },
                             [this] { return perception_->Staircases(); }});
}

void RobotAgent::Impl::ReadFirstScan() {
  if (time_.lockstep) {
    // The sensors read once at time 0, as a running agent has them before an operator commands it.
    perception_->ReadSensors();
    perception_->FeedObstacles(navigation_);
  } else if (platform_.capabilities.has_lidar) {
    // The first scan before the robot announces itself ready, so that it can take a goal at once.
    perception_->WaitForFirstScan(std::chrono::seconds(5));
    if (!perception_->FeedObstacles(navigation_)) {
      spdlog::warn("robot {}: no lidar scan within 5 s of start; waypoint driving waits for one",
                   options_.robot_id);
    }
  }
}

void RobotAgent::Impl::Resume(const JournalEntry& entry) {
  std::string map = "no map snapshot";
  if (!entry.map_file.empty()) {
    const std::string path = (std::filesystem::path(options_.journal_dir) / entry.map_file).string();
    try {
      perception_->LoadMap(path);
      map = "its map from " + path;
    } catch (const std::exception& e) {
      map = "no map (" + std::string(e.what()) + ")";
      spdlog::error("robot {}: resuming without its map: {}", options_.robot_id, e.what());
    }
  }
  command_->RestoreHolder(entry.holder_id, time_.clock->Now());
  if (entry.has_goal) resume_.goal_M = Eigen::Vector3d(entry.goal_x_m, entry.goal_y_m, entry.goal_z_m);
  spdlog::warn(
      "robot {}: resumed from its journal: idle (was {}), lock {}, {}; {}", options_.robot_id, entry.mode,
      entry.holder_id.empty() ? "free" : "with " + entry.holder_id + " (lost until it announces itself)", map,
      entry.has_goal
          ? fmt::format("goal {} at ({:.2f}, {:.2f}) offered to resume (resume-goal {}), not resumed",
                        entry.goal_id, entry.goal_x_m, entry.goal_y_m, options_.robot_id)
          : std::string("no goal was being driven"));
}

JournalEntry RobotAgent::Impl::JournalNow() const {
  JournalEntry e;
  e.robot_id = options_.robot_id;
  e.holder_id = command_->lock().holder_id();
  e.mode = modes_->control().mode();
  if (modes_->waypoint().has_goal()) {
    const WaypointGoal& goal = modes_->waypoint().goal();
    e.has_goal = true;
    e.goal_id = goal.goal_id;
    e.goal_x_m = goal.x_m;
    e.goal_y_m = goal.y_m;
    e.goal_z_m = goal.z_m;
    e.goal_tolerance_m = goal.tolerance_m;
  } else if (resume_.goal_M) {  // still offered: a second crash keeps the offer
    e.has_goal = true;
    e.goal_x_m = resume_.goal_M->x();
    e.goal_y_m = resume_.goal_M->y();
    e.goal_z_m = resume_.goal_M->z();
  }
  e.x_m = reading_.pose_M.x_m;
  e.y_m = reading_.pose_M.y_m;
  e.z_m = reading_.pose_M.z_m;
  e.yaw_rad = reading_.pose_M.yaw_rad;
  return e;
}

void RobotAgent::Impl::ShareRadioLink() {
  if (!core::IsRadioLink(options_.link) || !options_.perception.enabled) return;
  const int robots = std::max(1, link_->RobotsOnLink());
  if (robots == loop_.robots_on_link) return;
  loop_.robots_on_link = robots;
  perception_->SetLinkShare(1.0 / robots);
  const int flow_share = link_->SetBulkShare(robots);
  spdlog::info(
      "robot {}: {} robots share the {} kbit/s radio link: map telemetry {:.0f} bit/s, camera {:.0f} bit/s "
      "(DDS flow controllers at 1/{} of theirs)",
      options_.robot_id, robots, options_.link.link_kbps,
      options_.perception.telemetry.budget_bits_per_s / robots,
      options_.perception.camera_budget_bits_per_s / robots, flow_share);
}

CommandInterface::Hooks RobotAgent::Impl::CommandHooks() {
  CommandInterface::Hooks hooks;
  hooks.conditions = [this] { return Conditions(); };
  hooks.send = [this](const CommandReply& reply) {
    link_->Send(reply);
    telemetry_->RequestWholeState();  // its sender may read the state the command left behind
  };
  // Planned on the planning thread, never on the DDS thread that holds the agent lock.
  hooks.plan_goal = [this](const GoalCommand& goal) {
    planning_->SubmitGoal(goal, navigation_.GoalRequest(reading_.pose_M, goal.x_m, goal.y_m, goal.z_m));
  };
  hooks.start_goal = [this](const GoalCommand& goal, const nav::GlobalPlan& plan) {
    return StartGoal(goal, plan);
  };
  hooks.start_explore = [this](const ExploreCommand& explore) {
    const std::string refused = modes_->StartExplore(explore.task, NowS(time_.clock->Now()));
    if (!refused.empty()) return CommandOutcome{false, refused, 0};
    return CommandOutcome{true, "exploring " + std::to_string(modes_->explore().status().task_id),
                          modes_->explore().status().task_id};
  };
  hooks.convoy = [this](const ConvoyCommand& c) { return OnConvoy(c); };
  // Queued for the monitor's thread: a component's threads are never waited for under the agent lock.
  hooks.restart_component = [this](const std::string& component, const std::string& by) {
    return parts_.monitor->RequestRestart(component, by);
  };
  return hooks;
}

CommandOutcome RobotAgent::Impl::OnConvoy(const ConvoyCommand& c) {
  if (c.stop) {
    if (!modes_->convoy().active()) return CommandOutcome{true, "not in a convoy", 0};
    modes_->convoy().Deactivate("convoy stopped by " + c.sender.base_id);
    spdlog::info("robot {}: convoy stopped by {}", options_.robot_id, c.sender.base_id);
    if (modes_->control().mode() == modes_->convoy().name()) modes_->control().GoIdle(Conditions());
    return CommandOutcome{true, "left the convoy: idle", 0};
  }
  const double now_s = NowS(time_.clock->Now());
  const std::string refused = modes_->StartConvoy(c.ahead_ids, team_.peers.Live(now_s), now_s);
  if (!refused.empty()) return CommandOutcome{false, refused, 0};
  std::string order;
  for (const std::string& id : c.ahead_ids) order += (order.empty() ? "" : ", ") + id;
  spdlog::info("robot {}: convoy from {}: following {} (ahead: {})", options_.robot_id, c.sender.base_id,
               c.ahead_ids.front(), order);
  return CommandOutcome{true, "following " + c.ahead_ids.front() + " (ahead: " + order + ")", 0};
}

void RobotAgent::Impl::PublishPeerState() {
  const Peer self = modes_->AsPeer(reading_.pose_M);
  cairn_msgs::PeerState m;
  m.robot_id(self.robot_id);
  m.platform(options_.navigation.platform.name);
  m.x_MB_m(self.pose_M.x_m);
  m.y_MB_m(self.pose_M.y_m);
  m.z_MB_m(self.pose_M.z_m);
  m.yaw_MB_rad(self.pose_M.yaw_rad);
  m.v_B_mps(static_cast<float>(self.pose_M.v_mps));
  m.w_B_radps(static_cast<float>(self.pose_M.w_radps));
  m.footprint_radius_m(static_cast<float>(self.footprint_radius_m));
  m.mode(self.mode);
  m.yield_state(self.yield_state);
  m.yield_to_id(self.yield_to_id);
  m.yield_reason(self.yield_reason.size() > 480 ? self.yield_reason.substr(0, 477) + "..."
                                                : self.yield_reason);
  for (const Eigen::Vector3d& p : self.path_ahead_M) {
    cairn_msgs::PeerPathPoint q;
    q.x_m(static_cast<float>(p.x()));
    q.y_m(static_cast<float>(p.y()));
    q.z_m(static_cast<float>(p.z()));
    m.path_ahead_M().push_back(q);
  }
  if (!link_->Publish(m))
    spdlog::debug("robot {}: peer state not sent (DDS history full)", options_.robot_id);
}

AgentDdsHandlers RobotAgent::Impl::DdsHandlers() {
  // Each applies under the agent lock; discovery's departures are taken by the control loop instead.
  auto locked = [this](auto apply) {
    return [this, apply](const auto& message) {
      std::lock_guard<std::mutex> guard(mutex_);
      apply(message);
    };
  };
  AgentDdsHandlers h;
  h.control = locked([this](const ControlCommand& c) { command_->OnControl(c, time_.clock->Now()); });
  h.mode = locked([this](const ModeCommand& c) { command_->OnMode(c); });
  h.goal = locked([this](const GoalCommand& c) { command_->OnGoal(c); });
  h.explore = locked([this](const ExploreCommand& c) { command_->OnExplore(c); });
  h.convoy = locked([this](const ConvoyCommand& c) { command_->OnConvoy(c); });
  h.home = locked([this](const HomeCommand& c) { command_->OnHome(c, platform_.start_M); });
  h.stop = locked([this](const StopCommand& c) { command_->OnStop(c); });
  h.restart = locked([this](const RestartCommand& c) { command_->OnRestart(c); });
  h.teleop = locked([this](const TeleopCommand& c) { command_->OnTeleop(c, time_.clock->Now()); });
  h.base_announced = locked([this](const BaseAnnouncement& b) { command_->OnBaseAnnounced(b); });
  h.base_liveliness =
      locked([this](const WriterLiveliness& l) { command_->OnBaseLiveliness(l, time_.clock->Now()); });
  // No planning on a DDS thread: the query waits for the planning thread, within a per-process rate.
  h.path_query = [this](const PathQuery& q) { planning_->SubmitPathQuery(q, time_.clock->Now()); };
  // Peers' claims need no agent lock (ExploreTeam has its own); a bad one is named and dropped.
  h.explore_claim = [this](const ExploreClaim& claim, const std::string& fault) {
    const std::string refused = fault.empty() ? team_.explore.OnPeerClaim(claim, NowS(time_.clock->Now()))
                                              : "explore claim from \"" + claim.robot_id + "\": " + fault;
    if (!refused.empty()) spdlog::warn("robot {}: {}; dropped", options_.robot_id, refused);
  };
  // Peers' states need no agent lock either (PeerTracker has its own); at 5 Hz a bad one is named once per 5
  // s.
  h.peer_state = [this](const Peer& peer) {
    const SteadyTime now = time_.clock->Now();
    const std::string refused = team_.peers.OnPeerState(peer, NowS(now));
    std::uint64_t suppressed = 0;
    if (!refused.empty() && team_.peer_warnings.Allow(peer.robot_id, now, &suppressed)) {
      spdlog::warn(
          "robot {}: {}; dropped{}", options_.robot_id, refused,
          suppressed > 0 ? " (and " + std::to_string(suppressed) + " more since the last warning)" : "");
    }
  };
  h.yield = [this](const YieldCommand& c, const YieldOrigin& origin, const std::string& fault) {
    std::lock_guard<std::mutex> guard(mutex_);
    const double now_s = NowS(time_.clock->Now());
    const std::vector<Peer> live_peers = team_.peers.Live(now_s);
    modes_->yielding().OnRequest(c, origin, fault, ForYield(now_s, live_peers));
  };
  h.map_sync = [this](const std::string& requester) {
    spdlog::info("robot {}: map snapshot requested by {}", options_.robot_id, requester);
    perception_->RequestMapSnapshot();
  };
  return h;
}

CommandOutcome RobotAgent::Impl::StartGoal(const GoalCommand& goal, const nav::GlobalPlan& plan) {
  if (!plan.IsUsable())
    return {false, "no path: " + planning_->PlanReason(plan), 0};  // the previous goal goes on
  const GoalStart start =
      modes_->StartGoal(plan, goal.x_m, goal.y_m, goal.tolerance_m, goal.z_m, NowS(time_.clock->Now()));
  if (!start.accepted) return {false, start.reason, 0};
  spdlog::info("robot {}: waypoint {} to ({:.2f}, {:.2f}) from {} accepted, path {:.1f} m", options_.robot_id,
               start.goal_id, goal.x_m, goal.y_m, goal.sender.base_id, plan.result.length_m);
  telemetry_
      ->PublishGlobalPathIfChanged();  // before the acknowledgement, so `path R` right after `goto` shows it
  const std::string home = goal.kind == CommandKind::kHome ? "home to (" + core::Fixed(goal.x_m, 2) + ", " +
                                                                 core::Fixed(goal.y_m, 2) + "): "
                                                           : "";
  const std::string notice = GoalNotice(options_.robot_id, plan);  // a goal where the map has not seen
  return {true,
          home + "path " + core::Fixed(plan.result.length_m, 1) + " m, ETA " +
              core::Fixed(navigation_.eta_s(), 0) + " s" + (notice.empty() ? "" : "; " + notice),
          start.goal_id};
}

ModeConditions RobotAgent::Impl::Conditions() const {
  ModeConditions c;
  command_->FillConditions(&c);  // holder, its liveliness, its joystick
  c.localized = reading_.pose_healthy;
  c.localization_problem = reading_.pose_problem;
  c.has_waypoint_goal = modes_->waypoint().has_goal();
  c.local_planner_healthy =
      navigation_.ObstacleSensingAlive(NowS(time_.clock->Now()), &c.local_planner_problem);
  c.has_explore_task = modes_->explore().exploring();
  c.has_convoy_task = modes_->convoy().active();
  c.has_yield_task = modes_->yield().active();
  c.mapping_healthy = perception_->MappingHealthy(&c.mapping_problem);
  if (parts_.monitor) c.components_down = parts_.monitor->Down();
  return c;
}

void RobotAgent::Impl::Step(SteadyTime now) {
  ResetRestartedParts();
  parts_.command->Run([&] { command_->Update(now); });
  const double now_s = NowS(now);
  parts_.mode_tree->Run([&] { modes_->Recheck(now_s); });

  const bool platform_ok = ReadPose(now_s);
  const ModeInputs inputs{now, now_s, reading_.pose_M};
  const bool navigated = parts_.navigation->Run([&] { StepNavigation(now, inputs); });
  parts_.telemetry->Run([&] { telemetry_->PublishGlobalPathIfChanged(); });

  Twist2 twist_B;
  const bool muxed = parts_.mux->Run([&] { twist_B = modes_->control().Compute(now).twist_B; });
  // A part of the driving chain that failed or is down: zero twist, and the robot leaves its mode (it is not
  // driven by a half-working chain when the part comes back).
  if (!(muxed && navigated && platform_ok && parts_.mode_tree->up() && parts_.navigation->up() &&
        parts_.mux->up())) {
    twist_B = Twist2{};
    LeaveModeForADownChain(now_s);
  }
  try {
    platform_.io->CommandTwist(twist_B.linear_x_mps, twist_B.angular_z_radps, now_s);
    const core::PlatformStatus status = platform_.io->ReadStatus();
    reading_.in_contact = status.in_contact;
    if (navigated && parts_.mode_tree->up()) {
      parts_.mode_tree->Run([&] { modes_->OnPlatformStatus(status, inputs); },
                            /*beat=*/false);
    }
  } catch (const std::exception& e) {
    parts_.platform->ReportFailure(std::string("driver: ") + e.what());
  }
}

bool RobotAgent::Impl::ReadPose(double now_s) {
  try {
    platform_.io->Update(now_s);
    const core::PoseEstimate estimate = platform_.io->ReadPose();
    reading_.pose_M = estimate.PlanarState();
    if (estimate.healthy != reading_.pose_healthy) {
      if (estimate.healthy) {
        spdlog::info("robot {}: localization recovered", options_.robot_id);
      } else {
        spdlog::warn("robot {}: localization lost: {}", options_.robot_id, estimate.problem);
      }
    }
    reading_.pose_healthy = estimate.healthy;
    reading_.pose_problem = estimate.healthy ? "" : estimate.problem;
    return true;
  } catch (const std::exception& e) {
    parts_.platform->ReportFailure(std::string("pose estimate: ") + e.what());
    return false;
  }
}

void RobotAgent::Impl::StepNavigation(SteadyTime now, const ModeInputs& inputs) {
  const double now_s = inputs.now_s;
  const std::vector<Peer> live_peers = team_.peers.Live(now_s);
  // Peers heard lately are obstacles too (added to the next live points: no robot drives into another).
  navigation_.SetPeers(std::vector<nav::PeerBody>(live_peers.begin(), live_peers.end()),
                       team_.peers.options().avoidance);
  perception_->FeedObstacles(navigation_);  // obstacles from live lidar points, at the sensor's rate
  // A robot waiting on a goal (or between frontiers) watches the world.
  perception_->SetMapRefreshAtRest(modes_->waypoint().has_goal() || modes_->explore().exploring());
  perception_->SetFrontierSearch(modes_->explore().frontier_search(), modes_->explore().every_level());
  perception_->SetRobotPosition({reading_.pose_M.x_m, reading_.pose_M.y_m, reading_.pose_M.z_m});
  if (auto frontiers = perception_->TakeFrontiers())
    modes_->explore().OnFrontiers(std::move(frontiers->first), frontiers->second);
  perception_->SetPeerCoverage(team_.explore.Coverage());
  modes_->Step(inputs, ForYield(now_s, live_peers), team_.explore);
  come_home_.Step(command_->SecondsSinceBaseHeard(now), reading_.pose_M, modes_->explore(), navigation_,
                  [&](const nav::GlobalPlan& plan, const core::BaseState& goal_M) {
                    return modes_->StartGoal(plan, goal_M.x_m, goal_M.y_m, 0.0, goal_M.z_m, now_s);
                  });
  // Written by Run() once the agent lock is released: Fast DDS hands the sample to this participant's own
  // claim reader on the writing thread, and the liveliness callbacks that come with it take the agent lock.
  team_.claim_to_send = DueClaim(modes_->explore(), team_.explore, now_s, [this] {
    return perception_->TakeSeenCoverage(team_.explore.options().coverage_cell_m);
  });
}

void RobotAgent::Impl::LeaveModeForADownChain(double now_s) {
  if (modes_->control().mode() == ModeManager::kIdleMode) return;
  modes_->StopKeepingMission("a component of the driving chain is down (health " + options_.robot_id + ")",
                             now_s);
}

void RobotAgent::Impl::ResetRestartedParts() {
  for (ControlLoopComponent* part : {parts_.mode_tree.get(), parts_.mux.get(), parts_.navigation.get()}) {
    if (part->TakeRestart()) {
      try {
        modes_->control().Stop(part->name() +
                               " restarted");  // idle, no goal: the operator decides what comes next
      } catch (const std::exception& e) {
        part->ReportFailure(std::string("reset after restart: ") + e.what());
      }
    }
  }
  if (parts_.telemetry->TakeRestart()) telemetry_->RequestWholeState();
  parts_.command->TakeRestart();  // the lock, its holder and the reply cache are kept: nothing to reset
}

void RobotAgent::Impl::MakeComponents() {
  const double lidar_hz =
      platform_.capabilities.lidar_rate_hz > 0 ? platform_.capabilities.lidar_rate_hz : 10.0;
  parts_.platform = std::make_unique<PlatformComponent>(perception_.get(), 2 * lidar_hz);
  parts_.perception = std::make_unique<PerceptionComponent>(perception_.get(), 2 * lidar_hz);
  parts_.planning =
      std::make_unique<PlanningComponent>(planning_.get(), parts_.faults.empty() ? nullptr : &parts_.faults);
  FaultInjector* faults = parts_.faults.empty() ? nullptr : &parts_.faults;
  const double control_hz = 1.0 / kLoopPeriodS;
  parts_.command = std::make_unique<ControlLoopComponent>("command_interface", control_hz, faults);
  parts_.mode_tree = std::make_unique<ControlLoopComponent>("mode_tree", control_hz, faults);
  parts_.mux = std::make_unique<ControlLoopComponent>("mux", control_hz, faults);
  parts_.navigation = std::make_unique<ControlLoopComponent>("navigation", control_hz, faults);
  parts_.telemetry = std::make_unique<ControlLoopComponent>("telemetry", control_hz, faults);
  if (faults != nullptr)
    perception_->SetFaultHook([faults](const char* component) { faults->Check(component); });
  parts_.monitor =
      std::make_unique<core::HealthMonitor>([this](const core::HealthEvent& e) { OnHealthEvent(e); });
  // Deadlines: a loop beats every iteration; perception's ticks (a map insert, a staircase search, a
  // navigation map update) and planning's plans may each take seconds on a big map, the control cycle 20 ms.
  core::RestartPolicy base;
  base.first_backoff_s = options_.restart_backoff_s;
  base.max_backoff_s = options_.restart_backoff_max_s;
  core::RestartPolicy sensor = base;
  sensor.heartbeat_deadline_s = 1.0;
  core::RestartPolicy perception = base;
  perception.heartbeat_deadline_s = 3.0;
  core::RestartPolicy planning = base;
  planning.heartbeat_deadline_s = 10.0;
  core::RestartPolicy control = base;
  control.heartbeat_deadline_s = 2.0;
  if (!time_.lockstep) {  // a stepped agent runs their work on its caller's thread (StepOnce)
    parts_.monitor->Add(parts_.platform.get(), sensor);
    parts_.monitor->Add(parts_.perception.get(), perception);
    parts_.monitor->Add(parts_.planning.get(), planning);
  }
  for (core::Component* c : {static_cast<core::Component*>(parts_.command.get()),
                             static_cast<core::Component*>(parts_.mode_tree.get()),
                             static_cast<core::Component*>(parts_.mux.get()),
                             static_cast<core::Component*>(parts_.navigation.get()),
                             static_cast<core::Component*>(parts_.telemetry.get())}) {
    parts_.monitor->Add(c, control);
  }
}

void RobotAgent::Impl::OnHealthEvent(const core::HealthEvent& event) {
  health_.report.OnEvent(event);
  if (event.kind == core::HealthEvent::Kind::kEscalated && options_.supervised) {
    // The work that did not stop may hold the component's state: the process restarts from its journal (the
    // control loop stops the robot and tells the basestations on its way out).
    spdlog::error("robot {}: {}: restarting the process (supervised)", options_.robot_id, event.message);
    health_.restart_requested = true;
    core::RequestShutdown();
  }
}

void RobotAgent::Impl::PublishHealthIfDue(SteadyTime now) {
  const std::optional<cairn_msgs::AgentHealth> m =
      health_.report.MessageIfDue(now, *parts_.monitor, loop_.late_cycles.load());
  if (m && !link_->Publish(*m))
    spdlog::warn("robot {}: health not sent (DDS history full)", options_.robot_id);
}

RobotAgent::Impl::CycleOutbox RobotAgent::Impl::LockedCycle(uint64_t cycle, SteadyTime wanted,
                                                            const CycleRates& every) {
  CycleOutbox out;
  const SteadyTime now = time_.clock->Now();
  const SteadyTime started = SteadyClock::now();
  command_->OnParticipantsGone(link_->TakeGoneParticipants(), now);
  Step(now);
  if (resume_.goal_M && modes_->control().mode() != "idle") resume_.goal_M.reset();  // the operator moved on
  if (resume_.journal && cycle % 10 == 0) resume_.journal->Submit(JournalNow());
  if (cycle % every.state == 0) {
    telemetry_->PublishState(StateInputs());
  }
  if (cycle % every.local_plan == 0) telemetry_->PublishLocalPlan();
  if (cycle % every.peer_state == 0) PublishPeerState();
  out.listen_to_peers = !team_.listening_to_peers && (modes_->control().mode() != ModeManager::kIdleMode ||
                                                      modes_->yielding().waiting_to_hear_peers());
  if (modes_->yielding().waiting_to_hear_peers() && team_.listening_to_peers) {
    const double now_s = NowS(now);
    const std::vector<Peer> live_peers = team_.peers.Live(now_s);
    modes_->yielding().DecideWaitingRequest(ForYield(now_s, live_peers));
  }
  telemetry_->PublishTreeStateIfChanged();
  out.claim = std::move(team_.claim_to_send);
  team_.claim_to_send.reset();
  out.yield_request = modes_->yielding().TakeRequestToSend();
  // A late cycle is a robot driving blind: say where the time went (waiting for the lock, or working).
  const double lock_wait_s = core::SecondsBetween(wanted, started);
  const double work_s = core::SecondsBetween(started, SteadyClock::now());
  if (lock_wait_s + work_s > 0.1) {
    spdlog::warn(
        "robot {}: control cycle took {:.0f} ms ({:.0f} ms waiting for the agent lock, {:.0f} ms "
        "working; period {:.0f} ms)",
        options_.robot_id, 1000 * (lock_wait_s + work_s), 1000 * lock_wait_s, 1000 * work_s,
        1000 * kLoopPeriodS);
  }
  return out;
}

void RobotAgent::Impl::SendOutbox(CycleOutbox out) {
  if (out.claim) SendClaim(*out.claim);
  if (out.yield_request && !link_->Send(out.yield_request->first, out.yield_request->second)) {
    spdlog::warn("robot {}: yield request to {} not sent (DDS history full)", options_.robot_id,
                 out.yield_request->first);
  }
  if (out.listen_to_peers) {
    // A robot that drives keeps clear of its peers: it reads their states from now on (outside the agent
    // lock, as the explore claims' endpoints are made).
    link_->ListenToPeers();
    team_.listening_to_peers = true;
  }
}

void RobotAgent::Impl::Run(const std::function<void()>& on_started) {
  const auto period =
      std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(kLoopPeriodS));
  const CycleRates every = Rates();
  // The components' threads (sensor, perception, navigation map, planning) start, and their monitor watches
  // every component from now on. The lidar feeds navigation (live obstacles, the navigation map) even with
  // perception's outputs disabled.
  parts_.monitor->StartAll();
  // Stops them however Run() ends (an exception would otherwise leave threads running).
  struct StopOnExit {
    core::HealthMonitor* health;
    ~StopOnExit() {
      core::RequestShutdown();
      health->StopAll();
    }
  } stop_on_exit{parts_.monitor.get()};
  parts_.monitor->StartChecking();
  if (on_started) on_started();
  SteadyTime next = SteadyClock::now();
  for (uint64_t cycle = 0; !core::ShutdownRequested(); ++cycle) {
    const SteadyTime wanted = SteadyClock::now();
    loop_.periods.Note(wanted);
    const double late_s = core::SecondsBetween(next, wanted);
    if (late_s > 0.5 * kLoopPeriodS) ++loop_.late_cycles;
    if (late_s > 0.1) {
      spdlog::warn("robot {}: control loop woke {:.0f} ms late (the process was not scheduled)",
                   options_.robot_id, 1000 * late_s);
    }
    CycleOutbox outbox;
    {
      std::lock_guard<std::mutex> guard(mutex_);
      outbox = LockedCycle(cycle, wanted, every);
    }
    SendOutbox(std::move(outbox));
    PublishHealthIfDue(time_.clock->Now());
    if (cycle % 50 == 0) ShareRadioLink();
    next += period;
    const auto now = SteadyClock::now();
    if (next < now) next = now;  // overrun: do not try to catch up
    core::WaitForShutdown(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
  Leave();
}

void RobotAgent::Impl::StepOnce(double clock_s) {
  Lockstep& step = *time_.lockstep;
  step.clock->SetSeconds(clock_s);
  const double now_s = NowS(time_.clock->Now());  // the agent's time: since its clock's time at construction
  // Sense, then act: the platform brought to now, then the threads' work at their periods on this clock (the
  // sensor loop every cycle, as it polls; perception and the navigation map when due), then the control cycle
  // on what they saw, as Run()'s cycle does it, then the planning it queued (a goal is answered before the
  // next cycle).
  try {
    platform_.io->Update(now_s);
  } catch (const std::exception& e) {
    parts_.platform->ReportFailure(std::string("platform update: ") + e.what());
  }
  const bool scanned = perception_->ReadSensors();
  auto due = [now_s](double* next_s, double period_s) {
    if (now_s < *next_s) return false;
    *next_s += period_s;
    if (*next_s <= now_s) *next_s = now_s + period_s;  // a step longer than the period: no burst
    return true;
  };
  if (due(&step.next_perception_s, perception_->perception_period_s()) || scanned)
    perception_->PerceptionTick();
  if (due(&step.next_nav_map_s, options_.nav_map.update_period_s)) perception_->NavMapTick();
  CycleOutbox outbox;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    outbox = LockedCycle(step.cycle++, SteadyClock::now(), Rates());
  }
  SendOutbox(std::move(outbox));
  PublishHealthIfDue(time_.clock->Now());
  while (planning_->RunOnce(std::chrono::milliseconds(0))) {
  }
}

void RobotAgent::Impl::Leave() {
  // The escalation that ends the process reaches the basestations first (the health message is reliable).
  PublishHealthIfDue(time_.clock->Now());
  std::optional<ExploreClaim> release;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    modes_->control().Stop("agent shutting down");
    telemetry_->PublishState(StateInputs());
    release = DueClaim(modes_->explore(), team_.explore, NowS(time_.clock->Now()),
                       {});  // an exploring robot lets go of its claim
  }
  if (release) SendClaim(*release);
  // Leaving takes a moment (the threads finish, the last map changes go out, the map is saved: over a second
  // on a busy link): the robot keeps sending its pose meanwhile, so that basestations see it leave when its
  // participant goes, not fall silent and be shown lost first.
  std::atomic<bool> finished{false};
  std::exception_ptr failure;
  std::thread finisher([&] {
    try {
      if (health_.restart_requested) {
        // A component's work still runs: its state is not to be read (map telemetry, map file) nor its
        // threads waited for; the journal has the last safe state.
        spdlog::warn("robot {}: leaving for a restart: the map is not flushed or saved at exit",
                     options_.robot_id);
        // A moment for the health message that says why, and the stopped state, to reach the basestations.
        std::this_thread::sleep_for(std::chrono::milliseconds(500));
        finished = true;
        return;
      }
      parts_.monitor->StopAll();  // the component threads end (they see the shutdown)
      if (const std::string running = WorkStillRunning(); !running.empty()) {
        // The map is still in use by a loop that did not stop: neither flushed nor saved.
        spdlog::error("robot {}: {}: the map is not flushed or saved at exit", options_.robot_id, running);
        finished = true;
        return;
      }
      if (options_.perception.enabled) {
        // The last changes (within the budget), and a moment for the asynchronous writer to deliver them.
        telemetry_->PublishPerception(perception_->Flush());
        link_->WaitForMapDelivery(std::chrono::seconds(1));
      }
      perception_->Finish(options_.map_save_path);
    } catch (...) {
      failure = std::current_exception();
    }
    finished = true;
  });
  while (!finished) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    std::lock_guard<std::mutex> guard(mutex_);
    telemetry_->PublishState(StateInputs());
  }
  finisher.join();
  if (failure) std::rethrow_exception(failure);
}

RobotAgent::RobotAgent(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform)
    : impl_(std::make_unique<Impl>(options, std::move(platform), Impl::Hosting{})) {}
RobotAgent::RobotAgent(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RobotAgent::~RobotAgent() = default;

std::unique_ptr<RobotAgent> RobotAgent::Stepped(const AgentOptions& options,
                                                std::shared_ptr<core::PlatformIO> platform,
                                                std::shared_ptr<AgentLink> link,
                                                std::shared_ptr<core::SimulatedClock> clock) {
  if (!link) throw std::invalid_argument("RobotAgent::Stepped: link is null");
  if (!clock) throw std::invalid_argument("RobotAgent::Stepped: clock is null");
  return std::unique_ptr<RobotAgent>(new RobotAgent(std::make_unique<Impl>(
      options, std::move(platform), Impl::Hosting{std::move(link), std::move(clock)})));
}

void RobotAgent::Run(const std::function<void()>& on_started) {
  if (impl_->stepped()) throw std::logic_error("RobotAgent::Run on a stepped agent (use Step)");
  impl_->Run(on_started);
}
void RobotAgent::Step(double now_s) {
  if (!impl_->stepped()) throw std::logic_error("RobotAgent::Step on an agent that runs its own threads");
  impl_->StepOnce(now_s);
}
bool RobotAgent::planning() const { return impl_->planning(); }
const RobotModes& RobotAgent::modes() const { return impl_->modes(); }
const nav::Navigation& RobotAgent::navigation() const { return impl_->navigation(); }
const NavMap& RobotAgent::nav_map() const { return impl_->nav_map(); }
bool RobotAgent::restart_requested() const { return impl_->restart_requested(); }

}  // namespace cairn::agent
