// Copyright Cairn authors.
//
// Iterative LQR (iLQR) trajectory tracking for a unicycle platform whose forward speed and yaw rate are
// states driven by accelerations. Method: iLQR (Li & Todorov, "Iterative Linear Quadratic Regulator Design
// for Nonlinear Biological Movement Systems", ICINCO 2004), a Gauss-Newton member of the differential dynamic
// programming family (Mayne, "Differential Dynamic Programming - A Unified Approach to the Optimization of
// Dynamic Systems", 1973), with the regularization schedule, backtracking line search and clamped control
// limits of Tassa, Erez & Todorov, "Synthesis and Stabilization of Complex Behaviors through Online
// Trajectory Optimization", IROS 2012 (box-constrained backward pass as in Tassa, Mansard & Todorov,
// "Control-Limited Differential Dynamic Programming", ICRA 2014). Eigen only, no middleware.
//
// Model (step dt_s, velocities ramp linearly within a step, pose integrated at the mid-step heading):
//   v_bar = v + a dt / 2,  w_bar = w + alpha dt / 2,  yaw_mid = yaw + w_bar dt / 2
//   x' = x + v_bar dt cos(yaw_mid),  y' = y + v_bar dt sin(yaw_mid),  yaw' = yaw + w_bar dt
//   v' = v + a dt,  w' = w + alpha dt
// Limits: the speed and yaw-rate limits are folded into state-dependent control bounds,
//   a     in [max(-max_accel, (-max_reverse_speed - v) / dt), min(max_accel, (max_speed - v) / dt)]
//   alpha in [max(-max_yaw_accel, (-max_yaw_rate - w) / dt), min(max_yaw_accel, (max_yaw_rate - w) / dt)],
// so every returned state satisfies the velocity limits and every returned control the acceleration limits,
// and states and controls are consistent (states[k+1] = IlqrModelStep(states[k], controls[k], dt_s)). The
// backward pass solves each step's 2-D box QP exactly; a control held at a velocity bound gets the bound's
// derivative as its feedback row (-1/dt on v or w), so the linearization of the clamped dynamics is exact.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"

namespace cairn::nav {

/// State of the iLQR model, in a planar frame F chosen by the caller: (x_m, y_m) position (metres, frame F),
/// yaw_rad heading about +z of F (radians; not wrapped along a trajectory), v_mps forward speed (m/s, body x,
/// negative when reversing), w_radps yaw rate (rad/s).
using IlqrState = Eigen::Matrix<double, 5, 1>;
/// Control of the iLQR model: (a_mps2 forward acceleration, m/s^2; alpha_radps2 yaw acceleration, rad/s^2).
using IlqrControl = Eigen::Matrix<double, 2, 1>;

/// Velocity and acceleration limits of the platform: the simulated platform's limits type (fields
/// max_speed_mps, max_reverse_speed_mps, max_accel_mps2, max_yaw_rate_radps, max_yaw_accel_radps2, with
/// IsValid()), so the controller and the platform it drives share one definition.
using IlqrLimits = core::VelocityLimits;

/// Options of IlqrController. The cost of a trajectory (states x_0..x_N, controls u_0..u_N-1, reference
/// r_0..r_N from BuildIlqrReference()) is
///   J = sum_{k<N} dt_s (l(x_k, r_k) + accel_weight a_k^2 + yaw_accel_weight alpha_k^2)
///       + terminal_weight_s l(x_N, r_N),
///   l(x, r) = along_track_weight e_t^2 + cross_track_weight e_n^2 + heading_weight wrap(yaw - yaw_r)^2
///             + speed_weight (v - v_r)^2 + yaw_rate_weight w^2,
/// where (e_t, e_n) is the position error p - p_r resolved along and across the reference heading yaw_r
/// (metres), wrap() maps to (-pi, pi]. Weights are per second of trajectory, so changing dt_s keeps their
/// meaning.
struct IlqrOptions {
  /// Horizon length N, steps, range [1, 500]. Default: 3 s at dt_s 0.1.
  int horizon_steps = 30;
  /// Time step of the model, seconds, range (0, 1].
  double dt_s = 0.1;
  /// Largest number of iLQR iterations (backward + forward pass) of a cold-started solve, range [1, 1000].
  int max_iterations = 50;
  /// Largest number of iterations of a warm-started solve, range [1, 1000].
  int max_iterations_warm = 15;
  /// Stop (converged) when an accepted iteration lowers the cost by less than this fraction of it, or the
  /// predicted decrease of a full step is below it, unitless, range (0, 0.5].
  double tolerance = 1e-4;

