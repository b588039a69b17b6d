// Copyright Cairn authors.
//
// The simulated robot behind core::PlatformIO: a unicycle base moving on the ground truth of a World, a
// spinning lidar and a camera rendered from the true pose, and a SLAM estimate that drifts with motion. The
// autonomy gets only what PlatformIO gives (estimated pose, registered scans, frames); the truth is reachable
// through TrueState() and world() for tests and benches that score results, never for the agent.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/platform_io.h"
#include "cairn/sim/body_terrain.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/camera.h"
#include "cairn/sim/lidar.h"
#include "cairn/sim/slam_drift.h"
#include "cairn/sim/unicycle.h"
#include "cairn/sim/world.h"

namespace cairn::sim {

/// A rockfall: the columns of `area_W` (x-y box, metres, frame W) fill from the floor up to `height_m` above
/// it: an obstacle that is in no map the robot has. It falls at `at_s` (seconds on the agent's clock) or,
/// with `near_m` set, when the robot's true position first comes within near_m of the box (x-y), so that a
/// test can drop it in front of the robot whatever the robot's speed. It stays, or is removed again (the
/// voxels it filled become free) at `clear_s` or `clear_after_s` after it fell.
struct Rockfall {
  /// When the rock falls, seconds on the agent's clock (>= 0); ignored when near_m is set.
  double at_s = 0.0;
  /// Proximity trigger: the rock falls on the first update with the true body within this distance of
  /// area_W, metres (> 0); none: it falls at at_s.
  std::optional<double> near_m;
  Eigen::AlignedBox2d area_W;
  double height_m = 1.0;
  /// When the rock is cleared, seconds on the agent's clock (> at_s; time trigger only); none: see
  /// clear_after_s.
  std::optional<double> clear_s;
  /// When the rock is cleared, seconds after it fell (> 0); none with clear_s none: it stays.
  std::optional<double> clear_after_s;
};

/// Parses rockfalls "WHEN:X0,Y0,X1,Y1,HEIGHT_M[:CLEAR]" separated by ';'. WHEN is AT_S (seconds on the
/// agent's clock) or "nearR_M" (falls when the robot comes within R_M metres of the box); CLEAR is CLEAR_S
/// (seconds on the agent's clock, time trigger only) or "+S" (seconds after the fall). E.g.
/// "5:14,19,15,21,1.2", "5:14,19,15,21,1.2:30", "near1.0:8.5,5.7,9.7,6.1,1.0:+8". Throws
/// std::invalid_argument naming the entry, the field and its value and the rule (numbers, AT_S >= 0, R_M in
/// (0, 100], X0 < X1, Y0 < Y1, HEIGHT_M in (0, 10], CLEAR_S > AT_S, S > 0). Time-triggered entries come
/// first, sorted by AT_S.
std::vector<Rockfall> ParseRockfalls(const std::string& text);

/// Options of SimulatedPlatform (cairn_agent: --world, --start, --pcd-resolution and the config file's
/// `simulation` section). Defaults are valid.
struct SimulatedPlatformOptions {
  /// World spec: builtin:NAME, a .bt/.ot or a .pcd path (see LoadWorld()).
  std::string world = "builtin:tunnels";
  /// Voxel edge for .pcd worlds, metres, [0.02, 2].
  double pcd_resolution_m = 0.1;
  /// Start pose (m, m, rad), frame W; must be free ground.
  std::optional<PlanarPose> start_W;
  /// Start slot K (when no start_W): the K-th suggested start of a builtin world, else the K-th of a fixed
  /// seeded sample of free starts >= 2 m apart. None = a free cell chosen from `start_key`.
  std::optional<int> start_slot;
  /// Picks the start when neither start_W nor start_slot is given (the robot id), and seeds the sensors.
  std::string start_key = "robot";
  /// Base limits and footprint (the platform profile's).
  core::VelocityLimits limits;
  double footprint_radius_m = 0.3;
  /// The body on the ground truth: step height, body height (the platform profile's; see BodyTerrain and
  /// ApplyPlatformProfile in platform_profile.h).
  BodyOptions body;
  /// Lidar: VLP-16-like, 10 Hz.
  LidarOptions lidar;
  /// Lidar (and camera) height above the ground under the robot, metres, [0, 3].
  double lidar_height_m = 0.5;
  /// SLAM drift of the pose estimate.
  SlamDriftOptions slam;
  /// Camera intrinsics (320 x 240, 90 deg).
  CameraOptions camera;
  /// Largest physics step, seconds, (0, 0.1]; Update() sub-steps longer intervals.
  double physics_step_s = 0.02;
  /// A base that got no command for this long stops (driver watchdog), seconds, (0, 10].
  double command_timeout_s = 0.25;
  /// Obstacles dropped into the world while the robot runs (config `simulation.rockfalls`, see
  /// ParseRockfalls()).
  std::vector<Rockfall> rockfalls;

