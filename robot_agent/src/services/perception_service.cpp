#include "cairn/agent/services/perception_service.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <thread>

#include "cairn/core/range_check.h"
#include "cairn/core/shutdown.h"

namespace cairn::agent {

namespace {

template <class T>
T Required(T pointer, const char* name) {
  if (!pointer) throw std::invalid_argument(std::string("PerceptionService: ") + name + " is null");
  return pointer;
}

void LogUpdate(const std::string& robot_id, const NavMapUpdateStats& stats) {
  if (stats.grown) {
    spdlog::info("robot {}: navigation map grown to x [{:.1f}, {:.1f}], y [{:.1f}, {:.1f}] (v{}, {:.0f} ms)",
                 robot_id, stats.extent_M.min().x(), stats.extent_M.max().x(), stats.extent_M.min().y(),
                 stats.extent_M.max().y(), stats.map_version,
                 stats.read_ms + stats.traversability_ms + stats.publish_ms);
  }
  if (stats.applied) {
    spdlog::debug(
        "robot {}: navigation map v{}: {} tiles in {:.1f} x {:.1f} m, {} occupied voxels, read {:.1f} "
        "ms, traversability {:.1f} ms, publish {:.1f} ms, {} staircase priors",
        robot_id, stats.map_version, stats.tiles, stats.region_M.sizes().x(), stats.region_M.sizes().y(),
        stats.occupied_voxels, stats.read_ms, stats.traversability_ms, stats.publish_ms, stats.stair_priors);
  }
}

}  // namespace

PerceptionService::PerceptionService(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform,
                                     const core::BaseState& start_M,
                                     std::shared_ptr<nav::GlobalPlanner> planner,
                                     std::shared_ptr<const core::Clock> clock, core::SteadyTime start_time,
                                     std::function<void(const perception::PerceptionOutput&)> publish)
    : options_(options),
      platform_(Required(std::move(platform), "platform")),
      capabilities_(platform_->Capabilities()),
      planner_(Required(std::move(planner), "planner")),
      clock_(Required(std::move(clock), "clock")),
      start_time_(start_time),
      publish_(Required(std::move(publish), "publish")),
      live_obstacle_sensor_(options.navigation, options.obstacle_window_s,
                            capabilities_.lidar_min_elevation_rad),
      perception_(std::make_unique<perception::PerceptionPipeline>(options.perception, options.robot_id)),
      nav_map_(std::make_unique<NavMap>(options.nav_map, options.perception.map.resolution_m, start_M,
                                        planner_, options.navigation.platform.name)) {}

bool PerceptionService::WaitForFirstScan(std::chrono::milliseconds timeout) {
  if (!capabilities_.has_lidar) return false;
  const core::SteadyTime deadline = core::SteadyClock::now() + timeout;
  while (!ReadScan(NowS())) {
    // A shutdown meanwhile (SIGINT, SIGTERM) ends the wait: the process exits promptly even without a lidar.
    if (core::SteadyClock::now() >= deadline || core::ShutdownRequested()) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return true;
}

bool PerceptionService::FeedObstacles(nav::Navigation& navigation) {
  std::lock_guard<std::mutex> guard(obstacles_mutex_);
  if (!live_obstacles_.fresh) return false;
  live_obstacles_.fresh = false;
  navigation.SetObstacles(live_obstacles_.points_B, live_obstacles_.pose_M, live_obstacles_.stamp_s);
  return true;
}

void PerceptionService::ClearObstacleMemory() {
  clear_obstacle_memory_ = true;
  std::lock_guard<std::mutex> guard(obstacles_mutex_);
  live_obstacles_.fresh = false;  // points from before the clearing
}

bool PerceptionService::ReadScan(double now_s) {
  auto scan = std::make_shared<core::LidarScan>();
  if (!platform_->ReadLidarScan(now_s, scan.get())) return false;
  core::BaseState pose_M;
  if (clear_obstacle_memory_.exchange(false)) live_obstacle_sensor_.Clear();
  map_health_.last_scan_s = now_s;
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

void PerceptionService::SensorLoop(core::WorkLoop& loop) {
  // Polls the platform at twice its lidar rate: a scan reaches the local planner within half a period of its
  // arrival, whatever the perception thread is busy with (mapping, stairs, camera).
  const double rate_hz = capabilities_.lidar_rate_hz > 0 ? capabilities_.lidar_rate_hz : 10.0;
  const auto period =
      std::chrono::duration_cast<core::SteadyClock::duration>(std::chrono::duration<double>(0.5 / rate_hz));
  core::SteadyTime next = core::SteadyClock::now();
  while (loop.Running()) {
    loop.Beat();
    {
      // A read fault ends the loop: its component (platform) is restarted, and meanwhile the local planner's
      // input goes stale and the robot stops (navigation.obstacle_timeout_s).
      core::ScopedCpu cpu(loop.component());
      if (fault_hook_) fault_hook_("platform");
      ReadSensors();
    }
    next += period;
    const auto now = core::SteadyClock::now();
    if (next < now) next = now;
    loop.WaitFor(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
}

void PerceptionService::PerceptionLoop(core::WorkLoop& loop) {
  const auto period = std::chrono::duration_cast<core::SteadyClock::duration>(
      std::chrono::duration<double>(perception_period_s()));
  core::SteadyTime next = core::SteadyClock::now();
  // Between the steps of a tick: a slow tick still beats (slow, not hung). Dropped when this loop ends.
  perception_->SetProgress([&loop] { loop.Beat(); });
  perception_->set_adapt_to_load(true);
  struct DropProgress {
    perception::PerceptionPipeline* pipeline;
    ~DropProgress() { pipeline->SetProgress({}); }
  } drop_progress{perception_.get()};
  while (loop.Running()) {
    loop.Beat();
    {
      // A fault ends the loop: its component (perception) is restarted alone; the robot drives on without it
      // where its modes allow (the mode tree's IsComponentUp).
      core::ScopedCpu cpu(loop.component());
      if (fault_hook_) fault_hook_("perception");
      PerceptionTick();
    }
    next += period;
    const auto now = core::SteadyClock::now();
    if (next < now) next = now;  // over budget: the next scan comes late, never a burst
    loop.WaitFor(std::chrono::duration_cast<std::chrono::milliseconds>(next - now));
  }
}

bool PerceptionService::ReadSensors() { return capabilities_.has_lidar && ReadScan(NowS()); }

void PerceptionService::PerceptionTick() {
  const double now_s = NowS();
  std::shared_ptr<core::LidarScan> scan;
  {
    std::lock_guard<std::mutex> guard(scan_mutex_);
    scan.swap(latest_scan_);
  }
  if (map_snapshot_requested_.exchange(false)) perception_->RequestMapSnapshot();
  core::CameraImage image;
  const bool has_image =
      capabilities_.has_camera && perception_->CameraDue(now_s) && platform_->ReadCameraImage(now_s, &image);
  publish_(perception_->Tick(now_s, scan.get(), has_image ? &image : nullptr));
  // Counting the map's memory walks every leaf of the octree (7.9 % of a stepped robot's CPU when done every
  // tick, 1.7 % once a second): every 5 s is plenty for a figure that grows with the explored area.
  if (now_s >= memory_measured_s_ + 5.0 || now_s < memory_measured_s_) {
    map_memory_bytes_ = perception_->map()->MemoryBytes();
    memory_measured_s_ = now_s;
  }
}

void PerceptionService::SearchTheNewMap() {
  std::optional<nav::FrontierOptions> search;
  Eigen::Vector3d robot_p_M;
  bool every_level = false;
  std::shared_ptr<const nav::PeerCoverage> peers;
  double coverage_cell_m = 0.0;
  {
    std::lock_guard<std::mutex> guard(frontier_.mutex);
    search = frontier_.search;
    robot_p_M = frontier_.robot_p_M;
    every_level = frontier_.every_level;
    peers = frontier_.peer_coverage;
    coverage_cell_m = frontier_.coverage_cell_m;
  }
  if (coverage_cell_m > 0) {
    nav::CoverageBitmap seen = nav::SeenCoverage(nav_map_->grid(), coverage_cell_m);
    std::lock_guard<std::mutex> guard(frontier_.mutex);
    frontier_.seen_coverage = std::move(seen);
    frontier_.coverage_cell_m = 0.0;
  }
  if (search) {
    nav::FrontierSet set = nav_map_->Frontiers(robot_p_M, *search, every_level, peers.get());
    std::lock_guard<std::mutex> guard(frontier_.mutex);
    frontier_.frontiers = std::move(set);
    frontier_.frontiers_at_s = NowS();
  }
}

void PerceptionService::NavMapLoop(core::WorkLoop& loop) {
  const auto period = std::chrono::duration_cast<core::SteadyClock::duration>(
      std::chrono::duration<double>(options_.nav_map.update_period_s));
  // The first update at once: exploring needs a map updated lately (MappingHealthy()).
  core::SteadyTime next = core::SteadyClock::now();
  // Beats at least every 100 ms while it waits for its next update, and between the steps of an update (a
  // growth over a large map takes seconds: slow, not hung).
  const auto beat_every = std::chrono::milliseconds(100);
  nav_map_->SetProgressHook([this, &loop] {
    loop.Beat();
    map_health_.progress_s = NowS();
  });
  struct ClearHook {
    NavMap* map;
    ~ClearHook() { map->SetProgressHook({}); }
  } clear_hook{nav_map_.get()};
  while (loop.Running()) {
    loop.Beat();
    const auto now = core::SteadyClock::now();
    if (now < next) {
      loop.WaitFor(std::min(beat_every, std::chrono::duration_cast<std::chrono::milliseconds>(next - now) +
                                            std::chrono::milliseconds(1)));
      continue;
    }
    next += period;
    if (next < core::SteadyClock::now()) next = core::SteadyClock::now() + period;
    core::ScopedCpu cpu(loop.component());
    if (fault_hook_) fault_hook_("navigation_map");
    NavMapTick([&loop] { loop.Beat(); });
  }
}

void PerceptionService::NavMapTick(const std::function<void()>& beat) {
  const double work_start_s = NowS();
  map_health_.progress_s = work_start_s;
  map_health_.work_started_s = work_start_s;
  const std::vector<Eigen::Vector2i> tiles = perception_->TakeChangedTiles();
  // With no changed tile, Update() still grows the map when a goal beyond it asked to.
  const NavMapUpdateStats stats = nav_map_->Update(*perception_->map(), tiles, perception_->change_tile_m(),
                                                   perception_->max_sensor_z_m(), perception_->Staircases());
  if (beat) beat();
  map_health_.progress_s = NowS();
  SearchTheNewMap();
  // The map and what is computed on it (frontiers, seen coverage) are done: how long that took sets how old
  // the map may grow before it counts as not kept up (MappingHealthy()).
  const double done_s = NowS();
  const double work_s = done_s - work_start_s;
  const double slowest_s = map_health_.work_slowest_s.load();
  // The slowest of the recent iterations: one slow update raises it at once; it decays by 10 % a time.
  map_health_.work_slowest_s = std::max(work_s, 0.9 * slowest_s);
  map_health_.last_update_s = done_s;
  map_health_.progress_s = done_s;
  map_health_.work_started_s = -1e9;
  LogUpdate(options_.robot_id, stats);
}

void PerceptionService::SetFrontierSearch(const std::optional<nav::FrontierOptions>& search,
                                          bool every_level) {
  std::lock_guard<std::mutex> guard(frontier_.mutex);
  frontier_.search = search;
  frontier_.every_level = every_level;
  if (!search) frontier_.frontiers.reset();
}

void PerceptionService::SetPeerCoverage(std::shared_ptr<const nav::PeerCoverage> coverage) {
  std::lock_guard<std::mutex> guard(frontier_.mutex);
  frontier_.peer_coverage = std::move(coverage);
}

std::optional<nav::CoverageBitmap> PerceptionService::TakeSeenCoverage(double cell_m) {
  std::lock_guard<std::mutex> guard(frontier_.mutex);
  frontier_.coverage_cell_m = cell_m;
  std::optional<nav::CoverageBitmap> out = std::move(frontier_.seen_coverage);
  frontier_.seen_coverage.reset();
  return out;
}

void PerceptionService::SetRobotPosition(const Eigen::Vector3d& p_M) {
  std::lock_guard<std::mutex> guard(frontier_.mutex);
  frontier_.robot_p_M = p_M;
}

std::optional<std::pair<nav::FrontierSet, double>> PerceptionService::TakeFrontiers() {
  std::lock_guard<std::mutex> guard(frontier_.mutex);
  if (!frontier_.frontiers) return std::nullopt;
  std::optional<std::pair<nav::FrontierSet, double>> out(std::in_place, std::move(*frontier_.frontiers),
                                                         frontier_.frontiers_at_s);
  frontier_.frontiers.reset();
  return out;
}

double PerceptionService::MapAgeLimitS() const {
  const double period_s = options_.nav_map.update_period_s;
  return std::max({kMinMapAgeLimitS, 3 * period_s, 3 * map_health_.work_slowest_s.load() + period_s});
}

bool PerceptionService::MappingHealthy(std::string* why) const {
  const double now_s = NowS();
  std::string problem;
  const double limit_s = MapAgeLimitS();
  if (!capabilities_.has_lidar) {
    problem = "the platform has no lidar to map with";
  } else if (const double age = now_s - map_health_.last_scan_s.load();
             age > options_.navigation.obstacle_lost_s) {
    problem = map_health_.last_scan_s.load() < -1e8 ? "no lidar scan yet"
                                                    : "no lidar scan for " + core::Fixed(age, 1) + " s";
  } else if (const double idle_s = now_s - map_health_.progress_s.load();
             map_health_.work_started_s.load() > -1e8) {
    // An update under way: healthy while it makes progress (a growth over a large map takes seconds).
    if (idle_s > limit_s) {
      problem = "the navigation map update made no progress for " + core::Fixed(idle_s, 1) + " s";
    }
  } else if (const double map_age = now_s - map_health_.last_update_s.load();
             map_age > limit_s && now_s > limit_s) {
    problem = map_health_.last_update_s.load() < -1e8
                  ? "the navigation map was never updated"
                  : "the navigation map was not updated for " + core::Fixed(map_age, 1) + " s (limit " +
                        core::Fixed(limit_s, 1) + " s: its updates take up to " +
                        core::Fixed(map_health_.work_slowest_s.load(), 1) + " s)";
  }
  if (!problem.empty() && why != nullptr) *why = problem;
  return problem.empty();
}

perception::PerceptionOutput PerceptionService::Flush() {
  perception::PerceptionOutput last;
  if (options_.perception.enabled) last.map_messages = perception_->FlushMapTelemetry(NowS());
  return last;
}

void PerceptionService::Finish(const std::string& path) {
  if (!path.empty()) {
    try {
      perception_->map()->SaveBt(path);
      spdlog::info("robot {}: map saved to {}", options_.robot_id, path);
    } catch (const std::exception& e) {
      spdlog::error("robot {}: cannot save the map: {}", options_.robot_id, e.what());
    }
  }
  const perception::PerceptionStats& ps = perception_->stats();
  spdlog::info(
      "robot {}: shutting down; perception: {} scans ({:.1f} ms map per inserted scan; scan to map "
      "{:.1f} ms mean, {:.1f} ms max; {} keyframes deferred under load), {} staircase runs ({:.1f} ms each; "
      "{} "
      "deferred), {} camera frames; navigation map version {}",
      options_.robot_id, ps.scans, ps.scans_inserted ? ps.map_ms_total / ps.scans_inserted : 0.0,
      ps.scans_inserted ? ps.scan_to_map_ms_total / ps.scans_inserted : 0.0, ps.scan_to_map_ms_max,
      ps.scans_deferred, ps.staircase_runs,
      ps.staircase_runs ? ps.staircase_ms_total / ps.staircase_runs : 0.0, ps.staircase_runs_deferred,
      ps.camera_frames, planner_->map_version());
}

}  // namespace cairn::agent
