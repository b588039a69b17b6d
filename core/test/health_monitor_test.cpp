// HealthMonitor: a component that throws or stalls is restarted alone, after a back-off that grows; an
// operator's restart; a stall of the whole process is not taken for a component's.
#include "cairn/core/health_monitor.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <thread>

namespace cairn::core {
namespace {

using std::chrono::milliseconds;

SteadyTime At(SteadyTime t0, double s) {
  return t0 + std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(s));
}

// A component driven by the test: heartbeats and failures are set by hand, activations counted.
class Manual : public Component {
 public:
  explicit Manual(std::string name) : Component(std::move(name), 10.0) {}
  int activations = 0;
  int deactivations = 0;
  bool fail_activation = false;

 protected:
  void OnActivate() override {
    ++activations;
    if (fail_activation) throw std::runtime_error("sensor not found");
  }
  void OnDeactivate() override { ++deactivations; }
};

RestartPolicy Policy() {
  RestartPolicy p;
  p.heartbeat_deadline_s = 1.0;
  p.missed_deadlines_to_fail = 3;
  p.first_backoff_s = 1.0;
  p.max_backoff_s = 4.0;
  p.stable_after_s = 10.0;
  return p;
}

TEST(HealthMonitor, RestartsAFailedComponentAloneWithAGrowingBackoff) {
  std::vector<HealthEvent> events;
  HealthMonitor monitor([&](const HealthEvent& e) { events.push_back(e); });
  Manual a("perception"), b("telemetry");
  monitor.Add(&a, Policy());
  monitor.Add(&b, Policy());
  ASSERT_EQ(monitor.Down().size(), 2u);  // before StartAll(): starting, not down
  EXPECT_EQ(monitor.Down().at("perception"), "perception is starting");
  monitor.StartAll();
  EXPECT_TRUE(monitor.Down().empty());
  const SteadyTime t0 = SteadyClock::now();
  auto beat_both = [&](double s) {
    a.Heartbeat(At(t0, s));
    b.Heartbeat(At(t0, s));
  };
  double t = 0.0;
  for (; t < 2.0; t += 0.1) {
    beat_both(t);
    monitor.Check(At(t0, t));
  }
  a.ReportFailure("map insert threw: bad_alloc");
  monitor.Check(At(t0, t));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, HealthEvent::Kind::kFailed);
  EXPECT_EQ(events[0].message, "perception failed: map insert threw: bad_alloc; restart in 1.0 s");
  EXPECT_EQ(a.state(), LifecycleState::kInactive);
  EXPECT_EQ(b.state(), LifecycleState::kActive);  // alone
  EXPECT_EQ(b.deactivations, 0);
  ASSERT_EQ(monitor.Down().count("perception"), 1u);
  EXPECT_NE(monitor.Down().at("perception").find("map insert threw"), std::string::npos);
  // Not before its back-off.
  monitor.Check(At(t0, t + 0.9));
  EXPECT_EQ(a.activations, 1);
  monitor.Check(At(t0, t + 1.05));
  EXPECT_EQ(a.activations, 2);
  EXPECT_EQ(a.state(), LifecycleState::kActive);
  EXPECT_TRUE(monitor.Down().empty());
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, HealthEvent::Kind::kRestarted);
  // Fails again at once: the back-off doubles (2 s), then is capped (4 s).
  t += 1.05;
  a.ReportFailure("again");
  monitor.Check(At(t0, t));
  EXPECT_NE(events.back().message.find("restart in 2.0 s"), std::string::npos) << events.back().message;
  t += 2.05;
  monitor.Check(At(t0, t));
  EXPECT_EQ(a.activations, 3);
  a.ReportFailure("again");
  monitor.Check(At(t0, t));
  EXPECT_NE(events.back().message.find("restart in 4.0 s"), std::string::npos);
  t += 4.05;
  monitor.Check(At(t0, t));
  a.ReportFailure("again");
  monitor.Check(At(t0, t));
  EXPECT_NE(events.back().message.find("restart in 4.0 s"), std::string::npos);
  t += 4.05;
  monitor.Check(At(t0, t));
  EXPECT_EQ(a.state(), LifecycleState::kActive);
  // Up longer than stable_after_s: the next failure waits the first back-off again.
  for (double u = 0; u <= 10.5; u += 0.1) {
    beat_both(t + u);
    monitor.Check(At(t0, t + u));
  }
  t += 10.5;
  a.ReportFailure("later");
  monitor.Check(At(t0, t));
  EXPECT_NE(events.back().message.find("restart in 1.0 s"), std::string::npos) << events.back().message;
  const std::vector<ComponentHealth> health = monitor.Snapshot(At(t0, t));
  ASSERT_EQ(health.size(), 2u);
  EXPECT_EQ(health[0].state, "down");
  EXPECT_EQ(health[0].restarts, 4u);
  EXPECT_EQ(health[0].last_error, "later");
  EXPECT_NEAR(health[0].restart_in_s, 1.0, 1e-6);
  EXPECT_EQ(health[1].state, "active");
  EXPECT_NEAR(health[1].loop_rate_hz, 10.0, 1.0);
  EXPECT_EQ(b.activations, 1);
  monitor.StopAll();
}

