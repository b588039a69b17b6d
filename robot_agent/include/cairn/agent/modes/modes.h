// The built-in mode modules of sliding autonomy (Sriganesh et al. 2024, lesson L1) besides waypoint
// (waypoint_mode.h): idle, manual (teleoperation) and smart joystick. Each is one ModeModule; the mode tree's
// subtree of the same name (config/mode_tree.xml) says when it may run.
#pragma once

#include <string>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/modes/mode_module.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

/// The fail-safe mode: drives nothing (channel "none", zero twist). Every agent has it.
class IdleMode : public ModeModule {
 public:
  static constexpr const char* kName = ModeManager::kIdleMode;
  IdleMode();
  ModeOutput Step(const ModeInputs&) override { return {}; }
};

/// Manual (teleoperation): the control holder's stick goes to the mux as it is, on channel "teleop" (forward
/// speed and yaw rate; the sideways speed is ignored by a unicycle base).
class ManualMode : public ModeModule {
 public:
  static constexpr const char* kName = "manual";
  static constexpr const char* kChannel = "teleop";
  /// `stick_timeout_s`: a stick older than this is stale (the mux outputs zero), seconds, (0, 60].
  explicit ManualMode(double stick_timeout_s);
  void Activate(core::SteadyTime) override { has_stick_ = false; }
  void Deactivate(const std::string&) override { has_stick_ = false; }
  /// The last stick received in this mode, with its arrival time (the mux judges its age).
  ModeOutput Step(const ModeInputs& in) override;
  void OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp) override;

 private:
  Twist2 stick_B_;
  core::SteadyTime stamp_{};
  bool has_stick_ = false;
};

/// Smart joystick: the stick gives a direction and speed; the local planner picks the free path closest to it
/// and the controller drives it (Navigation::StepJoystick), on channel "smart_joystick". A silent stick is a
/// zero stick: the robot brakes.
class SmartJoystickMode : public ModeModule {
 public:
  static constexpr const char* kName = "smart_joystick";
  static constexpr const char* kChannel = "smart_joystick";
  /// `navigation` (not owned) outlives this. `channel_timeout_s`: the channel's staleness, seconds, (0, 60].
  /// `stick_timeout_s`: a stick older than this counts as zero, seconds, (0, 60].
  SmartJoystickMode(nav::Navigation* navigation, double channel_timeout_s, double stick_timeout_s);
  void Activate(core::SteadyTime) override { stick_ = Stick{}; }
  void Deactivate(const std::string&) override { stick_ = Stick{}; }
  ModeOutput Step(const ModeInputs& in) override;
  void OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp) override;
  bool uses_local_planner() const override { return true; }

 private:
  struct Stick {
    OperatorTwist twist_B;
    core::SteadyTime stamp{};
  };
  nav::Navigation* navigation_;
  double stick_timeout_s_;
  Stick stick_;
};

}  // namespace cairn::agent
