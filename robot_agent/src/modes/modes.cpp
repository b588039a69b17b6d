#include "cairn/agent/modes/modes.h"

#include <stdexcept>

namespace cairn::agent {

IdleMode::IdleMode() : ModeModule(kName, MuxChannelOptions{"none", 0.5}) {}

ManualMode::ManualMode(double stick_timeout_s)
    : ModeModule(kName, MuxChannelOptions{kChannel, stick_timeout_s}) {}

ModeOutput ManualMode::Step(const ModeInputs&) {
  ModeOutput out;
  if (has_stick_) {
    out.twist_B = stick_B_;
    out.stamp = stamp_;
  }
  return out;
}

void ManualMode::OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp) {
  stick_B_ = Twist2{twist_B.vx_mps, twist_B.wz_radps};
  stamp_ = stamp;
  has_stick_ = true;
}

SmartJoystickMode::SmartJoystickMode(nav::Navigation* navigation, double channel_timeout_s,
                                     double stick_timeout_s)
    : ModeModule(kName, MuxChannelOptions{kChannel, channel_timeout_s}),
      navigation_(navigation),
      stick_timeout_s_(stick_timeout_s) {
  if (navigation_ == nullptr) throw std::invalid_argument("SmartJoystickMode: navigation is null");
}

ModeOutput SmartJoystickMode::Step(const ModeInputs& in) {
  // A silent joystick is a zero stick: the robot brakes (the mux would zero it after its timeout anyway).
  const bool fresh = core::SecondsBetween(stick_.stamp, in.now) <= stick_timeout_s_;
  const OperatorTwist stick = fresh ? stick_.twist_B : OperatorTwist{};
  const nav::NavigationStep step =
      navigation_->StepJoystick(in.pose_M, stick.vx_mps, stick.vy_mps, stick.wz_radps, in.now_s);
  ModeOutput out;
  out.twist_B = Twist2{step.linear_x_mps, step.angular_z_radps};
  out.stamp = in.now;
  return out;
}

void SmartJoystickMode::OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp) {
  stick_ = Stick{twist_B, stamp};
}

}  // namespace cairn::agent
