#include "cairn/core/peer_input.h"

#include <algorithm>
#include <stdexcept>

namespace cairn::core {

std::string CheckId(const std::string& field, const std::string& id) {
  const bool valid =
      !id.empty() && id.size() <= kMaxIdLength && std::all_of(id.begin(), id.end(), [](char c) {
        return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
               c == '-';
      });
  if (valid) return "";
  std::string shown;
  for (const char c : id.substr(0, kMaxIdLength)) {
    const auto u = static_cast<unsigned char>(c);
    shown += u >= 0x20 && u < 0x7f ? std::string(1, c) : "?";  // no control bytes into a log or a terminal
  }
  return field + " '" + shown +
         (id.size() > kMaxIdLength ? "...' (" + std::to_string(id.size()) + " characters)" : "'") +
         " must be 1-64 characters of A-Z a-z 0-9 _ -";
}

WarningLimiter::WarningLimiter(double period_s) : period_s_(period_s) {
  if (!(period_s > 0)) throw std::invalid_argument("WarningLimiter: period_s must be > 0");
}

bool WarningLimiter::Allow(const std::string& key, SteadyTime now, std::uint64_t* suppressed) {
  std::lock_guard<std::mutex> guard(mutex_);
  auto it = entries_.find(key);
  if (it == entries_.end()) {
    if (entries_.size() >= kMaxKeys) {
      entries_.erase(std::min_element(entries_.begin(), entries_.end(), [](const auto& a, const auto& b) {
        return a.second.last < b.second.last;
      }));
    }
    entries_[key] = Entry{now, 0};
    if (suppressed != nullptr) *suppressed = 0;
    return true;
  }
  if (SecondsBetween(it->second.last, now) < period_s_) {
    ++it->second.suppressed;
    return false;
  }
  if (suppressed != nullptr) *suppressed = it->second.suppressed;
  it->second = Entry{now, 0};
  return true;
}

}  // namespace cairn::core
