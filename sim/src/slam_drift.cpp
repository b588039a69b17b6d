// Copyright Cairn authors.
#include "cairn/sim/slam_drift.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "cairn/core/kinematics.h"

namespace cairn::sim {
namespace {

// Heading of a rotation: angle of its x axis projected on the x-y plane, radians, (-pi, pi].
double YawOf(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

bool InUnitRange(double v) { return std::isfinite(v) && v >= 0.0 && v <= 1.0; }

}  // namespace

bool SlamDriftOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  if (!InUnitRange(position_drift_per_sqrt_m)) {
    msg << "SlamDriftOptions::position_drift_per_sqrt_m = " << position_drift_per_sqrt_m
        << " must be finite and in [0, 1] m/sqrt(m)";
  } else if (!InUnitRange(yaw_drift_rad_per_sqrt_m)) {
    msg << "SlamDriftOptions::yaw_drift_rad_per_sqrt_m = " << yaw_drift_rad_per_sqrt_m
        << " must be finite and in [0, 1] rad/sqrt(m)";
  } else if (!InUnitRange(z_drift_per_sqrt_m)) {
    msg << "SlamDriftOptions::z_drift_per_sqrt_m = " << z_drift_per_sqrt_m
        << " must be finite and in [0, 1] m/sqrt(m)";
  } else if (!InUnitRange(yaw_drift_rad_per_sqrt_rad)) {
    msg << "SlamDriftOptions::yaw_drift_rad_per_sqrt_rad = " << yaw_drift_rad_per_sqrt_rad
        << " must be finite and in [0, 1] rad/sqrt(rad)";
  } else {
    return true;
  }
  if (why != nullptr) *why = msg.str();
  return false;
}

SlamDrift::SlamDrift(const SlamDriftOptions& options, std::uint32_t seed)
    : options_(options), rng_(seed), gauss_(0.0, 1.0) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument("SlamDrift: " + why);
}

Eigen::Isometry3d SlamDrift::Update(const Eigen::Isometry3d& T_W_B_true) {
  if (!T_W_B_true.matrix().allFinite()) {
    throw std::invalid_argument("SlamDrift::Update: T_W_B_true must be finite");
  }
  if (!has_previous_) {
    has_previous_ = true;
    T_W_B_previous_ = T_W_B_true;
    return Estimate(T_W_B_true);
  }
  const Eigen::Vector3d p_W_B = T_W_B_true.translation();
  const double ds_m = (p_W_B - T_W_B_previous_.translation()).norm();
  const double dyaw_rad =
      std::abs(core::WrapAngle(YawOf(T_W_B_true.linear()) - YawOf(T_W_B_previous_.linear())));
  T_W_B_previous_ = T_W_B_true;
  if (ds_m == 0.0 && dyaw_rad == 0.0) return Estimate(T_W_B_true);  // At rest: no drift, no draw.
  distance_travelled_m_ += ds_m;
  yaw_turned_rad_ += dyaw_rad;

  const double sqrt_ds = std::sqrt(ds_m);
  const Eigen::Vector3d n_W(options_.position_drift_per_sqrt_m * sqrt_ds * gauss_(rng_),
                            options_.position_drift_per_sqrt_m * sqrt_ds * gauss_(rng_),
                            options_.z_drift_per_sqrt_m * sqrt_ds * gauss_(rng_));
  const double yaw_var = options_.yaw_drift_rad_per_sqrt_m * options_.yaw_drift_rad_per_sqrt_m * ds_m +
                         options_.yaw_drift_rad_per_sqrt_rad * options_.yaw_drift_rad_per_sqrt_rad * dyaw_rad;
  const double n_yaw_rad = std::sqrt(yaw_var) * gauss_(rng_);
  // Increment pivoting about the robot's true position: rotate about +z through p_W_B, then shift by n_W.
  const Eigen::Isometry3d increment = Eigen::Translation3d(p_W_B + n_W) *
                                      Eigen::AngleAxisd(n_yaw_rad, Eigen::Vector3d::UnitZ()) *
                                      Eigen::Translation3d(-p_W_B);
  T_est_true_ = T_est_true_ * increment;
  return Estimate(T_W_B_true);
}

}  // namespace cairn::sim
