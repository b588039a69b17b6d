#include "cairn/core/component.h"

namespace cairn::core {

const char* ToString(LifecycleState state) {
  switch (state) {
    case LifecycleState::kUnconfigured:
      return "unconfigured";
    case LifecycleState::kInactive:
      return "inactive";
    case LifecycleState::kActive:
      return "active";
  }
  return "?";
}

void Component::Configure() {
  if (state_ != LifecycleState::kUnconfigured) {
    throw ComponentError(name_ + ": configure requested while " + ToString(state_));
  }
  try {
    OnConfigure();
  } catch (const std::exception& e) {
    try {
      OnCleanup();
    } catch (...) {
    }
    throw ComponentError(name_ + ": configure failed: " + e.what());
  }
  state_ = LifecycleState::kInactive;
}

void Component::Activate() {
  if (state_ != LifecycleState::kInactive) {
    throw ComponentError(name_ + ": activate requested while " + ToString(state_));
  }
  try {
    OnActivate();
  } catch (const std::exception& e) {
    throw ComponentError(name_ + ": activate failed: " + e.what());
  }
  last_heartbeat_ = SteadyClock::now();
  state_ = LifecycleState::kActive;
}

void Component::Deactivate() {
  if (state_ != LifecycleState::kActive) return;
  OnDeactivate();
  state_ = LifecycleState::kInactive;
}

void Component::Cleanup() {
  if (state_ != LifecycleState::kInactive) return;
  OnCleanup();
  state_ = LifecycleState::kUnconfigured;
}

void ComponentManager::StartAll() {
  std::size_t started = 0;
  try {
    for (; started < components_.size(); ++started) {
      components_[started]->Configure();
      components_[started]->Activate();
    }
  } catch (...) {
    for (std::size_t i = started + 1; i-- > 0;) {
      try {
        components_[i]->Deactivate();
        components_[i]->Cleanup();
      } catch (...) {
      }
    }
    throw;
  }
}

void ComponentManager::StopAll() noexcept {
  for (auto it = components_.rbegin(); it != components_.rend(); ++it) {
    try {
      (*it)->Deactivate();
      (*it)->Cleanup();
    } catch (...) {
    }
  }
}

std::vector<std::string> ComponentManager::StaleComponents(SteadyTime now, double max_age_s) const {
  std::vector<std::string> stale;
  for (const Component* c : components_) {
    if (c->state() == LifecycleState::kActive && SecondsBetween(c->last_heartbeat(), now) > max_age_s) {
      stale.push_back(c->name());
    }
  }
  return stale;
}

}  // namespace cairn::core
