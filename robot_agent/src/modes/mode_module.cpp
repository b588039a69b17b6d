#include "cairn/agent/modes/mode_module.h"

#include <stdexcept>

#include "cairn/core/range_check.h"

namespace cairn::agent {

std::string ContactTimer::Update(const core::PlatformStatus& status, const ModeInputs& in, double timeout_s) {
  if (!status.in_contact) {
    in_contact_ = false;
    return "";
  }
  if (!in_contact_) {
    in_contact_ = true;
    since_ = in.now;
    return "";
  }
  if (core::SecondsBetween(since_, in.now) <= timeout_s) return "";
  return "blocked: in contact with occupied space at (" + core::Fixed(in.pose_M.x_m, 2) + ", " +
         core::Fixed(in.pose_M.y_m, 2) + ")";
}

ModeModule& ModeRegistry::Add(std::unique_ptr<ModeModule> module) {
  if (!module) throw std::invalid_argument("mode registry: a mode module is null");
  const std::string& name = module->name();
  if (name.empty()) throw std::invalid_argument("mode registry: a mode module has an empty name");
  if (Find(name) != nullptr)
    throw std::invalid_argument("mode registry: mode '" + name + "' is registered twice");
  const MuxChannelOptions& channel = module->channel();
  if (channel.name.empty())
    throw std::invalid_argument("mode registry: mode '" + name + "' has no channel name");
  for (const auto& other : modules_) {
    if (channel.name != "none" && other->channel().name == channel.name &&
        other->channel().timeout_s != channel.timeout_s) {
      throw std::invalid_argument("mode registry: mode '" + name + "' declares mux channel '" + channel.name +
                                  "' with timeout_s = " + core::Fixed(channel.timeout_s, 3) + ", mode '" +
                                  other->name() + "' with " + core::Fixed(other->channel().timeout_s, 3));
    }
  }
  modules_.push_back(std::move(module));
  return *modules_.back();
}

ModeModule* ModeRegistry::Find(const std::string& name) const {
  for (const auto& m : modules_) {
    if (m->name() == name) return m.get();
  }
  return nullptr;
}

std::vector<std::string> ModeRegistry::names() const {
  std::vector<std::string> names;
  for (const auto& m : modules_) names.push_back(m->name());
  return names;
}

std::vector<ModeModule*> ModeRegistry::modules() const {
  std::vector<ModeModule*> modules;
  for (const auto& m : modules_) modules.push_back(m.get());
  return modules;
}

std::map<std::string, std::string> ModeRegistry::ModeChannels() const {
  std::map<std::string, std::string> channels;
  for (const auto& m : modules_) channels[m->name()] = m->channel().name;
  return channels;
}

std::vector<MuxChannelOptions> ModeRegistry::MuxChannels() const {
  std::vector<MuxChannelOptions> channels;
  for (const auto& m : modules_) {
    const MuxChannelOptions& c = m->channel();
    if (c.name == "none") continue;
    bool seen = false;
    for (const auto& s : channels) seen = seen || s.name == c.name;
    if (!seen) channels.push_back(c);
  }
  return channels;
}

}  // namespace cairn::agent
