#include "cairn/core/shutdown.h"

#include <pthread.h>
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>  // program_invocation_short_name
#include <chrono>
#include <cstdio>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>

namespace cairn::core {
namespace {

std::atomic<bool> g_requested{false};
std::atomic<void (*)()> g_on_interrupt{nullptr};
std::atomic<long long> g_deadline_ms{kDefaultShutdownDeadline.count()};
std::atomic<bool> g_signalled{false};

// Writes `text` to stderr with write(2): the deadline may fall while another thread holds stdio's lock.
void WriteStderr(const std::string& text) {
  std::size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(STDERR_FILENO, text.data() + done, text.size() - done);
    if (n <= 0) return;
    done += static_cast<std::size_t>(n);
  }
}

// The second stage of a signal's shutdown: a process whose teardown waits on a loop that does not stop (a
// hung component, a blocked read) must still end. Runs on its own thread from the first SIGINT/SIGTERM.
void ArmDeadline(int signal_number) {
  const auto deadline = std::chrono::milliseconds(g_deadline_ms.load());
  std::thread([deadline, signal_number] {
    std::this_thread::sleep_for(deadline);
    WriteStderr(
        std::string(program_invocation_short_name) + ": still running " + std::to_string(deadline.count()) +
        " ms after " + (signal_number == SIGINT ? "SIGINT" : "SIGTERM") +
        " (a part of it did not stop): exiting now with status " + std::to_string(kForcedExitStatus) + "\n");
    // What stdout holds goes out, unless another thread holds it (blocked writing to a full pipe, perhaps).
    if (ftrylockfile(stdout) == 0) {
      fflush_unlocked(stdout);
      funlockfile(stdout);
    }
    ::_exit(kForcedExitStatus);
  }).detach();
}

}  // namespace

void InstallShutdownHandler() {
  static std::once_flag once;
  std::call_once(once, [] {
    // A parent that ignores SIGINT (a shell script running a console) would make it vanish before sigwait.
    signal(SIGINT, SIG_DFL);
    signal(SIGTERM, SIG_DFL);
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    std::thread([set] {
      while (true) {
        int signal_number = 0;
        if (sigwait(&set, &signal_number) != 0) continue;
        void (*on_interrupt)() = g_on_interrupt.load();
        if (signal_number == SIGINT && on_interrupt != nullptr) {
          on_interrupt();
          continue;
        }
        if (g_signalled.exchange(true)) {
          // A second signal: the operator insists.
          WriteStderr(std::string(program_invocation_short_name) + ": a second " +
                      (signal_number == SIGINT ? "SIGINT" : "SIGTERM") + ": exiting now with status " +
                      std::to_string(kForcedExitStatus) + "\n");
          ::_exit(kForcedExitStatus);
        }
        RequestShutdown();
        ArmDeadline(signal_number);
      }
    }).detach();
  });
}

void SetInterruptHandler(void (*on_interrupt)()) { g_on_interrupt.store(on_interrupt); }

void SetShutdownDeadline(std::chrono::milliseconds deadline) {
  if (deadline.count() < 1 || deadline > std::chrono::minutes(10)) {
    throw std::invalid_argument("shutdown deadline " + std::to_string(deadline.count()) +
                                " ms is not in [1, 600000] ms");
  }
  g_deadline_ms.store(deadline.count());
}

bool ShutdownRequested() { return g_requested.load(); }

void RequestShutdown() { g_requested.store(true); }

bool WaitForShutdown(std::chrono::milliseconds timeout) {
  // Sleeps in slices and polls the flag rather than waiting on one condition variable shared by every thread
  // of the process (a thread preempted while holding its mutex would hold up every other thread's wake, the
  // robot's control loop among them). A shutdown is seen within one slice.
  constexpr std::chrono::milliseconds kSlice(20);
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!g_requested.load()) {
    const auto now = std::chrono::steady_clock::now();
    if (now >= end) return false;
    std::this_thread::sleep_for(std::min<std::chrono::steady_clock::duration>(end - now, kSlice));
  }
  return true;
}

}  // namespace cairn::core
