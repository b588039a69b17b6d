#include "cairn/agent/agent_options.h"

#include <cmath>
#include <regex>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "cairn/core/config.h"

namespace cairn::agent {

void AgentOptions::LoadConfigFile(const std::string& path) {
  const auto config = core::ConfigSection::LoadFile(path);
  config.RejectUnknownKeys({"command_interface", "mux", "navigation", "platform", "traversability", "telemetry"});
  const auto ci = config.Section("command_interface");
  ci.RejectUnknownKeys({"lock_keep_s"});
  ci.ReadDouble("lock_keep_s", &lock.lock_keep_s, /*allow_infinity=*/true);
  const auto mux = config.Section("mux");
  mux.RejectUnknownKeys({"teleop_timeout_s", "waypoint_timeout_s"});
  mux.ReadDouble("teleop_timeout_s", &teleop_timeout_s);
  mux.ReadDouble("waypoint_timeout_s", &waypoint_timeout_s);
  const auto nav = config.Section("navigation");
  nav.RejectUnknownKeys(
      {"cruise_speed_mps", "goal_tolerance_m", "lookahead_m", "blocked_timeout_s", "contact_timeout_s"});
  nav.ReadDouble("cruise_speed_mps", &cruise_speed_mps);
  nav.ReadDouble("goal_tolerance_m", &goal_tolerance_m);
  nav.ReadDouble("lookahead_m", &lookahead_m);
  nav.ReadDouble("blocked_timeout_s", &blocked_timeout_s);
  nav.ReadDouble("contact_timeout_s", &contact_timeout_s);
  const auto platform_section = config.Section("platform");
  platform_section.RejectUnknownKeys({"footprint_radius_m", "max_speed_mps", "max_reverse_speed_mps",
                                      "max_accel_mps2", "max_yaw_rate_radps", "max_yaw_accel_radps2"});
  platform_section.ReadDouble("footprint_radius_m", &footprint_radius_m);
  platform_section.ReadDouble("max_speed_mps", &limits.max_speed_mps);
  platform_section.ReadDouble("max_reverse_speed_mps", &limits.max_reverse_speed_mps);
  platform_section.ReadDouble("max_accel_mps2", &limits.max_accel_mps2);
  platform_section.ReadDouble("max_yaw_rate_radps", &limits.max_yaw_rate_radps);
  platform_section.ReadDouble("max_yaw_accel_radps2", &limits.max_yaw_accel_radps2);
  const auto trav = config.Section("traversability");
  trav.RejectUnknownKeys({"robot_radius_m", "robot_height_m", "max_step_m"});
  trav.ReadDouble("robot_radius_m", &robot_radius_m);
  trav.ReadDouble("robot_height_m", &robot_height_m);
  trav.ReadDouble("max_step_m", &max_step_m);
  const auto telemetry = config.Section("telemetry");
  telemetry.RejectUnknownKeys({"state_rate_hz"});
  telemetry.ReadDouble("state_rate_hz", &state_rate_hz);
  std::string why;
  if (!IsValid(&why)) throw core::ConfigError(path + ": " + why);
}

namespace {

bool InRange(const char* field, double value, double lo, double hi, bool lo_open, std::string* why) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    std::ostringstream out;
    out << field << " = " << value << " must be in " << (lo_open ? "(" : "[") << lo << ", " << hi << "]";
    *why = out.str();
  }
  return ok;
}

}  // namespace

bool AgentOptions::IsValid(std::string* why) const {
  static const std::regex kIdPattern("[A-Za-z0-9_-]{1,64}");
  if (!std::regex_match(robot_id, kIdPattern)) {
    *why = "robot id '" + robot_id + "' must be 1-64 characters of A-Z a-z 0-9 _ -";
    return false;
  }
  if (platform != "wheeled" && platform != "legged") {
    *why = "platform '" + platform + "' is not supported (valid: wheeled, legged)";
    return false;
  }
  if (!lock.IsValid(why)) return false;
  std::string limits_why;
  if (!limits.IsValid(&limits_why)) {
    *why = "platform." + limits_why;
    return false;
  }
  return InRange("mux.teleop_timeout_s", teleop_timeout_s, 0, 60, true, why) &&
         InRange("mux.waypoint_timeout_s", waypoint_timeout_s, 0, 60, true, why) &&
         InRange("navigation.cruise_speed_mps", cruise_speed_mps, 0, limits.max_speed_mps, true, why) &&
         InRange("navigation.goal_tolerance_m", goal_tolerance_m, 0, 5, true, why) &&
         InRange("navigation.lookahead_m", lookahead_m, 0, 5, true, why) &&
         InRange("navigation.blocked_timeout_s", blocked_timeout_s, 0, 600, true, why) &&
         InRange("navigation.contact_timeout_s", contact_timeout_s, 0, 60, true, why) &&
         InRange("platform.footprint_radius_m", footprint_radius_m, 0, 2, true, why) &&
         InRange("traversability.robot_radius_m", robot_radius_m, footprint_radius_m, 2, false, why) &&
         InRange("traversability.robot_height_m", robot_height_m, 0, 5, true, why) &&
         InRange("traversability.max_step_m", max_step_m, 0, 1, false, why) &&
         InRange("telemetry.state_rate_hz", state_rate_hz, 0, 100, true, why) &&
         InRange("--pcd-resolution", pcd_resolution_m, 0.02, 2, false, why);
}

void ParseStart(const std::string& text, AgentOptions* options) {
  if (text.rfind("slot:", 0) == 0) {
    const std::string k = text.substr(5);
    if (k.empty() || k.size() > 2 || k.find_first_not_of("0123456789") != std::string::npos) {
      throw std::invalid_argument("--start '" + text + "': slot must be an integer in [0, 99]");
    }
    options->start_slot = std::stoi(k);
    return;
  }
  options->start_W = ParseStartPose(text);
}

sim::PlanarPose ParseStartPose(const std::string& text) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    std::size_t used = 0;
    double value = 0;
    try {
      value = std::stod(item, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != item.size() || !std::isfinite(value)) {
      throw std::invalid_argument("--start '" + text + "': '" + item + "' is not a finite number");
    }
    values.push_back(value);
  }
  if (values.size() < 2 || values.size() > 3 || (!text.empty() && text.back() == ',')) {
    throw std::invalid_argument("--start '" + text + "' must be X,Y or X,Y,YAW (metres, metres, radians)");
  }
  return sim::PlanarPose{values[0], values[1], values.size() == 3 ? values[2] : 0.0};
}

}  // namespace cairn::agent
