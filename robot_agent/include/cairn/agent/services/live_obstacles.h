// The local planner's obstacles from the live lidar: the points seen within the last `window_s` (the agent's
// obstacle_window_s),
// and, for as long as they stay there (up to 10 min), those under the lidar's lowest beam near the robot (a
// deduplicated perception::LocalCloud around the robot) analysed by nav::ObstaclesFromPoints. Used by the
// agent's sensor thread and by in-process tests and benches, so all sense exactly alike. Not thread-safe.
#pragma once

#include <algorithm>
#include <limits>
#include <vector>

#include "cairn/core/platform_io.h"
#include "cairn/nav/navigation.h"
#include "cairn/nav/scan_obstacles.h"
#include "cairn/perception/staircase.h"

namespace cairn::agent {

class LiveObstacles {
 public:
  /// `navigation`: the sensor range and the platform's step and height; `window_s`: how long a point seen is
  /// kept, seconds. `lidar_min_elevation_rad`: the platform's lowest lidar beam (core::PlatformCapabilities;
  /// NaN: unknown), under which points near the robot stay in memory while they stay under it (no scan can
  /// show them again nor clear them; up to kBlindWindow_s) instead of `window_s`: the robot does not forget a
  /// step it drove up to, however long it stands there. Once it moves so that they are in view again, the
  /// short window applies (a ghost goes, a real step is seen again).
  LiveObstacles(const nav::NavigationOptions& navigation, double window_s,
                double lidar_min_elevation_rad = std::numeric_limits<double>::quiet_NaN())
      : cloud_(CloudOptions(navigation, window_s, lidar_min_elevation_rad)) {
    obstacle_options_.range_m = navigation.sensor_range_m;
    obstacle_options_.max_step_m = navigation.platform.traversability.max_step_m;
    obstacle_options_.robot_height_m = navigation.platform.traversability.robot_height_m;
  }

  /// Forgets every point a new scan can show again (recovery: "clear the local obstacle memory"): a ghost
  /// (dust, a person who walked on) goes, a step in the lidar's blind zone beside the robot stays.
  void Clear() { cloud_.ForgetVisible(); }

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
  // The longest time a point under the lowest beam is kept, seconds (LocalCloudOptions' largest): a robot
  // waiting beside a step while another robot climbs (30 s was too short for that).
  static constexpr double kBlindWindow_s = 600.0;

  static perception::LocalCloudOptions CloudOptions(const nav::NavigationOptions& navigation, double window_s,
                                                    double lidar_min_elevation_rad) {
    perception::LocalCloudOptions o;
    o.voxel_size_m = 0.05;
    o.window_s = window_s;
    o.blind_below_elevation_rad = lidar_min_elevation_rad;
    o.blind_window_s = std::max(o.window_s, kBlindWindow_s);
    o.radius_m = std::max(1.0, navigation.sensor_range_m + 0.5);
    return o;
  }

  perception::LocalCloud cloud_;
  nav::ScanObstacleOptions obstacle_options_;
};

}  // namespace cairn::agent
