// Copyright Cairn authors.
//
// The emulator's command line: every flag with its unit and default, parsed strictly (a bad value is an
// error naming the flag and the value; the process exits with code 2).
#pragma once

#include <cstdint>
#include <string>

#include "cli_values.h"
#include "world.h"

namespace ros2_emulator {

/// Which message type the velocity command topic carries.
enum class CmdType { kTwist, kTwistStamped };

/// Everything the command line sets.
struct EmulatorOptions {
  /// --help was given: print Usage() and exit 0.
  bool help = false;
  /// The world: a built-in one by name (--world) or the walls of a file (--world-file); resolved.
  World world;
  /// --start X,Y,YAW: the base's start pose in the world, metres and radians; the world's default if unset.
  Pose2 start;
  /// --domain N: the DDS domain (ROS_DOMAIN_ID when unset, else 0), 0..232.
  std::uint32_t domain_id = 0;
  /// --interface NAME: the network interface DDS uses, with multicast discovery on it as a ROS 2 robot's
  /// computers find each other on their own network; "" = loopback only (127.0.0.1, no multicast).
  std::string interface_name;
  /// DDS topic names (already mapped from the ROS names: "/points" -> "rt/points").
  std::string points_topic = "rt/points";
  std::string odom_topic = "rt/odom";
  std::string cmd_topic = "rt/cmd_vel";
  /// --cmd-type twist|twist_stamped.
  CmdType cmd_type = CmdType::kTwist;
  /// --drift FACTOR: multiplies the odometry drift (0.002 rad/s yaw-rate bias, 1 % distance scale error);
  /// 0 = perfect odometry, >= 0.
  double drift_factor = 1.0;
  /// --slam: also publish map -> odom on /tf at 10 Hz so that map -> base_link is the truth.
  bool slam = false;
  /// --seed N: seed of the lidar's range noise.
  std::uint64_t seed = 1;
  /// --truth-out FILE: where to write the truth every 20 ms ("" = nowhere).
  std::string truth_out;
};

/// The --help text.
std::string Usage();

/// Parses argv. `ros_domain_id_env` is the ROS_DOMAIN_ID environment variable (nullptr if unset). Throws
/// UsageError on an unknown flag, a missing or bad value, a bad world file (its message names the file, line
/// and value), or a start pose at which the robot would overlap a wall.
EmulatorOptions ParseOptions(int argc, const char* const* argv, const char* ros_domain_id_env);

}  // namespace ros2_emulator
