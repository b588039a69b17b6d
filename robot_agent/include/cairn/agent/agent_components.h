// The parts of cairn_agent as core::Components watched by core::HealthMonitor (Sriganesh et al.
// 2024, § Resilience): each beats a heartbeat, reports what it throws, and is restarted alone.
//
//   platform           the sensor thread: lidar scans from the platform (live obstacles, the map's input)
//   perception         the perception and navigation map threads: mapping, staircases, map and camera
//                      telemetry, frontiers
//   planning           the planning thread: goals' global plans, peers' path queries
//   command_interface, mode_tree, mux, navigation, telemetry
//                      parts of the 50 Hz control cycle: a throw stops the robot that cycle and takes the
//                      part down until its restart (its state is reset then); the lock is never forgotten
//
// The mode tree's IsComponentUp refuses the modes that need a part that is down (config/mode_tree.xml).
#pragma once

#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "cairn/agent/services/perception_service.h"
#include "cairn/agent/services/planning_service.h"
#include "cairn/core/component.h"
#include "cairn/core/health_monitor.h"

namespace cairn::agent {

/// A fault to inject into a component (test hook: `cairn_agent --inject-fault COMPONENT:KIND:AFTER_S`).
struct FaultInjection {
  /// kThrow: the work throws. kHang: it stops making progress until the process shuts down. kStuck: it never
  /// returns, even at shutdown (a loop that does not stop: the process must end without it).
  enum class Kind { kThrow, kHang, kStuck };
  std::string component;  ///< one of AgentComponentNames()
  Kind kind = Kind::kThrow;
  double after_s = 0.0;  ///< seconds after the agent started, >= 0
};

/// Parses "COMPONENT:throw|hang|stuck:AFTER_S". A hang or stuck work is for threaded components only
/// (platform, perception, planning): a control cycle that hangs cannot be restarted within the process.
/// @throws std::invalid_argument naming the part and the value at fault.
FaultInjection ParseFaultInjection(const std::string& text);

/// Fires injected faults, each once, when due. Thread-safe.
class FaultInjector {
 public:
  FaultInjector(std::vector<FaultInjection> faults, core::SteadyTime start);
  /// In `component`'s work: throws std::runtime_error("injected fault ...") or hangs (ignoring its
  /// component's stop, until the process shuts down; stuck: for good) when one of its faults is due.
  void Check(const std::string& component);
  bool empty() const { return faults_.empty(); }

 private:
  struct Pending {
    FaultInjection fault;
    std::atomic<bool> fired{false};
  };
  std::vector<std::unique_ptr<Pending>> faults_;
  core::SteadyTime start_;
};

/// A part of the control cycle. Its work runs on the control thread through Run().
class ControlLoopComponent : public core::Component {
 public:
  ControlLoopComponent(std::string name, double rate_hz, FaultInjector* faults)
      : core::Component(std::move(name), rate_hz), faults_(faults) {}
  /// Control thread: runs `work` when the component is active (a heartbeat after it unless `beat` is false:
  /// one per cycle; CPU counted); a throw is its failure (reported, not rethrown). @return true when the work
  /// ran and did not throw.
  template <class Work>
  bool Run(Work&& work, bool beat = true) {
    // Not before its state was reset after a restart (TakeRestart()): a restart landing between the control
    // cycle's resets and this part's turn waits for the next cycle.
    if (state() != core::LifecycleState::kActive || failed() || restarted_.load()) return false;
    core::ScopedCpu cpu(*this);
    try {
      if (faults_ != nullptr) faults_->Check(name());
      work();
    } catch (const std::exception& e) {
      ReportFailure(e.what());
      return false;
    }
    if (beat) Heartbeat(core::SteadyClock::now());
    return true;
  }
  /// Control thread: true once after each restart (activation after the first): reset the part's state.
  bool TakeRestart() { return restarted_.exchange(false); }
  /// Up: active and not failed.
  bool up() const { return state() == core::LifecycleState::kActive && !failed(); }

 protected:
  void OnActivate() override {
    if (activations_++ > 0) restarted_ = true;
  }

 private:
  FaultInjector* faults_;
  std::atomic<bool> restarted_{false};
  int activations_ = 0;
};

/// The perception and navigation map threads of a PerceptionService.
class PerceptionComponent : public core::ThreadedComponent {
 public:
  PerceptionComponent(PerceptionService* service, double rate_hz)
      : core::ThreadedComponent("perception", rate_hz), service_(service) {}
  ~PerceptionComponent() override { StopLoops(); }
  /// Its map, the OctoMap, bytes. The navigation map's grids, which it keeps up to date, are the planner's
  /// too (handed over, not copied): PlanningComponent counts them.
  std::size_t MemoryBytes() const override { return service_->map_memory_bytes(); }

 protected:
  std::vector<std::function<void(core::WorkLoop&)>> Loops() override {
    return {[this](core::WorkLoop& loop) { service_->PerceptionLoop(loop); },
            [this](core::WorkLoop& loop) { service_->NavMapLoop(loop); }};
  }

 private:
  PerceptionService* service_;
};

/// The sensor thread of a PerceptionService (the platform's lidar).
class PlatformComponent : public core::ThreadedComponent {
 public:
  PlatformComponent(PerceptionService* service, double rate_hz)
      : core::ThreadedComponent("platform", rate_hz), service_(service) {}
  ~PlatformComponent() override { StopLoops(); }

 protected:
  std::vector<std::function<void(core::WorkLoop&)>> Loops() override {
    return {[this](core::WorkLoop& loop) { service_->SensorLoop(loop); }};
  }

 private:
  PerceptionService* service_;
};

/// The planning thread of a PlanningService.
class PlanningComponent : public core::ThreadedComponent {
 public:
  PlanningComponent(PlanningService* service, FaultInjector* faults)
      : core::ThreadedComponent("planning", 10.0), service_(service), faults_(faults) {}
  ~PlanningComponent() override { StopLoops(); }
  /// The map the global planner holds (the navigation map's grids, shared with it), bytes.
  std::size_t MemoryBytes() const override { return service_->map_memory_bytes(); }

 protected:
  std::vector<std::function<void(core::WorkLoop&)>> Loops() override {
    return {[this](core::WorkLoop& loop) {
      while (loop.Running()) {
        loop.Beat();
        if (faults_ != nullptr) faults_->Check("planning");
        // Waits up to 100 ms for work; CPU is counted while it plans.
        core::ScopedCpu cpu(loop.component());
        service_->RunOnce(std::chrono::milliseconds(100));
      }
    }};
  }

 private:
  PlanningService* service_;
  FaultInjector* faults_;
};

/// The agent process's resident memory, bytes (/proc/self/statm; 0 when unreadable).
std::uint64_t ProcessRssBytes();
/// The agent process's CPU time so far, seconds (CLOCK_PROCESS_CPUTIME_ID).
double ProcessCpuSeconds();

/// Makes glibc serve every allocation of `threshold_bytes` or more (default 1 MiB) with its own mmap, so that
/// freeing one returns it to the system at once (mallopt M_MMAP_THRESHOLD; a fixed threshold also turns off
/// glibc's raising of it after such a free). Without it, a navigation map that grows (grids of 10-30 MB,
/// old and new held at once for a moment) leaves tens of MB of freed heap the process keeps: measured 39 MB
/// in an hour's soak (docs/PERFORMANCE.md, Soak). Call once at the start of main(). Returns false if glibc
/// refused.
bool ReturnLargeBlocksWhenFreed(std::size_t threshold_bytes = std::size_t{1} << 20);

}  // namespace cairn::agent
