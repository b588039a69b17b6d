// Copyright Cairn authors.
#include "cairn/core/kinematics.h"

#include <cmath>
#include <sstream>

namespace cairn::core {
namespace {

constexpr double kPi = 3.14159265358979323846;

bool CheckRange(const char* field, double value, double lo, bool lo_open, double hi,
                std::ostringstream* msg) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    *msg << "VelocityLimits::" << field << " = " << value << " must be finite and in "
         << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
  }
  return ok;
}

}  // namespace

double WrapAngle(double angle_rad) {
  if (!std::isfinite(angle_rad)) return angle_rad;
  double a = std::fmod(angle_rad + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

bool VelocityLimits::IsValid(std::string* why) const {
  std::ostringstream msg;
  const bool ok = CheckRange("max_speed_mps", max_speed_mps, 0.0, true, 20.0, &msg) &&
                  CheckRange("max_reverse_speed_mps", max_reverse_speed_mps, 0.0, false, 20.0, &msg) &&
                  CheckRange("max_accel_mps2", max_accel_mps2, 0.0, true, 50.0, &msg) &&
                  CheckRange("max_yaw_rate_radps", max_yaw_rate_radps, 0.0, true, 20.0, &msg) &&
                  CheckRange("max_yaw_accel_radps2", max_yaw_accel_radps2, 0.0, true, 100.0, &msg);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

VelocityLimits VelocityLimits::Wheeled() { return VelocityLimits{}; }

VelocityLimits VelocityLimits::Legged() {
  VelocityLimits limits;
  limits.max_speed_mps = 0.6;
  limits.max_reverse_speed_mps = 0.3;
  limits.max_accel_mps2 = 0.6;
  limits.max_yaw_rate_radps = 1.0;
  limits.max_yaw_accel_radps2 = 2.0;
  return limits;
}

}  // namespace cairn::core
