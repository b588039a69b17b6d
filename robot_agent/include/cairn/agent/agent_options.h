// Options of one cairn_agent process: command line plus the YAML config file (config/agent.yaml).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/command/control_lock.h"
#include "cairn/agent/journal.h"
#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mission.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/agent/team/convoy.h"
#include "cairn/agent/team/peers.h"
#include "cairn/agent/team/yield.h"
#include "cairn/core/kinematics.h"
#include "cairn/core/link_options.h"
#include "cairn/nav/local_planner.h"
#include "cairn/nav/navigation.h"
#include "cairn/perception/perception_pipeline.h"

namespace cairn::agent {

/// Everything that configures one robot agent. Defaults are valid (tested).
struct AgentOptions {
  // From the command line.
  std::string robot_id;  ///< required; [A-Za-z0-9_-]{1,64}
  // The simulated platform's (cairn_agent --world/--start/--pcd-resolution; main.cpp hands them to
  // sim::SimulatedPlatform). The autonomy itself never reads them.
  std::string world = "builtin:tunnels";    ///< world spec: builtin:NAME, a .bt or a .pcd path
  std::optional<core::PlanarPose> start_W;  ///< start pose (m, m, rad) in W
  /// Start slot K (when no start_W): the K-th suggested start of a builtin world, or the K-th of a fixed
  /// seeded sample of free starts >= 2 m apart in other worlds. None = a free cell chosen from the robot id.
  std::optional<int> start_slot;
  std::string platform = "wheeled";  ///< "wheeled" | "legged"; set with SetPlatform()
  int domain_id = 0;                 ///< DDS domain [0, 232]
  std::string dds_profiles_file;     ///< "" = core::DefaultProfilesFile()
  core::LinkOptions link;            ///< loopback (default) or a named lan (core::LinkOptions)
  core::SecurityOptions security;    ///< DDS Security (--secure DIR), off by default
  std::string mode_tree_file;        ///< "" = config/mode_tree.xml of the source tree
  double pcd_resolution_m = 0.1;     ///< voxel size when the world is a PCD cloud, (0.02, 2]
  std::string map_save_path;         ///< "" = none; else the robot's map is saved here (.bt) at exit
  /// The journal's folder (--journal): the last known safe state, kept while the robot runs; "" = none.
  std::string journal_dir;
  double journal_map_every_s = 10.0;  ///< map snapshots into the journal, seconds, > 0
  /// The journal read at start (--resume, main.cpp): the robot comes up idle with its lock, its map and its
  /// old goal offered. Unset: a fresh start.
  std::optional<JournalEntry> resumed;
  /// Run by a supervisor that starts it again (--supervise: SuperviseAgent sets CAIRN_SUPERVISED in its
  /// child, main.cpp): a component whose work does not stop when asked ends the process for a restart from
  /// the journal (RobotAgent::restart_requested()); otherwise the component stays down and the operator is
  /// told.
  bool supervised = false;
  /// Test hook (--inject-fault COMPONENT:throw|hang:AFTER_S, agent_components.h): faults to inject, checked
  /// at start (ParseFaultInjection).
  std::vector<std::string> inject_faults;

  // From the config file.
  ControlLockOptions lock;
  double teleop_timeout_s = 0.5;    ///< (0, 60]
  double waypoint_timeout_s = 0.5;  ///< (0, 60]; also the smart_joystick channel's staleness
  double contact_timeout_s = 1.0;   ///< (0, 60]
  double state_rate_hz = 10.0;      ///< (0, 100]
  /// A failed or stalled component waits this long before its first restart, seconds, (0, 3600]; the wait
  /// doubles with each failure in a row up to restart_backoff_max_s, [restart_backoff_s, 3600].
  double restart_backoff_s = 1.0;
  double restart_backoff_max_s = 30.0;
  double local_plan_rate_hz = 2.0;  ///< local plan display messages, (0, 20]
  /// Navigation: platform profile (set from `platform` by SetPlatform(), then overridden by the config
  /// file's platform and traversability sections), local planner scoring, iLQR, mission timing.
  nav::NavigationOptions navigation;
  /// Explore mode: frontier search, target choice, timing (robot_id is filled in by the agent).
  ExploreModeOptions explore;
  /// Peers: how often this robot tells them where it is, and how it keeps clear of them (config `peers`).
  PeerOptions peers;
  /// Convoy: a follower's spacing to the robot ahead and when it counts it lost (config `convoy`).
  ConvoyOptions convoy;
  /// Get-out-of-the-way: the modes in which this robot yields, and how it asks peers (config `yield`).
  YieldOptions yield;
  /// Missions a transient condition paused: how long the robot keeps them (config `mission`).
  MissionOptions mission;
  /// Local planner library: collision radius = footprint + collision_margin_m; the heading range comes
  /// from the platform profile.
  nav::TrajectoryLibraryOptions library = DefaultLibraryOptions();
  double collision_margin_m = 0.03;  ///< [0, 1], metres added to the footprint for the local planner
  /// Folder of built trajectory libraries (trajectory_library_cache.h): "" = $XDG_CACHE_HOME/cairn or
  /// $HOME/.cache/cairn; "off" = build at every start.
  std::string library_cache_dir;
  /// Perception: mapping, staircases, map telemetry and camera frames (section `perception`).
  perception::PerceptionOptions perception;
  /// The navigation map on the robot's own OctoMap (section `navigation`, keys map_*).
  NavMapOptions nav_map;
  /// Live lidar obstacles: points seen within this many seconds feed the local planner, (0, 30]. Long enough
  /// to remember the ground next to the robot, which a lidar above it sees only from a distance.
  double obstacle_window_s = 3.0;
  /// Path requests answered per second per requesting process (token bucket, burst twice this), (0, 1000].
  /// A flood beyond it gets one "rate limited" answer a second and is otherwise dropped.
  double path_requests_per_s = 10.0;

  /// Library options used by default: 0.05 m correspondence voxels (the conservative voxel test then adds
  /// only 0.035 m to the collision radius, so the robot still threads 0.8 m gaps).
  static nav::TrajectoryLibraryOptions DefaultLibraryOptions();
  /// Selects the built-in profile of `name` ("wheeled" | "legged") into `platform` and navigation.platform.
  /// @throws std::invalid_argument naming the value and the valid names.
  void SetPlatform(const std::string& name);
  /// Library options for the current platform (heading range, collision radius filled in).
  nav::TrajectoryLibraryOptions LibraryForPlatform() const;

  /// Reads a YAML config file over the current values. @throws core::ConfigError naming file, field, value.
  void LoadConfigFile(const std::string& path);

  /// @return false and sets `*why` (field, value, rule) when any field is invalid.
  bool IsValid(std::string* why) const;

  /// On a radio link (link.link == "radio") with perception on, lowers map telemetry's budget to
  /// core::kRadioMapShare and the camera's to core::kRadioCameraShare of link.link_kbps (never raises them).
  /// @return what changed, or "". @throws std::invalid_argument naming --link-kbps when map telemetry's share
  /// cannot carry one map message.
  std::string ApplyLinkBudget();
};

/// Parses --start: "X,Y" or "X,Y,YAW" (metres, metres, radians) into options->start_W, or "slot:K" (K in
/// [0, 99]) into options->start_slot. @throws std::invalid_argument naming the value.
void ParseStart(const std::string& text, AgentOptions* options);
/// Parses "X,Y" or "X,Y,YAW". @throws std::invalid_argument naming the value.
core::PlanarPose ParseStartPose(const std::string& text);

}  // namespace cairn::agent
