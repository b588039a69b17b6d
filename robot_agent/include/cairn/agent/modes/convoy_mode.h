// Convoy mode: a follower drives behind the robot ahead of it in a convoy, on the path that robot
// drove (ConvoyTrail), through navigation's local planner and controller (Navigation::AcceptGoal with the
// trail as the global path, StepWaypoint), so that peers and live obstacles are avoided as in waypoint mode.
// It drives at the robot ahead's speed plus a gain times its spacing error (ConvoyTrail::Next), so that it
// slows and stops with the robot ahead, and tracks the trail itself while no obstacle is near it
// (StepWaypoint's follow_path: no corner cutting that would add up along the convoy).
//
// The robots ahead are given nearest first (the one followed, then the one ahead of it, ... the leader). When
// the one followed is not heard for lost_after_s, the follower re-links to the nearest one further ahead that
// is heard (it drove the same trail) and says so, keeping a spacing for each robot it re-linked past (a
// silent robot may still be in line); with none heard it stops, lost. A follower whose navigation gives up
// (blocked) stops too; it tries again once its target has moved on.
#pragma once

#include <string>
#include <vector>

#include "cairn/agent/modes/mode_module.h"
#include "cairn/agent/team/convoy.h"
#include "cairn/agent/team/peers.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

/// How a follower stands (RobotState and the operator's view).
struct ConvoyStatus {
  enum class State {
    kNone,       ///< not in a convoy
    kFollowing,  ///< driving after the robot ahead
    kHolding,    ///< at the spacing (or waiting to hear the robot ahead): at rest
    kLost,       ///< no robot ahead heard: stopped
    kBlocked,    ///< navigation gave up on the way: stopped until the target moves on
    kPaused,     ///< the robot's mission is paused (a part of it down): at rest, the trail still extended
  };
  State state = State::kNone;
  std::string ahead_id;                ///< the robot followed now
  std::vector<std::string> ahead_ids;  ///< the robots ahead, nearest first (the leader last)
  double gap_m = 0.0;                  ///< along the trail to the robot followed, metres (NaN: unknown)
  std::string reason;                  ///< why it holds, is lost or blocked; the last re-link
};

const char* ToString(ConvoyStatus::State state);

/// The convoy mode module. Not thread-safe (the agent calls it under its lock, on its control thread).
class ConvoyMode : public ModeModule {
 public:
  static constexpr const char* kName = "convoy";
  static constexpr const char* kChannel = "convoy";

  /// `navigation` (not owned) outlives this. `channel_timeout_s`: the convoy channel's staleness, seconds.
  /// @throws std::invalid_argument for a null navigation or invalid options.
  ConvoyMode(const ConvoyOptions& options, double channel_timeout_s, nav::Navigation* navigation);

  /// Follows `ahead_ids` (the robots ahead, nearest first, the leader last; ids unique, not `own_id`) from
  /// `now_s` on: with a new trail, or, already in a convoy and re-linked to one of the robots that were ahead
  /// (one peeled off), with the trail kept (it drove it). "" or why not (naming the id).
  std::string Start(const std::string& own_id, const std::vector<std::string>& ahead_ids, double now_s);
  /// The peers heard lately (PeerTracker::Live()) at `now_s`: the robot followed extends the trail; a lost
  /// one is replaced by the nearest one further ahead that is heard.
  void SetPeers(const std::vector<Peer>& peers, double now_s);
  /// Keeps this robot's place in the convoy while its mission is paused (MissionKeeper): `ahead_ids` as
  /// status().ahead_ids was when it paused, the trail kept and still extended by SetPeers, so that Start with
  /// the same robots ahead resumes on it. The status goes to kPaused with "paused: `why`".
  void Pause(const std::vector<std::string>& ahead_ids, const std::string& why);
  /// Leaves the convoy: the goal is dropped, the status goes to kNone with `why`.
  void Deactivate(const std::string& why) override;
  /// One control cycle: hold (zero twist), lost (zero twist), or a navigation step toward the target.
  ModeOutput Step(const ModeInputs& in) override;
  bool uses_local_planner() const override { return true; }

  const ConvoyStatus& status() const { return status_; }
  /// The trail being followed (breadcrumbs not yet passed), frame M.
  const std::vector<Eigen::Vector3d>& trail_M() const { return trail_.trail_M(); }
  /// True while in a convoy (started or paused, not deactivated).
  bool active() const { return status_.state != ConvoyStatus::State::kNone; }

  /// The target is handed to navigation again when it moved this far from the last one, metres.
  static constexpr double kRefreshM = 0.3;

 private:
  ModeOutput Stop(ConvoyStatus::State state, const std::string& reason, const ModeInputs& in);
  // Drops the target it handed to navigation, if navigation still holds it (Navigation::ClearGoal(serial)).
  void DropGoal();

  ConvoyOptions options_;
  nav::Navigation* navigation_;
  ConvoyTrail trail_;
  ConvoyStatus status_;
  Eigen::Vector2d goal_M_ = Eigen::Vector2d::Zero();  // the target last handed to navigation
  bool has_goal_ = false;
  int skipped_ = 0;  // robots ahead re-linked past since the operator's last order (silent ones)
  std::uint64_t goal_serial_ = 0;  // Navigation::goal_serial() of that target
  // kBlocked: where the target was when navigation failed; retried once it moves kBlockedRetryM from there.
  Eigen::Vector2d blocked_at_M_ = Eigen::Vector2d::Zero();
};

}  // namespace cairn::agent
