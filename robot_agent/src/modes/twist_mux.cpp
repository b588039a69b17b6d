#include "cairn/agent/modes/twist_mux.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace cairn::agent {

TwistMux::TwistMux(const std::vector<MuxChannelOptions>& channels) {
  for (const auto& c : channels) {
    if (c.name.empty() || c.name == "none") {
      throw std::invalid_argument("mux channel name '" + c.name + "' is reserved or empty");
    }
    if (!(c.timeout_s > 0.0 && c.timeout_s <= 60.0)) {
      throw std::invalid_argument("mux channel " + c.name + ": timeout_s = " + std::to_string(c.timeout_s) +
                                  " must be in (0, 60]");
    }
    if (!channels_.emplace(c.name, Channel{c.timeout_s, {}, {}, false}).second) {
      throw std::invalid_argument("mux channel '" + c.name + "' is defined twice");
    }
  }
}

bool TwistMux::Submit(const std::string& channel, const Twist2& twist_B, core::SteadyTime stamp) {
  auto it = channels_.find(channel);
  if (it == channels_.end()) return false;
  if (!std::isfinite(twist_B.linear_x_mps) || !std::isfinite(twist_B.angular_z_radps)) return false;
  it->second.twist_B = twist_B;
  it->second.stamp = stamp;
  it->second.has_input = true;
  return true;
}

bool TwistMux::Select(const std::string& channel) {
  if (channel == "none") {
    selected_ = channel;
    return true;
  }
  auto it = channels_.find(channel);
  if (it == channels_.end()) return false;
  if (selected_ != channel) it->second.has_input = false;
  selected_ = channel;
  return true;
}

std::vector<std::string> TwistMux::channel_names() const {
  std::vector<std::string> names;
  for (const auto& [name, channel] : channels_) names.push_back(name);
  return names;
}

MuxOutput TwistMux::Compute(core::SteadyTime now) const {
  MuxOutput out;
  out.active_channel = selected_;
  if (selected_ == "none") {
    out.reason = "no channel selected: zero twist";
    return out;
  }
  const Channel& c = channels_.at(selected_);
  char text[160];
  if (!c.has_input) {
    std::snprintf(text, sizeof(text), "%s stale: no input since selected: zero twist", selected_.c_str());
    out.reason = text;
    return out;
  }
  const double age_s = core::SecondsBetween(c.stamp, now);
  if (age_s > c.timeout_s) {
    std::snprintf(text, sizeof(text), "%s stale: no input for %.2f s > %.2f s: zero twist", selected_.c_str(),
                  age_s, c.timeout_s);
    out.reason = text;
    return out;
  }
  std::snprintf(text, sizeof(text), "%s fresh (%.2f s old)", selected_.c_str(), age_s);
  out.reason = text;
  out.twist_B = c.twist_B;
  out.forwarding = true;
  return out;
}

}  // namespace cairn::agent
