// What a robot sends on its link, per topic class, as rates: the agent's half of bandwidth monitoring.
// Cumulative counters (AgentDds::SentByClass) in, kbit/s over a sliding window out; the robot
// publishes them in RobotState::link_usage and every basestation shows them (`links`). Pure logic, no DDS.
#pragma once

#include <deque>
#include <utility>
#include <vector>

#include "cairn/agent/communication/agent_link.h"

namespace cairn::agent {

/// One topic class's totals and its recent rate.
struct SentRate {
  SentTraffic total;       ///< cumulative since the agent started
  double sent_kbps = 0.0;  ///< over the meter's window, kbit/s (1 kbit = 1000 bit)
};

/// Sliding-window rates of cumulative byte counters.
class LinkUsageMeter {
 public:
  /// `window_s`: how far back rates look, seconds, (0, 60]. @throws std::invalid_argument naming the value.
  explicit LinkUsageMeter(double window_s = 2.0);

  /// Adds the counters read at `now_s` (seconds of any monotonic clock, non-decreasing) and returns each
  /// class's rate over the last window_s (from the oldest reading within it; 0 for the first reading). A
  /// class that is new since the oldest reading counts from zero; a counter that went down (a restart)
  /// restarts the window.
  std::vector<SentRate> Update(double now_s, const std::vector<SentTraffic>& sent);

 private:
  double window_s_;
  std::deque<std::pair<double, std::vector<SentTraffic>>> readings_;  // oldest first
};

}  // namespace cairn::agent
