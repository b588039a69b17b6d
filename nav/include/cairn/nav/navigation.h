// Navigation, the agent's navigation component (Sriganesh et al. 2024, § Navigation Layer): the global
// planner service, the FALCO trajectory-library local planner and the iLQR controller, chained behind the
// mux. Waypoint mode: global path -> carrot -> local planner -> iLQR -> twist. Smart joystick mode: the
// operator's direction -> local planner (closest free path) -> iLQR -> twist. DDS-free: the agent feeds it
// poses, obstacle points and times (seconds on any monotonic clock), so it runs in tests faster than real
// time.
#pragma once

#include <Eigen/Core>
#include <chrono>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"
#include "cairn/nav/global_planner.h"
#include "cairn/nav/ilqr.h"
#include "cairn/nav/local_planner.h"
#include "cairn/nav/peers.h"
#include "cairn/nav/platform.h"

namespace cairn::nav {

/// Options of Navigation (config file sections navigation, local_planner, controller).
struct NavigationOptions {
  /// The platform: limits, footprint, traversability, cruise speed, local planner headings.
  PlatformProfile platform = GetPlatformProfile("wheeled");
  /// Local planner scoring.
  LocalPlannerOptions local_planner;
  /// iLQR controller (horizon, weights).
  IlqrOptions controller;
  /// Default arrival radius when a goal gives 0, metres, (0, 5].
  double goal_tolerance_m = 0.2;
  /// No progress toward the goal for this long -> the goal fails ("blocked: ..."), seconds, (0, 600].
  double blocked_timeout_s = 10.0;
  /// The robot moved less than 0.5 m for this long -> the goal fails ("stalled: ..."), seconds, (0, 3600],
  /// whatever its plans did (Nav2's progress checker): a new plan counts as progress for blocked_timeout_s,
  /// so a robot whose plans keep changing without taking it anywhere would otherwise keep its goal forever.
  double stall_timeout_s = 60.0;
  /// The local planner aims at the point this far along the global path, metres, (0, 10].
  double carrot_distance_m = 2.5;
  /// Waypoint mode: a local path must be free for this long (or to the goal if nearer); a path blocked
  /// further on is driven to its free end, braking, and re-chosen every cycle. Metres, (0, 10].
  double required_free_length_m = 1.5;
  /// Tight spots (a doorway, a pillar beside a wall): when no path free for required_free_length_m heads
  /// within tight_spot_deviation_rad of the carrot, the local planner tries shorter required lengths, halving
  /// down to this one, and drives the best-aligned path found to its free end, braking (a robot squeezes
  /// through a 1.0 m gap instead of turning away). Metres, (0, required_free_length_m].
  double tight_free_length_m = 0.5;
  /// See tight_free_length_m, radians, (0, pi].
  double tight_spot_deviation_rad = 0.7853981633974483;
  /// Obstacles within this range of the body feed the local planner, metres, (0, 20].
  double sensor_range_m = 3.5;
  /// Local planner cycle period (the sensor rate), seconds, (0, 1].
  double local_planner_period_s = 0.1;
  /// The local planner is unhealthy when its obstacle input is older than this, seconds, (0, 10]: the robot
  /// brakes and waits for a fresh scan.
  double obstacle_timeout_s = 1.0;
  /// Obstacle sensing is lost when its input is older than this, seconds, [obstacle_timeout_s, 60]: modes
  /// that need it (waypoint, smart joystick) end, with the reason. Between the two the goal survives a
  /// sensor hiccup (a late scan on a loaded computer) with the robot at rest.
  double obstacle_lost_s = 3.0;
  /// How often the global path is checked against the current map, seconds, (0, 60].
  double replan_check_period_s = 0.5;
  /// Farther than this from the global path -> replan from the current pose, metres, (0, 20].
  double max_path_deviation_m = 1.5;
  /// Smart joystick: the yaw rate bends the joystick direction by wz * this (capped at 90 deg), seconds,
  /// [0, 5].
  double joystick_turn_lookahead_s = 1.0;
  /// A goal in unmapped space (GlobalPlan::goal_unmapped: beyond the map or on ground not seen yet,
  /// which may be inside rock) is abandoned after this many replans without progress, [1, 1000]. Progress:
  /// the distance left (along the plan, plus a partial plan's remaining straight line) 0.5 m below its least
  /// so far; replans adopt longer routes as the map reveals walls, so they do not count as progress here.
  int unmapped_goal_max_replans = 20;
  /// ...or after this long without progress, seconds, (0, 3600].
  double unmapped_goal_timeout_s = 60.0;
  /// A robot held before a peer (SetHold(): waiting for it to get out of the way) abandons its goal ("blocked
  /// by r9: ...") once it was held this long without progress toward the goal, seconds, (0, 3600]: a peer
  /// that never moves (or a forged peer state) cannot hold it forever.
  double max_hold_s = 90.0;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// Output of one Navigation step.
struct NavigationStep {
  double linear_x_mps = 0.0;  ///< Twist to send through the mux, frame B.
  double angular_z_radps = 0.0;
  bool arrived = false;  ///< The goal was reached this step (the goal is cleared).
  bool failed = false;   ///< The goal failed this step (the goal is cleared); see reason.
  bool stalled = false;  ///< With failed: the robot moved less than 0.5 m in the goal's stall timeout.
  /// With failed: the goal is given up for good (a goal in unmapped space without progress, a peer that held
  /// the robot for max_hold_s): trying again (a recovery) would only repeat the wait.
  bool abandoned = false;
  std::string reason;  ///< Why it failed.
};

/// A driven path as a plan navigation follows (Navigation::AcceptGoal) without a search: the path a convoy's
/// robot ahead drove, or a yielding robot's way to its spot on its own grid. `path_M` frame M, metres (>= 1
/// point); `map_version` the planner's map it was taken on; `what` the plan's message.
GlobalPlan PlanAlong(const std::vector<Eigen::Vector3d>& path_M, std::uint64_t map_version,
                     const std::string& what);

/// True if `plan` (a future from Navigation::PlanGoalAsync() or a replan) holds a finished search: get() will
/// not block. False for an empty future.
inline bool PlanReady(const std::future<GlobalPlan>& plan) {
  return plan.valid() && plan.wait_for(std::chrono::seconds(0)) == std::future_status::ready;
}
/// True while `plan`'s search still runs on the planner's worker.
inline bool PlanRunning(const std::future<GlobalPlan>& plan) {
  return plan.valid() && plan.wait_for(std::chrono::seconds(0)) != std::future_status::ready;
}

/// The navigation stack of one robot. Not thread-safe (the agent calls it under its lock); the global
/// planner it shares is thread-safe and may also serve path requests from other threads.
class Navigation {
 public:
  /// @throws std::invalid_argument for invalid options, a null planner or library, or a planner that does
  ///         not serve the platform. The library should be built for the platform (heading range, collision
  ///         radius), see AgentOptions::LibraryForPlatform().
  Navigation(const NavigationOptions& options, std::shared_ptr<GlobalPlanner> planner,
             std::shared_ptr<const TrajectoryLibrary> library);

