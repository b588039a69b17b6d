// What the robot tells the basestations about its own software (AgentHealth, topic cairn/health): each
// component's state, loop rate, CPU, memory and restarts as the health monitor sees them, the process's CPU
// and resident memory, late control cycles, and the last health event. Sent at once after an event, else
// every `period_s` (longer on a radio link).
//
// Thread safety: OnEvent from any thread (the monitor's); MessageIfDue from one thread (the control loop).
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>

#include "cairn/core/health_monitor.h"
#include "cairn/core/time.h"
#include "cairn_msgs.h"

namespace cairn::agent {

class HealthReport {
 public:
  /// `period_s`: the longest time between two messages, seconds (> 0).
  HealthReport(std::string robot_id, double period_s);

  /// A health event (a component failed, restarted, escalated ...): counted, kept as the last one, and the
  /// next MessageIfDue sends at once.
  void OnEvent(const core::HealthEvent& event);

  /// The message to send at `now`, if one is due: `monitor`'s view of every component, the process's CPU
  /// (over the time since the last message) and memory, `late_control_cycles` so far. nullopt otherwise.
  std::optional<cairn_msgs::AgentHealth> MessageIfDue(core::SteadyTime now,
                                                      const core::HealthMonitor& monitor,
                                                      std::uint64_t late_control_cycles);

 private:
  const std::string robot_id_;
  const double period_s_;
  std::atomic<bool> due_{true};
  std::mutex event_mutex_;  // guards the two below (the monitor's thread writes them)
  std::uint32_t events_ = 0;
  core::HealthEvent last_event_{core::HealthEvent::Kind::kFailed, "", ""};
  core::SteadyTime last_publish_{};
  double last_process_cpu_s_ = 0.0;
  double process_cpu_percent_ = 0.0;
};

}  // namespace cairn::agent
