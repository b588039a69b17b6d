// Copyright Cairn authors.
//
// The exploration target choice: from the frontiers of the robot's map (FindFrontiers), which one
// to drive to now, when to switch to a better one as the map grows, which ones failed and must not be tried
// again, and when exploration is complete. Pure logic, DDS-free: the agent's explore mode feeds it each new
// frontier set and tells it when navigation gave up on a target.
//
// Frame M (the robot's map frame), metres.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "cairn/nav/frontier.h"

namespace cairn::nav {

/// Options of Explorer.
struct ExplorerOptions {
  /// A new frontier replaces the current target only when its utility is this many times the current one's,
  /// [1, 100]: the robot does not turn back and forth between two frontiers of about the same worth.
  double switch_utility_ratio = 1.5;
  /// The current target is still there when a cluster's target lies within this of it, metres, (0, 10]: the
  /// frontier moves a little as the map grows around it.
  double follow_radius_m = 1.5;
  /// A failed target bars clusters whose target lies within this of it, metres, (0, 20]...
  double blacklist_radius_m = 1.5;
  /// ...for this long after its first failure (the map around it may show a way later; sooner when no
  /// other frontier is left, see Explorer::Decide()), and for good after a second failure there, seconds,
  /// [0, 3600].
  double retry_after_s = 120.0;
  /// A target the robot reached bars clusters whose target lies within this of it, metres, (0, 20]: what
  /// is still unknown behind a frontier the robot stood on is out of its lidar's sight from there (below its
  /// lowest beam, behind a corner), and driving there again would show nothing new.
  double visited_radius_m = 1.0;
  /// A cluster whose target lies within this of a peer's claim is that peer's (unless this robot has held it
  /// longer), metres, (0, 50]: two robots never drive to the same frontier.
  double claim_radius_m = 3.0;
  /// A cluster's utility is scaled by d / peer_influence_m (at least 0.05) when its target lies d < this from
  /// a peer's claim (Burgard et al. 2005: what the peer will see from there is worth less here), so that the
  /// team spreads over the map instead of following one another, metres, [0, 200]; 0 = off. With it off,
  /// three robots in builtin:tunnels drove about the same 150 m each and reached 90 % only 1.64x sooner than
  /// one; with 10 m, 3.0x (docs/PERFORMANCE.md, "Exploration coverage"). An early version cost two robots in
  /// a region 88 % against 99 %; since the robots' planning is waited for on the simulated clock, that region
  /// test gives 100 % either way.
  double peer_influence_m = 10.0;
  /// Two targets are one place (for the current target, the failed and the reached ones) only when their
  /// ground heights differ by at most this, metres, (0, 10]: the landing over the pocket beneath it, a floor
  /// above another. Compared in x-y alone, the pocket reached barred the landing above it and a legged robot
  /// in builtin:building never climbed.
  double same_place_dz_m = 1.0;

  /// True when every field is in range; otherwise false with `*why` (if not null) naming the field, its value
  /// and the rule.
  bool IsValid(std::string* why) const;
};

/// A peer robot's claim on the frontier it drives to (ExploreClaim on the wire): its target and how long it
/// has held it. The caller leaves out claims that expired (a robot lost, or no longer exploring).
struct PeerClaim {
  std::string robot_id;
  Eigen::Vector2d target_M = Eigen::Vector2d::Zero();  ///< metres, frame M (shared by the team)
  double held_s = 0.0;                                 ///< seconds
};

/// The team as one robot sees it when it decides.
struct TeamView {
  std::string own_id;             ///< this robot's id: ties between claims of equal age go to the smaller id
  double now_s = 0.0;             ///< this robot's clock, seconds (how long it has held its own target)
  std::vector<PeerClaim> claims;  ///< the peers' live claims
};

/// A target navigation gave up on, and why.
struct FailedTarget {
  Eigen::Vector2d target_M = Eigen::Vector2d::Zero();
  double target_ground_z_m = 0.0;  ///< its ground height, metres, frame M
  std::string reason;              ///< the last failure's
  int failures = 1;                ///< failures within blacklist_radius_m of target_M
  double failed_at_s = 0.0;        ///< the last one's time (TeamView::now_s), seconds
};

/// What to do after a frontier update.
struct ExplorerDecision {
  enum class Kind {
    kGoTo,  ///< drive to `target` (new, or a better one than the current)
    kKeep,  ///< keep driving to the current target (it moved at most follow_radius_m: `target` is where it is
            ///< now)
    kComplete,  ///< no reachable frontier is left: exploration ends (`reason` says so and why)
    kWait,      ///< every reachable frontier is a peer's: hold still and decide again with the next set
  };
  Kind kind = Kind::kComplete;
  FrontierCluster target;  ///< the cluster to go to (kGoTo, kKeep)
  std::string
      reason;  ///< why: "best of 4 reachable frontiers", "exploration complete: no reachable frontier ..."
};

/// See the file comment. Not thread-safe.
class Explorer {
 public:
  /// @throws std::invalid_argument if `options` is invalid.
  explicit Explorer(ExplorerOptions options = {});