  /// Plans a global path from `state` to the goal (x_m, y_m) (metres, frame map). On success the goal
  /// becomes active (replacing any other) and the plan is returned; otherwise the previous goal is kept and
  /// the plan's reason says why. tolerance_m 0 = options.goal_tolerance_m.
  /// `z_m`: the goal's level, the walkable surface at (x_m, y_m) nearest this height (metres, frame M; an
  /// upper floor); NaN = the robot's level (see GlobalPlanRequest::goal_z_m).
  GlobalPlan SetGoal(const core::BaseState& state, double x_m, double y_m, double tolerance_m, double now_s,
                     double z_m = std::numeric_limits<double>::quiet_NaN());
  /// The planner request SetGoal() makes (from the robot's pose, start_is_robot), for callers that plan on
  /// another thread and hand the plan to AcceptGoal().
  GlobalPlanRequest GoalRequest(const core::BaseState& state, double x_m, double y_m,
                                double z_m = std::numeric_limits<double>::quiet_NaN()) const;
  /// Makes a goal planned elsewhere (request from GoalRequest()) active, replacing any other. `plan` must be
  /// usable. `stall_timeout_s`: this goal's stall timeout (the robot moves less than 0.5 m for this long ->
  /// the step fails with `stalled`), seconds; 0 = options.stall_timeout_s.
  void AcceptGoal(const GlobalPlan& plan, double x_m, double y_m, double tolerance_m, double now_s,
                  double z_m = std::numeric_limits<double>::quiet_NaN(), double stall_timeout_s = 0.0);
  /// Plans the goal (x_m, y_m, z_m) from `state` on a worker thread, with the request GoalRequest() makes
  /// now (the current clearance setting included), so that the control loop never waits for a search (one
  /// over the map's levels takes up to ~1 s). The caller polls the future and hands a usable plan to
  /// AcceptGoal(); a future it no longer wants goes to Abandon().
  std::future<GlobalPlan> PlanGoalAsync(const core::BaseState& state, double x_m, double y_m,
                                        double z_m = std::numeric_limits<double>::quiet_NaN()) const;
  /// True while a replan of the current goal (or a partial plan's extension) runs on the worker; the next
  /// StepWaypoint() after it ends adopts its plan.
  bool replanning() const;
  /// Keeps a plan future nobody waits for until its search ends (destroying a running std::async future
  /// would block the caller until then).
  void Abandon(std::future<GlobalPlan> plan);
  /// Drops the goal (the robot will be stopped by the caller's mode switch).
  void ClearGoal();
  /// Drops the goal only if it is still the one made active when goal_serial() was `serial`: a mode that
  /// leaves must not drop the goal the mode taking over has just set (its Deactivate comes after that).
  void ClearGoal(std::uint64_t serial);
  /// Bumped whenever a goal becomes active (AcceptGoal, SetGoal).
  std::uint64_t goal_serial() const { return goal_serial_; }
  /// Forgets the obstacle points (the local obstacle memory): waypoint driving brakes until the next
  /// SetObstacles() brings a fresh scan. Recovery step "clear the local obstacle memory".
  void ClearObstacles();
  /// True if the robot can drive `distance_m` (>= 0) straight backwards from `state`: no obstacle point
  /// (in the local planner's z band) within the footprint radius plus `margin_m` of that segment. Otherwise
  /// false and `why` (if not null) names the nearest one.
  bool ClearBehind(const core::BaseState& state, double distance_m, double margin_m, std::string* why) const;
  /// Reduced clearance for the current and next goals (the last recovery attempt): global plans prefer no
  /// extra clearance beyond the footprint and inflate obstacles by 70 % of it (a gap closed by the map's
  /// cell quantization opens), and tight spots are driven with no margin beyond the footprint.
  void SetReducedClearance(bool reduced) { reduced_clearance_ = reduced; }
  bool reduced_clearance() const { return reduced_clearance_; }
  /// Share of the footprint radius obstacles are inflated by under reduced clearance.
  static constexpr double kReducedRadiusRatio = 0.7;
  /// The radius global plans inflate obstacles by under reduced clearance, metres: kReducedRadiusRatio x
  /// the platform's footprint radius (the frontier search passes gaps this wide,
  /// FrontierOptions::tight_radius_m).
  double reduced_radius_m() const { return kReducedRadiusRatio * options_.platform.footprint_radius_m; }
  bool has_goal() const { return goal_.has_value(); }

