#include "cairn/core/thread_priority.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace cairn::core {

bool SetCurrentThreadNice(int nice, std::string* why) {
  if (nice < -20 || nice > 19) {
    if (why != nullptr) *why = "nice = " + std::to_string(nice) + " must be in [-20, 19]";
    return false;
  }
  // On Linux, PRIO_PROCESS with a thread id sets that thread's nice value alone (see setpriority(2), BUGS).
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (::setpriority(PRIO_PROCESS, tid, nice) != 0) {
    if (why != nullptr) *why = "setpriority(" + std::to_string(nice) + "): " + std::strerror(errno);
    return false;
  }
  return true;
}

void MakeCurrentThreadBackground() {
  errno = 0;
  const int now = ::getpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)));
  if (errno == 0 && now >= kBackgroundNice) return;  // already at or below background priority
  SetCurrentThreadNice(kBackgroundNice);
}

}  // namespace cairn::core
