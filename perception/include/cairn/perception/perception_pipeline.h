// The robot's perception component, DDS-free: OctoMap mapping of the platform's registered lidar scans,
// staircase detection and merging, map telemetry and camera frames, each at its own rate (Sriganesh et al.
// 2024, "System-wide services" and "Command Interface"). It sees only what core::PlatformIO gives (scans with
// the SLAM sensor pose, camera frames), never a world. The agent runs Tick() on its perception thread and
// publishes what it returns; tests drive it faster than real time.
#pragma once

#include <Eigen/Geometry>
#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cairn/core/platform_io.h"
#include "cairn/perception/map_telemetry.h"
#include "cairn/perception/occupancy_map.h"
#include "cairn/perception/staircase.h"

namespace cairn::perception {

/// Options of the perception component (config section `perception`). Defaults are valid (tested).
struct PerceptionOptions {
  bool enabled =
      true;  ///< false: no stairs, telemetry or camera (the map is still built: navigation's input)
  OccupancyMapOptions map;           ///< OctoMap at 0.1 m
  double map_insert_period_s = 0.2;  ///< insert one scan per period, [0.05, 10]
  /// Keyframes: a scan goes into the map once the sensor moved this far or turned this much since the last
  /// inserted one (as LIO-SAM-style mappers do), [0, 10] m, [0, pi] rad; 0 and 0 insert every period...
  double map_keyframe_distance_m = 0.05;
  double map_keyframe_angle_rad = 0.05;
  /// ...or, at rest with a task (set_refresh_at_rest()), once this long has passed since the last one, so
  /// that what changes while the robot waits (a rock or a person leaves the doorway it waits at) reaches its
  /// map. An idle robot at rest leaves its map (and its map telemetry) unchanged. Seconds, [0.05, 600].
  double map_keyframe_max_interval_s = 0.2;
  double staircase_period_s = 1.0;  ///< run the detector this often, [0.1, 60]
  StaircaseDetectorOptions staircase;
  int map_coarse_levels = 1;      ///< telemetry voxels are 2^levels x the map's, [0, 6]
  MapTelemetryOptions telemetry;  ///< budget (default 100 kbit/s) and period
  double camera_rate_hz = 1.0;    ///< frames published per second, [0, 30]; 0 = no camera
  int jpeg_quality = 75;          ///< [1, 100]
  /// Camera frames' budget, bit/s, [1000, 1e9]: the frame rate drops below camera_rate_hz when frames are too
  /// big for it (a frame of B bytes delays the next by B * 8 / budget s); also the DDS flow controller's.
  double camera_budget_bits_per_s = 400000;

  /// Coarse telemetry voxel edge, metres.
  double coarse_resolution_m() const { return map.resolution_m * (1 << map_coarse_levels); }
  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// A compressed camera frame ready to publish.
struct CameraFrame {
  std::uint32_t seq = 0;
  int width_px = 0;
  int height_px = 0;
  Eigen::Isometry3d T_W_C = Eigen::Isometry3d::Identity();  ///< camera pose (SLAM estimate), map frame
  std::vector<std::uint8_t> jpeg;
};

/// What one Tick() produced.
struct PerceptionOutput {
  std::vector<MapUpdate> map_messages;               ///< in order
  std::vector<StaircaseRegistry::Entry> staircases;  ///< new or changed merged staircases
  std::optional<CameraFrame> camera;
};

/// Counters and timings, for logs, telemetry and the CPU budget (PERFORMANCE.md).
struct PerceptionStats {
  std::int64_t scans = 0;
  std::int64_t scans_inserted = 0;
  /// Keyframes due by map_insert_period_s but left out because the last insertion took long: on a busy
  /// machine the map is updated less often (each insertion waits kLoadWait times as long as the last took)
  /// instead of the thread falling behind.
  std::int64_t scans_deferred = 0;
  std::int64_t staircase_runs_deferred = 0;  ///< likewise for the staircase detector
  std::int64_t points_dropped_non_finite = 0;
  std::int64_t staircase_runs = 0;
  std::int64_t camera_frames = 0;
  double local_cloud_ms_total = 0, map_ms_total = 0, staircase_ms_total = 0, camera_ms_total = 0,
         telemetry_ms_total = 0;
  /// Scan-to-map latency of the inserted scans: from a scan's stamp (the platform's, agent clock) to its
  /// insertion into the map finished, milliseconds; summed (divide by scans_inserted) and the largest.
  double scan_to_map_ms_total = 0, scan_to_map_ms_max = 0;
};

/// Runs the robot's perception. Not thread-safe except map() and TakeChangedRegion(), which are.
class PerceptionPipeline {
 public:
  /// @throws std::invalid_argument naming the field when `options` is invalid.
  /// `robot_id` names the map telemetry.
  PerceptionPipeline(const PerceptionOptions& options, const std::string& robot_id);

  /// Does what is due at `now_s` (seconds, monotonic): with a new `scan` (registered by the platform's pose
  /// estimate, map frame M; may be null) the local cloud and, at the insertion period on keyframes, the map;
  /// staircase detection and telemetry at their periods; with a new `image` (may be null) a JPEG frame. A
  /// late tick does each due thing once (no catch-up bursts).
  PerceptionOutput Tick(double now_s, const core::LidarScan* scan, const core::CameraImage* image);
  /// With set_adapt_to_load(true), each step of Tick() waits at least this many times as long as its last
  /// run took (wall clock) before it runs again (map insertion, staircase detection): a slow machine gets
  /// fewer runs, not a stalled thread.
  static constexpr double kLoadWait = 2.0;
  /// On for a robot on the wall clock (the agent's perception thread); off (the default) where `now_s` is a
  /// simulated clock, whose runs must not depend on how busy the machine is.
  void set_adapt_to_load(bool on) { schedule_.adapt_to_load = on; }
  /// Called between the steps of Tick() (may be empty): the work goes on (its thread's heartbeat).
  void SetProgress(std::function<void()> progress) { progress_ = std::move(progress); }

