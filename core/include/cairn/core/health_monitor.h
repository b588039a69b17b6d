// The agent's health monitor: it brings its components up, watches their heartbeats and failures, and
// restarts one that threw or stalled, alone, with a growing back-off (Sriganesh et al. 2024, § Resilience: a
// health tab, automatic or manual restarts of parts). Nav2's lifecycle manager takes every node down when one
// bond times out; here the others go on, and the modes that need the one that is down are refused meanwhile
// (the agent's mode tree asks Down()).
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/component.h"
#include "cairn/core/time.h"

namespace cairn::core {

/// How one component is judged and restarted.
struct RestartPolicy {
  /// A heartbeat older than this is one missed deadline, seconds, > 0.
  double heartbeat_deadline_s = 1.0;
  /// Missed deadlines in a row that make it stalled (it is then restarted), >= 1.
  int missed_deadlines_to_fail = 3;
  /// Wait before the first restart after a failure, seconds, > 0; it doubles with each failure up to
  /// max_backoff_s, and falls back to first_backoff_s after stable_after_s up.
  double first_backoff_s = 1.0;
  double max_backoff_s = 30.0;
  double stable_after_s = 60.0;
};

/// One component's health as the monitor last judged it.
struct ComponentHealth {
  std::string name;
  /// "active" | "down" (failed or stalled; restarted at restart_in_s) | "inactive" | "unconfigured".
  std::string state;
  double loop_rate_hz = 0.0;       ///< heartbeats per second over the last measuring window (about 1 s)
  double target_rate_hz = 0.0;     ///< what it should beat at (Component::target_rate_hz())
  std::string last_error;          ///< newest failure ("" = never failed)
  double cpu_percent = 0.0;        ///< of one core, over the last measuring window
  std::uint64_t memory_bytes = 0;  ///< Component::MemoryBytes() (0 = not reported)
  std::uint32_t restarts = 0;      ///< automatic and manual restarts so far
  double restart_in_s = 0.0;       ///< "down": seconds until the next restart attempt
  double down_for_s = 0.0;         ///< "down": seconds since it went down
  /// "active" and beating, but slowly: its loop rate stayed under kDegradedBelow of its target for
  /// kDegradedWindows measuring windows in a row (a busy machine); it is not restarted for that.
  bool degraded = false;
};

/// A change the operator is told about.
struct HealthEvent {
  /// kEscalated: a component that failed did not stop when asked (a loop still runs); it is not restarted in
  /// this process while that runs, and the process should be restarted (the agent's supervisor does).
  /// kDegraded: an active component beats, but under half its rate for a few seconds (slow, not hung: it is
  /// not restarted); kRecovered: back at its rate.
  enum class Kind { kFailed, kRestarted, kRestartFailed, kEscalated, kDegraded, kRecovered };
  Kind kind;
  std::string component;
  std::string message;  ///< e.g. "perception failed: stalled (no heartbeat for 6.0 s); restart in 1.0 s"
};
const char* ToString(HealthEvent::Kind kind);

/// Owns nothing. Add() components, Start() them, then Check() at a fixed period (its own thread with Run(),
/// or a test's clock). Thread-safe.
class HealthMonitor {
 public:
  /// A component beating under this fraction of its target rate for kDegradedWindows windows (of about a
  /// second) in a row is degraded; at or over kRecoveredAbove for as many, it is back.
  static constexpr double kDegradedBelow = 0.5;
  static constexpr double kRecoveredAbove = 0.8;
  static constexpr int kDegradedWindows = 3;
  /// `on_event` (may be empty) is called on the checking thread, without the monitor's lock held.
  explicit HealthMonitor(std::function<void(const HealthEvent&)> on_event = {});
  ~HealthMonitor();
  HealthMonitor(const HealthMonitor&) = delete;
  HealthMonitor& operator=(const HealthMonitor&) = delete;

  /// @throws std::invalid_argument for a null component, a name already added or a bad policy (the field).
  void Add(Component* component, const RestartPolicy& policy);
  /// Configures then activates every component in order (ComponentManager::StartAll: all or none).
  void StartAll();
  /// Stops the checking thread, then deactivates and cleans up every component in reverse order.
  void StopAll() noexcept;

