// The robot's perception threads (Sriganesh et al. 2024, § System-wide services): the sensor thread reads
// lidar scans from the platform and makes the local planner's live obstacles (LiveObstacles); the perception
// thread maps, detects staircases and makes map and camera telemetry (PerceptionPipeline); the navigation map
// thread copies the map's changed tiles into the global planner's map (NavMap). DDS-free: the telemetry
// leaves through a callback; the control loop takes the obstacles.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/services/live_obstacles.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/core/component.h"
#include "cairn/core/platform_io.h"
#include "cairn/core/time.h"
#include "cairn/nav/frontier.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/navigation.h"
#include "cairn/perception/perception_pipeline.h"

namespace cairn::agent {

/// The sensing side of one robot. The loops run on the threads of the agent's perception and platform
/// components (agent_components.h) until their WorkLoop stops; the other methods are thread-safe unless they
/// say otherwise.
class PerceptionService {
 public:
  /// `platform` is read by the sensor and perception threads; `planner` is the one the navigation map feeds;
  /// `start_M` centres the navigation map; `clock` is the agent's (the machine's, or a simulated one for a
  /// stepped agent) and `start_time` its origin (seconds since it are the perception clock); `publish` sends
  /// one tick's telemetry (called on the perception thread).
  /// @throws std::invalid_argument for a null platform, planner, clock or publish; what NavMap and
  ///         PerceptionPipeline throw for invalid options.
  PerceptionService(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform,
                    const core::BaseState& start_M, std::shared_ptr<nav::GlobalPlanner> planner,
                    std::shared_ptr<const core::Clock> clock, core::SteadyTime start_time,
                    std::function<void(const perception::PerceptionOutput&)> publish);

  /// Before the threads start: waits up to `timeout` for the first scan, so that the robot can take a goal as
  /// soon as it announces itself. true when one came (and false at once without a lidar).
  bool WaitForFirstScan(std::chrono::milliseconds timeout);
  /// Hands the obstacles of a scan not handed yet to `navigation` (control thread). true when there was one.
  bool FeedObstacles(nav::Navigation& navigation);
  /// Forgets the live obstacle points (the recovery's "clear the local obstacle memory"): the sensor thread
  /// clears its window before the next scan, and obstacles from before now are never handed on.
  void ClearObstacleMemory();
  /// A basestation asked for a full map snapshot; the perception thread sends it.
  void RequestMapSnapshot() { map_snapshot_requested_ = true; }
  /// Map telemetry and camera at `share` of their budgets, (0, 1] (PerceptionPipeline::SetLinkShare). Any
  /// thread.
  void SetLinkShare(double share) { perception_->SetLinkShare(share); }
  /// The robot has a task (a waypoint goal): its map follows the world while it stands (see
  /// PerceptionPipeline::set_refresh_at_rest). Any thread.
  void SetMapRefreshAtRest(bool on) { perception_->set_refresh_at_rest(on); }

