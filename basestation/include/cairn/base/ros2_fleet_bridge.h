// The fleet for ROS 2 tools (cairn_base --ros2-domain N): what this basestation sees of the fleet, published
// on a ROS 2 domain in ROS 2's standard types, so that RViz2 (config/rviz/cairn.rviz), `ros2 topic echo` and
// rosbag2 show it as the paper's operators watched their fleet in RViz. Through Fast DDS with ROS 2's wire
// conventions (topics rt/..., types pkg::msg::dds_::Type_, idl/ros2/ros2_msgs.idl); no ROS 2 installed.
//
// Topics (ROS 2 names), all in frame `map` (the fleet's shared map frame):
//   /tf               tf2_msgs/TFMessage      map -> ROBOT_ID/base_link for every robot heard, state_rate_hz
//   /ROBOT_ID/path    nav_msgs/Path           the robot's global path, when it changes (latched)
//   /cairn/fleet_map  sensor_msgs/PointCloud2 the merged fleet map's occupied voxel centres (FLOAT32 x, y,
//                                             z), every map_period_s when it changed (latched)
//   /cairn/markers    visualization_msgs/MarkerArray (Humble's Marker) every map_period_s: staircases (a cube
//                                             per step, a label), robot labels (id and mode), the frontier
//                                             each exploring robot drives to
//   /ROBOT_ID/camera/image/compressed  sensor_msgs/CompressedImage  the robot's JPEG frames, as they arrive
//                                             (frame ROBOT_ID/camera)
// Cairn's own topics, forwarded unchanged (the same CDR) under ROS 2's names so that `ros2 topic echo` reads
// them once the generated package cairn_msgs (ros2/cairn_msgs_ros2, tools/gen_ros2_msgs.py) is built:
//   /cairn/robot_state  cairn_msgs/msg/RobotState   every robot's whole state (its latest pose applied), on
//   change /cairn/bt_state     cairn_msgs/msg/BehaviorTreeState /cairn/global_path  cairn_msgs/msg/GlobalPath
//   /cairn/health       cairn_msgs/msg/AgentHealth
// (ROS 2 topics have no keys: every robot's samples share the topic; robot_id tells them apart.)
// QoS: reliable (a reliable writer serves RViz's reliable and best-effort subscriptions alike); paths and the
// map transient local, keep-last 1, so that a viewer started later gets them at once.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "cairn/base/fleet_client.h"
#include "cairn/core/dds.h"

namespace cairn::base {

/// Options of the ROS 2 publisher of the fleet.
struct Ros2FleetOptions {
  int domain_id = 0;  ///< the ROS 2 domain, [0, 232]
  /// Fast DDS profiles file and participant profile: loopback by default (RViz on the operator's computer).
  std::string profiles_file = core::DefaultProfilesFile();
  std::string participant_profile = "cairn.ros2.loopback";
  double state_rate_hz = 10.0;  ///< /tf, (0, 50]
  double map_period_s = 2.0;    ///< /cairn/fleet_map at most this often, seconds, [0.2, 60]
  /// @return false and sets `*why` (field, value, rule) when invalid.
  bool IsValid(std::string* why) const;
};

/// What went out (tests, logs).
struct Ros2FleetStats {
  std::uint64_t tf_messages = 0;
  std::uint64_t paths = 0;
  std::uint64_t map_clouds = 0;
  std::uint64_t map_points = 0;  ///< in the last cloud
  std::uint64_t marker_arrays = 0;
  std::uint64_t camera_frames = 0;
  std::uint64_t forwarded = 0;  ///< Cairn's own samples forwarded (/cairn/robot_state, ...)
};

/// Publishes `client`'s fleet until destroyed (its own thread). Thread-safe.
class Ros2FleetBridge {
 public:
  /// @throws std::invalid_argument for invalid options; core::DdsError when the participant or a writer
  ///         cannot be created.
  Ros2FleetBridge(FleetClient& client, const Ros2FleetOptions& options);
  ~Ros2FleetBridge();
  Ros2FleetBridge(const Ros2FleetBridge&) = delete;
  Ros2FleetBridge& operator=(const Ros2FleetBridge&) = delete;

  Ros2FleetStats Stats() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::base