  /// True when a camera frame is due at `now_s` (camera_rate_hz): the caller reads one from the platform.
  bool CameraDue(double now_s) const;

  /// Edge of the square x-y tiles changes are reported in, metres (10 coarse telemetry voxels).
  double change_tile_m() const { return 10 * options_.coarse_resolution_m(); }
  /// Highest lidar origin of the scans inserted so far (metres, map frame M); NaN before the first. Any
  /// thread.
  double max_sensor_z_m() const { return max_sensor_z_m_.load(); }
  /// Tiles (ix, iy): tile covers [ix * change_tile_m(), (ix + 1) * change_tile_m()) x [iy * ..., ...) in the
  /// map frame, over all heights) where the map changed since the last call, in no particular order.
  /// Thread-safe: navigation's map thread calls it while Tick() runs.
  std::vector<Eigen::Vector2i> TakeChangedTiles();

  /// The merged staircases seen at least kStairPriorDetections times (map frame M), for the navigation map's
  /// tread prior (NavMap::Update). Thread-safe: navigation's map thread calls it while Tick() runs.
  std::vector<Staircase> Staircases() const;
  static constexpr int kStairPriorDetections = 2;

  /// Map telemetry only (no scan, no insertion): takes the map's changes and returns what the budget lets out
  /// at `now_s`. For shutdown (the last changes), and for tests that need the map to stand still.
  std::vector<MapUpdate> FlushMapTelemetry(double now_s);

  /// A basestation asked for the full map: the next telemetry messages carry a snapshot.
  void RequestMapSnapshot();

  /// Map telemetry and camera frames at `share` of their budgets from now on, (0, 1]: a radio link shared by
  /// 1 / share robots. Thread-safe. @throws std::invalid_argument naming the value when out of range.
  void SetLinkShare(double share);

  /// While on, a robot at rest still inserts a scan every map_keyframe_max_interval_s (it has a goal and
  /// waits for the world to change); off (idle), only keyframes from motion. Thread-safe.
  void set_refresh_at_rest(bool on) { refresh_at_rest_ = on; }

  /// Before the first Tick(): replaces the (empty) map with the OctoMap file `path` (a journal's snapshot,
  /// written by this robot), marks all of it changed for the navigation map and sends it as map telemetry.
  /// @throws MapError naming the file; std::invalid_argument when its resolution is not the
  /// map's (perception.map.resolution_m).
  void LoadMap(const std::string& path);

  /// The robot's map (thread-safe queries: occupancy, ray cast, bounding box).
  std::shared_ptr<const OccupancyMap> map() const { return map_; }
  /// Body pose of the latest scan (the platform's estimate), map frame.
  const Eigen::Isometry3d& T_W_B_estimate() const { return T_W_B_estimate_; }
  const PerceptionStats& stats() const { return stats_; }
  const MapTelemetrySender& telemetry() const { return sender_; }
  const PerceptionOptions& options() const { return options_; }

 private:
  std::atomic<double> max_sensor_z_m_{std::numeric_limits<double>::quiet_NaN()};
  // Takes the map's coarse changes: extends the changed region (navigation) and queues them for telemetry.
  void CollectChanges();
  // The scan into the local cloud, and into the map when a keyframe is due.
  void MapScan(double now_s, const core::LidarScan& scan);
  // The detector on the local cloud; new or changed staircases into out->staircases.
  void DetectStaircases(double now_s, PerceptionOutput* out);
  // A JPEG of `image` into out->camera, the next frame held back by the camera's budget.
  void EncodeCameraFrame(double now_s, const core::CameraImage& image, PerceptionOutput* out);

  PerceptionOptions options_;
  std::shared_ptr<OccupancyMap> map_;
  StaircaseDetector detector_;
  StaircaseRegistry registry_;
  mutable std::mutex staircases_mutex_;
  std::vector<Staircase> staircases_;  // Staircases(), updated by Tick()
  LocalCloud local_cloud_;
  MapTelemetrySender sender_;
  Eigen::Isometry3d T_W_B_estimate_ = Eigen::Isometry3d::Identity();
  // The last scan inserted into the map (its sensor pose, frame W, and stamp): the next keyframe is due when
  // the sensor moved or turned enough, or (refresh at rest) after map_keyframe_max_interval_s.
  struct Keyframe {
    std::optional<Eigen::Isometry3d> T_W_S;
    double stamp_s = 0.0;
  } last_keyframe_;
  std::atomic<bool> refresh_at_rest_{false};
  std::atomic<double> link_share_{1.0};  // SetLinkShare()
  // When each part of Tick() is due next (seconds, the caller's clock), and the wait after a slow run.
  struct Schedule {
    double next_insert_s = 0, next_staircase_s = 0, next_telemetry_s = 0, next_camera_s = 0;
    double insert_after_s = 0, staircase_after_s = 0;  // kLoadWait after the last run's duration
    bool adapt_to_load = false;                        // set_adapt_to_load()
  } schedule_;
  std::function<void()> progress_;
  // The map's coarse tiles changed since TakeChangedTiles() (perception thread in, navigation map out).
  struct ChangedTiles {
    std::mutex mutex;
    std::set<std::pair<int, int>> tiles;
  } changed_;
  std::uint32_t camera_seq_ = 0;
  PerceptionStats stats_;
};

}  // namespace cairn::perception
