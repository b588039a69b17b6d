// Mode selection through the behavior tree (Sriganesh et al. 2024, § Behavior Tree and Mux): validates mode
// requests against conditions and selects the mux channel. The tree is a BehaviorTree.CPP v4 XML file.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cairn/bt/behavior_tree.h"

namespace cairn::agent {

/// Facts the mode tree's conditions read. Filled by the agent before each tick.
struct ModeConditions {
  std::string holder_id;             ///< basestation holding the control lock ("" = free)
  bool holder_alive = false;         ///< the holder's liveliness is alive
  bool localized = false;            ///< the pose estimate is valid
  std::string localization_problem;  ///< why not (the platform's estimator), e.g. "SLAM diverged"
  bool has_waypoint_goal = false;    ///< an accepted, unfinished waypoint goal exists
  /// The control holder has a joystick: it advertises the "joystick" capability and is alive.
  bool joystick_alive = false;
  /// The local planner ran on fresh obstacle input recently; when false, local_planner_problem says why.
  bool local_planner_healthy = false;
  std::string local_planner_problem;  ///< e.g. "no obstacle input for 0.8 s"
  /// An exploration task is running (sent with explore R).
  bool has_explore_task = false;
  /// A convoy follower's task is running (sent with convoy L R1 R2 ...).
  bool has_convoy_task = false;
  bool has_yield_task = false;  ///< a yield request accepted (YieldMode::active)
  /// The robot maps: fresh lidar scans reach its map and its navigation map is updated; when false,
  /// mapping_problem says why.
  bool mapping_healthy = false;
  std::string mapping_problem;  ///< e.g. "no lidar scan for 3.2 s"
  /// The agent's components that are down now (core::HealthMonitor::Down()): name -> why. A name of
  /// kAgentComponents missing here is up.
  std::map<std::string, std::string> components_down;
};

/// The components of cairn_agent (RobotAgent, core::HealthMonitor), as IsComponentUp and `restart R` name
/// them, in the order the monitor has them.
inline const std::vector<std::string>& AgentComponentNames() {
  static const std::vector<std::string> names = {"platform",  "perception", "planning",   "command_interface",
                                                 "mode_tree", "mux",        "navigation", "telemetry"};
  return names;
}

/// Result of a mode request or re-check.
struct ModeDecision {
  bool accepted = false;
  std::string mode;     ///< mode after the decision
  std::string channel;  ///< mux channel after the decision
  std::string reason;   ///< failed condition when refused; why the mode changed on a re-check
};

/// Owns the mode tree and the current mode. Not thread-safe (the agent calls it under its lock).
class ModeManager {
 public:
  /// The fail-safe mode every tree must have: it selects channel "none" (zero twist); stops and lost
  /// conditions fall back to it.
  static constexpr const char* kIdleMode = "idle";

  /// Loads the tree and checks it against the mux it drives and the mode modules that implement its modes.
  /// `mux_channels`: the channels the mux has ("none", no channel, is always allowed). `module_channels`:
  /// mode name -> the mux channel its module feeds (ModeRegistry::ModeChannels()).
  /// @throws bt::TreeError (file, line, node) when the XML is invalid; when the tree has no branch for "idle"
  ///         (the fail-safe mode) or its idle branch selects a channel other than "none"; when a SelectMode
  ///         names a channel that is not a literal mux channel, a mode no module implements, or a channel
  ///         other than its module's (the file, line, branch, mode and channel are named).
  ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels,
              const std::map<std::string, std::string>& module_channels);
  /// The same check without mode modules: the tree against the mux alone (tools, and tests of a tree).
  ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels);

  /// The `<TreeNodesModel>` element (BehaviorTree.CPP v4 / Groot2 format) of the nodes a mode tree may use
  /// beyond BT.CPP's built-ins: the conditions (IsControlHeld, IsLocalized, ...) and SelectMode, with their
  /// ports. `cairn_agent --print-tree-nodes-model` prints it.
  static std::string TreeNodesModel();
  /// Registers the mode tree's node types (conditions, SelectMode; not the recovery actions) in `factory`,
  /// e.g. so that another component loading a tree of the same file validates the document.
  static void RegisterModeNodes(bt::TreeFactory& factory);
  /// `tree_xml` (a mode tree file's text) with its `<TreeNodesModel>` replaced by (or extended with) the
  /// generated one, so Groot2 can open and edit the file. Throws bt::TreeError for malformed XML.
  static std::string WithTreeNodesModel(const std::string& tree_xml);

  /// Stop: mode idle and channel "none" now, whatever the tree says (an operator's stop, or a failed
  /// channel switch). `refusal`, when not empty, is kept as the last refusal shown to operators (a fault).
  ModeDecision ForceIdle(const std::string& refusal);

  /// Asks for `mode`. On acceptance the mode and channel switch; on refusal they stay and `reason` names
  /// the failed condition, or says the mode is unknown and lists the valid ones.
  ModeDecision Request(const std::string& mode, const ModeConditions& conditions);

  /// Re-checks that the current mode is still allowed; if not, switches to idle and says why.
  /// `accepted` is false exactly when the mode changed.
  ModeDecision Recheck(const ModeConditions& conditions);

  /// Modes whose conditions hold now (dry-run ticks; nothing switches): the operator's valid actions.
  std::vector<std::string> ValidModes(const ModeConditions& conditions);

  const std::string& mode() const { return mode_; }
  const std::string& channel() const { return channel_; }
  const std::vector<std::string>& known_modes() const { return known_modes_; }
  const bt::Tree& tree() const { return tree_; }
  uint64_t tick_count() const { return tick_count_; }
  const std::string& last_refusal() const { return last_refusal_; }
  /// What `node` returned in the last Request/Recheck tick (the root and leaves; kIdle if not ticked).
  bt::NodeStatus LastTickStatus(const bt::TreeNode& node) const;

 private:
  ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels,
              const std::map<std::string, std::string>* module_channels);
  // Ticks the tree once for `mode`. Returns true when a branch accepted; fills selection and failure.
  bool Evaluate(const std::string& mode, const ModeConditions& conditions, std::string* channel,
                std::string* failure);

  void KeepTrace();
  // Throws bt::TreeError when a SelectMode names a channel the mux does not have, or (with `module_channels`)
  // a mode without a module or a channel other than its module's (see the constructor).
  void CheckChannels(const std::string& tree_file, const std::vector<std::string>& mux_channels,
                     const std::map<std::string, std::string>* module_channels) const;

  struct Context;
  // Registers the mode tree's condition and action nodes, whose callbacks read and write `ctx`.
  static void RegisterNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx);
  static void RegisterModeNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx);
  // The condition nodes that check one fact of ModeConditions each (IsControlHeld, IsLocalized, ...).
  static void RegisterFactNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx);
  std::shared_ptr<Context> context_;
  bt::Tree tree_;
  std::vector<std::string> known_modes_;
  std::string mode_ = kIdleMode;
  std::string channel_ = "none";
  std::string last_refusal_;
  uint64_t tick_count_ = 0;
  bt::NodeStatus last_root_status_ = bt::NodeStatus::kIdle;
  std::map<const bt::TreeNode*, bt::NodeStatus> last_trace_;
};

}  // namespace cairn::agent
