// Component model of cairn_agent (like ROS 2 composable lifecycle nodes, in one process): each component has
// an explicit lifecycle (configure -> activate -> deactivate -> cleanup) and a heartbeat for health checks.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
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
class Component {
 public:
  explicit Component(std::string name) : name_(std::move(name)) {}
  virtual ~Component() = default;
  Component(const Component&) = delete;
  Component& operator=(const Component&) = delete;

  const std::string& name() const { return name_; }
  LifecycleState state() const { return state_; }

  /// unconfigured -> inactive. On failure OnCleanup() runs and ComponentError is thrown (no half-start).
  void Configure();
  /// inactive -> active. @throws ComponentError when not inactive or OnActivate throws.
  void Activate();
  /// active -> inactive (no-op otherwise).
  void Deactivate();
  /// inactive -> unconfigured (no-op otherwise).
  void Cleanup();

  /// Called by the component's own work loop to show it is alive.
  void Heartbeat(SteadyTime now) { last_heartbeat_ = now; }
  SteadyTime last_heartbeat() const { return last_heartbeat_; }

 protected:
  virtual void OnConfigure() {}
  virtual void OnActivate() {}
  virtual void OnDeactivate() {}
  virtual void OnCleanup() {}

 private:
  std::string name_;
  LifecycleState state_ = LifecycleState::kUnconfigured;
  SteadyTime last_heartbeat_{};
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
