// The mode tree running the mode modules through the mux (Sriganesh et al. 2024, § Behavior Tree and Mux;
// lessons L3 and L5). The tree (ModeManager) decides which mode the robot is in; the module of that mode
// (ModeRegistry) is the only one that runs, and the mux forwards only its channel. DDS-free: the agent feeds
// it the tree's conditions and the robot's state; tests drive it with their own modules.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/modes/mode_module.h"
#include "cairn/agent/modes/twist_mux.h"
#include "cairn/core/time.h"

namespace cairn::agent {

/// Mode switching and the control cycle's twist. Not thread-safe (the agent calls it under its lock).
class ModeControl {
 public:
  /// Builds the mux from the modules' channels and loads the tree, checked against both (ModeManager).
  /// `robot_id` names the robot in log lines; `clock` stamps a module's activation and the zero command of a
  /// Stop() (the agent's clock: real, or simulated in scenario tests).
  /// @throws std::invalid_argument when the registry has no module for the fail-safe mode "idle" feeding
  ///         channel "none", or a channel is invalid (TwistMux); bt::TreeError as ModeManager (file, line,
  ///         branch, mode and channel named).
  ModeControl(const std::string& tree_file, ModeRegistry registry, std::string robot_id,
              std::shared_ptr<const core::Clock> clock = core::RealClock());

  /// Asks the tree for `mode` under `conditions`; on acceptance switches the mux channel and the running
  /// module (the one left is deactivated, the new one activated). A channel switch that fails (impossible
  /// with a checked tree) stops the robot: the decision then comes back refused with that fault as its
  /// reason.
  ModeDecision Request(const std::string& mode, const ModeConditions& conditions);
  /// Re-checks the current mode; when it is no longer allowed, switches to idle (applied) and returns
  /// accepted = false with the reason.
  ModeDecision Recheck(const ModeConditions& conditions);
  /// Idle after a mode's task ended: through the tree, or a Stop() if the tree refuses idle.
  void GoIdle(const ModeConditions& conditions);
  /// Stops whatever the tree and the mux say: mode idle, no channel (zero twist at once), every module
  /// deactivated with `reason` (a goal is cancelled). A `fault` is also kept as the tree's last refusal.
  void Stop(const std::string& reason, bool fault = false);

  /// Runs the active module for one control cycle; its twist goes to its mux channel. @return true when the
  /// module's task ended (the caller then calls GoIdle with the tree's conditions).
  bool Step(const ModeInputs& in);
  /// Hands the platform's status after the cycle's command to the active module. @return as Step().
  bool OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in);
  /// The control holder's stick, to the active module (only stick-driven modes use it).
  void OnOperatorTwist(const OperatorTwist& twist_B, core::SteadyTime stamp);
  /// The mux's output now; also kept as last_output().
  const MuxOutput& Compute(core::SteadyTime now);
  /// The last Compute() (or the zero command of the last Stop()).
  const MuxOutput& last_output() const { return last_output_; }

  /// Modes whose conditions hold now (no switch): the operator's valid actions.
  std::vector<std::string> ValidModes(const ModeConditions& conditions) {
    return tree_.ValidModes(conditions);
  }
  /// True when the tree would accept `mode` under `conditions` (no switch).
  bool IsValid(const std::string& mode, const ModeConditions& conditions);

  /// The running module (the current mode's).
  ModeModule& active() const { return *active_; }
  const std::string& mode() const { return tree_.mode(); }
  const std::string& channel() const { return tree_.channel(); }
  const ModeManager& tree() const { return tree_; }
  const TwistMux& mux() const { return mux_; }
  const ModeRegistry& registry() const { return registry_; }

 private:
  // Switches the mux to the decision's channel and the running module to its mode. A mode without a module
  // or a channel other than its module's or the mux's is never ignored: the robot stops. false then.
  bool Apply(const ModeDecision& decision);

  std::string robot_id_;
  std::shared_ptr<const core::Clock> clock_;
  ModeRegistry registry_;
  TwistMux mux_;
  ModeManager tree_;
  ModeModule* active_ = nullptr;
  MuxOutput last_output_;
};

}  // namespace cairn::agent
