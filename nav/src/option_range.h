// Copyright Cairn authors.
//
// The range check of option structs' IsValid() (frontier.cpp, explorer.cpp): one message format.
#pragma once

#include <cmath>
#include <ostream>

namespace cairn::nav::internal {

/// True when `value` is finite and in [lo, hi] ((lo, hi] when `lo_open`); otherwise false, writing
/// "<owner>::<field> = <value> must be in [lo, hi]" to `msg`.
inline bool InOptionRange(std::ostream& msg, const char* owner, const char* field, double value, double lo,
                          double hi, bool lo_open) {
  if (std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi) return true;
  msg << owner << "::" << field << " = " << value << " must be in " << (lo_open ? "(" : "[") << lo << ", "
      << hi << "]";
  return false;
}

}  // namespace cairn::nav::internal