  /// New obstacle points (frame B of `state`, metres) sensed at now_s. The peers of the last SetPeers() are
  /// added to them (AppendPeerObstacles within sensor_range_m, unless their options say not to avoid them).
  void SetObstacles(const std::vector<Eigen::Vector3f>& points_B, const core::BaseState& state, double now_s);
  /// The peer robots to keep clear of from the next SetObstacles() on (the agent's PeerTracker::Live()), with
  /// `options` (valid). An empty list: none.
  void SetPeers(std::vector<PeerBody> peers, const PeerAvoidanceOptions& options);
  /// Peers of the last SetPeers().
  const std::vector<PeerBody>& peers() const { return obstacles_.peers; }
  /// This robot's body as its peers see it (cairn/peer_state): at `pose_M` (frame M), with the platform's
  /// footprint radius and, with a goal, the next kPeerPathPoints points of its global path from the pose,
  /// kPeerPathSpacingM apart (PathAhead).
  PeerBody AsPeer(const std::string& robot_id, const core::BaseState& pose_M) const;

  /// One control step in waypoint mode (call at the control rate). Without a goal: a zero twist. The goal
  /// is reached when the robot is within its tolerance moving at most 0.1 m/s (the controller brakes to
  /// rest at the goal). `speed_mps`: the speed to drive at, m/s, capped at the platform's max speed; NaN (or
  /// not > 0) = the platform's cruise speed (a convoy follower matches the robot ahead's speed).
  /// `follow_path`: the controller tracks the global path itself (its next kFollowTrackM) whenever no live
  /// obstacle point comes within the footprint radius plus kFollowMarginM of it, the local planner's path
  /// otherwise: a convoy follower drives the corners the robot ahead drove instead of cutting them toward a
  /// point ahead, which adds up along a convoy. A goal whose plan said it lies in unmapped space
  /// (GlobalPlan::goal_unmapped) fails `abandoned` after unmapped_goal_max_replans replans or
  /// unmapped_goal_timeout_s without progress ("goal in unmapped space abandoned: ..."); see also SetHold().
  NavigationStep StepWaypoint(const core::BaseState& state, double now_s,
                              double speed_mps = std::numeric_limits<double>::quiet_NaN(),
                              bool follow_path = false);
  /// Holds the robot at rest with its goal kept (a non-empty `why`, e.g. waiting for a peer to get out of
  /// the way, YieldAsker) until called with "": StepWaypoint() then gives a zero twist, and the time held
  /// counts neither as a lack of progress nor as a stall, up to options().max_hold_s in all without progress:
  /// then the goal is abandoned, "blocked by <by_id>: ..." (`by_id`: the robot that holds it; "" = none
  /// named). The local planner's status says `why`.
  void SetHold(const std::string& why, const std::string& by_id = "") {
    hold_.reason = why;
    hold_.by = by_id;
  }
  const std::string& hold_reason() const { return hold_.reason; }
  /// StepWaypoint(follow_path): the track along the global path, metres, and its clearance beyond the
  /// footprint radius, metres.
  static constexpr double kFollowTrackM = 2.0;
  static constexpr double kFollowMarginM = 0.15;
  /// One control step in smart joystick mode: `joystick` is the operator's twist (frame B: forward,
  /// left m/s; yaw rate rad/s); zero means stop. The direction is atan2(vy, vx) bent by wz *
  /// joystick_turn_lookahead_s; the speed is |(vx, vy)| capped at the platform's max speed. A pure yaw rate
  /// turns in place (a disk footprint cannot collide by turning).
  NavigationStep StepJoystick(const core::BaseState& state, double vx_mps, double vy_mps, double wz_radps,
                              double now_s);

