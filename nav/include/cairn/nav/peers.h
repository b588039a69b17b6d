// Peer robots as obstacles (Sriganesh et al. 2024, § Advanced Multi-agent Coordination): every robot tells
// the others where it is, how big it is and where it is going, and each keeps clear of the bodies it hears. A
// simulated robot's lidar does not see its peers (each agent simulates its own world), and a real one sees a
// peer only once it is in line of sight and near: the peer's own word covers both. This is the geometry of
// it, free of how the word travels (the agent's team/peers.h hears it over DDS). Peers share the team's map
// frame M.
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "cairn/core/kinematics.h"

namespace cairn::nav {

/// How a robot keeps clear of its peers (config section `peers`; the field names in errors are its keys).
struct PeerAvoidanceOptions {
  /// Peers are kept clear of by their footprint radius plus this, metres, [0, 2]: room for the error of two
  /// pose estimates.
  double margin_m = 0.25;
  /// A moving peer's body is also placed where it will be after up to this long at its speed and yaw rate,
  /// seconds, [0, 5]: two robots meeting head-on each see the other's next second.
  double prediction_s = 1.0;
  /// Peers within this height of the robot block it, metres, (0, 10]: a robot on the floor above does not.
  double same_level_dz_m = 1.0;
  /// False: peers are heard (and shown) but not avoided.
  bool avoid = true;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// A peer robot's body as it last described itself, frame M.
struct PeerBody {
  std::string robot_id;
  core::BaseState pose_M;           ///< x, y, z, yaw (metres, radians); v_mps and w_radps as measured
  double footprint_radius_m = 0.0;  ///< (0, 5]
  /// The next metres of the global path it follows, frame M (metres, z the ground); empty: none.
  std::vector<Eigen::Vector3d> path_ahead_M;
};

/// Spacing of the points of PeerBody.path_ahead_M, metres, and their largest number (the IDL's bound).
inline constexpr double kPeerPathSpacingM = 1.0;
inline constexpr int kPeerPathPoints = 16;

/// The path `path_M` (frame M, metres) ahead of `from_M` (x, y): from the point of the path nearest `from_M`,
/// points `spacing_m` (> 0) apart along it (the last one its end), at most `max_points`. Empty for an empty
/// path.
std::vector<Eigen::Vector3d> PathAhead(const std::vector<Eigen::Vector3d>& path_M,
                                       const Eigen::Vector2d& from_M, double spacing_m, int max_points);

/// "" when `peer`'s body is usable, else why not, naming the field and value: an empty id, coordinates not
/// finite or beyond 1e6 m, |yaw| > 10 rad, |v| or |w| > 20, a footprint radius outside (0, 5].
std::string CheckPeerBody(const PeerBody& peer);

/// Obstacle points standing for `peers` around a robot at `state` (frame M), expressed in the robot's body
/// frame B at height `z_B_m` (metres; inside the local planner's obstacle band): points 0.1 m apart (at most
/// 64 per circle) on a circle of the peer's footprint radius plus `options.margin_m` around where it is and
/// where it will be in options.prediction_s (half and whole, for a peer moving faster than 0.05 m/s, on its
/// current arc). Peers more than options.same_level_dz_m above or below the robot, or whose circles lie
/// wholly beyond `range_m` of it, give none. Appends to `*points_B`.
void AppendPeerObstacles(const std::vector<PeerBody>& peers, const core::BaseState& state, double range_m,
                         double z_B_m, const PeerAvoidanceOptions& options,
                         std::vector<Eigen::Vector3f>* points_B);

}  // namespace cairn::nav
