// Copyright Cairn authors.
//
// The exploration target choice (issue 14): from the frontiers of the robot's map (FindFrontiers), which one to
// drive to now, when to switch to a better one as the map grows, which ones failed and must not be tried again,
// and when exploration is complete. Pure logic, DDS-free: the agent's explore mode feeds it each new frontier
// set and tells it when navigation gave up on a target.
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
  /// A failed target bars clusters whose target lies within this of it, metres, (0, 20].
  double blacklist_radius_m = 1.5;
  /// A target the robot reached bars clusters whose target lies within this of it, metres, (0, 20]: what
  /// is still unknown behind a frontier the robot stood on is out of its lidar's sight from there (below its
  /// lowest beam, behind a corner), and driving there again would show nothing new.
  double visited_radius_m = 1.0;

  /// True when every field is in range; otherwise false with `*why` (if not null) naming the field, its value
  /// and the rule.
  bool IsValid(std::string* why) const;
};

/// A target navigation gave up on, and why.
struct FailedTarget {
  Eigen::Vector2d target_M = Eigen::Vector2d::Zero();
  std::string reason;
};

/// What to do after a frontier update.
struct ExplorerDecision {
  enum class Kind {
    kGoTo,      ///< drive to `target` (new, or a better one than the current)
    kKeep,      ///< keep driving to the current target (it moved at most follow_radius_m: `target` is where it is now)
    kComplete,  ///< no reachable frontier is left: exploration ends (`reason` says so and why)
  };
  Kind kind = Kind::kComplete;
  FrontierCluster target;  ///< the cluster to go to (kGoTo, kKeep)
  std::string reason;      ///< why: "best of 4 reachable frontiers", "exploration complete: no reachable frontier ..."
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
  /// exploration is complete.
  ExplorerDecision Decide(const FrontierSet& set);

  /// Navigation gave up on the current target (no path, blocked): it is barred for good (a frontier seen
  /// across a gap the robot cannot cross, a doorway too narrow) with `reason`, and there is no current
  /// target any more.
  void Fail(const std::string& reason);
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
  /// Targets reached so far, oldest first.
  const std::vector<Eigen::Vector2d>& visited() const { return visited_; }
  const ExplorerOptions& options() const { return options_; }

 private:
  bool Barred(const Eigen::Vector2d& target_M) const;
  bool Visited(const Eigen::Vector2d& target_M) const;

  ExplorerOptions options_;
  std::optional<FrontierCluster> current_;
  std::vector<FailedTarget> failed_;
  std::vector<Eigen::Vector2d> visited_;
};

}  // namespace cairn::nav
