// Small helpers the bench binaries share: the median of a run's samples and the wall time of a call.
#pragma once

#include <algorithm>
#include <chrono>
#include <functional>
#include <vector>

namespace cairn::bench {

/// The median of `v` (the upper one of an even count); 0 for no samples.
inline double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

/// Wall time of `f()`, milliseconds (steady clock).
inline double TimeMs(const std::function<void()>& f) {
  const auto t0 = std::chrono::steady_clock::now();
  f();
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace cairn::bench