  /// True when the local planner has fresh obstacle input (age <= obstacle_timeout_s); else false and `why`.
  bool LocalPlannerHealthy(double now_s, std::string* why) const;
  /// True unless obstacle sensing is lost (input older than obstacle_lost_s, or none yet); else false and
  /// `why`. The mode condition IsLocalPlannerHealthy reads this.
  bool ObstacleSensingAlive(double now_s, std::string* why) const;

  /// The active (or last) global plan; empty path when none.
  const GlobalPlan& global_plan() const { return plan_; }
  /// Waypoint goal id-independent progress: distance left along the global path, metres.
  double distance_left_m() const { return progress_.distance_left_m; }
  /// Estimated time to arrival, seconds (distance left / recent mean speed); -1 without a goal.
  double eta_s() const { return goal_ ? progress_.eta_s : -1.0; }
  /// Global replans of the current goal.
  int replans() const { return replan_.count; }
  /// Bumped whenever the global path changes (new goal, replan, clear), to republish it.
  std::uint64_t path_revision() const { return replan_.path_revision; }
  /// Last local planner result (frame B of local_pose()).
  const LocalPlanResult& local_result() const { return local_.result; }
  /// The point the local planner last aimed at in waypoint mode ((x, y), metres, map frame): up to
  /// carrot_distance_m along the global path, no farther than the robot sees it in a straight line (see
  /// Carrot()).
  const Eigen::Vector2d& carrot_W() const { return progress_.carrot_W; }
  /// Pose the last local plan was made from.
  const core::BaseState& local_pose() const { return local_.pose; }
  /// "" (not run), "path", "boxed in: ..." or "invalid input: ...".
  const std::string& local_status() const { return local_.status; }
  /// Last controller solution.
  const IlqrSolution& controller_solution() const { return control_.solution; }
  const NavigationOptions& options() const { return options_; }
  /// The local planner's trajectory library (path geometry for display).
  const TrajectoryLibrary& library() const { return local_planner_.library(); }

