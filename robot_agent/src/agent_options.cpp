#include "cairn/agent/agent_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "cairn/core/config.h"
#include "cairn/core/peer_input.h"
#include "range_check.h"

namespace cairn::agent {

nav::TrajectoryLibraryOptions AgentOptions::DefaultLibraryOptions() {
  nav::TrajectoryLibraryOptions o;
  o.voxel_size_m = 0.05;
  return o;
}

void AgentOptions::SetPlatform(const std::string& name) {
  navigation.platform = nav::GetPlatformProfile(name);
  platform = name;
}

nav::TrajectoryLibraryOptions AgentOptions::LibraryForPlatform() const {
  nav::TrajectoryLibraryOptions o = library;
  o.heading_range_rad = navigation.platform.local_heading_range_rad;
  o.collision_radius_m = navigation.platform.footprint_radius_m + collision_margin_m;
  return o;
}

void AgentOptions::LoadConfigFile(const std::string& path) {
  const auto config = core::ConfigSection::LoadFile(path);
  config.RejectUnknownKeys({"command_interface", "mux", "navigation", "local_planner", "controller",
                            "platform", "traversability", "telemetry", "perception", "explore", "peers",
                            "convoy", "yield", "mission", "health", "simulation",
                            "ros2"});  // the simulated platform's (sim::SimulatedPlatformOptions) and the ROS
                                       // 2 driver's (ros2::Ros2PlatformOptions)
  const auto ci = config.Section("command_interface");
  ci.RejectUnknownKeys({"lock_keep_s"});
  ci.ReadDouble("lock_keep_s", &lock.lock_keep_s, /*allow_infinity=*/true);
  const auto mux = config.Section("mux");
  mux.RejectUnknownKeys({"teleop_timeout_s", "waypoint_timeout_s"});
  mux.ReadDouble("teleop_timeout_s", &teleop_timeout_s);
  mux.ReadDouble("waypoint_timeout_s", &waypoint_timeout_s);
  NavigationOptions& n = navigation;
  const auto nav = config.Section("navigation");
  nav.RejectUnknownKeys({"cruise_speed_mps",
                         "goal_tolerance_m",
                         "blocked_timeout_s",
                         "stall_timeout_s",
                         "contact_timeout_s",
                         "carrot_distance_m",
                         "required_free_length_m",
                         "tight_free_length_m",
                         "tight_spot_deviation_rad",
                         "sensor_range_m",
                         "local_planner_period_s",
                         "obstacle_timeout_s",
                         "obstacle_lost_s",
                         "replan_check_period_s",
                         "max_path_deviation_m",
                         "joystick_turn_lookahead_s",
                         "map_half_extent_m",
                         "map_max_extent_m",
                         "map_grow_margin_m",
                         "map_grow_step_m",
                         "map_update_period_s",
                         "map_update_budget_s",
                         "obstacle_window_s",
                         "path_requests_per_s",
                         "unmapped_goal_max_replans",
                         "unmapped_goal_timeout_s",
                         "max_hold_s"});
  nav.ReadDouble("cruise_speed_mps", &n.platform.cruise_speed_mps);
  nav.ReadDouble("goal_tolerance_m", &n.goal_tolerance_m);
  nav.ReadDouble("blocked_timeout_s", &n.blocked_timeout_s);
  nav.ReadDouble("stall_timeout_s", &n.stall_timeout_s);
  nav.ReadDouble("contact_timeout_s", &contact_timeout_s);
  nav.ReadDouble("carrot_distance_m", &n.carrot_distance_m);
  nav.ReadDouble("required_free_length_m", &n.required_free_length_m);
  nav.ReadDouble("tight_free_length_m", &n.tight_free_length_m);
  nav.ReadDouble("tight_spot_deviation_rad", &n.tight_spot_deviation_rad);
  nav.ReadDouble("sensor_range_m", &n.sensor_range_m);
  nav.ReadDouble("local_planner_period_s", &n.local_planner_period_s);
  nav.ReadDouble("obstacle_timeout_s", &n.obstacle_timeout_s);
  nav.ReadDouble("obstacle_lost_s", &n.obstacle_lost_s);
  nav.ReadDouble("replan_check_period_s", &n.replan_check_period_s);
  nav.ReadDouble("max_path_deviation_m", &n.max_path_deviation_m);
  nav.ReadDouble("joystick_turn_lookahead_s", &n.joystick_turn_lookahead_s);
  nav.ReadInt("unmapped_goal_max_replans", &n.unmapped_goal_max_replans);
  nav.ReadDouble("unmapped_goal_timeout_s", &n.unmapped_goal_timeout_s);
  nav.ReadDouble("max_hold_s", &n.max_hold_s);
  nav.ReadDouble("map_half_extent_m", &nav_map.half_extent_m);
  nav.ReadDouble("map_max_extent_m", &nav_map.max_extent_m);
  nav.ReadDouble("map_grow_margin_m", &nav_map.grow_margin_m);
  nav.ReadDouble("map_grow_step_m", &nav_map.grow_step_m);
  nav.ReadDouble("map_update_period_s", &nav_map.update_period_s);
  nav.ReadDouble("map_update_budget_s", &nav_map.update_budget_s);
  nav.ReadDouble("obstacle_window_s", &obstacle_window_s);
  nav.ReadDouble("path_requests_per_s", &path_requests_per_s);
  const auto local = config.Section("local_planner");
  local.RejectUnknownKeys({"collision_margin_m", "clearance_band_m", "voxel_size_m", "goal_direction_weight",
                           "heading_change_weight", "clearance_weight", "hysteresis_weight",
                           "min_free_length_m", "library_cache_dir"});
  local.ReadDouble("collision_margin_m", &collision_margin_m);
  local.ReadString("library_cache_dir", &library_cache_dir);
  local.ReadDouble("clearance_band_m", &library.clearance_band_m);
  local.ReadDouble("voxel_size_m", &library.voxel_size_m);
  local.ReadDouble("goal_direction_weight", &n.local_planner.goal_direction_weight);
  local.ReadDouble("heading_change_weight", &n.local_planner.heading_change_weight);
  local.ReadDouble("clearance_weight", &n.local_planner.clearance_weight);
  local.ReadDouble("hysteresis_weight", &n.local_planner.hysteresis_weight);
  local.ReadDouble("min_free_length_m", &n.local_planner.min_free_length_m);
  const auto controller = config.Section("controller");
  controller.RejectUnknownKeys(
      {"horizon_steps", "dt_s", "max_iterations", "cross_track_weight", "heading_weight", "speed_weight"});
  controller.ReadInt("horizon_steps", &n.controller.horizon_steps);
  controller.ReadDouble("dt_s", &n.controller.dt_s);
  controller.ReadInt("max_iterations", &n.controller.max_iterations);
  controller.ReadDouble("cross_track_weight", &n.controller.cross_track_weight);
  controller.ReadDouble("heading_weight", &n.controller.heading_weight);
  controller.ReadDouble("speed_weight", &n.controller.speed_weight);
  auto& limits = n.platform.limits;
  const auto platform_section = config.Section("platform");
  platform_section.RejectUnknownKeys({"footprint_radius_m", "max_speed_mps", "max_reverse_speed_mps",
                                      "max_accel_mps2", "max_yaw_rate_radps", "max_yaw_accel_radps2"});
  platform_section.ReadDouble("footprint_radius_m", &n.platform.footprint_radius_m);
  platform_section.ReadDouble("max_speed_mps", &limits.max_speed_mps);
  platform_section.ReadDouble("max_reverse_speed_mps", &limits.max_reverse_speed_mps);
  platform_section.ReadDouble("max_accel_mps2", &limits.max_accel_mps2);
  platform_section.ReadDouble("max_yaw_rate_radps", &limits.max_yaw_rate_radps);
  platform_section.ReadDouble("max_yaw_accel_radps2", &limits.max_yaw_accel_radps2);
  const auto trav = config.Section("traversability");
  trav.RejectUnknownKeys({"robot_radius_m", "robot_height_m", "max_step_m"});
  trav.ReadDouble("robot_radius_m", &n.platform.traversability.robot_radius_m);
  trav.ReadDouble("robot_height_m", &n.platform.traversability.robot_height_m);
  trav.ReadDouble("max_step_m", &n.platform.traversability.max_step_m);
  const auto ex = config.Section("explore");
  ex.RejectUnknownKeys({"target_tolerance_m",   "settle_s",
                        "complete_settle_s",    "map_wait_s",
                        "min_gain_m2",          "gain_radius_m",
                        "max_cluster_extent_m", "unknown_reach_m",
                        "search_horizon_m",     "switch_utility_ratio",
                        "blacklist_radius_m",   "visited_radius_m",
                        "same_place_dz_m",      "tight_gap_stall_s",
                        "retry_after_s",        "claim_radius_m",
                        "peer_influence_m",     "claim_period_s",
                        "coverage_period_s",    "claim_lease_s",
                        "coverage_cell_m",      "levels"});
  if (std::string levels; ex.ReadString("levels", &levels), !levels.empty()) {
    using Levels = ExploreModeOptions::Levels;
    if (levels == "auto") {
      explore.levels = Levels::kAuto;
    } else if (levels == "main") {
      explore.levels = Levels::kMain;
    } else if (levels == "all") {
      explore.levels = Levels::kAll;
    } else {
      throw core::ConfigError(path + ": explore.levels = '" + levels + "' must be auto, main or all");
    }
  }
  ex.ReadDouble("target_tolerance_m", &explore.target_tolerance_m);
  ex.ReadDouble("settle_s", &explore.settle_s);
  ex.ReadDouble("complete_settle_s", &explore.complete_settle_s);
  ex.ReadDouble("map_wait_s", &explore.map_wait_s);
  ex.ReadDouble("tight_gap_stall_s", &explore.tight_gap_stall_s);
  ex.ReadDouble("min_gain_m2", &explore.frontiers.min_gain_m2);
  ex.ReadDouble("gain_radius_m", &explore.frontiers.gain_radius_m);
  ex.ReadDouble("max_cluster_extent_m", &explore.frontiers.max_cluster_extent_m);
  ex.ReadDouble("unknown_reach_m", &explore.frontiers.unknown_reach_m);
  ex.ReadDouble("search_horizon_m", &explore.frontiers.search_horizon_m, /*allow_infinity=*/true);
  ex.ReadDouble("switch_utility_ratio", &explore.explorer.switch_utility_ratio);
  ex.ReadDouble("blacklist_radius_m", &explore.explorer.blacklist_radius_m);
  ex.ReadDouble("visited_radius_m", &explore.explorer.visited_radius_m);
  ex.ReadDouble("same_place_dz_m", &explore.explorer.same_place_dz_m);
  ex.ReadDouble("retry_after_s", &explore.explorer.retry_after_s);
  ex.ReadDouble("claim_radius_m", &explore.explorer.claim_radius_m);
  ex.ReadDouble("peer_influence_m", &explore.explorer.peer_influence_m);
  ex.ReadDouble("claim_period_s", &explore.team.claim_period_s);
  ex.ReadDouble("coverage_period_s", &explore.team.coverage_period_s);
  ex.ReadDouble("claim_lease_s", &explore.team.lease_s);
  ex.ReadDouble("coverage_cell_m", &explore.team.coverage_cell_m);
  const auto pe_section = config.Section("peers");
  pe_section.RejectUnknownKeys(
      {"rate_hz", "timeout_s", "margin_m", "prediction_s", "same_level_dz_m", "avoid"});
  pe_section.ReadDouble("rate_hz", &peers.rate_hz);
  pe_section.ReadDouble("timeout_s", &peers.timeout_s);
  pe_section.ReadDouble("margin_m", &peers.margin_m);
  pe_section.ReadDouble("prediction_s", &peers.prediction_s);
  pe_section.ReadDouble("same_level_dz_m", &peers.same_level_dz_m);
  pe_section.ReadBool("avoid", &peers.avoid);
  const auto convoy_section = config.Section("convoy");
  convoy_section.RejectUnknownKeys(
      {"spacing_m", "hold_band_m", "breadcrumb_step_m", "gap_gain_per_s", "lost_after_s", "max_trail_m"});
  convoy_section.ReadDouble("spacing_m", &convoy.spacing_m);
  convoy_section.ReadDouble("hold_band_m", &convoy.hold_band_m);
  convoy_section.ReadDouble("breadcrumb_step_m", &convoy.breadcrumb_step_m);
  convoy_section.ReadDouble("gap_gain_per_s", &convoy.gap_gain_per_s);
  convoy_section.ReadDouble("lost_after_s", &convoy.lost_after_s);
  convoy_section.ReadDouble("max_trail_m", &convoy.max_trail_m);
  const auto yield_section = config.Section("yield");
  yield_section.RejectUnknownKeys({"modes", "ask_peers", "margin_m", "max_drive_m", "max_wait_s",
                                   "lookahead_m", "standoff_m", "ask_every_s"});
  std::string yield_modes;
  for (const std::string& m : yield.modes) yield_modes += (yield_modes.empty() ? "" : " ") + m;
  yield_section.ReadString("modes", &yield_modes);
  if (const std::string why = ParseYieldModes(yield_modes, &yield.modes); !why.empty())
    throw core::ConfigError(path + ": " + why);
  yield_section.ReadBool("ask_peers", &yield.ask_peers);
  yield_section.ReadDouble("margin_m", &yield.margin_m);
  yield_section.ReadDouble("max_drive_m", &yield.max_drive_m);
  yield_section.ReadDouble("max_wait_s", &yield.max_wait_s);
  yield_section.ReadDouble("lookahead_m", &yield.lookahead_m);
  yield_section.ReadDouble("standoff_m", &yield.standoff_m);
  yield_section.ReadDouble("ask_every_s", &yield.ask_every_s);
  const auto mission_section = config.Section("mission");
  mission_section.RejectUnknownKeys({"resume_within_s", "retry_every_s"});
  mission_section.ReadDouble("resume_within_s", &mission.resume_within_s);
  mission_section.ReadDouble("retry_every_s", &mission.retry_every_s);
  const auto telemetry = config.Section("telemetry");
  telemetry.RejectUnknownKeys({"state_rate_hz", "local_plan_rate_hz"});
  telemetry.ReadDouble("state_rate_hz", &state_rate_hz);
  telemetry.ReadDouble("local_plan_rate_hz", &local_plan_rate_hz);
  const auto health_section = config.Section("health");
  health_section.RejectUnknownKeys({"restart_backoff_s", "restart_backoff_max_s"});
  health_section.ReadDouble("restart_backoff_s", &restart_backoff_s);
  health_section.ReadDouble("restart_backoff_max_s", &restart_backoff_max_s);
  PerceptionOptions& pe = perception;
  const auto per = config.Section("perception");
  per.RejectUnknownKeys({"enabled", "map_resolution_m", "map_insert_period_s", "map_keyframe_distance_m",
                         "map_keyframe_angle_rad", "map_keyframe_max_interval_s", "staircase_period_s",
                         "map_coarse_levels", "map_budget_bits_per_s", "map_period_s", "camera_rate_hz",
                         "jpeg_quality", "camera_budget_bits_per_s"});
  per.ReadBool("enabled", &pe.enabled);
  per.ReadDouble("map_resolution_m", &pe.map.resolution_m);
  per.ReadDouble("map_insert_period_s", &pe.map_insert_period_s);
  per.ReadDouble("map_keyframe_distance_m", &pe.map_keyframe_distance_m);
  per.ReadDouble("map_keyframe_angle_rad", &pe.map_keyframe_angle_rad);
  per.ReadDouble("map_keyframe_max_interval_s", &pe.map_keyframe_max_interval_s);
  per.ReadDouble("staircase_period_s", &pe.staircase_period_s);
  per.ReadInt("map_coarse_levels", &pe.map_coarse_levels);
  per.ReadDouble("map_budget_bits_per_s", &pe.telemetry.budget_bits_per_s);
  per.ReadDouble("map_period_s", &pe.telemetry.period_s);
  per.ReadDouble("camera_rate_hz", &pe.camera_rate_hz);
  per.ReadInt("jpeg_quality", &pe.jpeg_quality);
  per.ReadDouble("camera_budget_bits_per_s", &pe.camera_budget_bits_per_s);
  std::string why;
  if (!IsValid(&why)) throw core::ConfigError(path + ": " + why);
}

using internal::InRange;

std::string AgentOptions::ApplyLinkBudget() {
  if (!core::IsRadioLink(link) || !perception.enabled) return "";  // without perception: no map, no camera
  std::string changed;
  const double budget_bits_per_s = link.link_kbps * 1000.0;
  const auto lower = [&](const char* name, double share, double* value) {
    const double limit = share * budget_bits_per_s;
    if (*value <= limit) return;
    changed += (changed.empty() ? "" : ", ") + std::string(name) + " " +
               std::to_string(static_cast<long>(*value)) + " -> " + std::to_string(static_cast<long>(limit)) +
               " bit/s";
    *value = limit;
  };
  lower("map telemetry", core::kRadioMapShare, &perception.telemetry.budget_bits_per_s);
  lower("camera", core::kRadioCameraShare, &perception.camera_budget_bits_per_s);
  std::string why;
  if (!perception.telemetry.IsValid(&why)) {
    throw std::invalid_argument(
        "--link-kbps " + std::to_string(link.link_kbps) + ": map telemetry's share (" +
        std::to_string(static_cast<long>(perception.telemetry.budget_bits_per_s)) +
        " bit/s) cannot carry one map message (" + why +
        "): give the radio a larger budget, or turn perception off (perception.enabled: "
        "false)");
  }
  return changed;
}

bool AgentOptions::IsValid(std::string* why) const {
  if (std::string fault = core::CheckId("robot id", robot_id); !fault.empty()) {
    *why = std::move(fault);
    return false;
  }
  if (platform != navigation.platform.name) {
    try {
      nav::GetPlatformProfile(platform);
      *why = "platform '" + platform + "' was not selected with SetPlatform()";
    } catch (const std::invalid_argument& e) {
      *why = e.what();
    }
    return false;
  }
  if (!lock.IsValid(why)) return false;
  if (!navigation.IsValid(why)) return false;
  const auto& fp = navigation.platform;
  if (!InRange("local_planner.path_length_m", library.path_length_m, 0.1, 10, false, why)) return false;
  if (!InRange("local_planner.collision_margin_m", collision_margin_m, 0, 1, false, why)) return false;
  // Combinations: fresh obstacle input must be possible, and the sensor must see as far as a local path.
  if (navigation.obstacle_timeout_s <= navigation.local_planner_period_s + 0.02) {
    *why = "navigation.obstacle_timeout_s = " + std::to_string(navigation.obstacle_timeout_s) +
           " must exceed navigation.local_planner_period_s (" +
           std::to_string(navigation.local_planner_period_s) +
           ") plus one 0.02 s control cycle, or the input is always stale";
    return false;
  }
  const double reach_m = library.path_length_m + fp.footprint_radius_m + collision_margin_m;
  if (navigation.sensor_range_m < reach_m) {
    *why = "navigation.sensor_range_m = " + std::to_string(navigation.sensor_range_m) +
           " must be at least the local path length plus the collision radius (" + std::to_string(reach_m) +
           " m), or obstacles at the end of a path are unseen";
    return false;
  }
  if (!perception.IsValid(why)) return false;
  if (!nav_map.IsValid(why)) return false;
  if (!explore.IsValid(why)) return false;
  if (!peers.IsValid(why)) return false;
  if (!convoy.IsValid(why)) return false;
  if (!yield.IsValid(why)) return false;
  if (!mission.IsValid(why)) return false;
  if (!InRange("navigation.obstacle_window_s", obstacle_window_s, 0, 30, true, why)) return false;
  if (!InRange("navigation.path_requests_per_s", path_requests_per_s, 0, 1000, true, why)) return false;
  std::string inner;
  if (!LibraryForPlatform().IsValid(&inner)) {
    *why = "local_planner: " + inner;
    return false;
  }
  return InRange("mux.teleop_timeout_s", teleop_timeout_s, 0, 60, true, why) &&
         InRange("mux.waypoint_timeout_s", waypoint_timeout_s, 0, 60, true, why) &&
         InRange("navigation.contact_timeout_s", contact_timeout_s, 0, 60, true, why) &&
         InRange("traversability.robot_radius_m", fp.traversability.robot_radius_m, fp.footprint_radius_m, 2,
                 false, why) &&
         InRange("telemetry.state_rate_hz", state_rate_hz, 0, 100, true, why) &&
         InRange("telemetry.local_plan_rate_hz", local_plan_rate_hz, 0, 20, true, why) &&
         InRange("health.restart_backoff_s", restart_backoff_s, 0, 3600, true, why) &&
         InRange("health.restart_backoff_max_s", restart_backoff_max_s, restart_backoff_s, 3600, false,
                 why) &&
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

core::PlanarPose ParseStartPose(const std::string& text) {
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
  return core::PlanarPose{values[0], values[1], values.size() == 3 ? values[2] : 0.0};
}

}  // namespace cairn::agent
