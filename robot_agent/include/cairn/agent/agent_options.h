// Options of one cairn_agent process: command line plus the YAML config file (config/agent.yaml).
#pragma once

#include <optional>
#include <string>

#include "cairn/agent/control_lock.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/unicycle.h"

namespace cairn::agent {

/// Everything that configures one robot agent. Defaults are valid (tested).
struct AgentOptions {
  // From the command line.
  std::string robot_id;                           ///< required; [A-Za-z0-9_-]{1,64}
  std::string world = "builtin:tunnels";          ///< world spec: builtin:NAME, a .bt or a .pcd path
  std::optional<sim::PlanarPose> start_W;         ///< start pose (m, m, rad) in W
  /// Start slot K (when no start_W): the K-th suggested start of a builtin world, or the K-th of a fixed
  /// seeded sample of free starts >= 2 m apart in other worlds. None = a free cell chosen from the robot id.
  std::optional<int> start_slot;
  std::string platform = "wheeled";               ///< "wheeled" | "legged"
  int domain_id = 0;                              ///< DDS domain [0, 232]
  std::string dds_profiles_file;                  ///< "" = core::DefaultProfilesFile()
  std::string mode_tree_file;                     ///< "" = config/mode_tree.xml of the source tree
  double pcd_resolution_m = 0.1;                  ///< voxel size when the world is a PCD cloud, (0.02, 2]

  // From the config file.
  ControlLockOptions lock;
  double teleop_timeout_s = 0.5;      ///< (0, 60]
  double waypoint_timeout_s = 0.5;    ///< (0, 60]
  double cruise_speed_mps = 0.6;      ///< (0, platform max speed]
  double goal_tolerance_m = 0.2;      ///< (0, 5]
  double lookahead_m = 0.6;           ///< (0, 5]
  double blocked_timeout_s = 10.0;    ///< (0, 600]
  double contact_timeout_s = 1.0;     ///< (0, 60]
  double footprint_radius_m = 0.3;    ///< collision disk of the body, (0, 2]
  double robot_radius_m = 0.3;        ///< planning inflation, [footprint_radius_m, 2]
  double robot_height_m = 0.8;        ///< (0, 5]
  double max_step_m = 0.15;           ///< [0, 1]
  double state_rate_hz = 10.0;        ///< (0, 100]
  sim::UnicycleLimits limits;         ///< platform preset, then overridden by the config file

  /// Reads a YAML config file over the current values. @throws core::ConfigError naming file, field, value.
  void LoadConfigFile(const std::string& path);

  /// @return false and sets `*why` (field, value, rule) when any field is invalid.
  bool IsValid(std::string* why) const;
};

/// Parses --start: "X,Y" or "X,Y,YAW" (metres, metres, radians) into options->start_W, or "slot:K" (K in
/// [0, 99]) into options->start_slot. @throws std::invalid_argument naming the value.
void ParseStart(const std::string& text, AgentOptions* options);
/// Parses "X,Y" or "X,Y,YAW". @throws std::invalid_argument naming the value.
sim::PlanarPose ParseStartPose(const std::string& text);

}  // namespace cairn::agent