 private:
  struct Goal {
    Eigen::Vector2d p_W = Eigen::Vector2d::Zero();
    double z_m = std::numeric_limits<double>::quiet_NaN();  // level named by the operator, NaN = none
    double tolerance_m = 0.2;
    double best_distance_m = 0.0;
    double best_time_s = 0.0;
    double stall_timeout_s = 60.0;  // see AcceptGoal()
    // Where the robot last was 0.5 m away from (stall_timeout_s), NaN until its first step, and since when.
    Eigen::Vector2d anchor_W = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
    double anchor_time_s = 0.0;
    // Held before a peer (max_hold_s): seconds held since the last progress, and since when the current
    // hold runs (-1: not held).
    double held_s = 0.0;
    double held_since_s = -1.0;
  };
  // Progress toward a goal in unmapped space (unmapped_goal_max_replans). Kept across the goal's end: the
  // same goal accepted again within unmapped_goal_timeout_s (a recovery's retry, a resumed mission) goes on
  // with this record, so retries do not renew the bound; an abandoned or reached goal ends it.
  struct UnmappedWatch {
    bool active = false;
    Eigen::Vector2d p_W = Eigen::Vector2d::Zero();
    double best_left_m = 0.0;  // least distance left so far, metres
    double best_time_s = 0.0;  // ...since when
    double last_s = 0.0;       // last checked
    int replans = 0;           // replans (and acceptances again) since best_left_m
  };
  // Abandons a goal in unmapped space that made no progress within its bounds (the step that fails it), or
  // nullopt.
  std::optional<NavigationStep> CheckUnmappedProgress(double now_s);
  // The held branch of StepWaypoint(): at rest, or the goal abandoned after max_hold_s.
  NavigationStep StepHeld(double now_s);
  // StepWaypoint()'s steps, in order: a finished replan taken (the step that fails the goal, or nullopt);
  // replans asked of the worker; progress checked (stall, unmapped space, blocked: the failing step, or
  // nullopt); the robot driven toward the carrot (local planner and iLQR, or a turn in place).
  std::optional<NavigationStep> TakeReplan(double now_s);
  void RequestReplans(const core::BaseState& state, double now_s);
  void ReplanOnWorker(const core::BaseState& state, double now_s, bool at_end, std::string cause);
  std::optional<NavigationStep> CheckProgress(const core::BaseState& state, double now_s);
  NavigationStep DriveToCarrot(const core::BaseState& state, double to_goal, double cruise_mps, double now_s);
  // A turn toward `carrot_B` (frame B) while the carrot lies behind or the robot is boxed in; nullopt
  // otherwise.
  std::optional<NavigationStep> TurnInPlace(const core::BaseState& state, const Eigen::Vector2d& carrot_B);
  // How far a (partial) plan's end is from the goal (PartialRemainingM).
  double PartialRemaining(const GlobalPlan& plan) const;
  // Makes `plan` (usable, for the current goal) the one followed, from its start.
  void AdoptPlan(const GlobalPlan& plan, double now_s);
  // Forgets a running replan without waiting for it.
  void DropExtension();
  // Runs `request` on a new thread.
  std::future<GlobalPlan> PlanOnWorker(GlobalPlanRequest request) const;
  // Progress along the global path: updates progress_.segment and progress_.distance_left_m; returns the
  // distance from the robot to the path.
  double UpdateProgress(const Eigen::Vector2d& p_W);
  // Point carrot_distance_m ahead of the robot's projection on the global path.
  // Up to carrot_distance_m, but no farther than the robot at `state` sees in a straight line free of the
  // live obstacle points (footprint clearance, or the clearance it has now if less): at a doorway off a
  // corridor, the turn's corner, not a point in the room behind the door jamb, which no local path reaches
  // and whose bearing disagrees with the path's (the robot turned back and forth past the door for a minute).
  Eigen::Vector2d Carrot(const core::BaseState& state) const;
  // Point `ahead_m` along the global path from the robot's projection (its end when shorter).
  Eigen::Vector2d PointAhead(double ahead_m) const;
  // The next `track_m` of the global path becomes the track if every live obstacle point stays farther than
  // the footprint radius plus `margin_m` from it. Returns whether it did. `tight`: the tight-spot fallback
  // when no library path heads toward the carrot (1 m, the bare footprint: it creeps and says so); else
  // StepWaypoint(follow_path)'s (kFollowTrackM, kFollowMarginM).
  bool TrackGlobalPathIfClear(const core::BaseState& state, double track_m, double margin_m, bool tight);
  // True if the obstacle point (frame B) is finite and in the local planner's obstacle z band.
  bool IsObstacle(const Eigen::Vector3f& p_B) const;
  // Runs the local planner if its period elapsed; fills local_.track_W and local_.track_stop_at_end.
  void RunLocalPlanner(const core::BaseState& state, const LocalPlanRequest& request, double now_s,
                       const std::optional<Eigen::Vector2d>& goal_W);
  // RunLocalPlanner()'s steps: the obstacles re-expressed in the body frame at `state`; for a goal, shorter
  // required free lengths tried while every path turns away from the carrot (true when one heads toward it:
  // within tight_spot_deviation_rad); the track cut at its sample nearest `goal_W` and ended at the goal when
  // the goal is that near.
  void ReexpressObstacles(const core::BaseState& state);
  bool PlanTowardCarrot(const LocalPlanRequest& request);
  void SnapTrackToGoal(const Eigen::Vector2d& goal_W);
  // iLQR on local_.track_W; zero twist (braking) when there is no track.
  NavigationStep Control(const core::BaseState& state, double cruise_mps, double now_s);
  NavigationStep Fail(const std::string& reason);

