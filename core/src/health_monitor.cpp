#include "cairn/core/health_monitor.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::core {

namespace {

void CheckPolicy(const std::string& name, const RestartPolicy& p) {
  auto bad = [&](const char* field, double value) {
    return std::invalid_argument("component " + name + ": restart policy " + field + " " +
                                 core::Fixed(value, 1) + " is out of range");
  };
  if (!(p.heartbeat_deadline_s > 0)) throw bad("heartbeat_deadline_s", p.heartbeat_deadline_s);
  if (p.missed_deadlines_to_fail < 1) throw bad("missed_deadlines_to_fail", p.missed_deadlines_to_fail);
  if (!(p.first_backoff_s > 0)) throw bad("first_backoff_s", p.first_backoff_s);
  if (!(p.max_backoff_s >= p.first_backoff_s)) throw bad("max_backoff_s", p.max_backoff_s);
  if (!(p.stable_after_s >= 0)) throw bad("stable_after_s", p.stable_after_s);
}

}  // namespace

const char* ToString(HealthEvent::Kind kind) {
  switch (kind) {
    case HealthEvent::Kind::kFailed:
      return "failed";
    case HealthEvent::Kind::kRestarted:
      return "restarted";
    case HealthEvent::Kind::kRestartFailed:
      return "restart_failed";
    case HealthEvent::Kind::kEscalated:
      return "escalated";
    case HealthEvent::Kind::kDegraded:
      return "degraded";
    case HealthEvent::Kind::kRecovered:
      return "recovered";
  }
  return "?";
}

HealthMonitor::HealthMonitor(std::function<void(const HealthEvent&)> on_event)
    : on_event_(std::move(on_event)) {}

HealthMonitor::~HealthMonitor() {
  {
    std::lock_guard<std::mutex> guard(stop_mutex_);
    stop_ = true;
  }
  stop_wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void HealthMonitor::Add(Component* component, const RestartPolicy& policy) {
  if (component == nullptr) throw std::invalid_argument("HealthMonitor: null component");
  CheckPolicy(component->name(), policy);
  std::lock_guard<std::mutex> guard(mutex_);
  for (const Entry& e : entries_) {
    if (e.component->name() == component->name()) {
      throw std::invalid_argument("HealthMonitor: component " + component->name() + " added twice");
    }
  }
  Entry e;
  e.component = component;
  e.policy = policy;
  entries_.push_back(std::move(e));
}

void HealthMonitor::StartAll() {
  std::lock_guard<std::mutex> transition(transition_mutex_);
  ComponentManager manager;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    for (const Entry& e : entries_) manager.Add(e.component);
  }
  manager.StartAll();
  const SteadyTime now = SteadyClock::now();
  std::lock_guard<std::mutex> guard(mutex_);
  for (Entry& e : entries_) {
    e.up_since = now;
    e.window_start = now;
    e.window_beats = e.component->heartbeats();
    e.window_cpu_s = e.component->cpu_s();
  }
  started_ = true;
}

void HealthMonitor::StopAll() noexcept {
  {
    std::lock_guard<std::mutex> guard(stop_mutex_);
    stop_ = true;
  }
  stop_wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard<std::mutex> transition(transition_mutex_);
  ComponentManager manager;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    for (const Entry& e : entries_) manager.Add(e.component);
  }
  manager.StopAll();
}

void HealthMonitor::StartChecking(std::chrono::milliseconds period) {
  if (thread_.joinable()) throw std::logic_error("HealthMonitor: already checking");
  thread_ = std::thread([this, period] {
    std::unique_lock<std::mutex> lock(stop_mutex_);
    while (!stop_) {
      lock.unlock();
      Check(SteadyClock::now());
      lock.lock();
      stop_wake_.wait_for(lock, period, [this] { return stop_; });
    }
  });
}

HealthMonitor::Entry* HealthMonitor::Find(const std::string& name) {
  for (Entry& e : entries_) {
    if (e.component->name() == name) return &e;
  }
  return nullptr;
}

