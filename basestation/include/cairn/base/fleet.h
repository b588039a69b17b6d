// The fleet as the console sees it: each robot's view, the commands a basestation sends, the answers, and
// the events. FleetClient is the DDS implementation; the console (CommandShell) reads only this interface, so
// it runs in process against a fake fleet in tests.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "cairn/base/fleet_events.h"
#include "cairn/base/fleet_perception.h"
#include "cairn/base/link_monitor.h"
#include "cairn/core/time.h"
#include "cairn/fleet/robot_view.h"
#include "cairn_msgs.h"

namespace cairn::base {

using fleet::RobotView;

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

/// Answer of the global path service (FleetClient::RequestPath()).
struct PathAnswer {
  bool ok = false;                    ///< a path was found
  std::string result;                 ///< outcome::kAccepted (a path) | kRefused | kTimedOut
  std::string reason;                 ///< the planner's reason, or the local error
  cairn_msgs::PathResponse response;  ///< the full answer when one arrived
  double round_trip_ms = 0;
};

/// What a basestation's console needs of the fleet. Implementations are thread-safe.
class Fleet {
 public:
  virtual ~Fleet() = default;

  virtual const std::string& base_id() const = 0;

  /// Snapshot of every robot seen so far, sorted by id (staleness applied at `now`).
  virtual std::vector<RobotView> Robots() const = 0;
  /// One robot, if seen.
  virtual std::optional<RobotView> Robot(const std::string& robot_id) const = 0;

  /// Waits until `robot_id` is known and alive: up to `timeout_s` for a robot already known (lost now), until
  /// discovery_s after this client's start for one not heard of yet. false when it is not.
  virtual bool WaitForRobot(const std::string& robot_id, double timeout_s) const = 0;

  /// Waits up to `timeout_s` until `predicate(view)` holds for `robot_id` (evaluated on every update).
  /// Returns the view that satisfied it, or nullopt on timeout.
  virtual std::optional<RobotView> WaitUntil(
      const std::string& robot_id, double timeout_s,
      const std::function<bool(const RobotView&)>& predicate) const = 0;

