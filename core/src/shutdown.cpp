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
std::mutex g_mutex;
std::condition_variable g_cv;

}  // namespace

void InstallShutdownHandler() {
  static std::once_flag once;
  std::call_once(once, [] {
    sigset_t set;
    sigemptyset(&set);
    sigaddset(&set, SIGINT);
    sigaddset(&set, SIGTERM);
    pthread_sigmask(SIG_BLOCK, &set, nullptr);
    std::thread([set] {
      int signal_number = 0;
      sigwait(&set, &signal_number);
      RequestShutdown();
    }).detach();
  });
}

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
