// Copyright Cairn authors.
#include "cairn/sim/unicycle.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace cairn::sim {
namespace {

// Largest distance between two footprint checks along one step, metres (half a 0.1 m voxel).
constexpr double kCheckSpacing_m = 0.05;

}  // namespace

Unicycle::Unicycle(const UnicycleLimits& limits, double footprint_radius_m,
                   const UnicycleState& initial_state)
    : limits_(limits), footprint_radius_m_(footprint_radius_m) {
  std::string why;
  if (!limits.IsValid(&why)) throw std::invalid_argument(why);
  if (!std::isfinite(footprint_radius_m) || footprint_radius_m < 0.0 || footprint_radius_m > 5.0) {
    throw std::invalid_argument("Unicycle footprint_radius_m = " + std::to_string(footprint_radius_m) +
                                " must be finite and in [0, 5]");
  }
  set_state(initial_state);
}

void Unicycle::set_state(const UnicycleState& state) {
  state_ = state;
  state_.yaw_rad = WrapAngle(state.yaw_rad);
}

UnicycleStepResult Unicycle::Step(double vx_mps, double wz_radps, double dt_s,
                                  const FootprintChecker& terrain) {
  if (!std::isfinite(dt_s) || dt_s <= 0.0 || dt_s > 1.0) {
    throw std::invalid_argument("Unicycle::Step dt_s = " + std::to_string(dt_s) +
                                " must be finite and in (0, 1]");
  }
  UnicycleStepResult result;
  if (!std::isfinite(vx_mps)) {
    vx_mps = 0.0;
    result.command_non_finite = true;
  }
  if (!std::isfinite(wz_radps)) {
    wz_radps = 0.0;
    result.command_non_finite = true;
  }
  const double v_cmd = std::clamp(vx_mps, -limits_.max_reverse_speed_mps, limits_.max_speed_mps);
  const double w_cmd = std::clamp(wz_radps, -limits_.max_yaw_rate_radps, limits_.max_yaw_rate_radps);
  result.command_clamped = v_cmd != vx_mps || w_cmd != wz_radps;

  const double dv_max = limits_.max_accel_mps2 * dt_s;
  const double dw_max = limits_.max_yaw_accel_radps2 * dt_s;
  const double v = state_.v_mps + std::clamp(v_cmd - state_.v_mps, -dv_max, dv_max);
  const double w = state_.w_radps + std::clamp(w_cmd - state_.w_radps, -dw_max, dw_max);

  const double yaw_mid = state_.yaw_rad + 0.5 * w * dt_s;
  const double dx = v * std::cos(yaw_mid) * dt_s;
  const double dy = v * std::sin(yaw_mid) * dt_s;
  const int checks = std::max(1, static_cast<int>(std::ceil(std::hypot(dx, dy) / kCheckSpacing_m)));
  bool free = true;
  const bool moves = dx != 0.0 || dy != 0.0;  // Turning in place never collides (disk footprint).
  for (int k = 1; moves && k <= checks && free; ++k) {
    const double f = static_cast<double>(k) / checks;
    free = terrain.IsFootprintFreeNear(state_.x_m + f * dx, state_.y_m + f * dy, state_.z_m,
                                       footprint_radius_m_);
  }
  state_.yaw_rad = WrapAngle(state_.yaw_rad + w * dt_s);
  state_.w_radps = w;
  if (!free) {
    result.contact = true;
    state_.v_mps = 0.0;
    return result;
  }
  state_.x_m += dx;
  state_.y_m += dy;
  state_.v_mps = v;
  if (const auto z = terrain.GroundHeightNear(state_.x_m, state_.y_m, state_.z_m)) state_.z_m = *z;
  return result;
}

}  // namespace cairn::sim
