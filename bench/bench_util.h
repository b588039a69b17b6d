// Small helpers the bench binaries share: the median of a run's samples and the wall time of a call.
#pragma once

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
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

/// The value of a bench's --runs flag: an integer in [1, 100]; otherwise prints why and exits with status 2.
inline int RunsOrExit(const std::string& text) {
  char* end = nullptr;
  const long runs = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || runs < 1 || runs > 100) {
    std::fprintf(stderr, "--runs '%s' must be an integer in [1, 100]\n", text.c_str());
    std::exit(2);
  }
  return static_cast<int>(runs);
}

}  // namespace cairn::bench
