#include "cairn/agent/agent_options.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "cairn/core/config.h"
#include "cairn/core/peer_input.h"
#include "cairn/core/range_check.h"

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

namespace {

using core::ConfigField;
using core::ConfigSection;

void ReadNavigation(const ConfigSection& config, AgentOptions* o) {
  nav::NavigationOptions& n = o->navigation;
  config.Section("navigation")
      .ReadFields({{"cruise_speed_mps", &n.platform.cruise_speed_mps},
                   {"goal_tolerance_m", &n.goal_tolerance_m},
                   {"blocked_timeout_s", &n.blocked_timeout_s},
                   {"stall_timeout_s", &n.stall_timeout_s},
                   {"contact_timeout_s", &o->contact_timeout_s},
                   {"carrot_distance_m", &n.carrot_distance_m},
                   {"required_free_length_m", &n.required_free_length_m},
                   {"tight_free_length_m", &n.tight_free_length_m},
                   {"tight_spot_deviation_rad", &n.tight_spot_deviation_rad},
                   {"sensor_range_m", &n.sensor_range_m},
                   {"local_planner_period_s", &n.local_planner_period_s},
                   {"obstacle_timeout_s", &n.obstacle_timeout_s},
                   {"obstacle_lost_s", &n.obstacle_lost_s},
                   {"replan_check_period_s", &n.replan_check_period_s},
                   {"max_path_deviation_m", &n.max_path_deviation_m},
                   {"joystick_turn_lookahead_s", &n.joystick_turn_lookahead_s},
                   {"unmapped_goal_max_replans", &n.unmapped_goal_max_replans},
                   {"unmapped_goal_timeout_s", &n.unmapped_goal_timeout_s},
                   {"max_hold_s", &n.max_hold_s},
                   {"map_half_extent_m", &o->nav_map.half_extent_m},
                   {"map_max_extent_m", &o->nav_map.max_extent_m},
                   {"map_grow_margin_m", &o->nav_map.grow_margin_m},
                   {"map_grow_step_m", &o->nav_map.grow_step_m},
                   {"map_update_period_s", &o->nav_map.update_period_s},
                   {"map_update_budget_s", &o->nav_map.update_budget_s},
                   {"obstacle_window_s", &o->obstacle_window_s},
                   {"path_requests_per_s", &o->path_requests_per_s}});
  nav::LocalPlannerOptions& local = n.local_planner;
  config.Section("local_planner")
      .ReadFields({{"collision_margin_m", &o->collision_margin_m},
                   {"library_cache_dir", &o->library_cache_dir},
                   {"clearance_band_m", &o->library.clearance_band_m},
                   {"voxel_size_m", &o->library.voxel_size_m},
                   {"goal_direction_weight", &local.goal_direction_weight},
                   {"heading_change_weight", &local.heading_change_weight},
                   {"clearance_weight", &local.clearance_weight},
                   {"hysteresis_weight", &local.hysteresis_weight},
                   {"min_free_length_m", &local.min_free_length_m}});
  nav::IlqrOptions& controller = n.controller;
  config.Section("controller")
      .ReadFields({{"horizon_steps", &controller.horizon_steps},
                   {"dt_s", &controller.dt_s},
                   {"max_iterations", &controller.max_iterations},
                   {"cross_track_weight", &controller.cross_track_weight},
                   {"heading_weight", &controller.heading_weight},
                   {"speed_weight", &controller.speed_weight}});
  core::VelocityLimits& limits = n.platform.limits;
  config.Section("platform")
      .ReadFields({{"footprint_radius_m", &n.platform.footprint_radius_m},
                   {"max_speed_mps", &limits.max_speed_mps},
                   {"max_reverse_speed_mps", &limits.max_reverse_speed_mps},
                   {"max_accel_mps2", &limits.max_accel_mps2},
                   {"max_yaw_rate_radps", &limits.max_yaw_rate_radps},
                   {"max_yaw_accel_radps2", &limits.max_yaw_accel_radps2}});
  nav::TraversabilityOptions& trav = n.platform.traversability;
  config.Section("traversability")
      .ReadFields({{"robot_radius_m", &trav.robot_radius_m},
                   {"robot_height_m", &trav.robot_height_m},
                   {"max_step_m", &trav.max_step_m}});
}

void ReadExplore(const ConfigSection& config, const std::string& path, ExploreModeOptions* explore) {
  std::string levels;
  nav::FrontierOptions& frontiers = explore->frontiers;
  nav::ExplorerOptions& explorer = explore->explorer;
  config.Section("explore").ReadFields(
      {{"levels", &levels},
       {"target_tolerance_m", &explore->target_tolerance_m},
       {"settle_s", &explore->settle_s},
       {"complete_settle_s", &explore->complete_settle_s},
       {"map_wait_s", &explore->map_wait_s},
       {"tight_gap_stall_s", &explore->tight_gap_stall_s},
       {"min_gain_m2", &frontiers.min_gain_m2},
       {"gain_radius_m", &frontiers.gain_radius_m},
       {"max_cluster_extent_m", &frontiers.max_cluster_extent_m},
       {"unknown_reach_m", &frontiers.unknown_reach_m},
       {"search_horizon_m", &frontiers.search_horizon_m, /*allow_infinity_in=*/true},
       {"viewpoint_radius_m", &frontiers.viewpoint_radius_m},
       {"switch_utility_ratio", &explorer.switch_utility_ratio},
       {"blacklist_radius_m", &explorer.blacklist_radius_m},
       {"visited_radius_m", &explorer.visited_radius_m},
       {"same_place_dz_m", &explorer.same_place_dz_m},
       {"retry_after_s", &explorer.retry_after_s},
       {"claim_radius_m", &explorer.claim_radius_m},
       {"peer_influence_m", &explorer.peer_influence_m},
       {"claim_period_s", &explore->team.claim_period_s},
       {"coverage_period_s", &explore->team.coverage_period_s},
       {"claim_lease_s", &explore->team.lease_s},
       {"coverage_cell_m", &explore->team.coverage_cell_m}});
  using Levels = ExploreModeOptions::Levels;
  if (levels.empty()) return;
  if (levels == "auto") {
    explore->levels = Levels::kAuto;
  } else if (levels == "main") {
    explore->levels = Levels::kMain;
  } else if (levels == "all") {
    explore->levels = Levels::kAll;
  } else {
    throw core::ConfigError(path + ": explore.levels = '" + levels + "' must be auto, main or all");
  }
}

// Peers, convoy, get out of the way, missions across interruptions.
void ReadTeam(const ConfigSection& config, const std::string& path, AgentOptions* o) {
  PeerOptions& peers = o->peers;
  config.Section("peers").ReadFields({{"rate_hz", &peers.rate_hz},
                                      {"timeout_s", &peers.timeout_s},
                                      {"margin_m", &peers.avoidance.margin_m},
                                      {"prediction_s", &peers.avoidance.prediction_s},
                                      {"same_level_dz_m", &peers.avoidance.same_level_dz_m},
                                      {"avoid", &peers.avoidance.avoid}});
  ConvoyOptions& convoy = o->convoy;
  config.Section("convoy").ReadFields({{"spacing_m", &convoy.spacing_m},
                                       {"hold_band_m", &convoy.hold_band_m},
                                       {"breadcrumb_step_m", &convoy.breadcrumb_step_m},
                                       {"gap_gain_per_s", &convoy.gap_gain_per_s},
                                       {"lost_after_s", &convoy.lost_after_s},
                                       {"max_trail_m", &convoy.max_trail_m}});
  YieldOptions& yield = o->yield;
  std::string yield_modes;
  for (const std::string& m : yield.modes) yield_modes += (yield_modes.empty() ? "" : " ") + m;
  config.Section("yield").ReadFields({{"modes", &yield_modes},
                                      {"ask_peers", &yield.ask_peers},
                                      {"margin_m", &yield.margin_m},
                                      {"max_drive_m", &yield.max_drive_m},
                                      {"max_wait_s", &yield.max_wait_s},
                                      {"lookahead_m", &yield.lookahead_m},
                                      {"standoff_m", &yield.standoff_m},
                                      {"ask_every_s", &yield.ask_every_s}});
  if (const std::string why = ParseYieldModes(yield_modes, &yield.modes); !why.empty())
    throw core::ConfigError(path + ": " + why);
  config.Section("mission").ReadFields(
      {{"resume_within_s", &o->mission.resume_within_s}, {"retry_every_s", &o->mission.retry_every_s}});
}

void ReadPerception(const ConfigSection& config, perception::PerceptionOptions* pe) {
  config.Section("perception")
      .ReadFields({{"enabled", &pe->enabled},
                   {"map_resolution_m", &pe->map.resolution_m},
                   {"map_insert_period_s", &pe->map_insert_period_s},
                   {"map_keyframe_distance_m", &pe->map_keyframe_distance_m},
                   {"map_keyframe_angle_rad", &pe->map_keyframe_angle_rad},
                   {"map_keyframe_max_interval_s", &pe->map_keyframe_max_interval_s},
                   {"staircase_period_s", &pe->staircase_period_s},
                   {"map_coarse_levels", &pe->map_coarse_levels},
                   {"map_budget_bits_per_s", &pe->telemetry.budget_bits_per_s},
                   {"map_period_s", &pe->telemetry.period_s},
                   {"camera_rate_hz", &pe->camera_rate_hz},
                   {"jpeg_quality", &pe->jpeg_quality},
                   {"camera_budget_bits_per_s", &pe->camera_budget_bits_per_s}});
}

}  // namespace