  /// @return false and sets `*why` (field prefixed "simulation.", value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
  /// Reads the `simulation` section of a YAML config file (other sections are ignored). Throws
  /// std::invalid_argument naming the file, field and value.
  void LoadConfigFile(const std::string& path);
};

/// A simulated robot. Thread-safe as core::PlatformIO requires (one mutex).
class SimulatedPlatform : public core::PlatformIO {
 public:
  /// Loads the world and places the robot. Throws WorldError for a bad world, std::invalid_argument for bad
  /// options or a start that is not free ground (naming the start and the world).
  explicit SimulatedPlatform(const SimulatedPlatformOptions& options);

  core::PlatformCapabilities Capabilities() const override;
  void Update(double now_s) override;
  core::PoseEstimate ReadPose() const override;
  core::PlatformStatus ReadStatus() const override;
  bool ReadLidarScan(double now_s, core::LidarScan* scan) override;
  bool ReadCameraImage(double now_s, core::CameraImage* image) override;
  void CommandTwist(double linear_x_mps, double angular_z_radps, double now_s) override;

  /// Ground truth, for tests and benches only: the base's true state (frame W).
  UnicycleState TrueState() const;
  /// Drops a rockfall now (tests; scheduled ones come from options().rockfalls): the world and the ground
  /// truth terrain change, the robot's sensors see it from the next scan. Returns the voxels filled.
  std::int64_t DropRock(const Eigen::AlignedBox2d& area_W, double height_m);
  /// Removes the rock a scheduled rockfall dropped (the voxels it filled become free); tests use it through
  /// Update() and Rockfall::clear_s / clear_after_s. Returns the voxels freed.
  std::int64_t ClearRock(const std::vector<Eigen::Vector3i>& filled);
  /// Teleports the base (tests); the SLAM drift keeps its current offset.
  void SetTrueState(const UnicycleState& state);
  /// The simulated world (ground truth).
  std::shared_ptr<const World> world() const;
  /// Ground truth the base moves on (the simulator's own, not navigation's classifier): where the body
  /// stands on every level of the world, what it touches, which steps it climbs. See BodyTerrain.
  std::shared_ptr<const BodyTerrain> ground_truth() const;
  /// Distance the base travelled, metres, and the SLAM position error now, metres (truth vs estimate).
  double distance_travelled_m() const;
  double slam_error_m() const;
  const SimulatedPlatformOptions& options() const { return options_; }

 private:
  Eigen::Isometry3d TrueBodyPose() const;  // with mutex_ held
  Eigen::Isometry3d SensorOnBody() const;

  SimulatedPlatformOptions options_;
  mutable std::mutex world_mutex_;  // guards the two pointers below (copy-on-write on a rockfall)
  std::shared_ptr<const World> world_;
  std::shared_ptr<const BodyTerrain> ground_truth_;
  std::vector<bool> rock_dropped_;  // per options_.rockfalls entry; control thread
  // Voxels each dropped rockfall with a clear time filled, and when to free them; control thread.
  struct PendingClear {
    double clear_s;
    std::vector<Eigen::Vector3i> filled;
  };
  std::vector<PendingClear> pending_clears_;
  // Fills the rock's voxels into a copy of the world, swaps it in; returns the voxels it filled.
  std::vector<Eigen::Vector3i> FillRock(const Eigen::AlignedBox2d& area_W, double height_m);
  // Makes `changed` the world and rebuilds the ground truth from it.
  void SwapWorld(std::shared_ptr<const World> changed);
  mutable std::mutex mutex_;  // base, SLAM, command and status below
  Unicycle base_;
  SlamDrift slam_;
  Eigen::Isometry3d T_MB_estimate_ = Eigen::Isometry3d::Identity();
  double last_update_s_ = -1.0;
  double command_v_mps_ = 0.0, command_w_radps_ = 0.0, command_time_s_ = -1e9;
  bool in_contact_ = false;
  std::mutex lidar_mutex_;  // the lidar and its schedule (perception thread)
  SimulatedLidar lidar_;
  LidarScan lidar_scan_;
  std::uint64_t lidar_seq_ = 0;
  double next_scan_s_ = 0.0;
  std::mutex camera_mutex_;  // the camera's last frame and sequence number (the camera's thread)
  std::uint32_t camera_seq_ = 0;
  // The last rendered frame, the world and the camera pose it shows: a camera that has not moved in an
  // unchanged world (copy-on-write, so the same pointer) sends it again instead of rendering (deterministic).
  std::shared_ptr<const World> frame_world_;
  Eigen::Isometry3d frame_T_WC_ = Eigen::Isometry3d::Identity();
  GrayImage frame_;
};

}  // namespace cairn::sim