TEST(HealthMonitor, AStalledComponentIsRestartedAfterNMissedDeadlines) {
  std::vector<HealthEvent> events;
  HealthMonitor monitor([&](const HealthEvent& e) { events.push_back(e); });
  Manual a("planning");
  monitor.Add(&a, Policy());
  monitor.StartAll();
  const SteadyTime t0 = SteadyClock::now();
  a.Heartbeat(t0);
  for (double t = 0; t < 2.95; t += 0.1) monitor.Check(At(t0, t));
  EXPECT_TRUE(events.empty());  // 2 deadlines missed: not yet
  monitor.Check(At(t0, 3.05));
  ASSERT_EQ(events.size(), 1u);
  EXPECT_NE(events[0].message.find("stalled: no heartbeat for 3.0 s (3 deadlines of 1.0 s missed)"),
            std::string::npos)
      << events[0].message;
  EXPECT_EQ(a.deactivations, 1);
  monitor.StopAll();
}

// Slow is not hung: a component that beats at 3 of its 10 Hz is degraded (told once, never restarted) and
// back once it beats at its rate again.
TEST(HealthMonitor, ASlowComponentIsDegradedNotRestartedAndComesBack) {
  std::vector<HealthEvent> events;
  HealthMonitor monitor([&](const HealthEvent& e) { events.push_back(e); });
  Manual a("perception");
  monitor.Add(&a, Policy());
  monitor.StartAll();
  const SteadyTime t0 = SteadyClock::now();
  double t = 0;
  double next_beat_s = 0;
  auto run = [&](double until_s, double rate_hz) {
    for (; t < until_s; t += 0.05) {
      if (t >= next_beat_s) {
        a.Heartbeat(At(t0, t));
        next_beat_s = t + 1.0 / rate_hz;
      }
      monitor.Check(At(t0, t));
    }
  };
  run(2.5, 10.0);
  EXPECT_TRUE(events.empty());
  run(8.0, 3.0);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].kind, HealthEvent::Kind::kDegraded);
  EXPECT_NE(events[0].message.find("perception degraded:"), std::string::npos) << events[0].message;
  EXPECT_NE(events[0].message.find("of 10.0 Hz (slow, not hung: not restarted)"), std::string::npos)
      << events[0].message;
  EXPECT_EQ(a.deactivations, 0) << "a slow component is not restarted";
  EXPECT_TRUE(monitor.Snapshot(At(t0, t))[0].degraded);
  run(14.0, 10.0);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].kind, HealthEvent::Kind::kRecovered);
  EXPECT_FALSE(monitor.Snapshot(At(t0, t))[0].degraded);
  monitor.StopAll();
}

TEST(HealthMonitor, AProcessWideStallIsNotAComponentStall) {
  std::vector<HealthEvent> events;
  HealthMonitor monitor([&](const HealthEvent& e) { events.push_back(e); });
  Manual a("mux");
  monitor.Add(&a, Policy());
  monitor.StartAll();
  const SteadyTime t0 = SteadyClock::now();
  a.Heartbeat(t0);
  monitor.Check(At(t0, 0.1));
  // The whole process was not scheduled for 5 s: the monitor's own pass comes late too.
  monitor.Check(At(t0, 5.1));
  monitor.Check(At(t0, 5.2));
  EXPECT_TRUE(events.empty());
  a.Heartbeat(At(t0, 5.25));
  for (double t = 5.3; t < 8.2; t += 0.1) monitor.Check(At(t0, t));
  EXPECT_TRUE(events.empty());
  monitor.Check(At(t0, 8.3));  // 3 deadlines after its last heartbeat
  EXPECT_EQ(events.size(), 1u);
  monitor.StopAll();
}