  /// A goal at `goal_M` (x, y, metres, map frame): "" when the navigation map covers it or may grow to (then
  /// its thread grows the map over it at its next update), else why not (naming navigation.map_max_extent_m).
  /// Any thread (the planning thread).
  std::string CoverGoal(const Eigen::Vector2d& goal_M) { return nav_map_->Cover(goal_M); }
  /// The navigation map: for the navigation map thread, or a stepped agent's caller between steps.
  const NavMap& nav_map() const { return *nav_map_; }
  /// Frontier search for the explore mode: while `search` is set, the navigation map thread runs
  /// nav::FindFrontiers with it on its map after each update, from the robot's position given with
  /// SetRobotPosition(); none = no search. Any thread.
  /// `every_level`: on every level of the map (NavMap::Frontiers()).
  void SetFrontierSearch(const std::optional<nav::FrontierOptions>& search, bool every_level = false);
  /// The robot's x-y position (metres, frame M) the frontier search starts from. Any thread.
  void SetRobotPosition(const Eigen::Vector3d& p_M);
  /// What the robot's peers have seen (ExploreTeam::Coverage(); null = nothing): no gain for the frontier
  /// search. Any thread.
  void SetPeerCoverage(std::shared_ptr<const nav::PeerCoverage> coverage);
  /// The robot's seen floor for its peers: the newest nav::SeenCoverage(cell_m) of the navigation map made
  /// since the last call, if any; each call asks the map thread for a new one after its next update. Any
  /// thread.
  std::optional<nav::CoverageBitmap> TakeSeenCoverage(double cell_m);
  /// The newest frontier set not taken yet, and when it was computed (seconds on the agent's clock). Any
  /// thread.
  std::optional<std::pair<nav::FrontierSet, double>> TakeFrontiers();
  /// True when the robot's mapping keeps the navigation map up: a lidar scan came within
  /// navigation.obstacle_lost_s, and either the map's last update (with the frontier search on it) ended
  /// within MapAgeLimitS(), or an update is under way and made progress within it (a growth over a large map
  /// takes seconds and is not a stall). Otherwise false and `*why` (if not null) says which and for how long.
  /// Any thread.
  bool MappingHealthy(std::string* why) const;
  /// How old the navigation map may be, seconds: the larger of 3 s, 3 update periods, and 3 times its recent
  /// slowest update plus a period (a large map's updates take longer: the limit follows what they take, not a
  /// fixed figure). Any thread.
  double MapAgeLimitS() const;

  /// The staircases detected so far (PerceptionPipeline::Staircases()). Thread-safe.
  std::vector<perception::Staircase> Staircases() const { return perception_->Staircases(); }

  /// Sensor thread (the platform component's loop): polls the platform's lidar at twice its rate (a scan
  /// reaches the local planner within half a period, whatever the perception thread is busy with) until
  /// `loop` stops. A read fault is thrown (the component restarts).
  void SensorLoop(core::WorkLoop& loop);
  /// Perception thread (the perception component's): maps, detects, makes telemetry and camera frames at
  /// their periods, publishing each tick's output, until `loop` stops. A fault is thrown.
  void PerceptionLoop(core::WorkLoop& loop);
  /// Navigation map thread (the perception component's): applies the map's changed tiles to the planner's
  /// map every update_period_s, growing it as the robot maps beyond it or is sent beyond it, until `loop`
  /// stops. A fault is thrown.
  void NavMapLoop(core::WorkLoop& loop);
  /// One iteration of each loop, for a stepped agent (RobotAgent::Stepped) that runs them on its own thread
  /// at their periods on its clock: ReadSensors() the sensor loop's (a new lidar scan, if the platform has
  /// one), PerceptionTick() the perception loop's, NavMapTick() the navigation map loop's (`beat`, if set, is
  /// called between its steps). Not concurrently with the loops nor with one another. A fault is thrown.
  bool ReadSensors();
  void PerceptionTick();
  /// The perception loop's period, seconds: half the lidar's (10 Hz when the platform does not say).
  double perception_period_s() const {
    return 0.5 / (capabilities_.lidar_rate_hz > 0 ? capabilities_.lidar_rate_hz : 10.0);
  }
  void NavMapTick(const std::function<void()>& beat = {});
  /// Test hook (--inject-fault): called with the component's name at the top of every iteration of its loops
  /// ("platform", "perception"; "navigation_map" at the top of each navigation map update, on the perception
  /// component's second loop); it may throw, hang or be slow. Set before the loops start.
  void SetFaultHook(std::function<void(const char* component)> hook) { fault_hook_ = std::move(hook); }
  /// The map's memory as the perception thread last measured it (once a second), bytes (never waits for the
  /// map). Any thread.
  std::size_t map_memory_bytes() const { return map_memory_bytes_.load(); }

