// Range check of one configuration value and number formatting for messages, shared by the agent's parts and
// the libraries they use.
#pragma once

#include <cmath>
#include <sstream>
#include <string>

namespace cairn::core {

/// True if `value` is finite and in [lo, hi] ((lo, hi] when lo_open); otherwise false and `*why` =
/// "FIELD = VALUE must be in [LO, HI]".
inline bool InRange(const char* field, double value, double lo, double hi, bool lo_open, std::string* why) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    std::ostringstream out;
    out << field << " = " << value << " must be in " << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    *why = out.str();
  }
  return ok;
}

/// `value` with `digits` decimals, for messages.
inline std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(digits);
  out << value;
  return out.str();
}

}  // namespace cairn::core
