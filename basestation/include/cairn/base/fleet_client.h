// The basestation's view of the fleet and its command channel to robots: host discovery (agent info with
// liveliness), robot and behavior-tree state, and commands answered by the robots' command interfaces.
#pragma once

#include <Eigen/Geometry>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "cairn/base/fleet_events.h"
#include "cairn/base/fleet_perception.h"
#include "cairn/base/link_monitor.h"
#include "cairn/core/link_options.h"
#include "cairn/core/time.h"
#include "cairn_msgs.h"

namespace cairn::base {

/// What the basestation knows about one robot.
struct RobotView {
  std::string robot_id;
  std::string platform;
  std::vector<std::string> capabilities;
  double max_speed_mps = 0.0;                   ///< from its agent info: largest forward speed (0 = unknown)
  double max_reverse_speed_mps = 0.0;           ///< largest reverse speed, a magnitude (0 = unknown)
  double max_yaw_rate_radps = 0.0;              ///< largest yaw rate, a magnitude (0 = unknown)
  double footprint_radius_m = 0.0;              ///< the disk its body fits in, metres (0 = unknown)
  std::vector<std::string> sensors;             ///< from its agent info: "lidar", "camera"
  double map_resolution_m = 0.0;                ///< voxel edge of the map it sends, metres (0 = no map)
  std::string version;                          ///< its cairn version
  bool announced = false;                       ///< its agent info arrived (capabilities above are its own)
  LinkView link;                                ///< its link as this basestation sees it (LinkMonitor)
  std::optional<cairn_msgs::RobotState> state;  ///< latest whole state with the latest pose applied
  /// The first whole state this basestation received from the robot: what it knew on arrival. The baseline
  /// of news (FleetEventDetector), so that a change between it and the detector's first look is still told.
  std::optional<cairn_msgs::RobotState> first_state;
  std::optional<cairn_msgs::BehaviorTreeState> tree;  ///< latest behavior-tree state
  std::optional<cairn_msgs::GlobalPath> global_path;  ///< global path being followed (latched)
  std::optional<cairn_msgs::LocalPlan> local_plan;    ///< latest local planner output (2 Hz)
  std::optional<cairn_msgs::AgentHealth> health;      ///< latest health of its agent's components (latched)
  core::SteadyTime last_seen{};                       ///< last agent info or state
  core::SteadyTime state_received{};                  ///< when its last whole state or pose arrived
  core::SteadyTime whole_state_received{};            ///< when its last whole state arrived
  bool lost = false;                                  ///< liveliness lost or state silent > lost_after_s
  bool left = false;                                  ///< lost because its process exited cleanly
  std::string lost_reason;
};

/// Outcome of one command as seen by the operator.
struct CommandOutcome {
  bool ok = false;     ///< accepted by the robot
  std::string result;  ///< outcome::kAccepted | kRefused | kFailed | kTimedOut (operator_text.h)
  std::string reason;  ///< why, in operator words (ExplainReason of the robot's reason), or the local error
  std::string robot_reason;  ///< the robot's own reason, unchanged ("" when the robot did not answer)
  std::string condition;  ///< mode-tree condition id that refused ("HasWaypointGoal"), "lock" when the sender
                          ///< does not hold the control lock, "" otherwise
  std::string holder_id;  ///< control holder reported by the robot
  std::string mode;       ///< robot mode after the command
  double round_trip_ms = 0;  ///< command -> acknowledgement
  uint32_t request_id = 0;   ///< id the command was sent with (unique within this process only)
  uint32_t goal_id = 0;      ///< accepted waypoint: the robot's id for the goal (RobotState::nav_goal_id)
  bool answered = false;     ///< the robot answered (holder_id, mode, valid_modes are its own, right after)
  std::vector<std::string> valid_modes;  ///< modes valid right after the command (answered only)
  bool goal_acceptable = false;          ///< a goto would be accepted right after the command (answered only)
};

/// Options of the fleet client.
struct FleetClientOptions {
  std::string base_id;             ///< required; [A-Za-z0-9_-]{1,64}
  int domain_id = 0;               ///< [0, 232]
  std::string dds_profiles_file;   ///< "" = shipped loopback-only profiles
  core::LinkOptions link;          ///< loopback (default) or a named lan (core::LinkOptions)
  double command_timeout_s = 3.0;  ///< give up waiting for an acknowledgement, (0, 60]
  double command_retry_s = 0.5;    ///< resend an unacknowledged command (robots de-duplicate), (0, 10]
  double lost_after_s = 3.0;       ///< a robot whose state is silent this long is shown lost, (0, 60]
  /// Advertised in this basestation's agent info. "joystick": it can stream teleop twists, which the
  /// robots' IsJoystickAlive condition requires for smart joystick mode.
  std::vector<std::string> capabilities = {"joystick"};
  /// A robot not seen this long after start is unknown: commands to it are refused at once, (0, 60]. Until
  /// then a command to a robot not heard of yet waits for it, however short the command's timeout.
  double discovery_s = 1.5;
  FleetEventOptions events;       ///< what raises operator events (proximity distances)
  std::size_t events_kept = 200;  ///< recent events kept for RecentEvents(), [1, 100000]
  /// DDS Security (--secure DIR; identity = base_id). Commands to robots its permissions do not give it are
  /// refused here, naming them; the robots' access control refuses them anyway.
  core::SecurityOptions security;
};

/// Answer of the global path service (FleetClient::RequestPath()).
struct PathAnswer {
  bool ok = false;                    ///< a path was found
  std::string result;                 ///< outcome::kAccepted (a path) | kRefused | kTimedOut
  std::string reason;                 ///< the planner's reason, or the local error
  cairn_msgs::PathResponse response;  ///< the full answer when one arrived
  double round_trip_ms = 0;
};

/// DDS client of one basestation. Thread-safe.
class FleetClient {
 public:
  /// @throws core::DdsError / std::invalid_argument naming the field at fault.
  explicit FleetClient(const FleetClientOptions& options);
  ~FleetClient();

