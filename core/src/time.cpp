#include "cairn/core/time.h"

namespace cairn::core {

WallStamp WallNow() {
  const auto ns = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count();
  return WallStamp{static_cast<int32_t>(ns / 1000000000LL), static_cast<uint32_t>(ns % 1000000000LL)};
}

double WallNowS() {
  const WallStamp now = WallNow();
  return static_cast<double>(now.sec) + 1e-9 * static_cast<double>(now.nanosec);
}

}  // namespace cairn::core
