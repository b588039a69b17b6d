#include "cairn/agent/supervisor.h"

#include <signal.h>
#include <spdlog/spdlog.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <thread>

#include "cairn/agent/robot_agent.h"
#include "cairn/core/shutdown.h"

namespace cairn::agent {
namespace {

std::string Describe(int status) {
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  return "status " + std::to_string(status);
}

}  // namespace

int SuperviseAgent(std::vector<std::string> argv, const std::string& robot_id) {
  // SIGINT and SIGTERM reach this process as core's shutdown request (core::InstallShutdownHandler, which
  // main() installed); the child inherits their blocked mask and installs its own.
  core::InstallShutdownHandler();
  // The agent has core::kDefaultShutdownDeadline from the forwarded SIGTERM (10 s with --map-save, which
  // writes the map at exit); one that is still there 200 ms later (stopped, or its deadline thread starved)
  // is killed, and this process ends 200 ms after that.
  const bool saves_map = std::any_of(argv.begin(), argv.end(),
                                     [](const std::string& a) { return a.rfind("--map-save", 0) == 0; });
  const auto kill_child_after =
      (saves_map ? std::chrono::milliseconds(10000) : core::kDefaultShutdownDeadline) +
      std::chrono::milliseconds(200);
  core::SetShutdownDeadline(kill_child_after + std::chrono::milliseconds(200));
  constexpr double kFirstBackoffS = 1.0, kMaxBackoffS = 30.0, kHealthyRunS = 60.0;
  double backoff_s = kFirstBackoffS;
  for (int start = 1;; ++start) {
    std::vector<char*> args;
    args.reserve(argv.size());
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    const auto started = std::chrono::steady_clock::now();
    const pid_t child = ::fork();
    if (child < 0) {
      spdlog::error("supervisor of {}: fork failed", robot_id);
      return 1;
    }
    if (child == 0) {
      ::setenv("CAIRN_SUPERVISED", "1", 1);  // the agent asks for a restart rather than run a part twice
      ::execv(args[0], args.data());
      _exit(127);
    }
    spdlog::info("supervisor of {}: agent started (pid {}, start {})", robot_id, child, start);
    int status = 0;
    bool forwarded = false, killed = false;
    std::chrono::steady_clock::time_point forwarded_at;
    for (;;) {
      const pid_t done = ::waitpid(child, &status, WNOHANG);
      if (done == child || (done < 0 && errno != EINTR)) break;
      if (core::ShutdownRequested() && !forwarded) {
        ::kill(child, SIGTERM);  // the agent stops the robot and leaves the DDS domain cleanly
        forwarded = true;
        forwarded_at = std::chrono::steady_clock::now();
      }
      if (forwarded && !killed && std::chrono::steady_clock::now() - forwarded_at > kill_child_after) {
        spdlog::error("supervisor of {}: the agent (pid {}) did not end {} ms after SIGTERM: killing it",
                      robot_id, child, kill_child_after.count());
        ::kill(child, SIGKILL);
        killed = true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    const double ran_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (core::ShutdownRequested()) {
      spdlog::info("supervisor of {}: asked to stop; the agent ended ({})", robot_id, Describe(status));
      return WIFEXITED(status) ? WEXITSTATUS(status) : 0;
    }
    if (WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 2)) {
      return WEXITSTATUS(status);  // shut down, or bad input that a restart would not mend
    }
    if (ran_s >= kHealthyRunS) backoff_s = kFirstBackoffS;
    const bool asked = WIFEXITED(status) && WEXITSTATUS(status) == RobotAgent::kRestartExitStatus;
    spdlog::error(
        "supervisor of {}: the agent {} ({}) after {:.1f} s; starting it again with --resume in {:.0f} s",
        robot_id, asked ? "asked for a restart: a part of it did not stop" : "died", Describe(status), ran_s,
        backoff_s);
    if (core::WaitForShutdown(std::chrono::milliseconds(static_cast<int>(backoff_s * 1000)))) return 0;
    backoff_s = std::min(kMaxBackoffS, backoff_s * 2);
    if (std::find(argv.begin(), argv.end(), "--resume") == argv.end()) argv.emplace_back("--resume");
  }
}

}  // namespace cairn::agent
