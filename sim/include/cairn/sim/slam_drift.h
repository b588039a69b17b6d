// Copyright Cairn authors.
//
// Simulated SLAM (lidar-inertial odometry) pose estimate: the true pose of the simulated robot corrupted by
// a drift that grows with the distance travelled and the angle turned, as a random walk, so that the estimate
// is locally consistent (small relative error) but globally drifts, like LIO-SAM / FAST-LIO in SubT tunnels.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <random>
#include <string>

namespace cairn::sim {

/// Options of SlamDrift: random-walk intensities of the drift per distance travelled and per angle turned.
///
/// On a straight path of length s (metres) the expected horizontal position error is
///   e_xy(s) = sqrt(2 p^2 s + y^2 s^3 / 3)  (rms, metres),
/// with p = position_drift_per_sqrt_m and y = yaw_drift_rad_per_sqrt_m: the first term is the direct
/// position random walk, the second the heading error integrated along the path. With the defaults:
/// 1.6 cm after 10 m, 0.29 m after 100 m (0.29 % of the distance), 9 m after 1 km (0.9 %), within the
/// 0.1-1 % drift reported for lidar-inertial odometry in the DARPA SubT Challenge. The vertical error is
/// z_drift_per_sqrt_m * sqrt(s) (rms): 1 cm after 100 m.
struct SlamDriftOptions {
  /// Random-walk standard deviation of the position error along each horizontal axis, metres per
  /// sqrt(metre travelled), range [0, 1].
  double position_drift_per_sqrt_m = 0.003;
  /// Random-walk standard deviation of the heading (yaw) error, radians per sqrt(metre travelled), range
  /// [0, 1]. Dominates the position error beyond a few tens of metres (see e_xy above).
  double yaw_drift_rad_per_sqrt_m = 0.0005;
  /// Random-walk standard deviation of the height error, metres per sqrt(metre travelled), range [0, 1].
  double z_drift_per_sqrt_m = 0.001;
  /// Random-walk standard deviation of the heading error, radians per sqrt(radian turned about z), range
  /// [0, 1]: turning in place drifts the heading (0.0013 rad = 0.07 deg rms per full turn by default) but
  /// not the position.
  double yaw_drift_rad_per_sqrt_rad = 0.0005;

  /// True when every field is finite and in range; otherwise false and, if `why` is not null, a message
  /// naming the field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// Simulated SLAM drift. The estimate is T_W_B_est = T_est_true * T_W_B_true, where the drift T_est_true
/// (a rigid transform applied on the left) starts at identity and, at each Update() after the robot moved
/// by ds metres and turned by dyaw radians, is multiplied on the right by a random increment pivoting about
/// the robot's current true position p: translation n ~ N(0, diag(p^2, p^2, z^2) ds) and a yaw rotation
/// about +z through p of angle ~ N(0, y^2 ds + y_turn^2 |dyaw|). Pivoting at the robot keeps the estimate
/// locally consistent: a heading error bends the path from where it arose on, it never makes the estimate
/// jump. The drift grows only with motion: updates at rest change nothing, whatever their rate. Roll and
/// pitch are not perturbed (an IMU observes gravity). Not thread-safe.
class SlamDrift {
 public:
  /// Throws std::invalid_argument with IsValid()'s message if `options` is invalid. `seed` seeds the drift:
  /// same seed and same sequence of true poses -> same estimates.
  SlamDrift(const SlamDriftOptions& options, std::uint32_t seed);

  /// Feeds the true base pose `T_W_B_true` (base frame B in world frame W, metres) and returns the estimate
  /// T_W_B_est after drifting by the motion since the previous call. The first call only records the pose
  /// (no error: returns `T_W_B_true`). Call it often enough that the motion between calls is small (e.g. at
  /// the simulation rate): the heading error of a step only affects the following steps. Throws
  /// std::invalid_argument if the pose is not finite.
  Eigen::Isometry3d Update(const Eigen::Isometry3d& T_W_B_true);

  /// The current drift applied to `T_W_B_true`: T_est_true() * T_W_B_true. Does not advance the drift.
  Eigen::Isometry3d Estimate(const Eigen::Isometry3d& T_W_B_true) const { return T_est_true_ * T_W_B_true; }

  /// The current drift: the transform taking true world coordinates to estimated ones (metres), identity
  /// until the robot moves.
  const Eigen::Isometry3d& T_est_true() const { return T_est_true_; }
  /// Distance travelled by the true base so far (sum of straight segments between updates), metres.
  double distance_travelled_m() const { return distance_travelled_m_; }
  /// Absolute yaw turned by the true base so far (sum of |dyaw| between updates), radians.
  double yaw_turned_rad() const { return yaw_turned_rad_; }
  /// Options given at construction.
  const SlamDriftOptions& options() const { return options_; }

 private:
  SlamDriftOptions options_;
  std::mt19937 rng_;
  std::normal_distribution<double> gauss_;
  Eigen::Isometry3d T_est_true_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d T_W_B_previous_ = Eigen::Isometry3d::Identity();
  bool has_previous_ = false;
  double distance_travelled_m_ = 0.0;
  double yaw_turned_rad_ = 0.0;
};

}  // namespace cairn::sim
