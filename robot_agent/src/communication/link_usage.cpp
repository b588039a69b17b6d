#include "cairn/agent/communication/link_usage.h"

#include <stdexcept>
#include <string>

namespace cairn::agent {

LinkUsageMeter::LinkUsageMeter(double window_s) : window_s_(window_s) {
  if (!(window_s > 0 && window_s <= 60)) {
    throw std::invalid_argument("link usage window_s = " + std::to_string(window_s) + " must be in (0, 60]");
  }
}

std::vector<SentRate> LinkUsageMeter::Update(double now_s, const std::vector<SentTraffic>& sent) {
  if (!readings_.empty() && now_s < readings_.back().first) readings_.clear();
  // Keep the newest reading at or before the window's start, so the window is as long as the history allows.
  while (readings_.size() >= 2 && readings_[1].first <= now_s - window_s_) readings_.pop_front();
  std::vector<SentRate> rates;
  rates.reserve(sent.size());
  bool restarted = false;
  for (const SentTraffic& now : sent) {
    SentRate rate{now, 0.0};
    if (!readings_.empty()) {
      const auto& [then_s, then] = readings_.front();
      std::uint64_t before = 0;
      for (const SentTraffic& t : then) {
        if (t.topic_class == now.topic_class) before = t.bytes;
      }
      const double elapsed_s = now_s - then_s;
      if (now.bytes < before) {
        restarted = true;
      } else if (elapsed_s > 0) {
        rate.sent_kbps = static_cast<double>(now.bytes - before) * 8.0 / 1000.0 / elapsed_s;
      }
    }
    rates.push_back(rate);
  }
  if (restarted) readings_.clear();
  readings_.emplace_back(now_s, sent);
  return rates;
}

}  // namespace cairn::agent