TEST(HealthMonitor, OperatorRestartAndRefusals) {
  std::vector<HealthEvent> events;
  HealthMonitor monitor([&](const HealthEvent& e) { events.push_back(e); });
  Manual a("perception"), b("navigation");
  monitor.Add(&a, Policy());
  monitor.Add(&b, Policy());
  EXPECT_THROW(monitor.Add(&a, Policy()), std::invalid_argument);
  RestartPolicy bad = Policy();
  bad.missed_deadlines_to_fail = 0;
  Manual c("c");
  try {
    monitor.Add(&c, bad);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("missed_deadlines_to_fail"), std::string::npos);
  }
  monitor.StartAll();
  EXPECT_EQ(monitor.RequestRestart("lidar", "opA"),
            "no component \"lidar\" (the components are perception, navigation)");
  EXPECT_EQ(monitor.RequestRestart("navigation", "opA"), "");
  const SteadyTime t0 = SteadyClock::now();
  a.Heartbeat(t0);
  b.Heartbeat(t0);
  monitor.Check(t0);
  EXPECT_EQ(b.deactivations, 1);
  EXPECT_EQ(b.activations, 2);
  EXPECT_EQ(a.activations, 1);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].message, "navigation restarted by opA (restart 1)");
  // A component that does not come back up is tried again with back-off, and named.
  a.fail_activation = true;
  a.ReportFailure("tick threw");
  monitor.Check(t0);
  monitor.Check(At(t0, 1.05));
  EXPECT_EQ(events.back().kind, HealthEvent::Kind::kRestartFailed);
  EXPECT_NE(events.back().message.find("sensor not found; next try in 2.0 s"), std::string::npos)
      << events.back().message;
  a.fail_activation = false;
  monitor.Check(At(t0, 3.1));
  EXPECT_EQ(a.state(), LifecycleState::kActive);
  monitor.StopAll();
}

// A threaded component: a loop that throws reports it and fresh loops take over; one that does not stop when
// asked is never run twice: the component stays down (escalated) until that loop has ended.
class Looping : public ThreadedComponent {
 public:
  // The shipping stop grace (2 s): a loop that stops when asked must be judged stopped even on a starved,
  // sanitized run at nice 19 (at 0.2 s, a TSan run beside the real-time tests once judged both loops hung).
  Looping() : ThreadedComponent("looping", 100.0, 2.0) {}
  ~Looping() override {
    release = true;
    StopLoops();
  }
  std::atomic<bool> throw_now{false};
  std::atomic<bool> hang_now{false};
  std::atomic<bool> release{false};
  std::atomic<int> starts{0};
  // Loops inside their work at once, over every run (> 2: two runs overlap).
  std::atomic<int> working{0};
  std::atomic<int> most_working{0};

 protected:
  std::vector<std::function<void(WorkLoop&)>> Loops() override {
    ++starts;
    auto work = [this](auto&& body) {
      const int now = ++working;
      int seen = most_working.load();
      while (now > seen && !most_working.compare_exchange_weak(seen, now)) {
      }
      body();
      --working;
    };
    return {[this, work](WorkLoop& loop) {
              while (loop.Running()) {
                loop.Beat();
                work([&] {
                  if (throw_now.exchange(false)) {
                    --working;
                    throw std::runtime_error("injected");
                  }
                  if (hang_now.exchange(false)) {
                    while (!release) std::this_thread::sleep_for(milliseconds(5));  // ignores its stop
                  }
                });
                loop.WaitFor(milliseconds(10));
              }
            },
            [](WorkLoop& loop) {
              while (loop.Running()) {
                loop.Beat();
                loop.WaitFor(milliseconds(10));
              }
            }};
  }
};

