// Clocks and conversions. Durations inside Cairn are steady-clock; stamps on the wire are wall clock.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>

namespace cairn::core {

using SteadyClock = std::chrono::steady_clock;
using SteadyTime = SteadyClock::time_point;

/// Seconds between two steady times (b - a).
inline double SecondsBetween(SteadyTime a, SteadyTime b) {
  return std::chrono::duration<double>(b - a).count();
}

/// Where a component reads steady time from: the machine's steady clock in a running agent (RealClock()), a
/// simulated clock that moves only when set in scenario tests and benches (SimulatedClock), so that the same
/// code runs on either. Now() is thread-safe in both.
class Clock {
 public:
  virtual ~Clock() = default;
  virtual SteadyTime Now() const = 0;
};

/// The machine's steady clock (SteadyClock::now()), one shared instance.
std::shared_ptr<const Clock> RealClock();

/// A clock that stands still until set: Now() is SteadyTime{} plus the seconds last given to SetSeconds().
class SimulatedClock final : public Clock {
 public:
  SteadyTime Now() const override { return SteadyTime(SteadyClock::duration(ticks_.load())); }
  /// Moves the clock to `now_s` seconds after its epoch (SteadyTime{}), finite and not before Now().
  /// @throws std::invalid_argument otherwise, naming the value (a clock never runs backwards).
  void SetSeconds(double now_s);

 private:
  std::atomic<SteadyClock::rep> ticks_{0};
};

/// Wall-clock now as (seconds, nanoseconds) since the Unix epoch.
struct WallStamp {
  int32_t sec = 0;
  uint32_t nanosec = 0;
};
WallStamp WallNow();
/// Wall-clock now as seconds since the Unix epoch (what ROS 2 stamps count; double: microsecond precision).
double WallNowS();

}  // namespace cairn::core
