// Copyright Cairn authors.
//
// The emulated differential-drive base: kinematics with velocity and acceleration limits, a command
// watchdog, a disk body that never enters a wall, and wheel odometry with a configurable drift. Pure math on
// explicit times (seconds of any monotonic clock), no DDS and no clock reads, so it is easy to reason about.
//
// Frames: W world (the truth), O odometry (where wheel odometry started: the start pose is its origin),
// B base_link (x forward, y left, z up, on the floor under the robot's centre).
#pragma once

#include "world.h"

namespace ros2_emulator {

/// Limits and noise of the base; defaults are those of the emulator's documentation (--help).
struct RobotModelOptions {
  /// Radius of the body disk, metres (> 0). Its centre never comes closer than this to a wall.
  double radius_m = 0.3;
  /// Commanded speeds are clamped to these: forward speed, m/s, and yaw rate, rad/s (> 0).
  double max_speed_mps = 1.0;
  double max_yaw_rate_radps = 1.5;
  /// Acceleration limits the base's controller obeys, m/s^2 and rad/s^2 (> 0).
  double max_accel_mps2 = 1.5;
  double max_yaw_accel_radps2 = 3.0;
  /// With no command for this long the base stops at once (a motor controller's command timeout), s (> 0).
  double watchdog_s = 0.5;
  /// Odometry's yaw-rate bias while the wheels turn, rad/s (a small heading drift), and its relative error
  /// on distance travelled (0.01 = odometry reports 1 % more than driven). Both 0: perfect odometry.
  double odom_yaw_bias_radps = 0.002;
  double odom_scale_error = 0.01;
  /// Longest integration step, seconds: a step never moves the body more than max_speed_mps times this, so
  /// the collision test at each step's end cannot skip over a wall.
  double max_step_s = 0.01;
};

/// The base's velocity, as measured by its wheels: forward speed, m/s, and yaw rate, rad/s (frame B).
struct BodyTwist {
  double v_mps = 0.0;
  double w_radps = 0.0;
};

/// The differential-drive robot. Not thread-safe: one thread commands and advances it.
class RobotModel {
 public:
  /// Starts at rest at X_WB = start (which must be at least radius_m from every wall: see Fits()).
  RobotModel(const World& world, const RobotModelOptions& options, const Pose2& start);

  /// True when a body at `pose` keeps radius_m from every wall of `world`.
  static bool Fits(const World& world, const RobotModelOptions& options, const Pose2& pose);

  /// A new velocity command (cmd_vel) received at now_s: linear.x, m/s, and angular.z, rad/s; clamped to
  /// the limits. Non-finite values count as 0 (and still feed the watchdog).
  void Command(double now_s, double v_mps, double w_radps);

  /// Integrates the motion up to now_s (no-op if now_s is not after the last call), in steps of at most
  /// max_step_s; the watchdog cuts the command at exactly last command + watchdog_s even when called late.
  void AdvanceTo(double now_s);

  /// The truth: pose of the base in W.
  const Pose2& X_WB() const { return X_WB_; }
  /// Wheel odometry: pose of the base in O (identity at start), drifting as the options say.
  const Pose2& X_OB() const { return X_OB_; }
  /// The body velocity the wheels measure (scale error included; 0 while a wall blocks the body).
  BodyTwist MeasuredTwist() const { return measured_; }
  /// True from a step whose translation a wall cut short (the body touches it) until a step's translation is
  /// made in full again; a base stopped against a wall stays in contact.
  bool InContact() const { return in_contact_; }

 private:
  /// One integration step of dt_s with the given target velocities (already clamped).
  void Step(double dt_s, double target_v_mps, double target_w_radps);

  const World& world_;
  RobotModelOptions options_;
  Pose2 X_WB_;
  Pose2 X_OB_;
  double v_mps_ = 0.0;    // actual forward speed (truth)
  double w_radps_ = 0.0;  // actual yaw rate (truth)
  BodyTwist measured_;
  bool in_contact_ = false;
  double command_v_mps_ = 0.0;
  double command_w_radps_ = 0.0;
  double last_command_s_ = -1e300;  // no command yet: the watchdog holds the base
  double now_s_ = 0.0;
  bool started_ = false;  // AdvanceTo called once (now_s_ valid)
};

}  // namespace ros2_emulator
