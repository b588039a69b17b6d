#include "cairn/core/shutdown.h"

#include <pthread.h>
#include <signal.h>

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>

namespace cairn::core {
namespace {

std::atomic<bool> g_requested{false};
std::atomic<void (*)()> g_on_interrupt{nullptr};
std::mutex g_mutex;
std::condition_variable g_cv;

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

void RequestShutdown() {
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    g_requested.store(true);
  }
  g_cv.notify_all();
}

bool WaitForShutdown(std::chrono::milliseconds timeout) {
  std::unique_lock<std::mutex> lock(g_mutex);
  return g_cv.wait_for(lock, timeout, [] { return g_requested.load(); });
}

}  // namespace cairn::core
