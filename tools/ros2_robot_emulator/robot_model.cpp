// Copyright Cairn authors.
#include "robot_model.h"

#include <algorithm>
#include <cmath>

namespace ros2_emulator {
namespace {

/// Wraps an angle to (-pi, pi], radians.
double WrapAngle(double angle_rad) { return std::remainder(angle_rad, 2.0 * kPi); }

/// Moves `value` towards `target` by at most `max_change` (an acceleration limit over one step).
double Approach(double value, double target, double max_change) {
  return value + std::clamp(target - value, -max_change, max_change);
}

/// Integrates a planar pose over dt_s at forward speed v_mps and yaw rate w_radps (midpoint heading:
/// second-order accurate, exact on straight lines).
Pose2 Integrate(const Pose2& pose, double v_mps, double w_radps, double dt_s) {
  const double heading_rad = pose.yaw_rad + 0.5 * w_radps * dt_s;
  return {pose.x_m + v_mps * dt_s * std::cos(heading_rad), pose.y_m + v_mps * dt_s * std::sin(heading_rad),
          WrapAngle(pose.yaw_rad + w_radps * dt_s)};
}

}  // namespace

RobotModel::RobotModel(const World& world, const RobotModelOptions& options, const Pose2& start)
    : world_(world), options_(options), X_WB_(start) {}

bool RobotModel::Fits(const World& world, const RobotModelOptions& options, const Pose2& pose) {
  return DistanceToNearestWall(world, pose.x_m, pose.y_m) >= options.radius_m;
}

void RobotModel::Command(double now_s, double v_mps, double w_radps) {
  command_v_mps_ =
      std::isfinite(v_mps) ? std::clamp(v_mps, -options_.max_speed_mps, options_.max_speed_mps) : 0.0;
  command_w_radps_ = std::isfinite(w_radps)
                         ? std::clamp(w_radps, -options_.max_yaw_rate_radps, options_.max_yaw_rate_radps)
                         : 0.0;
  last_command_s_ = now_s;
}

void RobotModel::AdvanceTo(double now_s) {
  if (!started_) {
    started_ = true;
    now_s_ = now_s;
    return;
  }
  while (now_s_ < now_s) {
    const double watchdog_deadline_s = last_command_s_ + options_.watchdog_s;
    const bool commanded = now_s_ < watchdog_deadline_s;
    // Never step across the watchdog's deadline: the command ends exactly there, however late we run.
    double step_end_s = std::min(now_s, now_s_ + options_.max_step_s);
    if (commanded) step_end_s = std::min(step_end_s, watchdog_deadline_s);
    if (commanded) {
      Step(step_end_s - now_s_, command_v_mps_, command_w_radps_);
    } else {
      // Watchdog: the drive is cut, the base stops at once (and stays stopped until the next command).
      v_mps_ = 0.0;
      w_radps_ = 0.0;
      Step(step_end_s - now_s_, 0.0, 0.0);
    }
    now_s_ = step_end_s;
  }
}

void RobotModel::Step(double dt_s, double target_v_mps, double target_w_radps) {
  v_mps_ = Approach(v_mps_, target_v_mps, options_.max_accel_mps2 * dt_s);
  w_radps_ = Approach(w_radps_, target_w_radps, options_.max_yaw_accel_radps2 * dt_s);

  // Turning in place never moves the centre, so it is always allowed. The translation is made only as far as
  // the body keeps its radius from every wall: a step that would come closer is cut at the contact point
  // (steps are at most 1 cm, see max_step_s: no wall can slip between a step's ends).
  const Pose2 full = Integrate(X_WB_, v_mps_, w_radps_, dt_s);
  double fraction = 1.0;  // of the step's translation actually made
  if (v_mps_ != 0.0 && !Fits(world_, options_, full)) {
    // Bisection for the largest fraction that fits (the start fits): 20 halvings of a <= 1 cm step.
    double fits = 0.0, blocked = 1.0;
    for (int i = 0; i < 20; ++i) {
      const double mid = 0.5 * (fits + blocked);
      const Pose2 trial{X_WB_.x_m + mid * (full.x_m - X_WB_.x_m), X_WB_.y_m + mid * (full.y_m - X_WB_.y_m),
                        0.0};
      (Fits(world_, options_, trial) ? fits : blocked) = mid;
    }
    fraction = fits;
    in_contact_ = true;
  } else if (v_mps_ != 0.0) {
    in_contact_ = false;
  }
  const double moved_v_mps = v_mps_ * fraction;  // the mean forward speed over the step
  X_WB_ = {X_WB_.x_m + fraction * (full.x_m - X_WB_.x_m), X_WB_.y_m + fraction * (full.y_m - X_WB_.y_m),
           full.yaw_rad};
  if (fraction < 1.0) v_mps_ = 0.0;  // stalled against the wall: the next push starts from rest

  // Wheel odometry: the wheels measure the actual motion (nothing while stalled), with a scale error on
  // distance and, while any wheel turns, a yaw-rate bias.
  const bool wheels_turn = moved_v_mps != 0.0 || w_radps_ != 0.0;
  measured_.v_mps = moved_v_mps * (1.0 + options_.odom_scale_error);
  measured_.w_radps = w_radps_ + (wheels_turn ? options_.odom_yaw_bias_radps : 0.0);
  X_OB_ = Integrate(X_OB_, measured_.v_mps, measured_.w_radps, dt_s);
}

}  // namespace ros2_emulator
