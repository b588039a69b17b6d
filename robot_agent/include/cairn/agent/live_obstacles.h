// The local planner's obstacles from the live lidar: the points seen within AgentOptions::obstacle_window_s
// (a deduplicated perception::LocalCloud around the robot) analysed by nav::ObstaclesFromPoints. Used by the
// agent's sensor thread and by in-process benches, so both sense exactly alike. Not thread-safe.
#pragma once

#include <algorithm>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/core/platform_io.h"
#include "cairn/nav/scan_obstacles.h"
#include "cairn/perception/staircase.h"

namespace cairn::agent {

class LiveObstacles {
 public:
  explicit LiveObstacles(const AgentOptions& options) : cloud_(CloudOptions(options)) {
    obstacle_options_.range_m = options.navigation.sensor_range_m;
    obstacle_options_.max_step_m = options.navigation.platform.traversability.max_step_m;
    obstacle_options_.robot_height_m = options.navigation.platform.traversability.robot_height_m;
  }

  /// Forgets every point seen so far (recovery: "clear the local obstacle memory").
  void Clear() { cloud_.Clear(); }

  /// Adds `scan` and fills `points_B` with the obstacles in the body frame of the scan's pose, which goes to
  /// `pose_M` (map frame). Throws what ObstaclesFromPoints throws.
  void AddScan(const core::LidarScan& scan, std::vector<Eigen::Vector3f>* points_B, core::BaseState* pose_M) {
    cloud_.AddScan(scan.points_S, scan.T_MS, scan.stamp_s);
    core::PoseEstimate at_scan;
    at_scan.T_MB = scan.T_MS * scan.T_BS.inverse();
    *pose_M = at_scan.PlanarState();
    nav::ObstaclesFromPoints(cloud_.Points(), *pose_M, obstacle_options_, points_B);
  }

 private:
  static perception::LocalCloudOptions CloudOptions(const AgentOptions& options) {
    perception::LocalCloudOptions o;
    o.voxel_size_m = 0.05;
    o.window_s = options.obstacle_window_s;
    o.radius_m = std::max(1.0, options.navigation.sensor_range_m + 0.5);
    return o;
  }

  perception::LocalCloud cloud_;
  nav::ScanObstacleOptions obstacle_options_;
};

}  // namespace cairn::agent
