// Ros2Platform: a robot's own ROS 2 stack behind Cairn's platform seam (core::PlatformIO), spoken on the wire
// through Fast DDS with ROS 2's conventions, with no ROS 2 installed and no bridge process:
//  - topic names "rt/<name>" for a ROS 2 topic "/<name>"; type names "<package>::msg::dds_::<Type>_"
//    (idl/ros2/ros2_msgs.idl); plain CDR as rmw_fastrtps and rmw_cyclonedds encode it;
//  - the QoS each topic conventionally has: the lidar best effort (sensor data), odometry, /tf and /cmd_vel
//    reliable, /tf_static reliable + transient local (config/dds_profiles.xml, profiles "ros2.*").
//
// Reads sensor_msgs/PointCloud2 (ReadPointCloud2: any layout with FLOAT32 x, y, z), nav_msgs/Odometry (the
// pose estimate T_MB, frame M = the odometry frame) and, when ros2.map_frame is set, map -> odom from /tf
// (REP-105: map -> odom -> base_link; then M = map and T_MB = T_map_odom * T_odom_base), /tf and /tf_static
// for the sensor's extrinsics T_BS (base_link -> the cloud's frame_id). Writes geometry_msgs/Twist (or
// TwistStamped) on /cmd_vel every control cycle, zero when stopped.
//
// Time: ROS 2 stamps are the robot's wall clock; they are mapped onto the agent's clock (the now_s of each
// call) by the offset between the two read at the same instant. A scan is registered with the pose at its
// stamp (the transform history, interpolated); a scan older than the history, or whose pose has not come
// within 0.5 s, is dropped and counted.
//
// Thread safety: as core::PlatformIO requires (the control thread and the perception thread at once); the
// readers' callbacks run on Fast DDS threads and only store what came, under a lock.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "cairn/core/dds.h"
#include "cairn/core/kinematics.h"
#include "cairn/core/platform_io.h"
#include "cairn/ros2/point_cloud2.h"
#include "cairn/ros2/tf_buffer.h"
#include "cairn/ros2/wire.h"
#include "ros2_msgsPubSubTypes.h"

namespace cairn::ros2 {

/// Options of the ROS 2 driver (config section `ros2`; `--ros2-domain`).
struct Ros2PlatformOptions {
  /// The robot's ROS 2 domain (ROS_DOMAIN_ID), [0, 232]; separate from the fleet's.
  int domain_id = 0;
  /// Fast DDS profiles file and participant profile of the ROS 2 participant: loopback only by default (the
  /// robot's own computer), with 4 MiB socket buffers for clouds.
  std::string profiles_file = core::DefaultProfilesFile();
  std::string participant_profile = "cairn.ros2.loopback";
  /// The network interface of the robot's ROS 2 computers (config `ros2.interface`, e.g. "eth1" when the
  /// lidar driver and the SLAM run on another computer of the robot): the participant binds to that
  /// interface's address only, finds the ROS 2 nodes by multicast discovery there (239.255.0.1, port 7400 +
  /// 250 * domain, as every ROS 2 middleware announces by default) and keeps the profile's socket buffers.
  /// "" = loopback only (the nodes run on this computer).
  std::string interface_name;
  /// ROS 2 topic names ("/points"; "" for none: a base with odometry only can still be teleoperated).
  std::string points_topic = "/points";
  std::string odom_topic = "/odom";
  std::string cmd_vel_topic = "/cmd_vel";
  /// The camera ("" for none): sensor_msgs/CompressedImage (JPEG, `camera_compressed`) or sensor_msgs/Image
  /// (mono8, rgb8, bgr8, rgba8, bgra8); its frame_id an optical frame (z along the axis, REP-103) unless
  /// `camera_optical_frame` is false (then x along the axis, as Cairn's frame C).
  std::string camera_topic;
  bool camera_compressed = true;
  bool camera_optical_frame = true;
  /// True: geometry_msgs/TwistStamped on cmd_vel_topic (newer ROS 2 distributions), else Twist.
  bool cmd_vel_stamped = false;
  /// Frames (REP-105). map_frame "" takes the odometry frame as the map frame M.
  std::string map_frame;
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  /// The pose is stale (not localized) when no odometry (and, with map_frame, no map -> odom) came for this
  /// long, seconds, (0, 10].
  double pose_timeout_s = 0.5;
  /// How long transforms are kept to register scans with the pose at their stamp, seconds, [1, 60].
  double tf_history_s = 10.0;
  /// At start, how long to wait for the first odometry before starting not localized, seconds, [0, 120].
  double start_wait_s = 10.0;
  /// The lidar: its scan rate (announced to the autonomy), Hz, (0, 100]; returns kept in [min, max] range,
  /// metres; its lowest beam's elevation, radians (NaN: unknown).
  double lidar_rate_hz = 10.0;
  double lidar_min_range_m = 0.3;
  double lidar_max_range_m = 100.0;
  double lidar_min_elevation_rad = std::numeric_limits<double>::quiet_NaN();
  /// The base: velocity and acceleration limits and body radius (from the agent's platform profile).
  core::VelocityLimits limits;
  double footprint_radius_m = 0.3;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
  /// Reads section `ros2` of a YAML file (keys as the fields' names; the topics, frames and cmd_vel_type
  /// "twist" | "twist_stamped"). @throws std::invalid_argument naming the file, key and value.
  void LoadConfigFile(const std::string& path);
};

class Ros2Platform : public core::PlatformIO {
 public:
  /// Creates the ROS 2 participant and endpoints and waits up to options.start_wait_s for odometry.
  /// @throws std::invalid_argument for invalid options; core::DdsError when the participant or an endpoint
  ///         cannot be created (naming the profile or topic).
  explicit Ros2Platform(const Ros2PlatformOptions& options);
  ~Ros2Platform() override;

  core::PlatformCapabilities Capabilities() const override;
  void Update(double now_s) override;
  core::PoseEstimate ReadPose() const override;
  core::PlatformStatus ReadStatus() const override;
  bool ReadLidarScan(double now_s, core::LidarScan* scan) override;
  bool ReadCameraImage(double now_s, core::CameraImage* image) override;
  void CommandTwist(double linear_x_mps, double angular_z_radps, double now_s) override;

  /// What was dropped so far (for logs, health and tests).
  struct Counts {
    std::uint64_t clouds = 0;          ///< clouds received
    std::uint64_t scans = 0;           ///< scans handed to the autonomy
    std::uint64_t bad_clouds = 0;      ///< refused layouts (the last reason in last_cloud_problem)
    std::uint64_t unregistered = 0;    ///< no pose or extrinsics at their stamp
    std::uint64_t bad_transforms = 0;  ///< transforms refused (loops, second parents, not rigid)
    std::uint64_t images = 0;          ///< camera frames handed to the autonomy
    std::uint64_t bad_images = 0;      ///< camera frames not read (encoding, size, no pose)
  };
  Counts counts() const;
  /// The last reason a cloud was not used ("" if none).
  std::string last_cloud_problem() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::ros2
