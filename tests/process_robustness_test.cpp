// The processes under stress, across real processes: shutdown by SIGINT/SIGTERM whatever their parts are
// doing, a basestation reading a pipe prints events when they happen, a one-shot fleet stop reaches the
// robots at once, and a stalled robot is told from one whose process exited. Every process runs in the test's
// private network namespace.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/shutdown.h"
#include "integration_util.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using testing_util::ChildProcess;
using testing_util::Clock;
using testing_util::FreshLogs;
using testing_util::json;
using testing_util::kAgent;
using testing_util::kBase;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Sends `sig` and returns the seconds until the process exited (its status in *status), or -1 after 10 s.
double SecondsToExit(ChildProcess& process, int sig, int* status) {
  const auto start = Clock::now();
  process.Signal(sig);
  const auto waited = process.Wait(10s);
  if (!waited) return -1;
  *status = *waited;
  return SecondsSince(start);
}

std::unique_ptr<ChildProcess> StartAgent(const std::string& id, int domain, const std::string& logs,
                                         const std::vector<std::string>& extra = {}) {
  return testing_util::StartAgentIn("builtin:arena", id, domain, logs, extra);
}

// Reads lines of `process` until one contains `needle`; the line, or "" after `timeout`.
std::string WaitForOutput(ChildProcess& process, const std::string& needle, std::chrono::milliseconds timeout,
                          std::string* seen = nullptr) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    const auto line =
        process.ReadLine(std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
    if (!line) break;
    if (seen) *seen += *line + "\n";
    if (line->find(needle) != std::string::npos) return *line;
  }
  return "";
}

// The second stage of a signal's shutdown, in a process of its own whose main loop never looks at the
// request: it ends kDefaultShutdownDeadline after SIGTERM with kForcedExitStatus, and at once on a second
// signal.
TEST(Shutdown, AProcessThatDoesNotStopIsEndedAtTheDeadlineOrOnASecondSignal) {
  for (const bool twice : {false, true}) {
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      core::InstallShutdownHandler();
      while (true) std::this_thread::sleep_for(10ms);  // a loop that does not stop
    }
    std::this_thread::sleep_for(200ms);  // the handler is installed
    const auto start = Clock::now();
    kill(child, SIGTERM);
    if (twice) {
      std::this_thread::sleep_for(100ms);
      kill(child, SIGINT);
    }
    int status = 0;
    while (waitpid(child, &status, WNOHANG) == 0 && SecondsSince(start) < 5) std::this_thread::sleep_for(5ms);
    const double s = SecondsSince(start);
    if (s >= 5) {
      kill(child, SIGKILL);
      waitpid(child, &status, 0);
    }
    testing_util::Figure(twice ? "second_signal_exit_s" : "deadline_exit_s", s);
    ASSERT_TRUE(WIFEXITED(status)) << "status " << status;
    EXPECT_EQ(WEXITSTATUS(status), core::kForcedExitStatus);
    if (twice) {
      EXPECT_LT(s, 0.5);
    } else {
      EXPECT_GE(s, 1.4);
      EXPECT_LT(s, 2.0);
    }
  }
}

// A robot whose perception loop is stuck (it never returns, even at shutdown) still ends within 2 s of
// SIGTERM or SIGINT; an idle one ends cleanly (status 0).
TEST(Shutdown, AnAgentExitsWithin2sOfSigtermOrSigintEvenWithAHungComponent) {
  const std::string logs = FreshLogs("robustness", "agent_shutdown");
  for (const int sig : {SIGINT, SIGTERM}) {
    auto idle = StartAgent("r1", 81, logs);
    int status = 0;
    const double idle_s = SecondsToExit(*idle, sig, &status);
    testing_util::Figure(sig == SIGINT ? "idle_agent_sigint_exit_s" : "idle_agent_sigterm_exit_s", idle_s);
    EXPECT_GE(idle_s, 0) << "did not exit; see " << logs;
    EXPECT_LT(idle_s, 2.0);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "status " << status;

    auto hung = StartAgent("r2", 81, logs, {"--inject-fault", "perception:stuck:0.5"});
    std::this_thread::sleep_for(2s);  // the fault is in place
    const double hung_s = SecondsToExit(*hung, sig, &status);
    testing_util::Figure(sig == SIGINT ? "hung_agent_sigint_exit_s" : "hung_agent_sigterm_exit_s", hung_s);
    EXPECT_GE(hung_s, 0) << "did not exit; see " << logs;
    EXPECT_LT(hung_s, 2.0);
    EXPECT_TRUE(WIFEXITED(status)) << "status " << status;
  }
}