  NavigationOptions options_;
  std::shared_ptr<GlobalPlanner> planner_;
  LocalPlanner local_planner_;
  IlqrController controller_;

  std::optional<Goal> goal_;
  GlobalPlan plan_;
  // The robot's progress along plan_'s path.
  struct PathProgress {
    std::size_t segment = 0;             // segment of the global path the robot projects on
    double segment_start_along_m = 0.0;  // arc length at the start of segment
    double projection_along_m = 0.0;     // arc length of the robot's projection on the global path
    double distance_left_m = 0.0;
    double eta_s = -1.0;
    double mean_speed_mps = 0.0;
    Eigen::Vector2d carrot_W = Eigen::Vector2d::Zero();
  } progress_;
  // Replanning: when it last ran, and the plans running on workers.
  struct Replanning {
    int count = 0;
    std::uint64_t path_revision = 0;
    double last_check_s = -1e9;
    double last_partial_s = -1e9;                    // last extension of a partial plan (the map grew)
    double last_worker_s = -1e9;                     // last replan started on the worker
    std::future<GlobalPlan> extension;               // a replan (or a partial plan's extension) on a worker
    bool extension_at_end = false;                   // ...asked for at the partial plan's end
    std::string extension_cause;                     // ...and why it was asked for, for a failure's reason
    double partial_stuck_since_s = -1.0;             // at a partial plan's end with no way on since; -1 = not
    std::vector<std::future<GlobalPlan>> abandoned;  // plans of dropped goals, still running
  } replan_;
  bool creeping_ = false;  // the track is the global path through a tight spot (half speed)
  bool follow_path_ = false;
  std::uint64_t goal_serial_ = 0;  // see goal_serial()  // StepWaypoint(follow_path) of the step under way
  bool reduced_clearance_ = false;
  // SetHold(): why the robot holds, and the robot that holds it.
  struct Hold {
    std::string reason;
    std::string by;
  } hold_;
  UnmappedWatch unmapped_;
  // The live obstacle input (SetObstacles, SetPeers).
  struct ObstacleInput {
    std::vector<Eigen::Vector3f> points_B;
    double time_s = -1e9;
    core::BaseState pose;   // pose the points are expressed from
    bool awaiting = false;  // obstacle memory cleared: no local plan before the next SetObstacles()
    std::vector<PeerBody> peers;
    PeerAvoidanceOptions peer_options;
  } obstacles_;
  // The local planner's last cycle and the track it gave the controller.
  struct LocalPlanning {
    double last_time_s = -1e9;
    LocalPlanResult result;
    core::BaseState pose;  // pose of the last local plan
    std::string status;
    std::vector<Eigen::Vector2d> track_W;  // path for the controller, frame W
    bool track_stop_at_end = true;
  } local_;
  // The controller's last solve.
  struct Tracking {
    IlqrSolution solution;
    double last_solve_time_s = -1.0;
    bool turning_in_place = false;  // rotation shim: turning toward the path until aligned
  } control_;
};

}  // namespace cairn::nav