  /// Weight of the position error along the reference heading, 1/(m^2 s), range [0, 1e6]. Lower than the
  /// cross-track weight: lagging behind the reference is cheaper than leaving the path.
  double along_track_weight = 4.0;
  /// Weight of the position error across the reference heading, 1/(m^2 s), range [0, 1e6].
  double cross_track_weight = 40.0;
  /// Weight of the wrapped heading error, 1/(rad^2 s), range [0, 1e6].
  double heading_weight = 2.0;
  /// Weight of the speed error to the reference speed profile, s/m^2, range [0, 1e6].
  double speed_weight = 2.0;
  /// Weight of the yaw rate, s/rad^2, range [0, 1e6].
  double yaw_rate_weight = 0.1;
  /// Weight of the forward acceleration, s^3/m^2, range (0, 1e6] (> 0 keeps the problem strictly convex in
  /// the controls).
  double accel_weight = 0.5;
  /// Weight of the yaw acceleration, s^3/rad^2, range (0, 1e6].
  double yaw_accel_weight = 0.05;
  /// Terminal cost: l(x_N, r_N) counted as this many seconds of running cost, seconds, range [0, 1000].
  double terminal_weight_s = 1.0;
  /// The reference speed profile accelerates and brakes at this fraction of IlqrLimits::max_accel_mps2,
  /// leaving the rest for corrections, unitless, range (0, 1].
  double reference_accel_fraction = 0.7;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule, e.g. "IlqrOptions::dt_s = 0 must be finite and in (0, 1]".
  bool IsValid(std::string* why) const;
};

/// One point of the per-step reference (frame F of the path).
struct IlqrReferencePoint {
  double x_m = 0.0;      ///< Reference position x, metres, frame F.
  double y_m = 0.0;      ///< Reference position y, metres, frame F.
  double yaw_rad = 0.0;  ///< Reference heading (path tangent), radians about +z of F, in (-pi, pi].
  double v_mps = 0.0;    ///< Reference forward speed, m/s, >= 0.
  double s_m = 0.0;      ///< Arc length along the path from its first point, metres (beyond the end when
                         ///< the path continues).
};

/// Builds the reference of steps + 1 points (times 0, dt_s, ..., steps dt_s) along the polyline `path_F`
/// ((x, y) points, metres, frame F; consecutive duplicates ignored). Progress starts at the projection of
/// p0_F (metres, frame F) on the polyline (the nearest point; the earliest one on ties). The speed starts at
/// v0_mps (m/s; negative taken as 0) and moves towards cruise_speed_mps (m/s) at most by accel_mps2 (m/s^2);
/// with stop_at_end (the path ends at a goal) it also stays below sqrt(2 accel_mps2 d), d the path length
/// left, so the reference brakes to rest at the last point; otherwise the path is taken to continue straight
/// beyond its last point along the last segment. Heading = tangent of the segment holding the point (the
/// segment ahead at a vertex). Throws std::invalid_argument if a value is not finite, the path has fewer than
/// 2 distinct points, cruise_speed_mps < 0, accel_mps2 <= 0, steps < 1 or dt_s <= 0.
std::vector<IlqrReferencePoint> BuildIlqrReference(const std::vector<Eigen::Vector2d>& path_F,
                                                   const Eigen::Vector2d& p0_F, double v0_mps,
                                                   double cruise_speed_mps, bool stop_at_end,
                                                   double accel_mps2, int steps, double dt_s);

/// One step of the discrete model of the file comment (no limits applied), state and result in frame F.
IlqrState IlqrModelStep(const IlqrState& x, const IlqrControl& u, double dt_s);

/// Jacobians of IlqrModelStep(x, u, dt_s): A = d x' / d x (5x5), B = d x' / d u (5x2), the linearization the
/// solver uses. A and B must not be null.
void IlqrModelJacobians(const IlqrState& x, const IlqrControl& u, double dt_s, Eigen::Matrix<double, 5, 5>* A,
                        Eigen::Matrix<double, 5, 2>* B);

/// Result of IlqrController::Solve().
struct IlqrSolution {
  /// How the solve ended.
  enum class Status {
    kConverged,      ///< The relative cost decrease fell below IlqrOptions::tolerance.
    kMaxIterations,  ///< The iteration limit was hit; the best trajectory found is returned (usable).
    kStalled,        ///< No decrease found even at the largest regularization; best one kept (usable).
    kNoPath,         ///< The path has fewer than 2 distinct points: a braking trajectory is returned.
    kInvalidInput,   ///< A NaN/inf or out-of-range argument; zero command, empty trajectory.
  };
  Status status = Status::kInvalidInput;
  /// Human-readable outcome naming the values at fault, e.g. "x0[2] (yaw_rad) = nan is not finite".
  std::string message;
  /// Forward speed to command now: v of states[1] (the speed after one step), m/s. 0 on kInvalidInput.
  double command_v_mps = 0.0;
  /// Yaw rate to command now: w of states[1], rad/s. 0 on kInvalidInput.
  double command_w_radps = 0.0;
  /// Optimized states x_0..x_N (N = horizon_steps; frame F of the input), x_0 = the input state with v and w
  /// clamped to the limits. Empty on kInvalidInput.
  std::vector<IlqrState> states;
  /// Optimized controls u_0..u_N-1 (u_k applied from k dt_s to (k + 1) dt_s). Empty on kInvalidInput.
  std::vector<IlqrControl> controls;
  /// Reference r_0..r_N tracked (frame F). Empty on kInvalidInput and kNoPath.
  std::vector<IlqrReferencePoint> reference;
  /// Cost of the returned trajectory (see IlqrOptions), unitless.
  double cost = 0.0;
  /// Cost of the initial guess (warm start or cold guess), unitless.
  double initial_cost = 0.0;
  /// Cost after each accepted iteration, starting with initial_cost; never increases.
  std::vector<double> cost_history;
  /// Iterations run (backward passes with their line searches, accepted or not).
  int iterations = 0;
  /// True if the initial guess was the previous solution's controls, shifted in time.
  bool warm_started = false;
  /// Wall-clock time of Solve(), seconds.
  double solve_time_s = 0.0;