  const std::string& base_id() const;
  /// This process's DDS participant id (core::ParticipantIdOf): robots answer it, and show it as the
  /// participant speaking for the holder (RobotState::holder_participant).
  std::string participant_id() const;

  /// Snapshot of every robot seen so far, sorted by id (staleness applied at `now`).
  std::vector<RobotView> Robots() const;
  /// One robot, if seen.
  std::optional<RobotView> Robot(const std::string& robot_id) const;

  /// Waits until `robot_id` is known and alive: up to `timeout_s` for a robot already known (lost now), until
  /// discovery_s after this client's start for one not heard of yet. false when it is not.
  bool WaitForRobot(const std::string& robot_id, double timeout_s) const;

  /// Waits up to `timeout_s` until `predicate(view)` holds for `robot_id` (evaluated on every update).
  /// Returns the view that satisfied it, or nullopt on timeout.
  std::optional<RobotView> WaitUntil(const std::string& robot_id, double timeout_s,
                                     const std::function<bool(const RobotView&)>& predicate) const;

  CommandOutcome RequestControl(const std::string& robot_id);
  CommandOutcome ReleaseControl(const std::string& robot_id);
  CommandOutcome RequestMode(const std::string& robot_id, const std::string& mode);
  /// `z_m`: the goal's level, the walkable surface at (x_m, y_m) nearest this height (metres, map frame);
  /// NaN = the robot's level.
  CommandOutcome SendWaypoint(const std::string& robot_id, double x_m, double y_m, double tolerance_m = 0.0,
                              double z_m = std::numeric_limits<double>::quiet_NaN());
  /// Sends `robot_id` exploring by itself (ExploreRequest): frontiers within `region_M` (x-y box, metres, map
  /// frame; none = everywhere) whose ground lies in [min_z_m, max_z_m] (metres, map frame; NaN = no bound).
  /// `home_after_silence_s` > 0: the robot comes back to its start by itself when it has heard no basestation
  /// for that long (0 = never). The answer carries the task id in goal_id.
  CommandOutcome SendExplore(const std::string& robot_id, const std::optional<Eigen::AlignedBox2d>& region_M,
                             double min_z_m = std::numeric_limits<double>::quiet_NaN(),
                             double max_z_m = std::numeric_limits<double>::quiet_NaN(),
                             double home_after_silence_s = 0.0);
  /// Tells convoy follower `robot_id` to follow `ahead_ids` (the robots ahead of it, nearest first, the
  /// leader last; at most 16) on the path they drove, or, with none, to leave the convoy (ConvoyRequest).
  CommandOutcome SendConvoy(const std::string& robot_id, const std::vector<std::string>& ahead_ids);
  /// Asks `robot_id` to get out of `passing_id`'s way (YieldRequest on cairn/yield_request; under DDS
  /// Security on the robot's own cairn/yield_request/<robot>, which only its commanders may write; the
  /// robot's yield policy decides, not the lock): `keep_clear_M` is the passing robot's route from where it
  /// is (1..32 points, metres, frame map), `passing_radius_m` its footprint radius. No reply: the answer is
  /// the robot's yield_state (RobotState). "" when sent, else why not: this base may not command the robot
  /// under DDS Security (naming its permissions), or Fast DDS refused the sample.
  std::string SendYield(const std::string& robot_id, const std::string& passing_id, double passing_radius_m,
                        const std::vector<Eigen::Vector2d>& keep_clear_M);
  /// Sends `robot_id` home (HomeRequest): a waypoint goal the robot plans to its start, or to `point_M`
  /// (x, y metres, frame map; z its level, NaN = the robot's). The answer carries the goal id.
  CommandOutcome SendHome(const std::string& robot_id,
                          const std::optional<Eigen::Vector3d>& point_M = std::nullopt);
  /// Stops `robot_id` now: zero twist, mode idle, goal cancelled. Honoured by the robot from any basestation,
  /// with or without its control lock (an e-stop); the lock stays with its holder. Sent at once even to a
  /// robot this basestation thinks lost or has not seen (retried until answered or command_timeout_s).
  CommandOutcome Stop(const std::string& robot_id);
  /// Restarts one component of `robot_id`'s agent (RestartRequest; `health R` lists them). The holder's only;
  /// the answer says the restart is under way, AgentHealth how it went.
  CommandOutcome Restart(const std::string& robot_id, const std::string& component);
  /// Publishes one teleop twist (best effort, no acknowledgement), frame B of the robot: forward and
  /// left speed (m/s) and yaw rate (rad/s). false if it could not be written.
  bool PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                     double linear_y_mps = 0.0);
  /// Asks robot `robot_id`'s global planner for a path from start to goal ((x, y) metres, frame map) for
  /// `platform` ("" = the robot's own). Retries until answered or command_timeout_s passes.
  PathAnswer RequestPath(const std::string& robot_id, const std::string& platform, double start_x_m,
                         double start_y_m, double goal_x_m, double goal_y_m);

