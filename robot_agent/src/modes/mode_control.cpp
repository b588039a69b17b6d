#include "cairn/agent/modes/mode_control.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

namespace cairn::agent {

namespace {

// The registry, checked to have the fail-safe module before the tree is checked against it.
ModeRegistry Checked(ModeRegistry registry);

ModeModule& IdleModule(const ModeRegistry& registry) {
  ModeModule* idle = registry.Find(ModeManager::kIdleMode);
  if (idle == nullptr) {
    throw std::invalid_argument(std::string("mode registry: no module for the fail-safe mode '") +
                                ModeManager::kIdleMode + "'");
  }
  if (idle->channel().name != "none") {
    throw std::invalid_argument("mode registry: the fail-safe mode 'idle' must feed channel 'none', not '" +
                                idle->channel().name + "'");
  }
  return *idle;
}

ModeRegistry Checked(ModeRegistry registry) {
  IdleModule(registry);
  return registry;
}

std::shared_ptr<const core::Clock> CheckedClock(std::shared_ptr<const core::Clock> clock) {
  if (!clock) throw std::invalid_argument("ModeControl: clock is null");
  return clock;
}

}  // namespace

ModeControl::ModeControl(const std::string& tree_file, ModeRegistry registry, std::string robot_id,
                         std::shared_ptr<const core::Clock> clock)
    : robot_id_(std::move(robot_id)),
      clock_(CheckedClock(std::move(clock))),
      registry_(Checked(std::move(registry))),
      mux_(registry_.MuxChannels()),
      tree_(tree_file, mux_.channel_names(), registry_.ModeChannels()),
      active_(&IdleModule(registry_)) {
  last_output_ = mux_.Compute(clock_->Now());
}

bool ModeControl::Apply(const ModeDecision& decision) {
  ModeModule* next = registry_.Find(decision.mode);
  std::string fault;
  if (decision.mode == ModeManager::kIdleMode && decision.channel != "none") {
    fault = "the mode tree's idle selects mux channel '" + decision.channel + "': stopped";
  } else if (next == nullptr) {
    fault = "mode " + decision.mode + " has no mode module: stopped";
  } else if (next->channel().name != decision.channel) {
    fault = "mode " + decision.mode + " selects mux channel '" + decision.channel +
            "', but its module feeds '" + next->channel().name + "': stopped";
  } else if (!mux_.Select(decision.channel)) {
    fault = "mode " + decision.mode + " selects mux channel '" + decision.channel +
            "', which the mux does not have: stopped";
  }
  if (!fault.empty()) {
    spdlog::error("robot {}: {}", robot_id_, fault);
    Stop(fault, /*fault=*/true);
    return false;
  }
  if (next != active_) {
    // A re-check says why the mode had to go (e.g. stale obstacle input); an operator's switch says which.
    ModeModule* previous = active_;
    active_ = next;
    previous->Deactivate(decision.reason.empty() ? "mode switched to " + decision.mode : decision.reason);
    next->Activate(clock_->Now());
  }
  return true;
}

ModeDecision ModeControl::Request(const std::string& mode, const ModeConditions& conditions) {
  ModeDecision d = tree_.Request(mode, conditions);
  if (d.accepted && !Apply(d)) d = ModeDecision{false, tree_.mode(), tree_.channel(), tree_.last_refusal()};
  return d;
}

ModeDecision ModeControl::Recheck(const ModeConditions& conditions) {
  ModeDecision d = tree_.Recheck(conditions);
  if (!d.accepted) Apply(d);
  return d;
}

void ModeControl::GoIdle(const ModeConditions& conditions) {
  const ModeDecision d = tree_.Request(ModeManager::kIdleMode, conditions);
  if (!d.accepted) {
    Stop("the mode tree refused idle: " + d.reason, /*fault=*/true);
  } else {
    Apply(d);
  }
}

void ModeControl::Stop(const std::string& reason, bool fault) {
  tree_.ForceIdle(fault ? reason : "");
  mux_.Select("none");  // always succeeds: no channel, zero twist
  active_ = &IdleModule(registry_);
  for (ModeModule* module : registry_.modules()) module->Deactivate(reason);
  last_output_ = mux_.Compute(clock_->Now());  // the state shows the zero command at once
}

bool ModeControl::Step(const ModeInputs& in) {
  const ModeOutput out = active_->Step(in);
  if (out.twist_B) mux_.Submit(active_->channel().name, *out.twist_B, out.stamp);
  return out.done;
}

bool ModeControl::OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) {
  const ModeOutput out = active_->OnPlatformStatus(status, in);
  if (out.twist_B) mux_.Submit(active_->channel().name, *out.twist_B, out.stamp);
  return out.done;
}

void ModeControl::OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp) {
  active_->OnOperatorTwist(twist_B, stamp);
}

const MuxOutput& ModeControl::Compute(core::SteadyTime now) {
  last_output_ = mux_.Compute(now);
  return last_output_;
}

bool ModeControl::IsValid(const std::string& mode, const ModeConditions& conditions) {
  const std::vector<std::string> valid = tree_.ValidModes(conditions);
  return std::find(valid.begin(), valid.end(), mode) != valid.end();
}

}  // namespace cairn::agent