// A basestation ends within 2 s whether it waits for a line on its pipe, serves the GUI, or runs a command
// that waits (wait R arrived, up to its timeout).
TEST(Shutdown, ABaseExitsWithin2sOfSigtermOrSigintWhateverItIsDoing) {
  const std::string logs = FreshLogs("robustness", "base_shutdown");
  auto agent = StartAgent("r1", 82, logs);
  for (const int sig : {SIGINT, SIGTERM}) {
    const std::string name = sig == SIGINT ? "sigint" : "sigterm";
    int status = 0;
    {
      ChildProcess idle({kBase, "--base-id", "opA", "--domain", "82"}, logs + "/opA_" + name + ".log");
      std::this_thread::sleep_for(1s);
      const double s = SecondsToExit(idle, sig, &status);
      testing_util::Figure("piped_base_" + name + "_exit_s", s);
      EXPECT_GE(s, 0) << "a base waiting for a line did not exit";
      EXPECT_LT(s, 2.0);
    }
    {
      ChildProcess gui({kBase, "--base-id", "opG", "--domain", "82", "--gui", "--listen", "127.0.0.1:18090"},
                       logs + "/opG_" + name + ".log");
      ASSERT_NE(WaitForOutput(gui, "GUI ", 20s), "") << "no GUI line; see " << logs;
      std::this_thread::sleep_for(1s);
      const double s = SecondsToExit(gui, sig, &status);
      testing_util::Figure("gui_base_" + name + "_exit_s", s);
      EXPECT_GE(s, 0) << "a base serving the GUI did not exit";
      EXPECT_LT(s, 2.0);
    }
    {
      ChildProcess busy({kBase, "--base-id", "opB", "--domain", "82", "--json"},
                        logs + "/opB_" + name + ".log");
      busy.WriteLine("wait r1 arrived 30");
      std::this_thread::sleep_for(2s);
      const double s = SecondsToExit(busy, sig, &status);
      testing_util::Figure("waiting_base_" + name + "_exit_s", s);
      EXPECT_GE(s, 0) << "a base running a command did not exit";
      EXPECT_LT(s, 2.0);
    }
  }
}

// A basestation reading commands from a pipe prints an event when it happens, not with the next command's
// result: a robot joining while no command is sent, in text and in --json, and leaving during a `sleep`.
TEST(PipedBase, PrintsEventsWhenTheyHappen) {
  const std::string logs = FreshLogs("robustness", "piped_events");
  for (const bool as_json : {false, true}) {
    const std::string domain = as_json ? "84" : "83";
    std::vector<std::string> argv = {kBase, "--base-id", "opA", "--domain", domain};
    if (as_json) argv.emplace_back("--json");
    ChildProcess base(argv, logs + (as_json ? "/opA_json.log" : "/opA.log"));
    base.WriteLine("robots");
    ASSERT_NE(WaitForOutput(base, as_json ? "\"robots\"" : "no robots discovered", 20s), "")
        << "no answer to robots";
    auto agent = testing_util::StartAgentIn("builtin:arena", "r1", std::stoi(domain), logs);
    const auto ready = Clock::now();
    std::string seen;
    const std::string line = WaitForOutput(base, "r1 joined", 10s, &seen);
    const double s = SecondsSince(ready);
    testing_util::Figure(as_json ? "json_event_delay_s" : "text_event_delay_s", s);
    ASSERT_NE(line, "") << "no join event printed while no command ran; printed:\n" << seen;
    EXPECT_LT(s, 3.0);
    if (as_json) {
      EXPECT_EQ(json::parse(line).value("event", ""), "joined") << line;
    } else {
      EXPECT_EQ(line.rfind('[', 0), 0u) << line;
      continue;
    }
    // And while a command runs: the robot leaves during a `sleep 3`, told before the sleep's answer.
    base.WriteLine("sleep 3");
    std::this_thread::sleep_for(500ms);
    agent->Signal(SIGTERM);
    seen.clear();
    EXPECT_NE(WaitForOutput(base, "r1 left", 10s, &seen), "") << seen;
    EXPECT_EQ(seen.find("\"command\":\"sleep\""), std::string::npos) << "told only after the sleep:\n"
                                                                     << seen;
    EXPECT_NE(WaitForOutput(base, "\"command\":\"sleep\"", 10s, &seen), "") << seen;
  }
}