  /// Fleet map, camera frames and staircases (perception telemetry).
  FleetPerception& perception();

  /// Events not yet taken (arrivals, failures, losses, locks, stops, staircases, proximity), oldest first.
  /// Detected by a monitor thread at 10 Hz (FleetEventDetector) for every operator, whoever caused them.
  std::vector<OperatorEvent> TakeEvents();
  /// True if TakeEvents() would return something.
  bool HasEvents() const;
  /// The last events_kept events, oldest first (taken or not).
  std::vector<OperatorEvent> RecentEvents() const;
  /// Of the last events_kept events, those detected after the one numbered `*cursor` (OperatorEvent::seq),
  /// oldest first; sets `*cursor` to the newest. Independent of TakeEvents(): a GUI follows events this way
  /// without taking them from the console.
  std::vector<OperatorEvent> EventsSince(std::uint64_t* cursor) const;

  /// Robot ids seen so far (for completion and "did you mean").
  std::vector<std::string> RobotIds() const;

  /// True when `robot_id` has been seen (lost or not). Waits only while this client is younger than
  /// discovery_s, so an unknown robot is refused at once afterwards.
  bool Knows(const std::string& robot_id) const;
  /// When this client (its DDS participant) started: discovery is measured from it, by the client and by
  /// every shell on it (`robots`, `links` wait until 1.5 s / 2.5 s after it).
  core::SteadyTime started() const;
  /// The end of discovery: started() + FleetClientOptions::discovery_s (a robot not heard of by then is
  /// unknown).
  core::SteadyTime discovery_end() const;
  /// "unknown robot 'r9' (did you mean r1?) (known: r1, r2)" or "robot r1 is lost (...)".
  std::string UnknownRobotReason(const std::string& robot_id) const;

  class Impl;  ///< DDS entities and the fleet model, kept out of this header.

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::base