void AgentOptions::LoadConfigFile(const std::string& path) {
  const auto config = ConfigSection::LoadFile(path);
  config.RejectUnknownKeys({"command_interface", "mux", "navigation", "local_planner", "controller",
                            "platform", "traversability", "telemetry", "perception", "explore", "peers",
                            "convoy", "yield", "mission", "health", "simulation",
                            "ros2"});  // the simulated platform's (sim::SimulatedPlatformOptions) and the ROS
                                       // 2 driver's (ros2::Ros2PlatformOptions)
  config.Section("command_interface")
      .ReadFields({{"lock_keep_s", &lock.lock_keep_s, /*allow_infinity_in=*/true},
                   {"handover_request_timeout_s", &lock.handover_request_timeout_s}});
  config.Section("mux").ReadFields(
      {{"teleop_timeout_s", &teleop_timeout_s}, {"waypoint_timeout_s", &waypoint_timeout_s}});
  ReadNavigation(config, this);
  ReadExplore(config, path, &explore);
  ReadTeam(config, path, this);
  config.Section("telemetry")
      .ReadFields({{"state_rate_hz", &state_rate_hz}, {"local_plan_rate_hz", &local_plan_rate_hz}});
  config.Section("health").ReadFields(
      {{"restart_backoff_s", &restart_backoff_s}, {"restart_backoff_max_s", &restart_backoff_max_s}});
  ReadPerception(config, &perception);
  std::string why;
  if (!IsValid(&why)) throw core::ConfigError(path + ": " + why);
}

using core::InRange;

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