void HealthMonitor::ScheduleRestart(Entry& e, SteadyTime from) {
  e.backoff_s =
      e.backoff_s <= 0 ? e.policy.first_backoff_s : std::min(2 * e.backoff_s, e.policy.max_backoff_s);
  e.restart_at =
      from + std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(e.backoff_s));
}

std::vector<HealthEvent> HealthMonitor::TakeDown(Entry& e, const std::string& reason, SteadyTime now) {
  try {
    e.component->Deactivate();  // stops its loops (waiting up to its grace period for each)
  } catch (const std::exception& ex) {
    spdlog::error("{}: deactivation failed: {}", e.component->name(), ex.what());
  }
  const std::string still_running = e.component->StillRunning();
  const std::string& name = e.component->name();
  std::lock_guard<std::mutex> guard(mutex_);
  e.down = true;
  e.down_since = now;
  // The back-off counts from when its loops have stopped (a hung one is waited for up to its grace period).
  ScheduleRestart(e, std::max(now, SteadyClock::now()));
  e.down_reason = reason;
  if (still_running.empty()) {
    return {{HealthEvent::Kind::kFailed, name,
             name + " failed: " + reason + "; restart in " + core::Fixed(e.backoff_s, 1) + " s"}};
  }
  // Started again, it would run beside the work that did not stop, on the same state: the process must go.
  e.still_running = true;
  e.down_reason = reason + "; " + still_running;
  return {{HealthEvent::Kind::kFailed, name, name + " failed: " + reason},
          {HealthEvent::Kind::kEscalated, name,
           name + " did not stop when asked (" + still_running +
               "): not restarted in this process while it runs; the agent must restart"}};
}

std::vector<HealthEvent> HealthMonitor::StopForRestart(Entry& e, const std::string& by, SteadyTime now) {
  try {
    e.component->Deactivate();
  } catch (const std::exception& ex) {
    spdlog::error("{}: deactivation failed: {}", e.component->name(), ex.what());
  }
  const std::string still_running = e.component->StillRunning();
  if (still_running.empty()) return {};
  const std::string& name = e.component->name();
  std::lock_guard<std::mutex> guard(mutex_);
  e.down = true;
  e.down_since = now;
  ScheduleRestart(e, now);
  e.still_running = true;
  e.down_reason = "restart by " + by + "; " + still_running;
  return {{HealthEvent::Kind::kEscalated, name,
           name + " did not stop for its restart by " + by + " (" + still_running +
               "): not restarted in this process while it runs; the agent must restart"}};
}

std::optional<HealthEvent> HealthMonitor::JudgeRate(Entry& e) {
  Component& c = *e.component;
  const double target_hz = c.target_rate_hz();
  if (e.down || c.state() != LifecycleState::kActive || !(target_hz > 0)) {
    e.degraded = false;
    e.slow_windows = 0;
    return std::nullopt;
  }
  // No beat at all in the window is a stall in the making (the stall check judges it), not slowness.
  const bool off = e.degraded ? e.rate_hz >= kRecoveredAbove * target_hz
                              : e.rate_hz > 0 && e.rate_hz < kDegradedBelow * target_hz;
  e.slow_windows = off ? e.slow_windows + 1 : 0;
  if (e.slow_windows < kDegradedWindows) return std::nullopt;
  e.slow_windows = 0;
  e.degraded = !e.degraded;
  const std::string rates = core::Fixed(e.rate_hz, 1) + " of " + core::Fixed(target_hz, 1) + " Hz";
  if (e.degraded) {
    return HealthEvent{HealthEvent::Kind::kDegraded, c.name(),
                       c.name() + " degraded: " + rates + " (slow, not hung: not restarted)"};
  }
  return HealthEvent{HealthEvent::Kind::kRecovered, c.name(), c.name() + " back at its rate: " + rates};
}

void HealthMonitor::Check(SteadyTime now) {
  std::vector<HealthEvent> events;
  {
    std::lock_guard<std::mutex> transition(transition_mutex_);
    bool process_stalled = false;
    for (Entry* entry : EntriesToCheck(now, &process_stalled)) {
      Entry& e = *entry;
      std::string by;
      const std::string reason = Judge(e, now, process_stalled, &by, &events);
      if (!reason.empty()) {
        for (HealthEvent& event : TakeDown(e, reason, now)) {
          spdlog::error("{}", event.message);
          events.push_back(std::move(event));
        }
        continue;
      }
      BringUpIfDue(e, by, now, &events);
    }
  }
  if (on_event_) {
    for (const HealthEvent& event : events) on_event_(event);
  }
}

