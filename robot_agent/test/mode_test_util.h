// Shared by the mode tree's tests: the conditions under which an operator holds a robot.
#pragma once

#include "cairn/agent/modes/mode_manager.h"

namespace cairn::agent::mode_testing {

/// Basestation opA holds the lock and is alive; the robot is localized and its local planner healthy (no
/// joystick, no goal).
inline ModeConditions Held() {
  ModeConditions c;
  c.holder_id = "opA";
  c.holder_alive = true;
  c.localized = true;
  c.local_planner_healthy = true;
  return c;
}

}  // namespace cairn::agent::mode_testing
