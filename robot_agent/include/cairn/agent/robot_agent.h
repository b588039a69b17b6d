// cairn_agent: one process per robot hosting the command interface, mode tree with its mode modules, mux,
// navigation and perception, talking to basestations over Fast DDS (Sriganesh et al. 2024, Fig. 1). The robot
// itself (a hardware driver or the simulator) is reached only through core::PlatformIO. RobotAgent composes
// the components and runs their threads; docs/AGENT.md maps them (and shows how to add a mode).
#pragma once

#include <memory>

#include "cairn/agent/agent_options.h"
#include "cairn/core/platform_io.h"

namespace cairn::agent {

/// A running robot agent. Construction loads the mode tree, builds the empty navigation map at the platform's
/// current pose and creates the DDS entities (any failure throws with a clear message and leaves nothing
/// behind); Run() drives the robot until shutdown.
class RobotAgent {
 public:
  /// `platform` is the robot (not null); the agent commands it from its control thread and reads its sensors
  /// from its perception thread.
  /// @throws std::invalid_argument / core::ConfigError / bt::TreeError / core::DdsError naming the field or
  ///         file at fault.
  RobotAgent(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform);
  ~RobotAgent();

  /// Control loop at 50 Hz until core::ShutdownRequested(). The robot is stopped when it returns.
  void Run();
  /// After Run(): it ended because a component's work did not stop when asked and the agent is supervised
  /// (AgentOptions::supervised). That work may still run: leave with kRestartExitStatus at once (std::_Exit),
  /// without destroying the agent, and the supervisor starts the process again from its journal.
  bool restart_requested() const;
  /// The exit status that asks a supervisor for a restart (neither 0, shut down, nor 2, bad input).
  static constexpr int kRestartExitStatus = 3;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::agent
