// cairn_agent: one process per robot hosting the command interface, mode tree with its mode modules, mux,
// navigation and perception, talking to basestations over Fast DDS (Sriganesh et al. 2024, Fig. 1). The robot
// itself (a hardware driver or the simulator) is reached only through core::PlatformIO. RobotAgent composes
// the components and runs their threads; docs/AGENT.md maps them (and shows how to add a mode).
#pragma once

#include <functional>
#include <memory>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/communication/agent_link.h"
#include "cairn/agent/modes/robot_modes.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/core/platform_io.h"
#include "cairn/core/time.h"
#include "cairn/nav/navigation.h"

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

  /// The same agent stepped by its caller on `clock`, on the caller's thread, talking over `link` (an
  /// InProcessLink of an InProcessTeam: scenario tests and benches run a fleet faster than real time and
  /// deterministically). Same components, same wiring, same command path (commands come in through `link`'s
  /// handlers, replies go out through it); what differs: no thread of its own (each Step() brings the
  /// platform to now, runs the sensor, perception and navigation map loops when due on `clock`, then the
  /// control cycle, then the planning queued: sense, then act), the health monitor watches the control
  /// cycle's parts but never checks heartbeats (no restart on a stall), goal and task ids count from 1, and
  /// the navigation map reads every changed tile in the update it arrives with (no wall-clock budget). The
  /// agent's time 0 is `clock`'s time at construction.
  /// @throws std::invalid_argument for a null link or clock, and as the constructor above.
  static std::unique_ptr<RobotAgent> Stepped(const AgentOptions& options,
                                             std::shared_ptr<core::PlatformIO> platform,
                                             std::shared_ptr<AgentLink> link,
                                             std::shared_ptr<core::SimulatedClock> clock);

  /// Starts the components, calls `on_started` (if set; e.g. to announce readiness: commands that need a
  /// component are refused until then), then runs the control loop at 50 Hz until core::ShutdownRequested().
  /// The robot is stopped when it returns.
  /// @throws std::logic_error on a stepped agent.
  void Run(const std::function<void()>& on_started = {});
  /// A stepped agent's cycle: `clock` set to `now_s` (seconds since its epoch, not before its time now;
  /// cycles expected every 0.02 s), then as described at Stepped(). @throws std::logic_error on an agent that
  /// runs its own threads; std::invalid_argument for a time before the clock's.
  void Step(double now_s);
  /// A stepped agent: true while a plan its next Step() needs is computed on a worker (the explore mode's, a
  /// mission's resumption): the caller waits (wall time) before stepping on, so that results do not depend on
  /// the machine's speed.
  bool planning() const;
  /// A stepped agent, between Step() calls: its modes, navigation and navigation map (what tests and benches
  /// read).
  const RobotModes& modes() const;
  const nav::Navigation& navigation() const;
  const NavMap& nav_map() const;
  /// After Run(): it ended because a component's work did not stop when asked and the agent is supervised
  /// (AgentOptions::supervised). That work may still run: leave with kRestartExitStatus at once (std::_Exit),
  /// without destroying the agent, and the supervisor starts the process again from its journal.
  bool restart_requested() const;
  /// The exit status that asks a supervisor for a restart (neither 0, shut down, nor 2, bad input).
  static constexpr int kRestartExitStatus = 3;

 private:
  class Impl;
  explicit RobotAgent(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::agent
