// Conversions between Cairn clocks and wire types.
#pragma once

#include "cairn/core/time.h"
#include "cairn_msgs.h"

namespace cairn::msgs {

/// Wall-clock now as a cairn_msgs::Time (seconds and nanoseconds since the Unix epoch).
inline cairn_msgs::Time WallStampNow() {
  const core::WallStamp now = core::WallNow();
  cairn_msgs::Time t;
  t.sec(now.sec);
  t.nanosec(now.nanosec);
  return t;
}

/// A wire time as seconds since the Unix epoch (double: microsecond precision today).
inline double WallSeconds(const cairn_msgs::Time& t) { return t.sec() + 1e-9 * t.nanosec(); }

}  // namespace cairn::msgs