  /// Chooses what to do with the frontiers `set` (FindFrontiers on the latest map). Clusters that cannot be
  /// reached or lie within blacklist_radius_m of a failed target are left out; of the others the one with the
  /// highest utility is taken, unless the current target is still there and the best is not
  /// switch_utility_ratio times better; reached targets (visited_radius_m) are left out too. With none left,
  /// the best cluster barred only until its retry (one failure there) is retried at once; with none of those
  /// either, exploration is complete.
  /// With `team`: a cluster within claim_radius_m of a peer's claim is left to the peer, however fresh the
  /// claim, unless it is this robot's current target: then the peer wins when it has held its claim longer,
  /// or as long (within 0.5 s: two robots chose at once, before either heard the other) and its id is
  /// smaller. When only such clusters are left, the decision is kWait. Utilities are discounted near peers'
  /// claims (peer_influence_m); the decision's target carries the discounted one.
  ExplorerDecision Decide(const FrontierSet& set, const TeamView& team = {});
  /// True when a peer's claim in `team` takes the current target from this robot (as Decide() would see it);
  /// `*by` names the peer. The caller drops the target then, at once, instead of at the next frontier set.
  bool CurrentClaimedByPeer(const TeamView& team, std::string* by) const {
    return current_ && ClaimedByPeer(*current_, true, team, by);
  }
  /// How long the current target has been held at `now_s` (the team's clock), seconds; 0 without one.
  double HeldS(double now_s) const { return current_ ? now_s - current_since_s_ : 0.0; }

  /// Navigation gave up on the current target at `now_s` (no path, blocked) with `reason`: clusters near it
  /// are barred for retry_after_s, for good after a second failure there (a frontier seen across a gap the
  /// robot cannot cross, a doorway too narrow: never retried forever); there is no current target any more.
  void Fail(const std::string& reason, double now_s = 0.0);
  /// The robot reached the current target (it stands at that frontier): clusters within visited_radius_m of
  /// it are left out from now on, and there is no current target any more.
  void Reached();
  /// The current target is given up by the caller, without blame (e.g. the operator stopped the robot): the
  /// next Decide() chooses afresh.
  void ClearTarget() { current_.reset(); }

  /// The current target, if any.
  const std::optional<FrontierCluster>& current() const { return current_; }
  /// Targets barred so far, oldest first.
  const std::vector<FailedTarget>& failed() const { return failed_; }
  /// Targets reached so far (x, y, ground z; metres, frame M), oldest first.
  const std::vector<Eigen::Vector3d>& visited() const { return visited_; }
  const ExplorerOptions& options() const { return options_; }

 private:
  // True when clusters `a` and a place at `b_M`, ground height `b_z_m`, lie within `radius_m` in x-y and
  // same_place_dz_m in height.
  bool SamePlace(const FrontierCluster& a, const Eigen::Vector2d& b_M, double b_z_m, double radius_m) const;
  enum class Bar { kNone, kUntilRetry, kForGood };
  // Whether `c` lies near a failed target at `now_s`: barred until retry_after_s after one failure there, for
  // good after two.
  Bar Barred(const FrontierCluster& c, double now_s) const;
  bool Visited(const FrontierCluster& c) const;
  // Decide()'s pass over the clusters: the best candidate, the one followed (near the current target), the
  // best of those barred only until their retry, and why the others are no candidates.
  struct Tally {
    const FrontierCluster* best = nullptr;
    const FrontierCluster* followed = nullptr;
    const FrontierCluster* retry = nullptr;
    int candidates = 0, unreachable = 0, barred = 0, visited = 0, claimed = 0;
    std::vector<std::string> claimers;  // peers whose claims took frontiers, in order
  };
  Tally Classify(const std::vector<FrontierCluster>& clusters, const TeamView& team) const;
  // The decision on a tally (updates the current target).
  ExplorerDecision Choose(const Tally& tally, const TeamView& team);

  ExplorerOptions options_;
  // True when a peer's claim takes `c` from this robot (see Decide()).
  bool ClaimedByPeer(const FrontierCluster& c, bool is_current, const TeamView& team, std::string* by) const;
  std::optional<FrontierCluster> current_;
  double current_since_s_ = 0.0;
  std::vector<FailedTarget> failed_;
  std::vector<Eigen::Vector3d> visited_;
};

}  // namespace cairn::nav
