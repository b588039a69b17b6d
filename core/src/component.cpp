#include "cairn/core/component.h"

#include <spdlog/spdlog.h>
#include <time.h>

#include <algorithm>
#include <condition_variable>
#include <cstdio>

#include "cairn/core/shutdown.h"

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

std::int64_t ThreadCpuNanoseconds() {
  timespec ts{};
  if (clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts) != 0) return 0;
  return static_cast<std::int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

Component::Component(std::string name, double target_rate_hz)
    : name_(std::move(name)), target_rate_hz_(target_rate_hz) {
  if (name_.empty()) throw std::invalid_argument("Component: empty name");
  if (!(target_rate_hz_ > 0)) {
    throw std::invalid_argument("Component " + name_ + ": target_rate_hz must be > 0, got " +
                                std::to_string(target_rate_hz_));
  }
}

void Component::Configure() {
  if (state() != LifecycleState::kUnconfigured) {
    throw ComponentError(name_ + ": configure requested while " + ToString(state()));
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
  if (state() != LifecycleState::kInactive) {
    throw ComponentError(name_ + ": activate requested while " + ToString(state()));
  }
  failed_ = false;
  Heartbeat(SteadyClock::now());
  try {
    OnActivate();
  } catch (const std::exception& e) {
    throw ComponentError(name_ + ": activate failed: " + e.what());
  }
  state_ = LifecycleState::kActive;
}

void Component::Deactivate() {
  if (state() != LifecycleState::kActive) return;
  OnDeactivate();
  state_ = LifecycleState::kInactive;
}

void Component::Cleanup() {
  if (state() != LifecycleState::kInactive) return;
  OnCleanup();
  state_ = LifecycleState::kUnconfigured;
}

void Component::Heartbeat(SteadyTime now) {
  last_heartbeat_ = now.time_since_epoch().count();
  ++heartbeats_;
}

SteadyTime Component::last_heartbeat() const {
  return SteadyTime(SteadyClock::duration(last_heartbeat_.load()));
}

void Component::ReportFailure(const std::string& what) {
  std::lock_guard<std::mutex> guard(error_mutex_);
  if (failed_) return;  // the first cause, not its consequences
  last_error_ = what;
  failed_ = true;
}

std::string Component::last_error() const {
  std::lock_guard<std::mutex> guard(error_mutex_);
  return last_error_;
}

// ---- ThreadedComponent
// -------------------------------------------------------------------------------------

struct WorkLoop::Shared {
  std::mutex mutex;
  std::condition_variable wake;
  bool stop = false;
};

bool WorkLoop::Running() const {
  if (ShutdownRequested()) return false;
  std::lock_guard<std::mutex> guard(shared_->mutex);
  return !shared_->stop;
}

bool WorkLoop::WaitFor(std::chrono::milliseconds timeout) const {
  const SteadyTime deadline = SteadyClock::now() + timeout;
  std::unique_lock<std::mutex> lock(shared_->mutex);
  // Process shutdown has its own waiters: look at it at least every 50 ms.
  while (!shared_->stop && !ShutdownRequested()) {
    const SteadyTime now = SteadyClock::now();
    if (now >= deadline) break;
    shared_->wake.wait_until(lock, std::min(deadline, now + std::chrono::milliseconds(50)));
  }
  return !shared_->stop && !ShutdownRequested();
}

void WorkLoop::Beat() {
  const SteadyTime now = SteadyClock::now();
  last_beat_ = now.time_since_epoch().count();
  if (primary_) component_->Heartbeat(now);
}

struct ThreadedComponent::Running {
  std::unique_ptr<WorkLoop> loop;
  std::shared_ptr<WorkLoop::Shared> shared;
  std::shared_ptr<std::atomic<bool>> done;
  std::thread thread;
  int index = 0;
  SteadyTime abandoned_at{};  // when it was asked to stop and did not
};

ThreadedComponent::ThreadedComponent(std::string name, double target_rate_hz, double stop_grace_s)
    : Component(std::move(name), target_rate_hz), stop_grace_s_(stop_grace_s) {
  if (!(stop_grace_s_ > 0))
    throw std::invalid_argument("ThreadedComponent " + this->name() + ": stop_grace_s must be > 0");
}

ThreadedComponent::~ThreadedComponent() {
  // Subclasses stop their loops in their own destructors (their loops use their members); this is the
  // backstop. A loop that did not stop is joined, however long it takes: detached, it would go on using this
  // component and what its owner frees next (owners that cannot wait end the process instead).
  StopLoops();
  std::lock_guard<std::mutex> guard(loops_mutex_);
  for (auto& r : abandoned_) {
    for (int waited_s = 5; !*r->done; waited_s += 5) {
      const SteadyTime until = SteadyClock::now() + std::chrono::seconds(5);
      while (!*r->done && SteadyClock::now() < until)
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      if (!*r->done)
        spdlog::error("{}: loop {} still runs after {} s; waiting for it", name(), r->index, waited_s);
    }
    r->thread.join();
  }
}

SteadyTime ThreadedComponent::last_heartbeat() const {
  std::lock_guard<std::mutex> guard(loops_mutex_);
  if (running_.empty()) return Component::last_heartbeat();
  SteadyClock::rep oldest = running_.front()->loop->last_beat_.load();
  for (const auto& r : running_) oldest = std::min(oldest, r->loop->last_beat_.load());
  return SteadyTime(SteadyClock::duration(oldest));
}

std::string ThreadedComponent::StillRunning() {
  std::lock_guard<std::mutex> guard(loops_mutex_);
  std::string running;
  const SteadyTime now = SteadyClock::now();
  for (auto it = abandoned_.begin(); it != abandoned_.end();) {
    if (*(*it)->done) {
      (*it)->thread.join();
      it = abandoned_.erase(it);
      continue;
    }
    char buffer[128];
    std::snprintf(buffer, sizeof buffer, "loop %d still runs %.1f s after it was asked to stop", (*it)->index,
                  SecondsBetween((*it)->abandoned_at, now));
    running += (running.empty() ? "" : "; ") + std::string(buffer);
    ++it;
  }
  return running;
}

void ThreadedComponent::OnActivate() {
  // A loop of the last run that is still at work would run beside the fresh one on the same state.
  if (const std::string running = StillRunning(); !running.empty()) {
    throw std::runtime_error(running + ": not started again while it runs");
  }
  std::vector<std::function<void(WorkLoop&)>> loops = Loops();
  std::lock_guard<std::mutex> guard(loops_mutex_);
  int index = 0;
  for (auto& body : loops) {
    auto r = std::make_unique<Running>();
    r->shared = std::make_shared<WorkLoop::Shared>();
    r->loop.reset(new WorkLoop(this, r->shared, index == 0));
    r->loop->last_beat_ = SteadyClock::now().time_since_epoch().count();
    r->done = std::make_shared<std::atomic<bool>>(false);
    r->index = index++;
    WorkLoop* loop = r->loop.get();
    auto done = r->done;
    r->thread = std::thread([this, loop, done, loop_index = r->index, body = std::move(body)] {
      try {
        body(*loop);
        if (loop->Running()) ReportFailure("its loop " + std::to_string(loop_index) + " ended by itself");
      } catch (const std::exception& e) {
        ReportFailure(e.what());
      } catch (...) {
        ReportFailure("unknown exception");
      }
      *done = true;
    });
    running_.push_back(std::move(r));
  }
}

void ThreadedComponent::OnDeactivate() { StopLoops(); }

void ThreadedComponent::StopLoops() {
  std::lock_guard<std::mutex> guard(loops_mutex_);
  for (auto& r : running_) {
    std::lock_guard<std::mutex> lock(r->shared->mutex);
    r->shared->stop = true;
    r->shared->wake.notify_all();
  }
  const SteadyTime deadline = SteadyClock::now() + std::chrono::duration_cast<SteadyClock::duration>(
                                                       std::chrono::duration<double>(stop_grace_s_));
  for (auto& r : running_) {
    while (!*r->done && SteadyClock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (*r->done) {
      r->thread.join();
    } else {
      spdlog::error("{}: loop {} did not stop within {:.1f} s; it is not started again while it runs", name(),
                    r->index, stop_grace_s_);
      ++abandoned_count_;
      r->abandoned_at = SteadyClock::now();
      abandoned_.push_back(std::move(r));
    }
  }
  running_.clear();
}

// ---- ComponentManager
// --------------------------------------------------------------------------------------

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