  /// After the loops ended: the map's last changes within the telemetry budget (empty with perception off).
  perception::PerceptionOutput Flush();
  /// Before the loops start: the map is the OctoMap file `path` (a journal's snapshot). @throws
  /// perception::MapError / std::invalid_argument naming the file.
  void LoadMap(const std::string& path) { perception_->LoadMap(path); }
  /// Any thread: writes the map as it is now to `path` (OctoMap .bt, write-then-rename). @throws
  /// perception::MapError naming the file.
  void SaveMapSnapshot(const std::string& path) const { perception_->map()->SaveBt(path); }
  /// After the loops ended: saves the map to `path` ("" = no) and logs the perception statistics.
  void Finish(const std::string& path);

 private:
  // On a navigation map just updated: the frontiers (when exploring asked for them) and the floor seen (when
  // a claim is due to carry it).
  void SearchTheNewMap();
  // Reads a scan if the platform has a new one: obstacles for the control loop, the scan for perception.
  bool ReadScan(double now_s);
  double NowS() const { return core::SecondsBetween(start_time_, clock_->Now()); }

  // Obstacles from live lidar points, made on the sensor thread, taken by the control loop.
  struct ObstacleSlot {
    std::vector<Eigen::Vector3f> points_B;
    core::BaseState pose_M;  // pose the points are expressed from
    double stamp_s = -1e9;
    bool fresh = false;
  };

  AgentOptions options_;
  std::shared_ptr<core::PlatformIO> platform_;
  core::PlatformCapabilities capabilities_;
  std::shared_ptr<nav::GlobalPlanner> planner_;
  std::shared_ptr<const core::Clock> clock_;
  core::SteadyTime start_time_;
  std::function<void(const perception::PerceptionOutput&)> publish_;
  std::mutex obstacles_mutex_;
  ObstacleSlot live_obstacles_;
  LiveObstacles live_obstacle_sensor_;  // sensor thread only (and WaitForFirstScan, before it starts)
  std::vector<Eigen::Vector3f> obstacle_points_B_;  // sensor thread's buffer
  std::atomic<bool> clear_obstacle_memory_{false};
  std::mutex scan_mutex_;
  std::shared_ptr<core::LidarScan> latest_scan_;  // from the sensor thread to the perception thread
  // Perception thread (and the map and changed tiles, thread-safe).
  std::unique_ptr<perception::PerceptionPipeline> perception_;
  std::unique_ptr<NavMap> nav_map_;  // navigation map thread only (but CoverGoal())
  std::atomic<bool> map_snapshot_requested_{false};
  std::function<void(const char*)> fault_hook_;
  std::atomic<std::size_t> map_memory_bytes_{0};
  double memory_measured_s_ = -1e9;  // perception thread: when map_memory_bytes_ was last measured
  // When the sensors and the navigation map last made progress, on the agent's clock (MappingHealthy()).
  // Written by the sensor and navigation map threads, read by any.
  struct MapHealth {
    std::atomic<double> last_scan_s{-1e9};  // the newest scan read
    std::atomic<double> last_update_s{
        -1e9};  // the newest navigation map update (and its frontier search) ended
    std::atomic<double> work_started_s{-1e9};  // the update under way started (-1e9: none)
    std::atomic<double> progress_s{-1e9};      // the map thread's newest progress
    std::atomic<double> work_slowest_s{0.0};   // the slowest recent update, seconds (decays by 10 % each)
  } map_health_;
  static constexpr double kMinMapAgeLimitS = 3.0;
  // What the explore mode asks of the navigation map thread and gets back, under `mutex`.
  struct FrontierShare {
    std::mutex mutex;
    std::shared_ptr<const nav::PeerCoverage> peer_coverage;
    double coverage_cell_m = 0.0;  // > 0: SeenCoverage() asked for
    std::optional<nav::CoverageBitmap> seen_coverage;
    std::optional<nav::FrontierOptions> search;
    Eigen::Vector3d robot_p_M = Eigen::Vector3d::Zero();
    bool every_level = false;
    std::optional<nav::FrontierSet> frontiers;
    double frontiers_at_s = 0.0;
  } frontier_;
};

}  // namespace cairn::agent
