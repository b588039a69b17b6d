// Clocks and conversions. Durations inside Cairn are steady-clock; stamps on the wire are wall clock.
#pragma once

#include <chrono>
#include <cstdint>

namespace cairn::core {

using SteadyClock = std::chrono::steady_clock;
using SteadyTime = SteadyClock::time_point;

/// Seconds between two steady times (b - a).
inline double SecondsBetween(SteadyTime a, SteadyTime b) {
  return std::chrono::duration<double>(b - a).count();
}

/// Wall-clock now as (seconds, nanoseconds) since the Unix epoch.
struct WallStamp {
  int32_t sec = 0;
  uint32_t nanosec = 0;
};
WallStamp WallNow();
/// Wall-clock now as seconds since the Unix epoch (what ROS 2 stamps count; double: microsecond precision).
double WallNowS();

}  // namespace cairn::core