TEST(ThreadedComponent, AThrowIsRestartedAndALoopThatDoesNotStopIsNeverRunTwice) {
  // The component outlives its monitor (declared first): a failed assertion returns while the monitor's
  // thread still checks it.
  Looping c;
  std::vector<HealthEvent> events;
  std::mutex events_mutex;
  HealthMonitor monitor([&](const HealthEvent& e) {
    std::lock_guard<std::mutex> guard(events_mutex);
    events.push_back(e);
  });
  RestartPolicy p;
  p.heartbeat_deadline_s = 0.1;
  p.missed_deadlines_to_fail = 3;
  p.first_backoff_s = 0.2;
  monitor.Add(&c, p);
  monitor.StartAll();
  monitor.StartChecking(milliseconds(20));
  auto wait_for = [&](auto done) {
    const SteadyTime deadline = SteadyClock::now() + std::chrono::seconds(10);
    while (!done() && SteadyClock::now() < deadline) std::this_thread::sleep_for(milliseconds(10));
    return done();
  };
  auto count = [&](HealthEvent::Kind kind) {
    std::lock_guard<std::mutex> guard(events_mutex);
    return std::count_if(events.begin(), events.end(), [&](const HealthEvent& e) { return e.kind == kind; });
  };
  c.throw_now = true;
  ASSERT_TRUE(wait_for([&] { return count(HealthEvent::Kind::kRestarted) == 1; }));
  EXPECT_EQ(c.last_error(), "injected");
  EXPECT_EQ(c.starts.load(), 2);

  // A loop that ignores its stop: stalled, taken down, escalated once, and not started again meanwhile.
  c.hang_now = true;
  ASSERT_TRUE(wait_for([&] { return count(HealthEvent::Kind::kEscalated) == 1; }));
  EXPECT_EQ(c.abandoned_loops(), 1);
  EXPECT_NE(c.last_error().find("stalled"), std::string::npos) << c.last_error();
  {
    std::lock_guard<std::mutex> guard(events_mutex);
    EXPECT_NE(events.back().message.find("not restarted in this process"), std::string::npos)
        << events.back().message;
  }
  std::this_thread::sleep_for(milliseconds(600));  // three back-offs' worth
  EXPECT_EQ(c.starts.load(), 2) << "started again beside the loop that did not stop";
  EXPECT_EQ(count(HealthEvent::Kind::kRestarted), 1);
  EXPECT_EQ(count(HealthEvent::Kind::kEscalated), 1) << "escalated more than once";
  EXPECT_NE(c.state(), LifecycleState::kActive);
  EXPECT_NE(monitor.Down().at("looping").find("still runs"), std::string::npos)
      << monitor.Down().at("looping");
  EXPECT_NE(monitor.RequestRestart("looping", "opA").find("cannot be restarted in this process"),
            std::string::npos);

  // The loop ends by itself (it was slow, not hung): only now is the component started again.
  c.release = true;
  ASSERT_TRUE(wait_for([&] { return count(HealthEvent::Kind::kRestarted) == 2; }));
  EXPECT_EQ(c.starts.load(), 3);
  // Its loop beats again (every 10 ms; within the waiting bound even on a loaded, sanitized run).
  const std::uint64_t beats = c.heartbeats();
  EXPECT_TRUE(wait_for([&] { return c.heartbeats() > beats + 5; })) << c.heartbeats() << " vs " << beats;
  EXPECT_EQ(c.state(), LifecycleState::kActive);
  EXPECT_LE(c.most_working.load(), 1) << "two runs' loops worked at once";
  monitor.StopAll();
}

// An operator's restart of a component whose loop does not stop: escalated, not started twice.
TEST(ThreadedComponent, AnOperatorRestartOfALoopThatDoesNotStopEscalates) {
  // The component outlives its monitor (declared first): a failed assertion returns while the monitor's
  // thread still checks it.
  Looping c;
  std::vector<HealthEvent> events;
  std::mutex events_mutex;
  HealthMonitor monitor([&](const HealthEvent& e) {
    std::lock_guard<std::mutex> guard(events_mutex);
    events.push_back(e);
  });
  RestartPolicy p;
  p.heartbeat_deadline_s = 5.0;  // no stall is judged: only the operator's restart stops it
  p.first_backoff_s = 0.2;
  monitor.Add(&c, p);
  monitor.StartAll();
  c.hang_now = true;
  std::this_thread::sleep_for(milliseconds(50));
  ASSERT_EQ(monitor.RequestRestart("looping", "opA"), "");
  monitor.Check(SteadyClock::now());
  {
    std::lock_guard<std::mutex> guard(events_mutex);
    ASSERT_EQ(events.size(), 1u);
    EXPECT_EQ(events[0].kind, HealthEvent::Kind::kEscalated);
    EXPECT_NE(events[0].message.find("did not stop for its restart by opA"), std::string::npos)
        << events[0].message;
  }
  EXPECT_EQ(c.starts.load(), 1);
  monitor.Check(SteadyClock::now() + std::chrono::seconds(1));
  EXPECT_EQ(c.starts.load(), 1);
  c.release = true;
  std::this_thread::sleep_for(milliseconds(50));
  monitor.Check(SteadyClock::now() + std::chrono::seconds(2));
  EXPECT_EQ(c.starts.load(), 2);
  EXPECT_EQ(c.state(), LifecycleState::kActive);
  monitor.StopAll();
}

}  // namespace
}  // namespace cairn::core