  virtual CommandOutcome RequestControl(const std::string& robot_id) = 0;
  virtual CommandOutcome ReleaseControl(const std::string& robot_id) = 0;
  /// The holder (this basestation) gives `robot_id`'s lock to basestation `to_base_id`: a grant when `to`'s
  /// request waits, else unasked. The robot keeps its mode and goal.
  virtual CommandOutcome HandOverControl(const std::string& robot_id, const std::string& to_base_id) = 0;
  /// The holder refuses the waiting request of basestation `to_base_id` for `robot_id`'s lock.
  virtual CommandOutcome DenyControl(const std::string& robot_id, const std::string& to_base_id) = 0;
  virtual CommandOutcome RequestMode(const std::string& robot_id, const std::string& mode) = 0;
  /// `z_m`: the goal's level, the walkable surface at (x_m, y_m) nearest this height (metres, map frame);
  /// NaN = the robot's level.
  virtual CommandOutcome SendWaypoint(const std::string& robot_id, double x_m, double y_m,
                                      double tolerance_m = 0.0,
                                      double z_m = std::numeric_limits<double>::quiet_NaN()) = 0;
  /// Sends `robot_id` exploring by itself (ExploreRequest): frontiers within `region_M` (x-y box, metres, map
  /// frame; none = everywhere) whose ground lies in [min_z_m, max_z_m] (metres, map frame; NaN = no bound).
  /// `home_after_silence_s` > 0: the robot comes back to its start by itself when it has heard no basestation
  /// for that long (0 = never). The answer carries the task id in goal_id.
  virtual CommandOutcome SendExplore(const std::string& robot_id,
                                     const std::optional<Eigen::AlignedBox2d>& region_M,
                                     double min_z_m = std::numeric_limits<double>::quiet_NaN(),
                                     double max_z_m = std::numeric_limits<double>::quiet_NaN(),
                                     double home_after_silence_s = 0.0) = 0;
  /// Tells convoy follower `robot_id` to follow `ahead_ids` (the robots ahead of it, nearest first, the
  /// leader last; at most 16) on the path they drove, or, with none, to leave the convoy (ConvoyRequest).
  virtual CommandOutcome SendConvoy(const std::string& robot_id,
                                    const std::vector<std::string>& ahead_ids) = 0;
  /// Asks `robot_id` to get out of `passing_id`'s way (YieldRequest on cairn/yield_request; under DDS
  /// Security on the robot's own cairn/yield_request/<robot>, which only its commanders may write; the
  /// robot's yield policy decides, not the lock): `keep_clear_M` is the passing robot's route from where it
  /// is (1..32 points, metres, frame map), `passing_radius_m` its footprint radius. No reply: the answer is
  /// the robot's yield_state (RobotState). "" when sent, else why not: this base may not command the robot
  /// under DDS Security (naming its permissions), or Fast DDS refused the sample.
  virtual std::string SendYield(const std::string& robot_id, const std::string& passing_id,
                                double passing_radius_m,
                                const std::vector<Eigen::Vector2d>& keep_clear_M) = 0;
  /// Sends `robot_id` home (HomeRequest): a waypoint goal the robot plans to its start, or to `point_M`
  /// (x, y metres, frame map; z its level, NaN = the robot's). The answer carries the goal id.
  virtual CommandOutcome SendHome(const std::string& robot_id,
                                  const std::optional<Eigen::Vector3d>& point_M = std::nullopt) = 0;
  /// Stops `robot_id` now: zero twist, mode idle, goal cancelled. Honoured by the robot from any basestation,
  /// with or without its control lock (an e-stop); the lock stays with its holder. Sent at once even to a
  /// robot this basestation thinks lost or has not seen (retried until answered or command_timeout_s).
  virtual CommandOutcome Stop(const std::string& robot_id) = 0;
  /// Restarts one component of `robot_id`'s agent (RestartRequest; `health R` lists them). The holder's only;
  /// the answer says the restart is under way, AgentHealth how it went.
  virtual CommandOutcome Restart(const std::string& robot_id, const std::string& component) = 0;
  /// Publishes one teleop twist (best effort, no acknowledgement), frame B of the robot: forward and
  /// left speed (m/s) and yaw rate (rad/s). false if it could not be written.
  virtual bool PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                             double linear_y_mps = 0.0) = 0;
  /// Asks robot `robot_id`'s global planner for a path from start to goal ((x, y) metres, frame map) for
  /// `platform` ("" = the robot's own). Retries until answered or command_timeout_s passes.
  virtual PathAnswer RequestPath(const std::string& robot_id, const std::string& platform, double start_x_m,
                                 double start_y_m, double goal_x_m, double goal_y_m) = 0;

  /// Fleet map, camera frames and staircases (perception telemetry).
  virtual FleetPerception& perception() = 0;

  /// Events not yet taken (arrivals, failures, losses, locks, stops, staircases, proximity), oldest first.
  /// Detected by a monitor thread at 10 Hz (FleetEventDetector) for every operator, whoever caused them.
  virtual std::vector<OperatorEvent> TakeEvents() = 0;
  /// True if TakeEvents() would return something.
  virtual bool HasEvents() const = 0;
  /// The last events_kept events, oldest first (taken or not).
  virtual std::vector<OperatorEvent> RecentEvents() const = 0;

  /// Robot ids seen so far (for completion and "did you mean").
  virtual std::vector<std::string> RobotIds() const = 0;

  /// True when `robot_id` has been seen (lost or not). Waits only while this client is younger than
  /// discovery_s, so an unknown robot is refused at once afterwards.
  virtual bool Knows(const std::string& robot_id) const = 0;
  /// When this client (its DDS participant) started: discovery is measured from it, by the client and by
  /// every shell on it (`robots`, `links` wait until 1.5 s / 2.5 s after it).
  virtual core::SteadyTime started() const = 0;
  /// The end of discovery: started() + FleetClientOptions::discovery_s (a robot not heard of by then is
  /// unknown).
  virtual core::SteadyTime discovery_end() const = 0;
  /// "unknown robot 'r9' (did you mean r1?) (known: r1, r2)" or "robot r1 is lost (...)".
  virtual std::string UnknownRobotReason(const std::string& robot_id) const = 0;
};

}  // namespace cairn::base
