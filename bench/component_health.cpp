// Cost of the agent's component health: the control cycle's five parts run through
// ControlLoopComponent::Run (heartbeat, CPU accounting, failure capture) against the same work called
// plainly, in the same run; one HealthMonitor pass over the agent's eight components; and the size of
// AgentHealth on the wire (its bit rate at one message every 2 s, 10 s on a radio link). Usage:
// cairn_bench_component_health
// [--cycles N]
#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "cairn/agent/agent_components.h"
#include "cairn/core/health_monitor.h"
#include "cairn_msgs.h"
#include "cairn_msgsPubSubTypes.h"

namespace {

using Clock = std::chrono::steady_clock;

// Stand-in for one part's work in a control cycle: a few microseconds of arithmetic.
volatile double g_sink = 0.0;
void Work(int part) {
  double x = part;
  for (int i = 0; i < 400; ++i) x = std::sqrt(x * x + 1.0 + i);
  g_sink = g_sink + x;
}

double MedianNs(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int cycles = 20000;
  for (int i = 1; i + 1 < argc; ++i) {
    if (std::strcmp(argv[i], "--cycles") == 0) cycles = std::atoi(argv[i + 1]);
  }
  if (cycles < 100) {
    std::fprintf(stderr, "--cycles must be >= 100\n");
    return 2;
  }
  using cairn::agent::ControlLoopComponent;
  std::vector<std::unique_ptr<ControlLoopComponent>> parts;
  for (const char* name : {"command_interface", "mode_tree", "mux", "navigation", "telemetry"}) {
    parts.push_back(std::make_unique<ControlLoopComponent>(name, 50.0, nullptr));
    parts.back()->Configure();
    parts.back()->Activate();
  }
  std::vector<double> plain_ns, wrapped_ns;
  for (int c = 0; c < cycles; ++c) {
    // Alternate the two within one run, so that both see the same machine.
    auto t0 = Clock::now();
    for (int p = 0; p < 5; ++p) Work(p);
    auto t1 = Clock::now();
    for (int p = 0; p < 5; ++p) parts[p]->Run([p] { Work(p); });
    auto t2 = Clock::now();
    plain_ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    wrapped_ns.push_back(std::chrono::duration<double, std::nano>(t2 - t1).count());
  }
  const double plain = MedianNs(plain_ns), wrapped = MedianNs(wrapped_ns);
  std::printf(
      "control cycle, 5 parts: plain %.0f ns, through ControlLoopComponent::Run %.0f ns (median of %d)\n",
      plain, wrapped, cycles);
  std::printf("  ratio wrapped/plain %.3f; overhead %.0f ns per cycle = %.4f %% of the 20 ms period\n",
              wrapped / plain, wrapped - plain, 100.0 * (wrapped - plain) / 20e6);

  // One monitor pass over eight components (the agent's), against a pass over none.
  cairn::core::HealthMonitor empty;
  cairn::core::HealthMonitor monitor;
  std::vector<std::unique_ptr<ControlLoopComponent>> eight;
  for (int i = 0; i < 8; ++i) {
    eight.push_back(
        std::make_unique<ControlLoopComponent>("part_" + std::string(1, char('a' + i)), 50.0, nullptr));
    monitor.Add(eight.back().get(), cairn::core::RestartPolicy{});
  }
  monitor.StartAll();
  std::vector<double> pass_ns, empty_ns;
  for (int i = 0; i < 2000; ++i) {
    const auto now = Clock::now();
    for (auto& c : eight) c->Heartbeat(now);
    auto t0 = Clock::now();
    empty.Check(now);
    auto t1 = Clock::now();
    monitor.Check(now);
    auto t2 = Clock::now();
    empty_ns.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
    pass_ns.push_back(std::chrono::duration<double, std::nano>(t2 - t1).count());
  }
  std::printf(
      "health monitor pass: 8 components %.0f ns, none %.0f ns (ratio %.1f); at 10 Hz: %.4f %% of a core\n",
      MedianNs(pass_ns), MedianNs(empty_ns), MedianNs(pass_ns) / MedianNs(empty_ns),
      100.0 * MedianNs(pass_ns) * 10 / 1e9);
  monitor.StopAll();

  // AgentHealth on the wire: the agent's eight components, all up, then one down with a 200-character error.
  cairn_msgs::AgentHealth m;
  m.robot_id("r1");
  for (const char* name : {"platform", "perception", "planning", "command_interface", "mode_tree", "mux",
                           "navigation", "telemetry"}) {
    cairn_msgs::ComponentHealth c;
    c.name(name);
    c.state("active");
    m.components().push_back(c);
  }
  cairn_msgs::AgentHealthPubSubType type;
  auto size_of = [&](cairn_msgs::AgentHealth& msg) {
    return static_cast<double>(type.getSerializedSizeProvider(&msg)());
  };
  const double up_bytes = size_of(m);
  m.components()[1].state("down");
  m.components()[1].last_error(std::string(200, 'x'));
  m.last_event(std::string(220, 'x'));
  const double down_bytes = size_of(m);
  std::printf(
      "AgentHealth: %.0f bytes all up (%.0f bit/s every 2 s, %.0f bit/s every 10 s on radio); %.0f bytes "
      "with one down and its error\n",
      up_bytes, up_bytes * 8 / 2, up_bytes * 8 / 10, down_bytes);
  return 0;
}
