#include "cairn/core/time.h"

#include <cmath>
#include <stdexcept>
#include <string>

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

namespace {

class MachineClock final : public Clock {
 public:
  SteadyTime Now() const override { return SteadyClock::now(); }
};

}  // namespace

std::shared_ptr<const Clock> RealClock() {
  static const std::shared_ptr<const Clock> clock = std::make_shared<MachineClock>();
  return clock;
}

void SimulatedClock::SetSeconds(double now_s) {
  const auto ticks = std::chrono::duration_cast<SteadyClock::duration>(std::chrono::duration<double>(now_s));
  if (!std::isfinite(now_s) || now_s < 0 || ticks.count() < ticks_.load()) {
    throw std::invalid_argument(
        "SimulatedClock: now_s = " + std::to_string(now_s) +
        " must be finite and not before the clock's time (" +
        std::to_string(std::chrono::duration<double>(Now().time_since_epoch()).count()) + " s)");
  }
  ticks_.store(ticks.count());
}

}  // namespace cairn::core
