// Command round-trip benchmark: basestation command -> robot acknowledgement through cairn_agent's command
// interface, beside a raw Fast DDS ping-pong of the same types (ModeRequest -> CommandResponse) with the
// same QoS profile, measured in the same run on loopback. Run it through `./cairn bench` (private network
// namespace). Usage: cairn_bench_command_rtt [--count N] [--domain D]
#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "../tests/process.h"
#include "cairn/base/fleet_client.h"
#include "cairn/core/build_paths.h"
#include "cairn/core/dds.h"
#include "cairn/core/shutdown.h"
#include "cairn_msgsPubSubTypes.h"

namespace {

using Clock = std::chrono::steady_clock;
namespace msgs = cairn_msgs;

struct Stats {
  double median_ms = 0, p99_ms = 0, mean_ms = 0;
};

Stats Summarize(std::vector<double> samples_ms) {
  std::sort(samples_ms.begin(), samples_ms.end());
  Stats s;
  s.median_ms = samples_ms[samples_ms.size() / 2];
  s.p99_ms = samples_ms[std::min(samples_ms.size() - 1, samples_ms.size() * 99 / 100)];
  double sum = 0;
  for (double v : samples_ms) sum += v;
  s.mean_ms = sum / samples_ms.size();
  return s;
}

// Raw echo: answers every ModeRequest with a CommandResponse, no Cairn logic in between.
int RunEcho(int domain) {
  cairn::core::InstallShutdownHandler();
  cairn::core::ParticipantOptions options;
  options.domain_id = domain;
  options.name = "raw-echo";
  cairn::core::Participant participant(options);
  cairn::core::Writer<msgs::CommandResponsePubSubType> writer(participant, "cairn/command_response",
                                                              "cairn.command");
  cairn::core::Reader<msgs::ModeRequestPubSubType> reader(participant, "cairn/mode_request", "cairn.command",
                                                          [&](const msgs::ModeRequest& m, const auto&) {
                                                            msgs::CommandResponse r;
                                                            r.robot_id(m.robot_id());
                                                            r.base_id(m.base_id());
                                                            r.request_id(m.request_id());
                                                            r.kind(msgs::COMMAND_KIND_MODE);
                                                            r.result(msgs::COMMAND_RESULT_ACCEPTED);
                                                            r.holder_id(m.base_id());
                                                            r.mode(m.mode());
                                                            writer.Write(r);
                                                          });
  std::printf("READY echo\n");
  std::fflush(stdout);
  while (!cairn::core::WaitForShutdown(std::chrono::milliseconds(200))) {
  }
  return 0;
}

// Raw client: one ModeRequest out, wait for the matching CommandResponse, same wake-up path as FleetClient.
std::vector<double> RawPingPong(int domain, int count) {
  cairn::core::ParticipantOptions options;
  options.domain_id = domain;
  options.name = "raw-client";
  cairn::core::Participant participant(options);
  std::mutex mutex;
  std::condition_variable cv;
  uint32_t answered = 0;
  cairn::core::Reader<msgs::CommandResponsePubSubType> reader(
      participant, "cairn/command_response", "cairn.command",
      [&](const msgs::CommandResponse& r, const auto&) {
        {
          std::lock_guard<std::mutex> lock(mutex);
          answered = r.request_id();
        }
        cv.notify_all();
      });
  cairn::core::Writer<msgs::ModeRequestPubSubType> writer(participant, "cairn/mode_request", "cairn.command");
  writer.WaitForMatched(1, std::chrono::seconds(10));
  reader.WaitForMatched(1, std::chrono::seconds(10));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<double> samples;
  for (int i = 1; i <= count + 50; ++i) {
    msgs::ModeRequest m;
    m.robot_id("r1");
    m.base_id("bench");
    m.request_id(static_cast<uint32_t>(i));
    m.mode(i % 2 ? "manual" : "idle");
    const auto start = Clock::now();
    writer.Write(m);
    std::unique_lock<std::mutex> lock(mutex);
    if (!cv.wait_for(lock, std::chrono::seconds(3), [&] { return answered == static_cast<uint32_t>(i); })) {
      std::fprintf(stderr, "raw ping %d lost\n", i);
      continue;
    }
    if (i > 50) samples.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
  }
  return samples;
}

void Print(const char* name, const Stats& s, const Stats* baseline) {
  std::printf("  %-44s median %7.3f ms   p99 %7.3f ms   mean %7.3f ms", name, s.median_ms, s.p99_ms,
              s.mean_ms);
  if (baseline)
    std::printf("   ratio(median) %.2fx  ratio(p99) %.2fx", s.median_ms / baseline->median_ms,
                s.p99_ms / baseline->p99_ms);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  int count = 1000, domain = 90;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--echo" && i + 1 < argc) return RunEcho(std::stoi(argv[++i]));
    if (arg == "--count" && i + 1 < argc) {
      count = std::stoi(argv[++i]);
    } else if (arg == "--domain" && i + 1 < argc) {
      domain = cairn::core::ParseDomainId(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: %s [--count N (>= 100)] [--domain D (0..231)]\n", argv[0]);
      return 2;
    }
  }
  if (count < 100 || domain > 231) {
    std::fprintf(stderr, "--count must be >= 100 and --domain <= 231\n");
    return 2;
  }
  const std::string self = argv[0];
  std::printf("Command round trip on loopback (UDPv4 127.0.0.1, profile cairn.command), %d commands each\n",
              count);

  // 1. Raw Fast DDS ping-pong against an echo process (domain+1 so that nothing else is on the topics).
  std::vector<double> raw;
  {
    cairn::testing::ChildProcess echo({self, "--echo", std::to_string(domain + 1)});
    if (!echo.WaitForLine("READY", std::chrono::seconds(10))) {
      std::fprintf(stderr, "echo did not start\n");
      return 1;
    }
    raw = RawPingPong(domain + 1, count);
  }

  // 2. Cairn: basestation FleetClient -> cairn_agent command interface (+ mode tree + mux) ->
  // acknowledgement.
  const std::string agent_bin = cairn::core::BinaryDir() + "/robot_agent/cairn_agent";
  const std::string config = "/tmp/cairn_bench_agent.yaml";
  std::FILE* f = std::fopen(config.c_str(), "w");
  std::fprintf(f, "telemetry:\n  state_rate_hz: 100\n");
  std::fclose(f);
  cairn::testing::ChildProcess agent({agent_bin, "--robot-id", "r1", "--world", "builtin:arena", "--start",
                                      "slot:0", "--domain", std::to_string(domain), "--config", config},
                                     "/tmp/cairn_bench_agent.log");
  if (!agent.WaitForLine("READY", std::chrono::seconds(30))) {
    std::fprintf(stderr, "agent did not start (see /tmp/cairn_bench_agent.log)\n");
    return 1;
  }
  cairn::base::FleetClientOptions options;
  options.base_id = "bench";
  options.domain_id = domain;
  cairn::base::FleetClient client(options);
  if (!client.WaitForRobot("r1", 10) || !client.RequestControl("r1").ok) {
    std::fprintf(stderr, "could not take control of r1\n");
    return 1;
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  std::vector<double> control, mode, switch_to_state;
  for (int i = 0; i < count + 50; ++i) {
    const auto c = client.RequestControl("r1");  // idempotent re-request: command interface only
    if (i >= 50 && c.ok) control.push_back(c.round_trip_ms);
  }
  for (int i = 0; i < count + 50; ++i) {
    const std::string target = i % 2 ? "idle" : "manual";
    const auto m = client.RequestMode("r1", target);
    if (!m.ok) {
      std::fprintf(stderr, "mode %s refused: %s\n", target.c_str(), m.reason.c_str());
      return 1;
    }
    if (i >= 50) mode.push_back(m.round_trip_ms);
  }
  // Request -> the robot's published state shows the new mux channel. Each sample first waits until the
  // state shows the current channel, so that an old state is never taken for the new one.
  auto channel_of = [](const std::string& mode) { return mode == "manual" ? std::string("teleop") : "none"; };
  std::string current = "idle";
  client.RequestMode("r1", current);
  for (int i = 0; i < 200; ++i) {
    const std::string was = channel_of(current);
    if (!client.WaitUntil("r1", 2.0, [&](const cairn::base::RobotView& v) {
          return v.state && v.state->active_channel() == was;
        })) {
      std::fprintf(stderr, "state never showed channel %s\n", was.c_str());
      return 1;
    }
    current = current == "idle" ? "manual" : "idle";
    const std::string want = channel_of(current);
    const auto start = Clock::now();
    if (!client.RequestMode("r1", current).ok) return 1;
    if (client.WaitUntil("r1", 2.0, [&](const cairn::base::RobotView& v) {
          return v.state && v.state->active_channel() == want;
        })) {
      switch_to_state.push_back(std::chrono::duration<double, std::milli>(Clock::now() - start).count());
    }
  }
  // The robot's own measure of its control loop (RobotState.control_period_max_ms, worst period over the last
  // 10-20 s): right after the flood below (covering it), and after 21 s with nothing to do (the baseline).
  auto loop_worst_ms = [&client]() {
    double worst = -1.0;
    client.WaitUntil("r1", 2.0, [&](const cairn::base::RobotView& v) {
      if (v.state) worst = v.state->control_period_max_ms();
      return v.state.has_value();
    });
    return worst;
  };

  // Mode commands from the holder while another process floods the robot with path requests (paths
  // are planned on the planning thread within a per-process rate, never on the DDS thread the commands use),
  // and the holder sends a waypoint goal (planned on the same thread, first) every 10th command.
  std::vector<double> mode_under_flood;
  int goals_accepted = 0;
  std::atomic<int> flood_sent{0};
  {
    cairn::core::ParticipantOptions flood_options;
    flood_options.domain_id = domain;
    flood_options.name = "flooder";
    cairn::core::Participant flooder(flood_options);
    cairn::core::Writer<msgs::PathRequestPubSubType> path_writer(flooder, "cairn/path_request",
                                                                 "cairn.command");
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // discovery
    std::atomic<bool> flooding{true};
    std::thread flood([&] {
      for (int i = 0; i < 2000 && flooding; ++i) {
        msgs::PathRequest r;
        r.robot_id("r1");
        r.requester_id("flooder");
        r.request_id(static_cast<uint32_t>(i + 1));
        r.frame_id("map");
        r.start_M().x_m(2.0);
        r.start_M().y_m(7.0);
        r.goal_M().x_m(18.0);
        r.goal_M().y_m(7.0);
        path_writer.Write(r);
        ++flood_sent;
      }
    });
    for (int i = 0; i < 200; ++i) {
      if (i % 10 == 5) goals_accepted += client.SendWaypoint("r1", i % 20 == 5 ? 18.0 : 3.0, 7.0).ok ? 1 : 0;
      const std::string target = i % 2 ? "idle" : "manual";
      const auto m = client.RequestMode("r1", target);
      if (m.ok) mode_under_flood.push_back(m.round_trip_ms);
    }
    flooding = false;
    flood.join();
  }
  const double loaded_loop_worst_ms = loop_worst_ms();
  client.RequestMode("r1", "idle");
  std::this_thread::sleep_for(std::chrono::seconds(21));
  const double idle_loop_worst_ms = loop_worst_ms();
  double worst_late_ms = 0;
  int late_lines = 0;
  {
    std::FILE* log = std::fopen("/tmp/cairn_bench_agent.log", "r");
    char line[1024];
    while (log != nullptr && std::fgets(line, sizeof(line), log) != nullptr) {
      const char* woke = std::strstr(line, "control loop woke ");
      const char* took = std::strstr(line, "control cycle took ");
      if (woke != nullptr) worst_late_ms = std::max(worst_late_ms, std::atof(woke + 18) + 20.0);
      if (took != nullptr) worst_late_ms = std::max(worst_late_ms, std::atof(took + 19));
      late_lines += woke != nullptr || took != nullptr;
    }
    if (log != nullptr) std::fclose(log);
  }

  const Stats raw_stats = Summarize(raw);
  Print("raw Fast DDS ping-pong (ModeRequest->Response)", raw_stats, nullptr);
  Print("cairn control command -> ack", Summarize(control), &raw_stats);
  Print("cairn mode command -> ack (mux switched)", Summarize(mode), &raw_stats);
  Print("mode request -> state shows new mux channel", Summarize(switch_to_state), nullptr);
  std::printf(
      "  (%zu mode-switch samples; the state is published at 100 Hz by a 50 Hz loop, so this includes\n"
      "   up to 20 ms of loop and publication phase: the mux itself switched before the ack above)\n",
      switch_to_state.size());
  const Stats mode_stats = Summarize(mode);
  if (mode_under_flood.size() >= 100) {
    Print("cairn mode command -> ack during a 2000-request path flood", Summarize(mode_under_flood),
          &mode_stats);
  } else {
    std::printf("mode commands during the flood: only %zu of 200 answered\n", mode_under_flood.size());
  }
  std::printf(
      "control loop worst period (the robot's RobotState.control_period_max_ms): %.1f ms during the flood "
      "and %d waypoint goals, %.1f ms idle for 21 s after it (ratio %.2f; nominal period 20 ms)\n",
      loaded_loop_worst_ms, goals_accepted, idle_loop_worst_ms,
      idle_loop_worst_ms > 0 ? loaded_loop_worst_ms / idle_loop_worst_ms : 0.0);
  std::printf("  (%d path requests sent by another process; control loop: %s)\n", flood_sent.load(),
              late_lines == 0 ? "no period over 100 ms in the whole run"
                              : ("worst period " + std::to_string(static_cast<int>(worst_late_ms)) + " ms, " +
                                 std::to_string(late_lines) + " late cycles logged")
                                    .c_str());
  return 0;
}
