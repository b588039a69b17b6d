// cairn_agent: one process per robot hosting the command interface, mode tree, mux, waypoint navigation and
// the simulated platform, talking to basestations over Fast DDS (Sriganesh et al. 2024, Fig. 1).
#pragma once

#include <memory>

#include "cairn/agent/agent_options.h"

namespace cairn::agent {

/// A running robot agent. Construction loads the world, the mode tree and creates the DDS entities (any
/// failure throws with a clear message and leaves nothing behind); Run() drives the robot until shutdown.
class RobotAgent {
 public:
  /// @throws std::invalid_argument / core::ConfigError / sim::WorldError / bt::TreeError / core::DdsError
  ///         naming the field or file at fault.
  explicit RobotAgent(const AgentOptions& options);
  ~RobotAgent();

  /// Control loop at 50 Hz until core::ShutdownRequested(). The robot is stopped when it returns.
  void Run();

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::agent
