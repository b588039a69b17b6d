#include "cairn/core/shutdown.h"

#include <pthread.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>

namespace cairn::core {
namespace {

std::atomic<bool> g_requested{false};
std::atomic<void (*)()> g_on_interrupt{nullptr};

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
        RequestShutdown();
      }
    }).detach();
  });
}

void SetInterruptHandler(void (*on_interrupt)()) { g_on_interrupt.store(on_interrupt); }

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