// `cairn_base -- stop all` as a fresh process: the robot receives the stop soon after the process starts (it
// used to wait a fixed 1.5 s of discovery, then send).
TEST(OneShotStop, ReachesTheRobotsWithin2s) {
  const std::string logs = FreshLogs("robustness", "one_shot_stop");
  auto r1 = StartAgent("r1", 85, logs);
  ChildProcess r2(
      {kAgent, "--robot-id", "r2", "--world", "builtin:arena", "--start", "slot:1", "--domain", "85"},
      logs + "/r2.log");
  ASSERT_TRUE(r2.WaitForLine("READY", 60s)) << "r2 did not start; see " << logs;
  testing_util::Observer observer(85);
  for (const std::string robot : {"r1", "r2"}) {
    const auto deadline = Clock::now() + 20s;
    while (!observer.Latest(robot) && Clock::now() < deadline) std::this_thread::sleep_for(50ms);
    ASSERT_TRUE(observer.Latest(robot)) << robot << " not heard";
  }
  const double start_wall_s = msgs::WallSeconds(msgs::WallStampNow());
  ChildProcess stop({kBase, "--base-id", "opS", "--domain", "85", "--", "stop", "all"}, logs + "/opS.log");
  for (const std::string robot : {"r1", "r2"}) {
    double received_s = -1;
    const auto deadline = Clock::now() + 10s;
    while (Clock::now() < deadline) {
      const auto state = observer.Latest(robot);
      if (state && state->stopped_by() == "opS") {
        received_s = msgs::WallSeconds(state->stopped_at()) - start_wall_s;
        break;
      }
      std::this_thread::sleep_for(10ms);
    }
    testing_util::Figure("stop_all_reached_" + robot + "_s", received_s);
    EXPECT_GE(received_s, 0) << robot << " never received opS's stop; see " << logs;
    EXPECT_LT(received_s, 2.0) << robot;
  }
  std::string out;
  WaitForOutput(stop, "\n", 10s, &out);  // to EOF
  const auto status = stop.Wait(10s);
  ASSERT_TRUE(status);
  EXPECT_TRUE(WIFEXITED(*status) && WEXITSTATUS(*status) == 0) << out;
  EXPECT_NE(out.find("r1"), std::string::npos) << out;
  EXPECT_NE(out.find("r2"), std::string::npos) << out;
}

// A robot whose process is alive but not running (SIGSTOP) is lost, not "left": its process did not exit. It
// stays so past its participant's lease (2 s), and when it runs again (SIGCONT, its participant re-created
// after the stall) it is back; it was reported "left (its process exited)" then.
TEST(StalledAgent, IsReportedLostNotLeftAndBackWhenItRunsAgain) {
  const std::string logs = FreshLogs("robustness", "stalled_agent");
  auto agent = StartAgent("r1", 86, logs);
  ChildProcess base({kBase, "--base-id", "opA", "--domain", "86", "--json"}, logs + "/opA.log");
  std::string seen;
  ASSERT_NE(WaitForOutput(base, "r1 joined", 20s, &seen), "") << seen;
  seen.clear();
  agent->Signal(SIGSTOP);
  const auto stopped = Clock::now();
  double lost_after_s = -1;
  std::vector<json> events;
  auto read_events = [&](double until_s) {
    while (SecondsSince(stopped) < until_s) {
      const std::string line = WaitForOutput(base, "\"event\"", 200ms, &seen);
      if (line.empty()) continue;
      events.push_back(json::parse(line));
      if (events.back().value("event", "") == "lost" && lost_after_s < 0)
        lost_after_s = SecondsSince(stopped);
    }
  };
  read_events(5.0);  // past the participant's lease
  testing_util::Figure("stalled_agent_lost_after_s", lost_after_s);
  agent->Signal(SIGCONT);
  read_events(12.0);
  std::vector<std::string> kinds;
  kinds.reserve(events.size());
  for (const json& e : events) kinds.push_back(e.value("event", ""));
  EXPECT_GE(lost_after_s, 0) << "the stalled robot was not reported lost; printed:\n" << seen;
  EXPECT_EQ(std::count(kinds.begin(), kinds.end(), "left"), 0) << seen;
  EXPECT_EQ(seen.find("exited"), std::string::npos) << seen;
  EXPECT_NE(std::find(kinds.begin(), kinds.end(), "back"), kinds.end()) << "not back after SIGCONT:\n"
                                                                        << seen;
  // A process that does exit is told apart: it left. On a starved machine the agent may miss its 1 s
  // liveliness lease first (a "lost" line) and take seconds to shut down, so other events may come before.
  agent->Signal(SIGTERM);
  const auto terminated = Clock::now();
  std::string left;
  while (left.find("\"left\"") == std::string::npos && SecondsSince(terminated) < 20.0)
    left = WaitForOutput(base, "\"event\"", 1s, &seen);
  EXPECT_NE(left.find("r1 left (its process exited)"), std::string::npos) << seen << "\nsee " << logs;
}

}  // namespace
}  // namespace cairn