std::vector<HealthMonitor::Entry*> HealthMonitor::EntriesToCheck(SteadyTime now, bool* process_stalled) {
  std::lock_guard<std::mutex> guard(mutex_);
  std::vector<Entry*> entries;
  double shortest_deadline_s = 1e9;
  for (Entry& e : entries_) {
    entries.push_back(&e);
    shortest_deadline_s = std::min(shortest_deadline_s, e.policy.heartbeat_deadline_s);
  }
  *process_stalled = last_check_ != SteadyTime{} && SecondsBetween(last_check_, now) > shortest_deadline_s;
  last_check_ = now;
  return entries;
}

std::string HealthMonitor::Judge(Entry& e, SteadyTime now, bool process_stalled, std::string* by,
                                 std::vector<HealthEvent>* events) {
  Component& c = *e.component;
  std::lock_guard<std::mutex> guard(mutex_);
  // Loop rate and CPU over windows of about a second.
  if (const double window_s = SecondsBetween(e.window_start, now); window_s >= 1.0) {
    const std::uint64_t beats = c.heartbeats();
    const double cpu_s = c.cpu_s();
    e.rate_hz = static_cast<double>(beats - e.window_beats) / window_s;
    e.cpu_percent = 100.0 * (cpu_s - e.window_cpu_s) / window_s;
    e.window_start = now;
    e.window_beats = beats;
    e.window_cpu_s = cpu_s;
    if (std::optional<HealthEvent> slow = JudgeRate(e); slow) {
      spdlog::warn("{}", slow->message);
      events->push_back(std::move(*slow));
    }
  }
  if (process_stalled) {
    e.no_stall_before = now + std::chrono::duration_cast<SteadyClock::duration>(
                                  std::chrono::duration<double>(e.policy.heartbeat_deadline_s));
  }
  *by = std::move(e.restart_requested_by);
  e.restart_requested_by.clear();
  if (c.state() != LifecycleState::kActive) return "";
  std::string reason;
  if (c.failed()) {
    reason = c.last_error();
  } else if (now >= e.no_stall_before) {
    const double age_s = SecondsBetween(c.last_heartbeat(), now);
    const int missed = static_cast<int>(std::floor(age_s / e.policy.heartbeat_deadline_s));
    if (missed >= e.policy.missed_deadlines_to_fail) {
      reason = "stalled: no heartbeat for " + core::Fixed(age_s, 1) + " s (" + std::to_string(missed) +
               " deadlines of " + core::Fixed(e.policy.heartbeat_deadline_s, 1) + " s missed)";
      c.ReportFailure(reason);
    }
  }
  if (reason.empty() && e.backoff_s > 0 && SecondsBetween(e.up_since, now) >= e.policy.stable_after_s) {
    e.backoff_s = 0;  // up long enough: the next failure waits the first back-off again
  }
  return reason;
}

