// The perception component under its health monitor, with the agent's own PerceptionService and threads: a
// navigation map update that is slow past the watchdog (not hung) while the planner plans on the shared
// multi-level grid. Its component is taken down, but never started again beside the loop still in its update
// (two navigation map loops on one map crashed an agent in MultiLevelGrid::NodeNear); it comes back once that
// loop has ended. Run under ThreadSanitizer too (tests/sanitizers/run.sh), which flags any overlap.
#include "cairn/agent/services/perception_service.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "cairn/agent/agent_components.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/core/health_monitor.h"
#include "cairn/nav/global_planner.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using Clock = core::SteadyClock;
using std::chrono::milliseconds;

// The watchdog's heartbeat deadline, and how long the slow navigation map update takes: longer than the stall
// limit (3 deadlines) plus the stop's grace (2 s) by a second. ThreadSanitizer runs the perception steps 5-15
// times slower: a step between two beats can then take longer than 0.6 s, so the deadline grows with it.
#if defined(__SANITIZE_THREAD__)
constexpr double kHeartbeatDeadlineS = 0.5;
#else
constexpr double kHeartbeatDeadlineS = 0.2;
#endif
constexpr auto kSlowUpdate =
    std::chrono::milliseconds(static_cast<int>(1000 * (3 * kHeartbeatDeadlineS + 2.0 + 1.0)));

// One call of the navigation map loop's fault hook: which thread, and when it entered and left it.
struct HookCall {
  std::thread::id thread;
  Clock::time_point entered, left;
};

TEST(PerceptionService, ASlowNavigationMapUpdatePastTheWatchdogIsNeverRunTwice) {
  const nav::PlatformProfile profile = nav::GetPlatformProfile("wheeled");
  sim::SimulatedPlatformOptions sim_options;
  sim_options.world = "builtin:tunnels";
  sim_options.start_W = core::PlanarPose{4.0, 20.0, 0.0};
  sim::ApplyPlatformProfile(profile, &sim_options);
  auto platform = std::make_shared<sim::SimulatedPlatform>(sim_options);
  platform->Update(0.0);
  const core::BaseState start_M = platform->ReadPose().PlanarState();

  AgentOptions options;
  options.robot_id = "r1";
  options.perception.camera_rate_hz = 0;
  options.nav_map.update_period_s = 0.1;
  auto planner =
      NavMap::MakePlanner(options.nav_map, options.perception.map.resolution_m, start_M, {profile});
  const Clock::time_point t0 = Clock::now();
  PerceptionService service(options, platform, start_M, planner, core::RealClock(), t0,
                            [](const perception::PerceptionOutput&) {});

  // The 8th navigation map update is slow (kSlowUpdate: longer than the stall limit plus the stop's grace),
  // and it does not look at its stop meanwhile.
  std::mutex calls_mutex;
  std::vector<HookCall> calls;
  std::atomic<int> map_updates{0};
  service.SetFaultHook([&](const char* where) {
    if (std::string(where) != "navigation_map") return;
    HookCall call{std::this_thread::get_id(), Clock::now(), {}};
    if (++map_updates == 8) std::this_thread::sleep_for(kSlowUpdate);
    call.left = Clock::now();
    std::lock_guard<std::mutex> guard(calls_mutex);
    calls.push_back(call);
  });

  std::mutex events_mutex;
  std::vector<core::HealthEvent> events;
  core::HealthMonitor monitor([&](const core::HealthEvent& e) {
    std::lock_guard<std::mutex> guard(events_mutex);
    events.push_back(e);
  });
  PlatformComponent platform_c(&service, 20.0);
  PerceptionComponent perception_c(&service, 20.0);
  core::RestartPolicy policy;
  policy.heartbeat_deadline_s = kHeartbeatDeadlineS;
  policy.missed_deadlines_to_fail = 3;
  policy.first_backoff_s = 0.2;
  monitor.Add(&platform_c, policy);
  monitor.Add(&perception_c, policy);
  monitor.StartAll();
  monitor.StartChecking(milliseconds(20));

  // The simulator's clock, and a planning thread on the planner's shared grids (the multi-level grid too)
  // all along.
  std::atomic<bool> stop{false};
  std::atomic<int> plans{0};
  std::thread simulator([&] {
    while (!stop) {
      platform->Update(core::SecondsBetween(t0, Clock::now()));
      std::this_thread::sleep_for(milliseconds(20));
    }
  });
  std::thread planning([&] {
    while (!stop) {
      nav::GlobalPlanRequest request;
      request.start_W = {start_M.x_m, start_M.y_m};
      request.goal_W = {start_M.x_m + 6.0, start_M.y_m + (plans % 2 == 0 ? 0.5 : -0.5)};
      request.start_z_m = start_M.z_m;
      request.goal_z_m = start_M.z_m;
      planner->Plan(request);
      ++plans;
      std::this_thread::sleep_for(milliseconds(5));
    }
  });

  auto count = [&](core::HealthEvent::Kind kind) {
    std::lock_guard<std::mutex> guard(events_mutex);
    int n = 0;
    for (const auto& e : events) n += e.kind == kind && e.component == "perception";
    return n;
  };
  const Clock::time_point deadline = Clock::now() + std::chrono::seconds(30);
  while (Clock::now() < deadline && !(count(core::HealthEvent::Kind::kRestarted) >= 1 && map_updates > 14)) {
    std::this_thread::sleep_for(milliseconds(20));
  }
  monitor.StopAll();
  stop = true;
  simulator.join();
  planning.join();

  EXPECT_EQ(count(core::HealthEvent::Kind::kFailed), 1);
  EXPECT_EQ(count(core::HealthEvent::Kind::kEscalated), 1) << "the slow loop did not stop within its grace";
  EXPECT_EQ(count(core::HealthEvent::Kind::kRestarted), 1) << "not started again once the slow loop ended";
  EXPECT_GT(map_updates.load(), 14) << "the navigation map loop did not come back";
  EXPECT_GT(plans.load(), 10);
  // No navigation map loop ran while the slow one was in its update.
  std::lock_guard<std::mutex> guard(calls_mutex);
  const auto slow = std::find_if(calls.begin(), calls.end(), [](const HookCall& c) {
    return std::chrono::duration<double>(c.left - c.entered).count() > 2.5;
  });
  ASSERT_NE(slow, calls.end());
  for (const HookCall& c : calls) {
    if (&c == &*slow) continue;
    EXPECT_FALSE(c.entered > slow->entered && c.entered < slow->left)
        << "a second navigation map loop ran beside the slow one";
    if (c.entered > slow->left) {
      EXPECT_NE(c.thread, slow->thread) << "the slow loop went on after its stop";
    }
  }
}

}  // namespace
}  // namespace cairn::agent
