#include "cairn/agent/supervisor.h"

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <thread>

#include <spdlog/spdlog.h>

namespace cairn::agent {
namespace {

volatile sig_atomic_t g_stop_signal = 0;
volatile pid_t g_child = 0;

void OnStopSignal(int signal) {
  g_stop_signal = signal;
  if (g_child > 0) ::kill(g_child, signal);
}

std::string Describe(int status) {
  if (WIFSIGNALED(status)) return "killed by signal " + std::to_string(WTERMSIG(status));
  if (WIFEXITED(status)) return "exit status " + std::to_string(WEXITSTATUS(status));
  return "status " + std::to_string(status);
}

}  // namespace

int SuperviseAgent(std::vector<std::string> argv, const std::string& robot_id) {
  struct sigaction action {};
  action.sa_handler = OnStopSignal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  constexpr double kFirstBackoffS = 1.0, kMaxBackoffS = 30.0, kHealthyRunS = 60.0;
  double backoff_s = kFirstBackoffS;
  for (int start = 1;; ++start) {
    std::vector<char*> args;
    for (std::string& a : argv) args.push_back(a.data());
    args.push_back(nullptr);
    const auto started = std::chrono::steady_clock::now();
    const pid_t child = ::fork();
    if (child < 0) {
      spdlog::error("supervisor of {}: fork failed", robot_id);
      return 1;
    }
    if (child == 0) {
      signal(SIGINT, SIG_DFL);
      signal(SIGTERM, SIG_DFL);
      ::execv(args[0], args.data());
      _exit(127);
    }
    g_child = child;
    spdlog::info("supervisor of {}: agent started (pid {}, start {})", robot_id, child, start);
    int status = 0;
    while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
    }
    g_child = 0;
    const double ran_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    if (g_stop_signal != 0) {
      spdlog::info("supervisor of {}: stopped by signal {}; the agent ended ({})", robot_id,
                   static_cast<int>(g_stop_signal), Describe(status));
      return WIFEXITED(status) ? WEXITSTATUS(status) : 0;
    }
    if (WIFEXITED(status) && (WEXITSTATUS(status) == 0 || WEXITSTATUS(status) == 2)) {
      return WEXITSTATUS(status);  // shut down, or bad input that a restart would not mend
    }
    if (ran_s >= kHealthyRunS) backoff_s = kFirstBackoffS;
    spdlog::error("supervisor of {}: the agent died ({}) after {:.1f} s; starting it again with --resume in {:.0f} s",
                  robot_id, Describe(status), ran_s, backoff_s);
    const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(backoff_s);
    while (std::chrono::steady_clock::now() < until && g_stop_signal == 0) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (g_stop_signal != 0) return 0;
    backoff_s = std::min(kMaxBackoffS, backoff_s * 2);
    if (std::find(argv.begin(), argv.end(), "--resume") == argv.end()) argv.push_back("--resume");
  }
}

}  // namespace cairn::agent
