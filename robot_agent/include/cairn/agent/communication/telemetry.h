// The robot's telemetry (Sriganesh et al. 2024, § Command Interface: the robot publishes its state, its
// behavior-tree state, the downsampled map and the camera): builds the wire messages from the components that
// own the facts and publishes them through the DDS adapter. Topics and fields are those of
// idl/cairn_msgs.idl: AgentInfo, RobotState (pose_MB frame M, twists frame B) and its 10 Hz part RobotPose,
// BehaviorTreeState, GlobalPath (path_M), LocalPlan (poses and points frame B of pose_MB), MapUpdate,
// CompressedImage (pose_MC), StaircaseDetection (p_M_first_step).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/command/command_interface.h"
#include "cairn/agent/communication/agent_link.h"
#include "cairn/agent/communication/link_usage.h"
#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mission.h"
#include "cairn/agent/modes/mode_control.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/agent/team/yield.h"
#include "cairn/core/platform_io.h"
#include "cairn/msgs/robot_state.h"
#include "cairn/nav/navigation.h"
#include "cairn/perception/perception_pipeline.h"

namespace cairn::agent {

/// What RobotState carries besides what the components hold.
struct RobotStateInputs {
  core::BaseState pose_M;              ///< the pose estimate, frame M (metres, radians; v, w in frame B)
  bool in_contact = false;             ///< the platform reports contact with occupied space
  double control_period_max_ms = 0.0;  ///< the control loop's worst period lately, milliseconds
  /// A restarted robot's old goal, offered to resume (frame M, metres; z NaN: the robot's level).
  std::optional<Eigen::Vector3d> resumable_goal_M;
  /// Get-out-of-the-way: as the robot asked (YieldMode::status) when it has a yield state, else as the robot
  /// asking (YieldAsker::status).
  YieldStatus yield;
  /// The operator's mission a transient condition paused (MissionKeeper), if any, and its pause's age,
  /// seconds; `mission_note`: how the last pause ended (resumed, or ended with why), shown when none is
  /// paused.
  std::optional<PausedMission> paused_mission;
  double mission_paused_s = 0.0;
  std::string mission_note;
  /// Seconds until the request waiting for the lock's holder expires (ControlLock::PendingLeftS); 0 with
  /// none.
  double control_request_left_s = 0.0;
};

/// Builds and publishes the robot's telemetry. The control-loop methods run under the agent's lock (they read
/// the components); PublishPerception() runs on the perception thread and reads nothing shared.
class Telemetry {
 public:
  /// Every pointer is required and (not owned) outlives this. @throws std::invalid_argument for a null one.
  Telemetry(const AgentOptions& options, AgentLink* link, const ModeControl* modes,
            const WaypointMode* waypoint, const ExploreMode* explore, const ConvoyMode* convoy,
            const nav::Navigation* navigation, CommandInterface* command);

  /// AgentInfo (latched): id, kind robot, platform and its limits, the modes of the tree, version, world,
  /// sensors (lidar, camera), map resolution (0 with perception off), link class and budget.
  void PublishAgentInfo(const core::PlatformCapabilities& capabilities, const std::string& version);
  /// RobotPose every call (the 10 Hz stream: planar pose, measured and commanded twist, distance and time
  /// left, contact), and before it the whole RobotState (mode, mux, lock, waypoint goal, navigation, stops,
  /// its link budget...) when due: at once after an urgent change (cairn::msgs::UrgentChange) or a command's
  /// answer (RequestWholeState), 0.5 s after the last one for any other change of its slow part, and at least
  /// once a second, then with what the robot sends per topic class (LinkUsageMeter over
  /// AgentLink::SentByClass).
  void PublishState(const RobotStateInputs& in);
  /// The next PublishState sends the whole state: a command was answered, and its sender reads the state it
  /// left behind (the basestation's `status` after a command).
  void RequestWholeState() { whole_state_.Request(); }
  /// BehaviorTreeState, when the mode, channel, refusal or valid actions changed since the last one.
  void PublishTreeStateIfChanged();
  /// GlobalPath, when navigation's path changed (an empty one when no goal is driven: late joiners see it).
  void PublishGlobalPathIfChanged();
  /// LocalPlan, while the running mode drives through the local planner (for display, ~1 kB).
  void PublishLocalPlan();
  /// Map updates, staircase detections and a camera frame from one perception tick.
  void PublishPerception(const perception::PerceptionOutput& out);

 private:
  // Appends what the robot sends per topic class (rates over the last ~2 s) to `state`.
  void AddLinkUsage(double now_s, cairn_msgs::RobotState* state);

  std::string robot_id_;
  std::string platform_;      // AgentOptions::platform (RobotState, AgentInfo)
  std::string nav_platform_;  // navigation's platform profile (GlobalPath)
  core::VelocityLimits limits_;
  double footprint_radius_m_;
  core::LinkOptions link_;
  double map_resolution_m_;  // 0: perception off, no map sent
  LinkUsageMeter link_usage_;
  double next_link_usage_s_ = 0.0;  // steady clock, seconds
  // A change of the slow part that no one waits on (a reason, a status text) waits 0.5 s after the last whole
  // state: a text that changes every cycle (the local planner's clearance in a tight spot) costs 2 whole
  // states a second, not 10. At least one a second, with the link usage.
  cairn::msgs::WholeStateSchedule whole_state_{0.5, 1.0};
  AgentLink* agent_link_;
  const ModeControl* modes_;
  const WaypointMode* waypoint_;
  const ExploreMode* explore_;
  const ConvoyMode* convoy_;
  const nav::Navigation* navigation_;
  CommandInterface* command_;
  std::uint64_t published_path_revision_ = ~0ull;
  std::string last_tree_signature_;
};

}  // namespace cairn::agent
