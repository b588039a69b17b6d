#include "cairn/ros2/wire.h"

#include <algorithm>
#include <cmath>

namespace cairn::ros2 {

std::string DdsTopicName(const std::string& ros_topic) {
  if (ros_topic.empty()) return "";
  return "rt/" + ros_topic.substr(ros_topic[0] == '/' ? 1 : 0);
}

double StampS(const builtin_interfaces::msg::dds_::Time_& stamp) {
  return static_cast<double>(stamp.sec()) + 1e-9 * static_cast<double>(stamp.nanosec());
}

Eigen::Isometry3d ToIsometry(const Eigen::Vector3d& translation, double qx, double qy, double qz, double qw) {
  Eigen::Quaterniond q(qw, qx, qy, qz);
  const double norm = q.norm();
  q = norm > 1e-9 && std::isfinite(norm) ? Eigen::Quaterniond(q.coeffs() / norm)
                                         : Eigen::Quaterniond::Identity();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = q.toRotationMatrix();
  T.translation() = translation;
  return T;
}

builtin_interfaces::msg::dds_::Time_ ToStamp(double seconds) {
  builtin_interfaces::msg::dds_::Time_ stamp;
  const double whole = std::floor(seconds);
  stamp.sec(static_cast<std::int32_t>(whole));
  stamp.nanosec(static_cast<std::uint32_t>(std::min(999999999.0, (seconds - whole) * 1e9)));
  return stamp;
}

}  // namespace cairn::ros2
