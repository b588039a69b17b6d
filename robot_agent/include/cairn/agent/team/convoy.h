// Convoy (Sriganesh et al. 2024, § Advanced Multi-agent Coordination): followers keep behind the
// robot ahead of them on the path it actually drove, at a spacing along that path. The robot ahead's pose
// comes from its peer state (cairn/peer_state, peers.h); a follower keeps those poses as breadcrumbs (its
// trail), places itself on the trail and drives along it at the robot ahead's speed, corrected by its spacing
// error (the gap along the trail minus `spacing_m`), so that it takes the corners the robot ahead took (never
// the chord through a wall) and slows and stops with it. All positions are in the team's map frame M, metres.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

namespace cairn::agent {

/// Options of a convoy follower (config section `convoy`).
struct ConvoyOptions {
  /// Distance to keep to the robot ahead, along the path it drove, metres, [1, 50].
  double spacing_m = 3.0;
  /// Within spacing_m + this of the robot ahead the follower holds (at rest), metres, [0, 5]: it does not
  /// creep after every few centimetres the robot ahead moves.
  double hold_band_m = 0.5;
  /// The robot ahead's poses are kept this far apart along its path, metres, [0.05, 2].
  double breadcrumb_step_m = 0.2;
  /// Speed matching: the follower drives at the robot ahead's speed plus this gain times its spacing error
  /// (gap along the trail minus spacing_m), per second, [0.1, 5]; the error then decays with time constant
  /// 1 / gain (1.25 s by default), up to the platform's max speed. A follower braking to a point that moves
  /// on instead lags by its braking distance, and cannot make it up at the same speed as the robot ahead.
  double gap_gain_per_s = 0.8;
  /// The robot ahead is lost when not heard for this long, seconds, (0, 60]: the follower stops.
  double lost_after_s = 2.0;
  /// Trail kept ahead of the follower, metres, [10, 1000]: beyond it the oldest breadcrumbs go (a robot
  /// ahead that drove that far without its follower moving; the follower then drives to the nearest kept
  /// one).
  double max_trail_m = 300.0;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// What a follower does now (ConvoyTrail::Next()).
struct ConvoyDecision {
  enum class Kind {
    kHold,    ///< at the spacing (or nothing to follow yet): stay at rest
    kFollow,  ///< drive along path_M to its end
    kLost,    ///< the robot ahead was not heard for lost_after_s: stop
  };
  Kind kind = Kind::kHold;
  /// kFollow: the trail from the follower's place on it to kTargetBeyondM past the spacing point (never
  /// nearer the robot ahead than half the spacing), frame M, metres; the first point is the follower's own
  /// position.
  std::vector<Eigen::Vector3d> path_M;
  /// Distance from the follower to the robot ahead along the trail, metres (NaN before the robot ahead was
  /// heard).
  double gap_m = 0.0;
  /// kFollow: the speed to drive at, m/s, > 0 (the robot ahead's plus gap_gain_per_s x the spacing error;
  /// the caller caps it at the platform's max speed).
  double speed_mps = 0.0;
  /// Why it holds or is lost, for the operator.
  std::string reason;
};

/// The path the robot ahead drove (its breadcrumbs) and where a follower is on it. Not thread-safe.
class ConvoyTrail {
 public:
  /// @throws std::invalid_argument for invalid options (IsValid()'s message).
  explicit ConvoyTrail(const ConvoyOptions& options);

  /// The robot ahead was at `p_M` (frame M, metres) moving at `speed_mps` (its measured forward speed, m/s)
  /// at `now_s` (seconds, the follower's clock): a breadcrumb when it is breadcrumb_step_m or more from the
  /// last one. Non-finite points are ignored (a non-finite speed counts as 0).
  void OnAhead(const Eigen::Vector3d& p_M, double now_s, double speed_mps = 0.0);
  /// What the follower at `follower_M` does at `now_s`. Its place on the trail only moves forward (a trail
  /// that loops back past the follower is not taken as a shortcut); breadcrumbs behind it are dropped.
  /// It holds within spacing_m + hold_band_m of a robot ahead at rest, and whenever speed matching asks for
  /// less than kMinSpeedMps. Following, the way ends kTargetBeyondM past the spacing point (never nearer the
  /// robot ahead than half the spacing): speed matching, not braking to the way's end, keeps the spacing.
  ConvoyDecision Next(const Eigen::Vector3d& follower_M, double now_s);
  /// lost_after_s counts from `now_s`: at the start (a trail never heard is lost after lost_after_s too), and
  /// after a re-link to a new robot ahead (the trail is kept: the new one drove it too). `slots`: spacings to
  /// keep to the new robot ahead, >= 1: past k robots that fell silent, k + 1 (they may still stand in line
  /// between; a real lidar would see them, a simulated one and the peer avoidance no longer do).
  void Relinked(double now_s, int slots = 1) {
    last_heard_s_ = now_s;
    slots_ = slots < 1 ? 1 : slots;
  }

  /// True once the robot ahead (any since the start) was heard.
  bool heard() const { return heard_; }
  /// The breadcrumbs not yet passed, oldest first, frame M.
  const std::vector<Eigen::Vector3d>& trail_M() const { return trail_M_; }
  const ConvoyOptions& options() const { return options_; }

  /// A robot ahead slower than this is at rest, m/s.
  static constexpr double kAtRestMps = 0.1;
  /// Below this matched speed the follower holds, m/s.
  static constexpr double kMinSpeedMps = 0.05;
  /// The way ends this far past the spacing point, metres (see Next()). Measured through the X junction
  /// (convoy_test): with 1 m the local planner aimed at a point 1 m off and let a follower run 0.1 m aside of
  /// the robot ahead's trail, adding up along the convoy (the third follower 0.51 m off); with 1.5 m, 0.38 m.
  static constexpr double kTargetBeyondM = 1.5;

 private:
  ConvoyOptions options_;
  std::vector<Eigen::Vector3d> trail_M_;
  Eigen::Vector3d ahead_M_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  double ahead_speed_mps_ = 0.0;
  double last_heard_s_ = -1e9;
  int slots_ = 1;  // spacings to the robot followed (Relinked())
  bool heard_ = false;
};

/// Where `p` projects onto the polyline `path` in x-y: its distance to the path and the arc length of the
/// nearest point from the path's start, metres (infinity and 0 for an empty path; a single point: that
/// point).
struct PathProjection {
  double distance_m = 0.0;
  double along_m = 0.0;
};
PathProjection ProjectOntoPath2D(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p);
/// ProjectOntoPath2D(path, p).distance_m: how far a follower strayed from the path the leader drove.
double DistanceToPath2D(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p);

}  // namespace cairn::agent
