// ROS 2's wire conventions that Cairn's ROS 2 endpoints share (the robot's driver, the basestation's fleet
// publisher): topic names, stamps, poses.
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "ros2_msgs.h"

namespace cairn::ros2 {

/// "/points" -> "rt/points" (the DDS topic of a ROS 2 topic; rmw adds "rt/" to topics); "" stays "".
std::string DdsTopicName(const std::string& ros_topic);

/// builtin_interfaces/Time as seconds.
double StampS(const builtin_interfaces::msg::dds_::Time_& stamp);
/// Seconds (>= 0) as builtin_interfaces/Time (nanoseconds rounded down).
builtin_interfaces::msg::dds_::Time_ ToStamp(double seconds);
/// geometry_msgs Pose or Transform parts as an isometry (the quaternion normalised; a zero or non-finite one
/// is the identity).
Eigen::Isometry3d ToIsometry(const Eigen::Vector3d& translation, double qx, double qy, double qz, double qw);

}  // namespace cairn::ros2