  /// Runs Check() every `period` on a thread of its own until StopAll() (or the destructor).
  void StartChecking(std::chrono::milliseconds period = std::chrono::milliseconds(100));
  /// One pass at `now`: a failed or stalled active component is deactivated and its restart scheduled; a down
  /// one whose back-off has passed is activated again. A pass coming more than a heartbeat deadline after the
  /// previous one (this process was not scheduled: every thread stalled alike) judges no stall. A component
  /// whose work did not stop when deactivated (Component::StillRunning()) is never activated while it runs: a
  /// kEscalated event says so once, and it is restarted only if that work ends by itself.
  void Check(SteadyTime now);

  /// An operator's restart (`restart R COMPONENT`, by basestation `by`): done by the next Check(), without
  /// back-off (a down component is brought up at once). "" when queued, else why not (no such component,
  /// naming those there are; one whose work did not stop). Never waits for the component: any thread, any
  /// lock held.
  std::string RequestRestart(const std::string& name, const std::string& by);

  /// What Down() says, after the component's name, of a component StartAll() has not brought up yet: a
  /// peer (the operator's console) tells "still starting" from "went down" by it.
  static constexpr const char* kStartingSuffix = " is starting";
  /// Components that are not up now, with why (e.g. "perception is down: stalled ...; restart in 0.6 s", or
  /// "platform is starting" (kStartingSuffix) before StartAll() has brought it up).
  std::map<std::string, std::string> Down() const;
  /// Every component's health at `now`, in the order added.
  std::vector<ComponentHealth> Snapshot(SteadyTime now) const;
  /// Names in the order added.
  std::vector<std::string> Names() const;

 private:
  struct Entry {
    Component* component = nullptr;
    RestartPolicy policy;
    bool down = false;
    SteadyTime down_since{};
    SteadyTime restart_at{};
    SteadyTime up_since{};
    double backoff_s = 0.0;
    std::uint32_t restarts = 0;
    std::string down_reason;
    // Rate and CPU over the measuring window.
    SteadyTime window_start{};
    std::uint64_t window_beats = 0;
    double window_cpu_s = 0.0;
    double rate_hz = 0.0;
    double cpu_percent = 0.0;
    bool degraded = false;
    int slow_windows = 0;  // windows in a row under kDegradedBelow (or, degraded, at or over kRecoveredAbove)
    SteadyTime no_stall_before{};      // after this process stalled as a whole
    std::string restart_requested_by;  // RequestRestart(), done by the next Check()
    bool still_running = false;  // down, and its work did not stop when asked: never activated meanwhile
  };
  Entry* Find(const std::string& name);
  // Check()'s steps. Every entry, and whether this pass comes late (the whole process was not scheduled for
  // longer than the shortest deadline: no stall is judged then).
  std::vector<Entry*> EntriesToCheck(SteadyTime now, bool* process_stalled);
  // Updates the entry's rate and CPU windows (a rate event into `*events`) and takes its restart request
  // (who asked, into `*by`); returns why an active component must be taken down (it failed or stalled), or
  // "".
  std::string Judge(Entry& e, SteadyTime now, bool process_stalled, std::string* by,
                    std::vector<HealthEvent>* events);
  // Restarts a down component whose back-off is over, or any on `by`'s request (stopping it first).
  void BringUpIfDue(Entry& e, const std::string& by, SteadyTime now, std::vector<HealthEvent>* events);
  // After a measuring window (lock held): enters or leaves `degraded` (the event), from the window's rate.
  std::optional<HealthEvent> JudgeRate(Entry& e);
  // The next back-off (the first, or the last doubled up to its cap) and the restart at `from` plus it. Lock
  // held.
  void ScheduleRestart(Entry& e, SteadyTime from);
  // Deactivates a failed component (the lock not held: it may wait for its loops) and returns the events: its
  // failure, and kEscalated when its work did not stop.
  std::vector<HealthEvent> TakeDown(Entry& e, const std::string& reason, SteadyTime now);
  // Deactivates an active component for an operator's restart; the events when its work did not stop (it is
  // then down, as TakeDown leaves it).
  std::vector<HealthEvent> StopForRestart(Entry& e, const std::string& by, SteadyTime now);

  std::function<void(const HealthEvent&)> on_event_;
  mutable std::mutex mutex_;     // guards entries_' bookkeeping
  std::mutex transition_mutex_;  // one lifecycle transition at a time (Check and Restart)
  std::vector<Entry> entries_;
  bool started_ = false;  // StartAll() has run (an unconfigured component before that is starting)
  SteadyTime last_check_{};
  std::thread thread_;
  std::mutex stop_mutex_;
  std::condition_variable stop_wake_;
  bool stop_ = false;
};

}  // namespace cairn::core