  /// True when the command and trajectory may be used (every status but kInvalidInput).
  bool IsUsable() const { return status != Status::kInvalidInput; }
};

/// Name of a status, e.g. "kConverged".
const char* ToString(IlqrSolution::Status status);

/// Receding-horizon iLQR tracker of a polyline path, warm-started from its previous solution. Not
/// thread-safe. Buffers are sized at construction; the iteration loop does not allocate. Movable, not
/// copyable; a moved-from controller may only be destroyed or assigned to.
///
/// Frames: the controller is frame-agnostic. x0 and path_F must be expressed in the same planar frame F,
/// which may change from one call to the next (e.g. the robot body frame B of the current cycle, or the world
/// frame W). The warm start therefore reuses only the previous controls (accelerations, frame-independent),
/// shifted by the elapsed time and re-rolled out from the new x0; previous states are never reused.
class IlqrController {
 public:
  /// `options` and `limits` must be valid; throws std::invalid_argument with the IsValid() message otherwise.
  explicit IlqrController(const IlqrOptions& options = {}, const IlqrLimits& limits = {});
  ~IlqrController();
  IlqrController(IlqrController&&) noexcept;
  IlqrController& operator=(IlqrController&&) noexcept;
  IlqrController(const IlqrController&) = delete;
  IlqrController& operator=(const IlqrController&) = delete;

  /// Optimizes the next horizon_steps controls from x0_F (frame F; v and w are clamped to the limits first,
  /// as the platform cannot exceed them) to track `path_F` ((x, y) points, metres, frame F) at
  /// cruise_speed_mps (m/s, >= 0; clamped to max_speed_mps), braking to rest at the last point if
  /// `stop_at_end`, else cruising on (see BuildIlqrReference()).
  ///
  /// Initial guess: the cheaper of (a) the previous solution's controls shifted by
  /// elapsed_since_last_solve_s (seconds, >= 0; linearly interpolated between steps, the end padded with zero
  /// accelerations), available when a previous solution exists and the shift is shorter than the horizon,
  /// and (b) a cold guess (accelerations following the reference speed profile and turning towards a point
  /// 0.5 s ahead on the reference). Call Reset() when the path changed a lot to force a cold start.
  ///
  /// Errors are statuses, never exceptions: a NaN/inf in x0_F, path_F, cruise_speed_mps or
  /// elapsed_since_last_solve_s, a negative speed or elapsed time give kInvalidInput with a zero command, and
  /// drop the warm start. A path with fewer than 2 distinct points gives kNoPath and a trajectory braking to
  /// rest (holding the position as well as the limits allow) and drops the warm start.
  IlqrSolution Solve(const IlqrState& x0_F, const std::vector<Eigen::Vector2d>& path_F,
                     double cruise_speed_mps, bool stop_at_end, double elapsed_since_last_solve_s);

  /// Forgets the previous solution: the next Solve() starts cold.
  void Reset();

  /// True if the next Solve() may warm-start.
  bool has_warm_start() const;
  /// Options given at construction.
  const IlqrOptions& options() const;
  /// Limits given at construction.
  const IlqrLimits& limits() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::nav
