#include "cairn/agent/communication/health_report.h"

#include <utility>

#include "cairn/agent/agent_components.h"

namespace cairn::agent {
namespace {

// The longest last_error a message carries, characters (a component's error can be a whole exception text).
constexpr std::size_t kMaxErrorChars = 240;

}  // namespace

HealthReport::HealthReport(std::string robot_id, double period_s)
    : robot_id_(std::move(robot_id)), period_s_(period_s) {}

void HealthReport::OnEvent(const core::HealthEvent& event) {
  {
    std::lock_guard<std::mutex> guard(event_mutex_);
    ++events_;
    last_event_ = event;
  }
  due_ = true;
}

std::optional<cairn_msgs::AgentHealth> HealthReport::MessageIfDue(core::SteadyTime now,
                                                                  const core::HealthMonitor& monitor,
                                                                  std::uint64_t late_control_cycles) {
  if (!due_.exchange(false) && core::SecondsBetween(last_publish_, now) < period_s_) return std::nullopt;
  const double window_s = core::SecondsBetween(last_publish_, now);
  const double cpu_s = ProcessCpuSeconds();
  if (last_publish_ != core::SteadyTime{} && window_s > 0.2) {
    process_cpu_percent_ = 100.0 * (cpu_s - last_process_cpu_s_) / window_s;
  }
  if (last_publish_ == core::SteadyTime{} || window_s > 0.2) {
    last_process_cpu_s_ = cpu_s;
    last_publish_ = now;
  }
  cairn_msgs::AgentHealth m;
  m.robot_id(robot_id_);
  const core::WallStamp stamp = core::WallNow();
  m.stamp().sec(stamp.sec);
  m.stamp().nanosec(stamp.nanosec);
  for (const core::ComponentHealth& h : monitor.Snapshot(now)) {
    cairn_msgs::ComponentHealth c;
    c.name(h.name);
    c.state(h.state);
    c.loop_rate_hz(static_cast<float>(h.loop_rate_hz));
    c.target_rate_hz(static_cast<float>(h.target_rate_hz));
    c.last_error(h.last_error.size() > kMaxErrorChars ? h.last_error.substr(0, kMaxErrorChars - 3) + "..."
                                                      : h.last_error);
    c.cpu_percent(static_cast<float>(h.cpu_percent));
    c.memory_bytes(h.memory_bytes);
    c.restarts(h.restarts);
    c.restart_in_s(static_cast<float>(h.restart_in_s));
    c.down_for_s(static_cast<float>(h.down_for_s));
    c.degraded(h.degraded);
    m.components().push_back(std::move(c));
  }
  m.rss_bytes(ProcessRssBytes());
  m.process_cpu_percent(static_cast<float>(process_cpu_percent_));
  m.late_control_cycles(late_control_cycles);
  std::lock_guard<std::mutex> guard(event_mutex_);
  m.events(events_);
  if (events_ > 0) {
    m.last_event(last_event_.message);
    m.last_event_kind(core::ToString(last_event_.kind));
    m.last_event_component(last_event_.component);
  }
  return m;
}

}  // namespace cairn::agent
