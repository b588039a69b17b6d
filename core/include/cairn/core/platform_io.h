// Copyright Cairn authors.
//
// PlatformIO: the seam between a robot's autonomy (cairn_agent's command interface, mode tree, navigation and
// perception) and the robot it runs on. The autonomy sees the robot only through it: a pose estimate from
// SLAM or odometry, lidar scans with the sensor pose, camera frames and the platform's capabilities; and it
// commands the robot only through it: a body twist. The simulator is one implementation
// (cairn::sim::SimulatedPlatform); a hardware driver is another (docs/PLATFORM.md shows how to write one).
// In the architecture of Sriganesh et al. 2024 this is the boundary below the navigation layer: the driver
// and the state estimator ("SLAM") on one side, everything the paper's robots share on the other.
//
// Frames: M is the map frame of the robot's SLAM (its own map, its published poses and paths); B the body
// (x forward, y left, z up, on the ground under the robot's centre); S the lidar; C the camera (x along the
// optical axis, y left, z up). Times: seconds on the agent's monotonic clock (now_s arguments).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"

namespace cairn::core {

/// What a platform offers; read once at start (the agent announces it in its AgentInfo).
struct PlatformCapabilities {
  /// Name of the driver, e.g. "sim" or "husky-serial".
  std::string driver;
  /// What the driver runs on, for logs and operators, e.g. "builtin:tunnels" for the simulator.
  std::string description;
  /// The base's velocity and acceleration limits (the controller plans within them).
  VelocityLimits limits;
  /// Radius of the body disk, metres.
  double footprint_radius_m = 0.3;
  /// True when ReadLidarScan() can return scans.
  bool has_lidar = false;
  /// Rate at which new scans come, Hz (> 0 when has_lidar).
  double lidar_rate_hz = 0.0;
  /// Elevation of the lidar's lowest beam in the sensor frame S, radians (a VLP-16: -15 deg = -0.2618); NaN
  /// if unknown. Below it the lidar is blind near the robot (a 0.2 m step within 1.1 m of a VLP-16 0.5 m
  /// up): the local obstacle memory keeps what it saw there (LocalCloudOptions::blind_below_elevation_rad).
  double lidar_min_elevation_rad = std::numeric_limits<double>::quiet_NaN();
  /// True when ReadCameraImage() can return frames.
  bool has_camera = false;
};

/// The pose estimate the robot steers by (SLAM or odometry), never the truth.
struct PoseEstimate {
  /// When the estimate was made, seconds (agent clock).
  double stamp_s = 0.0;
  /// Pose of the body in the map frame M; metres, proper rotation.
  Eigen::Isometry3d T_MB = Eigen::Isometry3d::Identity();
  /// Forward speed (body x), m/s, and yaw rate, rad/s, measured by odometry.
  double v_mps = 0.0;
  double w_radps = 0.0;
  /// False while the estimator has lost track (then `problem` says why); the autonomy stops driving.
  bool healthy = true;
  std::string problem;

  /// The planar state (x, y, z, yaw; v, w) of T_MB, frame M.
  BaseState PlanarState() const {
    BaseState s;
    s.x_m = T_MB.translation().x();
    s.y_m = T_MB.translation().y();
    s.z_m = T_MB.translation().z();
    const Eigen::Vector3d x_axis = T_MB.linear().col(0);
    s.yaw_rad = std::atan2(x_axis.y(), x_axis.x());
    s.v_mps = v_mps;
    s.w_radps = w_radps;
    return s;
  }
};

/// One lidar revolution, registered by the pose estimate.
struct LidarScan {
  /// When the scan was taken, seconds (agent clock).
  double stamp_s = 0.0;
  /// Increments with every scan the platform produces (gaps mean scans were skipped).
  std::uint64_t seq = 0;
  /// Returns only, metres, sensor frame S; N x 3.
  std::vector<Eigen::Vector3f> points_S;
  /// Pose of the sensor in the map frame M at the scan, from the pose estimate (T_MB * T_BS).
  Eigen::Isometry3d T_MS = Eigen::Isometry3d::Identity();
  /// Pose of the sensor on the body (extrinsics), metres.
  Eigen::Isometry3d T_BS = Eigen::Isometry3d::Identity();
};

/// One camera frame, 8-bit grey.
struct CameraImage {
  double stamp_s = 0.0;   ///< When it was taken, seconds (agent clock).
  std::uint32_t seq = 0;  ///< Increments with every frame.
  int width_px = 0;       ///< Columns.
  int height_px = 0;      ///< Rows.
  /// Grey levels, row-major, top row first, width_px * height_px entries.
  std::vector<std::uint8_t> pixels;
  /// Pose of the camera in the map frame M at the frame, from the pose estimate.
  Eigen::Isometry3d T_MC = Eigen::Isometry3d::Identity();
};

/// Health of the base as its driver reports it.
struct PlatformStatus {
  /// The base pushed against something this cycle and did not move as commanded (bumper, stall current,
  /// or the simulator's collision check).
  bool in_contact = false;
  /// "" or a driver fault that stops the robot (e.g. "motor controller over temperature").
  std::string fault;
};

/// The robot as the autonomy sees it. Thread safety: the agent calls Update(), ReadPose(), ReadStatus() and
/// CommandTwist() from its control thread and ReadLidarScan() / ReadCameraImage() from its perception thread;
/// an implementation must allow these two threads at once.
class PlatformIO {
 public:
  virtual ~PlatformIO() = default;

  /// What the platform offers (constant).
  virtual PlatformCapabilities Capabilities() const = 0;

  /// Called once per control cycle (50 Hz) before the pose is read: a driver that polls its hardware does it
  /// here; one with its own I/O thread may do nothing. The simulator advances its physics to `now_s`.
  virtual void Update(double now_s) = 0;

  /// The latest pose estimate.
  virtual PoseEstimate ReadPose() const = 0;

  /// The base's health as of the last Update().
  virtual PlatformStatus ReadStatus() const = 0;

  /// The newest scan not read yet, into `scan` (its capacity reused): true if there was one. Never blocks.
  virtual bool ReadLidarScan(double now_s, LidarScan* scan) = 0;

  /// The newest camera frame not read yet, into `image`: true if there was one. Never blocks. The agent calls
  /// it only at its publishing rate, so a driver may render or fetch on demand.
  virtual bool ReadCameraImage(double now_s, CameraImage* image) = 0;

  /// Commands the base (frame B: forward m/s, yaw rate rad/s) until the next command. The agent sends one
  /// every control cycle, zero when stopped; a driver should stop the base itself when commands stop coming
  /// (a watchdog of a few cycles).
  virtual void CommandTwist(double linear_x_mps, double angular_z_radps, double now_s) = 0;
};

}  // namespace cairn::core
