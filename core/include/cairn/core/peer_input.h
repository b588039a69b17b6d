// Checks of what peers send (robot and basestation ids) and rate-limited warnings about bad peer input: a
// peer's messages are untrusted input, checked before anything reads them, and a flood of bad ones
// must not flood the log.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>

#include "cairn/core/time.h"

namespace cairn::core {

/// Longest robot or basestation id, characters.
inline constexpr std::size_t kMaxIdLength = 64;

/// "" when `id` is a valid robot or basestation id (1-64 characters of A-Z a-z 0-9 _ -, as the CLIs take
/// them), else the fault naming `field` and the id (its first 64 characters and its length when longer), e.g.
/// "base id 'x...' (100000 characters) must be 1-64 characters of A-Z a-z 0-9 _ -".
std::string CheckId(const std::string& field, const std::string& id);

/// At most one warning per key per period, for bad input that may repeat at a peer's rate (a non-finite twist
/// at 20 Hz). Thread-safe.
class WarningLimiter {
 public:
  /// `period_s` > 0, seconds.
  explicit WarningLimiter(double period_s = 5.0);
  /// True when a warning about `key` may be logged at `now`; then `*suppressed` (may be null) is the number
  /// of warnings about it refused since the last one allowed.
  bool Allow(const std::string& key, SteadyTime now, std::uint64_t* suppressed = nullptr);

 private:
  struct Entry {
    SteadyTime last;
    std::uint64_t suppressed = 0;
  };
  static constexpr std::size_t kMaxKeys = 1024;  // keys come from peers: bounded, oldest dropped
  double period_s_;
  std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

}  // namespace cairn::core
