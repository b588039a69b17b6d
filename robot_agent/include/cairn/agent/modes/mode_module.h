// Mode modules (Sriganesh et al. 2024, § Behavior Tree and Mux; lesson L5: a new mode is one module feeding
// the mux plus one subtree of the mode tree). A module is a mode's behaviour: its name (the tree's mode), the
// mux channel it feeds, and a step that turns the robot's state (and the operator's stick) into a twist. The
// mode tree decides which module runs (ModeControl); the mux forwards only that module's channel.
//
// Adding a mode: derive from ModeModule, register it (RobotAgent's mode registry), and add its subtree to
// config/mode_tree.xml (`<IsModeRequested mode="NAME"/>`, its conditions, `<SelectMode mode="NAME"
// channel="CHANNEL"/>`). The agent refuses at start a tree whose SelectMode names a mode no module
// implements, or a channel other than that module's (docs/AGENT.md).
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cairn/agent/modes/twist_mux.h"
#include "cairn/core/kinematics.h"
#include "cairn/core/platform_io.h"
#include "cairn/core/time.h"

namespace cairn::agent {

/// An operator's stick (TeleopTwist), frame B: forward and left speed in m/s, yaw rate in rad/s. Finite (the
/// command interface drops others).
struct OperatorTwist {
  double vx_mps = 0.0;
  double vy_mps = 0.0;
  double wz_radps = 0.0;
};

/// What a module's step reads, once per control cycle (the agent's control thread).
struct ModeInputs {
  core::SteadyTime now{};  ///< this cycle's time
  double now_s = 0.0;      ///< the same, in seconds since the agent started (the navigation clock)
  core::BaseState pose_M;  ///< latest pose estimate, frame M (metres, radians)
};

/// What a module's step produces.
struct ModeOutput {
  /// Twist for the module's mux channel, frame B; none = nothing this cycle (the channel goes stale and the
  /// mux then outputs zero).
  std::optional<Twist2> twist_B;
  core::SteadyTime stamp{};  ///< when the twist's source produced it (the mux's staleness clock)
  bool done = false;  ///< the mode's task ended this cycle (a goal arrived or failed): the agent goes idle
};

/// How long the platform has stayed in contact with occupied space, for the modes that drive a task
/// (waypoint, explore): a task fails when contact lasts longer than a timeout.
class ContactTimer {
 public:
  /// Forgets any contact (a new task starts).
  void Reset() { in_contact_ = false; }
  /// Notes `status` at `in.now`: "" while not in contact or for up to `timeout_s` seconds of contact, then
  /// "blocked: in contact with occupied space at (x, y)" (the pose of `in`, metres, frame M).
  std::string Update(const core::PlatformStatus& status, const ModeInputs& in, double timeout_s);

 private:
  bool in_contact_ = false;
  core::SteadyTime since_{};
};

/// One mode's behaviour. Not thread-safe: the agent calls every method under its lock.
class ModeModule {
 public:
  /// `name`: the mode's name in the tree, [a-z0-9_]+ by convention. `channel`: the mux input it feeds, with
  /// its staleness timeout; channel name "none" = the mode drives nothing (zero twist).
  ModeModule(std::string name, MuxChannelOptions channel)
      : name_(std::move(name)), channel_(std::move(channel)) {}
  virtual ~ModeModule() = default;
  ModeModule(const ModeModule&) = delete;
  ModeModule& operator=(const ModeModule&) = delete;

  const std::string& name() const { return name_; }
  const MuxChannelOptions& channel() const { return channel_; }

  /// The tree switched the robot into this mode (from another one).
  virtual void Activate(core::SteadyTime /*now*/) {}
  /// Ends what the module holds (operator input, a goal), `why` saying why (e.g. "mode switched to manual",
  /// "stopped by opB"). Called on the module the tree leaves, and on every module at a stop: harmless when
  /// the module holds nothing.
  virtual void Deactivate(const std::string& /*why*/) {}
  /// One control cycle while this mode is active.
  virtual ModeOutput Step(const ModeInputs& in) = 0;
  /// The control holder's stick arrived at `stamp` while this mode is active (ignored by default: only
  /// stick-driven modes use it).
  virtual void OnOperatorTwist(const OperatorTwist& /*twist_B*/, core::SteadyTime /*stamp*/) {}
  /// The platform's status after this cycle's twist was commanded (e.g. contact with occupied space).
  virtual ModeOutput OnPlatformStatus(const core::PlatformStatus& /*status*/, const ModeInputs& /*in*/) {
    return {};
  }
  /// True when the mode drives through the local planner (the agent then publishes its plan for display).
  virtual bool uses_local_planner() const { return false; }

 private:
  std::string name_;
  MuxChannelOptions channel_;
};

/// The modes an agent offers, by name. Owns the modules.
class ModeRegistry {
 public:
  /// Adds `module`. @throws std::invalid_argument for a null module, an empty or duplicate mode name, or a
  /// channel another module declares with a different timeout (modules may share a channel, not its rules).
  ModeModule& Add(std::unique_ptr<ModeModule> module);
  /// Constructs a `Module` from `args` and adds it; returns it. Throws as Add().
  template <class Module, class... Args>
  Module& Emplace(Args&&... args) {
    static_assert(std::is_base_of_v<ModeModule, Module>, "a mode module derives from ModeModule");
    auto module = std::make_unique<Module>(std::forward<Args>(args)...);
    Module& ref = *module;
    Add(std::move(module));
    return ref;
  }

  /// The module of mode `name`, or nullptr.
  ModeModule* Find(const std::string& name) const;
  /// Mode names in registration order.
  std::vector<std::string> names() const;
  /// The modules in registration order.
  std::vector<ModeModule*> modules() const;
  /// Mode name -> its channel's name (the tree check of ModeManager).
  std::map<std::string, std::string> ModeChannels() const;
  /// The channels the modules feed, each once, without "none" (the mux's inputs).
  std::vector<MuxChannelOptions> MuxChannels() const;

 private:
  std::vector<std::unique_ptr<ModeModule>> modules_;
};

}  // namespace cairn::agent