void HealthMonitor::BringUpIfDue(Entry& e, const std::string& by, SteadyTime now,
                                 std::vector<HealthEvent>* events) {
  Component& c = *e.component;
  bool bring_up = false;
  bool still_running = false;
  {
    std::lock_guard<std::mutex> guard(mutex_);
    bring_up = e.down && (now >= e.restart_at || !by.empty());
    still_running = e.still_running;
  }
  if (!by.empty() && c.state() == LifecycleState::kActive) {
    std::vector<HealthEvent> stuck = StopForRestart(e, by, now);
    if (!stuck.empty()) {
      spdlog::error("{}", stuck.front().message);
      events->push_back(std::move(stuck.front()));
      return;
    }
    bring_up = true;
  }
  if (!bring_up) return;
  if (still_running) {
    // Its work that did not stop may have ended since (slow, not hung): only then is a restart safe.
    if (!c.StillRunning().empty()) return;
    std::lock_guard<std::mutex> guard(mutex_);
    e.still_running = false;
  }
  const double down_s = e.down ? SecondsBetween(e.down_since, now) : 0.0;
  try {
    c.Activate();
    std::lock_guard<std::mutex> guard(mutex_);
    e.down = false;
    e.up_since = now;
    e.down_reason.clear();
    ++e.restarts;
    std::string message = c.name() + " restarted";
    message += by.empty() ? "" : " by " + by;
    message += down_s > 0 ? " after " + core::Fixed(down_s, 1) + " s down" : "";
    message += " (restart " + std::to_string(e.restarts) + ")";
    events->push_back({HealthEvent::Kind::kRestarted, c.name(), message});
    spdlog::warn("{}", message);
  } catch (const std::exception& ex) {
    std::lock_guard<std::mutex> guard(mutex_);
    if (!e.down) e.down_since = now;
    e.down = true;
    ScheduleRestart(e, now);
    e.down_reason = ex.what();
    events->push_back({HealthEvent::Kind::kRestartFailed, c.name(),
                       c.name() + " did not come back up: " + ex.what() + "; next try in " +
                           core::Fixed(e.backoff_s, 1) + " s"});
    spdlog::error("{}", events->back().message);
  }
}

std::string HealthMonitor::RequestRestart(const std::string& name, const std::string& by) {
  std::lock_guard<std::mutex> guard(mutex_);
  Entry* e = Find(name);
  if (e == nullptr) {
    std::string names;
    for (const Entry& x : entries_) names += (names.empty() ? "" : ", ") + x.component->name();
    return "no component \"" + name + "\" (the components are " + names + ")";
  }
  if (e->still_running) {
    return name + " cannot be restarted in this process: its work did not stop when asked (" +
           e->down_reason + "); restart the agent";
  }
  e->restart_requested_by = by.empty() ? "an operator" : by;
  return "";
}

std::map<std::string, std::string> HealthMonitor::Down() const {
  std::map<std::string, std::string> down;
  const SteadyTime now = SteadyClock::now();
  std::lock_guard<std::mutex> guard(mutex_);
  for (const Entry& e : entries_) {
    if (e.down && e.still_running) {
      down[e.component->name()] = e.component->name() + " is down (" + e.down_reason +
                                  "); not restarted in this process while that runs";
    } else if (e.down) {
      down[e.component->name()] = e.component->name() + " is down (" + e.down_reason + "); restart in " +
                                  core::Fixed(std::max(0.0, SecondsBetween(now, e.restart_at)), 1) + " s";
    } else if (!started_) {
      down[e.component->name()] = e.component->name() + kStartingSuffix;
    } else if (e.component->state() != LifecycleState::kActive) {
      down[e.component->name()] = e.component->name() + " is " + ToString(e.component->state());
    }
  }
  return down;
}

std::vector<ComponentHealth> HealthMonitor::Snapshot(SteadyTime now) const {
  std::vector<ComponentHealth> out;
  std::lock_guard<std::mutex> guard(mutex_);
  for (const Entry& e : entries_) {
    const Component& c = *e.component;
    ComponentHealth h;
    h.name = c.name();
    h.state = e.down ? "down" : ToString(c.state());
    h.loop_rate_hz = e.down ? 0.0 : e.rate_hz;
    h.degraded = e.degraded;
    h.target_rate_hz = c.target_rate_hz();
    h.last_error = c.last_error();
    h.cpu_percent = e.cpu_percent;
    h.memory_bytes = c.MemoryBytes();
    h.restarts = e.restarts;
    if (e.down) {
      h.restart_in_s = std::max(0.0, SecondsBetween(now, e.restart_at));
      h.down_for_s = SecondsBetween(e.down_since, now);
    }
    out.push_back(std::move(h));
  }
  return out;
}

std::vector<std::string> HealthMonitor::Names() const {
  std::vector<std::string> names;
  std::lock_guard<std::mutex> guard(mutex_);
  for (const Entry& e : entries_) names.push_back(e.component->name());
  return names;
}

}  // namespace cairn::core
