// What a basestation knows about one robot of the fleet: what the robot said of itself (its agent info, its
// latest state, behaviour-tree state, paths and health, in the RobotState vocabulary of robot_status.h) and
// what the basestation saw of its link. Filled by the basestation's DDS client (base::FleetClient), read by
// its console, events and GUI; DDS-free, so a test or another front end builds one without DDS.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/time.h"
#include "cairn_msgs.h"

namespace cairn::fleet {

/// What a robot sends in one topic class, as it reports it (cairn_msgs::LinkClassUsage).
struct ClassUsage {
  std::string topic_class;  ///< "command" | "state" | "tree" | "team" | "map" | "camera"
  double sent_kbps = 0.0;   ///< over the robot's last ~2 s, kbit/s
  std::uint64_t sent_bytes = 0;
};

/// One robot's link as this basestation sees it.
struct LinkView {
  std::string link;          ///< the robot's link class from its agent info ("" until it arrives)
  double budget_kbps = 0.0;  ///< its stated budget (radio), kbit/s; 0 = none stated
  double rtt_ms = -1.0;      ///< round trip of the last answered link probe, ms; -1 = none answered yet
  double rtt_max_ms = -1.0;  ///< worst of the last 10 answered probes, ms; -1 = none
  /// Seconds since the oldest probe sent after the last one it answered (0: none outstanding for more than
  /// the probe period): a link that stalls shows here before the robot is declared lost.
  double probe_wait_s = 0.0;
  std::uint64_t state_received = 0;  ///< state samples received since the robot was first heard
  std::uint64_t state_lost = 0;      ///< state samples its writer sent that never arrived (sequence gaps)
  double loss_pct = 0.0;             ///< state samples lost over the last 10 s, % of those sent
  std::vector<ClassUsage> usage;     ///< from its latest state, in priority order
  double sent_kbps = 0.0;            ///< sum of usage
  bool over_budget = false;          ///< budget_kbps > 0 and sent_kbps > budget_kbps
};

/// What the basestation knows about one robot.
struct RobotView {
  std::string robot_id;
  std::string platform;
  std::vector<std::string> capabilities;
  double max_speed_mps = 0.0;                   ///< from its agent info: largest forward speed (0 = unknown)
  double max_reverse_speed_mps = 0.0;           ///< largest reverse speed, a magnitude (0 = unknown)
  double max_yaw_rate_radps = 0.0;              ///< largest yaw rate, a magnitude (0 = unknown)
  double footprint_radius_m = 0.0;              ///< the disk its body fits in, metres (0 = unknown)
  std::vector<std::string> sensors;             ///< from its agent info: "lidar", "camera"
  double map_resolution_m = 0.0;                ///< voxel edge of the map it sends, metres (0 = no map)
  std::string version;                          ///< its cairn version
  bool announced = false;                       ///< its agent info arrived (capabilities above are its own)
  LinkView link;                                ///< its link as this basestation sees it (LinkMonitor)
  std::optional<cairn_msgs::RobotState> state;  ///< latest whole state with the latest pose applied
  /// The first whole state this basestation received from the robot: what it knew on arrival. The baseline
  /// of news (FleetEventDetector), so that a change between it and the detector's first look is still told.
  std::optional<cairn_msgs::RobotState> first_state;
  std::optional<cairn_msgs::BehaviorTreeState> tree;  ///< latest behavior-tree state
  std::optional<cairn_msgs::GlobalPath> global_path;  ///< global path being followed (latched)
  std::optional<cairn_msgs::LocalPlan> local_plan;    ///< latest local planner output (2 Hz)
  std::optional<cairn_msgs::AgentHealth> health;      ///< latest health of its agent's components (latched)
  core::SteadyTime last_seen{};                       ///< last agent info or state
  core::SteadyTime state_received{};                  ///< when its last whole state or pose arrived
  core::SteadyTime whole_state_received{};            ///< when its last whole state arrived
  bool lost = false;                                  ///< liveliness lost or state silent > lost_after_s
  bool left = false;                                  ///< lost because its process exited cleanly
  std::string lost_reason;
};

}  // namespace cairn::fleet
