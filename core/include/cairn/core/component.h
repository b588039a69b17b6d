// Component model of cairn_agent (like ROS 2 composable lifecycle nodes, in one process): each component has
// an explicit lifecycle (configure -> activate -> deactivate -> cleanup), a heartbeat its work loop beats,
// and a failure it reports when its work throws. core::HealthMonitor (health_monitor.h) watches them and
// restarts one that failed or stalled, alone (Nav2's lifecycle manager takes every node down when one bond
// times out).
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/time.h"

namespace cairn::core {

/// Lifecycle states, as in ROS 2 managed nodes.
enum class LifecycleState { kUnconfigured, kInactive, kActive };
const char* ToString(LifecycleState state);

/// A lifecycle transition failed. The message names the component and the cause.
class ComponentError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Base of every agent component. Subclasses override the On* hooks; the public transitions enforce order.
/// Transitions are made by one thread at a time (the owner, or HealthMonitor once it has the component); the
/// heartbeat, failure and CPU accounting are thread-safe (the component's own threads call them).
class Component {
 public:
  /// `name`: how operators name it (`restart R perception`), [a-z_]+. `target_rate_hz`: the rate its work
  /// loop should beat at (health reports the measured rate against it), > 0.
  explicit Component(std::string name, double target_rate_hz = 1.0);
  virtual ~Component() = default;
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  const std::string& name() const { return name_; }
  double target_rate_hz() const { return target_rate_hz_; }
  LifecycleState state() const { return state_.load(); }

  /// unconfigured -> inactive. On failure OnCleanup() runs and ComponentError is thrown (no half-start).
  void Configure();
  /// inactive -> active; clears a reported failure and starts the heartbeat afresh. @throws ComponentError
  /// when not inactive or OnActivate throws.
  void Activate();
  /// active -> inactive (no-op otherwise).
  void Deactivate();
  /// inactive -> unconfigured (no-op otherwise).
  void Cleanup();

  /// Called by the component's own work loop, once per loop, to show it is alive. Thread-safe.
  void Heartbeat(SteadyTime now);
  /// Newest heartbeat (the oldest of its threads' for a ThreadedComponent). Thread-safe.
  virtual SteadyTime last_heartbeat() const;
  /// Heartbeats since the component was made (the loop rate is their rate). Thread-safe.
  std::uint64_t heartbeats() const { return heartbeats_.load(); }

  /// Its work failed (an exception, a fault it detected): the health monitor restarts it. The first report
  /// since the last activation wins. Thread-safe.
  void ReportFailure(const std::string& what);
  /// A failure reported since the last activation. Thread-safe.
  bool failed() const { return failed_.load(); }
  /// The newest failure's message ("" = none yet; kept across restarts). Thread-safe.
  std::string last_error() const;

  /// Adds thread CPU time spent on the component's work, nanoseconds. Thread-safe.
  void AddCpuNanoseconds(std::int64_t ns) { cpu_ns_ += ns; }
  /// CPU time spent on its work so far, seconds. Thread-safe.
  double cpu_s() const { return 1e-9 * static_cast<double>(cpu_ns_.load()); }
  /// Memory the component's own data takes, bytes (0 = not reported). Thread-safe when overridden.
  virtual std::size_t MemoryBytes() const { return 0; }
  /// What of its last run still runs after it was deactivated ("" = nothing: it may be activated again), e.g.
  /// "loop 1 still runs 4.2 s after it was asked to stop". A component whose work still runs is never
  /// activated again (it would run twice on the same state). Call from the thread that makes its transitions.
  virtual std::string StillRunning() { return ""; }

 protected:
  virtual void OnConfigure() {}
  virtual void OnActivate() {}
  virtual void OnDeactivate() {}
  virtual void OnCleanup() {}

 private:
  std::string name_;
  double target_rate_hz_;
  std::atomic<LifecycleState> state_{LifecycleState::kUnconfigured};
  std::atomic<SteadyClock::rep> last_heartbeat_{0};
  std::atomic<std::uint64_t> heartbeats_{0};
  std::atomic<std::int64_t> cpu_ns_{0};
  std::atomic<bool> failed_{false};
  mutable std::mutex error_mutex_;
  std::string last_error_;
};

/// CPU time of the calling thread, nanoseconds (CLOCK_THREAD_CPUTIME_ID).
std::int64_t ThreadCpuNanoseconds();

/// Adds the calling thread's CPU time between construction and destruction to a component.
class ScopedCpu {
 public:
  explicit ScopedCpu(Component& component) : component_(component), start_ns_(ThreadCpuNanoseconds()) {}
  ~ScopedCpu() { component_.AddCpuNanoseconds(ThreadCpuNanoseconds() - start_ns_); }
  ScopedCpu(const ScopedCpu&) = delete;
  ScopedCpu& operator=(const ScopedCpu&) = delete;

 private:
  Component& component_;
  std::int64_t start_ns_;
};

/// One work loop of a ThreadedComponent: what its thread asks while it runs.
class WorkLoop {
 public:
  /// True while the loop should go on (its component is not stopping, the process is not shutting down).
  bool Running() const;
  /// Sleeps up to `timeout`, returning early when the loop should stop. @return Running() afterwards.
  bool WaitFor(std::chrono::milliseconds timeout) const;
  /// The loop is alive (one per iteration). The component's loop rate counts its first loop's beats.
  void Beat();
  /// The component this loop belongs to (for ScopedCpu).
  Component& component() const { return *component_; }

 private:
  friend class ThreadedComponent;
  struct Shared;
  WorkLoop(Component* component, std::shared_ptr<Shared> shared, bool primary)
      : component_(component), shared_(std::move(shared)), primary_(primary) {}
  Component* component_;
  std::shared_ptr<Shared> shared_;
  bool primary_;
  std::atomic<SteadyClock::rep> last_beat_{0};
};

/// A component whose work runs on threads of its own, started on activation and stopped on deactivation. A
/// loop that throws reports the failure (its other loops are stopped by the restart). A loop that does not
/// stop within the grace period on deactivation is left running (joined once it ends, or at destruction) and
/// the component cannot be activated again until it has ended: two runs of its loops never share its state.
/// Its owner escalates meanwhile (HealthMonitor: HealthEvent::Kind::kEscalated).
class ThreadedComponent : public Component {
 public:
  /// `stop_grace_s`: how long deactivation waits for each loop to end, seconds, > 0.
  ThreadedComponent(std::string name, double target_rate_hz, double stop_grace_s = 2.0);
  /// Stops the loops; waits for abandoned ones up to 5 s, then leaves them (logged) to the process's end.
  ~ThreadedComponent() override;

  /// The oldest heartbeat among its running loops (a stalled loop stalls the component).
  SteadyTime last_heartbeat() const override;
  /// Loops abandoned so far (did not stop within the grace period).
  int abandoned_loops() const { return abandoned_count_.load(); }
  /// Joins the abandoned loops that have ended since; describes those that still run ("" = none).
  std::string StillRunning() override;

 protected:
  /// The loops to run on activation, in order; each gets its WorkLoop (call Beat() every iteration).
  /// Called on each activation.
  virtual std::vector<std::function<void(WorkLoop&)>> Loops() = 0;
  /// Starts fresh loops. @throws std::runtime_error while a loop of an earlier run still runs
  /// (StillRunning()).
  void OnActivate() override;
  void OnDeactivate() override;
  /// Subclasses that override this call StopLoops() first.
  void StopLoops();

 private:
  struct Running;
  double stop_grace_s_;
  std::vector<std::unique_ptr<Running>> running_;
  std::vector<std::unique_ptr<Running>> abandoned_;
  std::atomic<int> abandoned_count_{0};
  mutable std::mutex loops_mutex_;
};

/// Owns nothing; brings a list of components up in order and down in reverse order.
class ComponentManager {
 public:
  void Add(Component* component) { components_.push_back(component); }

  /// Configures then activates every component in order. If one fails, the ones already brought up are
  /// deactivated and cleaned up in reverse order and the ComponentError is rethrown.
  void StartAll();
  /// Deactivates and cleans up every component in reverse order (never throws).
  void StopAll() noexcept;

  /// Names of active components whose heartbeat is older than `max_age_s` at `now`.
  std::vector<std::string> StaleComponents(SteadyTime now, double max_age_s) const;

 private:
  std::vector<Component*> components_;
};

}  // namespace cairn::core
