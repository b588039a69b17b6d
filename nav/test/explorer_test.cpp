// Copyright Cairn authors.
#include "cairn/nav/explorer.h"

#include <gtest/gtest.h>

#include <limits>

namespace cairn::nav {
namespace {

FrontierCluster Cluster(double x, double y, double utility, bool reachable = true) {
  FrontierCluster c;
  c.target_M = Eigen::Vector2d(x, y);
  c.centroid_M = c.target_M;
  c.cells = 10;
  c.gain_m2 = 10.0;
  c.travel_cost_m = reachable ? 5.0 : std::numeric_limits<double>::infinity();
  c.utility = reachable ? utility : 0.0;
  return c;
}

FrontierSet Set(std::vector<FrontierCluster> clusters) {
  FrontierSet set;
  set.clusters = std::move(clusters);
  set.robot_on_grid = true;
  return set;
}

TEST(ExplorerOptionsTest, DefaultsAreValidAndMessagesNameTheField) {
  std::string why;
  EXPECT_TRUE(ExplorerOptions{}.IsValid(&why)) << why;
  ExplorerOptions o;
  o.switch_utility_ratio = 0.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "ExplorerOptions::switch_utility_ratio = 0.5 must be in [1, 100]");
  EXPECT_THROW(Explorer{o}, std::invalid_argument);
}

TEST(ExplorerTest, TakesTheBestThenKeepsItUnlessAnotherIsClearlyBetter) {
  Explorer explorer;
  ExplorerDecision d = explorer.Decide(Set({Cluster(5, 0, 2.0), Cluster(0, 5, 3.0), Cluster(-5, 0, 1.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5));
  EXPECT_EQ(d.reason, "best of 3 reachable frontiers");
  ASSERT_TRUE(explorer.current().has_value());

  // The map grew: the current frontier moved 0.8 m and another is 1.3 times as good: keep going.
  d = explorer.Decide(Set({Cluster(5, 0, 4.0), Cluster(0, 5.8, 3.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kKeep);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5.8));
  // Twice as good: switch.
  d = explorer.Decide(Set({Cluster(5, 0, 6.0), Cluster(0, 6.0, 3.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(5, 0));
  EXPECT_EQ(d.reason, "a frontier 2.00 times as worth it as the current one");
  // The current frontier is gone (explored): the best of the rest.
  d = explorer.Decide(Set({Cluster(-5, 0, 1.0), Cluster(0, -5, 0.5)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(-5, 0));
}

TEST(ExplorerTest, AFailedTargetIsNeverTriedAgainAndExplorationCompletesWhenNothingIsLeft) {
  Explorer explorer;
  ExplorerDecision d = explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(0, 5, 1.0)}));
  ASSERT_EQ(d.target.target_M, Eigen::Vector2d(5, 0));
  explorer.Fail("no path: a 0.9 m doorway, narrower than the robot");
  EXPECT_FALSE(explorer.current().has_value());
  ASSERT_EQ(explorer.failed().size(), 1u);
  EXPECT_EQ(explorer.failed()[0].reason, "no path: a 0.9 m doorway, narrower than the robot");
  // The same frontier, moved 1 m, is still barred; the other one is taken.
  d = explorer.Decide(Set({Cluster(6, 0, 3.0), Cluster(0, 5, 1.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5));
  explorer.Fail("blocked: no progress for 10 s");
  // Nothing else is left: the better of the two given up on once is retried before its time (a completion
  // would leave both behind for good); it is kept as the map grows, and a second failure there bars it for
  // good.
  const FrontierSet left =
      Set({Cluster(6, 0, 3.0), Cluster(0, 5.5, 1.0), Cluster(20, 20, 0, /*reachable=*/false)});
  d = explorer.Decide(left);
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(6, 0));
  EXPECT_EQ(d.reason, "a frontier given up on once, retried before its time: no other reachable frontier");
  d = explorer.Decide(Set({Cluster(6.3, 0, 3.0), Cluster(0, 5.5, 1.0)}));
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kKeep);
  explorer.Fail("no path: a 0.9 m doorway, still");
  d = explorer.Decide(left);
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5.5));
  explorer.Fail("blocked again");
  d = explorer.Decide(left);
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kComplete);
  EXPECT_EQ(d.reason,
            "exploration complete: no reachable frontier (1 seen but unreachable, 2 given up on, 0 reached "
            "but still "
            "unseen beyond)");
  EXPECT_FALSE(explorer.current().has_value());
  d = explorer.Decide(Set({}));
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kComplete);
  EXPECT_EQ(d.reason, "exploration complete: no reachable frontier");
  explorer.Fail("ignored: no current target");
  EXPECT_EQ(explorer.failed().size(), 2u);
}

// A failed frontier is barred for retry_after_s while others are left, then tried once more, and barred for
// good after a second failure.
TEST(ExplorerTest, AFailedTargetIsRetriedOnceAfterAWhileThenBarredForGood) {
  Explorer explorer;
  ExplorerDecision d =
      explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(-5, 0, 1.0)}), TeamView{"r1", 10.0, {}});
  ASSERT_EQ(d.target.target_M, Eigen::Vector2d(5, 0));
  explorer.Fail("no path: the map showed no way", 10.0);
  d = explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(-5, 0, 1.0)}), TeamView{"r1", 100.0, {}});
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(-5, 0)) << "barred for 120 s";
  d = explorer.Decide(Set({Cluster(5.2, 0, 3.0), Cluster(-5, 0, 1.0)}), TeamView{"r1", 131.0, {}});
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo) << "the map may show a way now";
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(5.2, 0));
  explorer.Fail("no path: still none", 140.0);
  ASSERT_EQ(explorer.failed().size(), 1u);
  EXPECT_EQ(explorer.failed()[0].failures, 2);
  EXPECT_EQ(explorer.failed()[0].reason, "no path: still none");
  d = explorer.Decide(Set({Cluster(5, 0, 3.0)}), TeamView{"r1", 5000.0, {}});
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kComplete) << "never retried forever";
}

// Claims: a frontier a peer claimed first is the peer's; of two claims as old, the smaller id's; a robot
// whose every reachable frontier is claimed waits instead of completing.
TEST(ExplorerTest, APeersOlderClaimWinsAndAllClaimedMeansWait) {
  Explorer explorer;
  TeamView team{"r2", 50.0, {{"r1", Eigen::Vector2d(5, 0.5), 10.0}}};
  ExplorerDecision d = explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(0, 5, 1.0)}), team);
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5)) << "r1 claimed (5, 0.5) first";
  // r3 has just claimed the same frontier as r2 holds for 20 s: r2 keeps it.
  team = TeamView{"r2", 70.0, {{"r1", Eigen::Vector2d(5, 0.5), 30.0}, {"r3", Eigen::Vector2d(0, 5.5), 0.2}}};
  d = explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(0, 5, 1.0)}), team);
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kKeep);
  // A frontier a peer claimed, however recently, is never taken, whatever the ids.
  Explorer r3;
  d = r3.Decide(Set({Cluster(0, 5, 1.0)}), TeamView{"r3", 0.0, {{"r2", Eigen::Vector2d(0, 5), 0.3}}});
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kWait);
  EXPECT_EQ(d.reason, "every reachable frontier (1) is claimed by a peer (r2): waiting");
  Explorer r1;
  d = r1.Decide(Set({Cluster(0, 5, 1.0)}), TeamView{"r1", 0.0, {{"r2", Eigen::Vector2d(0, 5.1), 0.0}}});
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kWait) << "r1 < r2, but r2 claimed it first";
  // Two robots chose one frontier at once (before either heard the other): both hold it 0.3 s; the smaller id
  // keeps it and the other leaves it.
  Explorer a, b;
  ASSERT_EQ(a.Decide(Set({Cluster(0, 5, 1.0)}), TeamView{"r1", 0.0, {}}).kind, ExplorerDecision::Kind::kGoTo);
  ASSERT_EQ(b.Decide(Set({Cluster(0, 5, 1.0)}), TeamView{"r2", 0.0, {}}).kind, ExplorerDecision::Kind::kGoTo);
  std::string by;
  EXPECT_FALSE(a.CurrentClaimedByPeer(TeamView{"r1", 0.3, {{"r2", Eigen::Vector2d(0, 5), 0.3}}}, &by));
  EXPECT_TRUE(b.CurrentClaimedByPeer(TeamView{"r2", 0.3, {{"r1", Eigen::Vector2d(0, 5), 0.3}}}, &by));
  EXPECT_EQ(by, "r1");
  // The robot's own claim is never a peer's.
  Explorer self;
  d = self.Decide(Set({Cluster(0, 5, 1.0)}), TeamView{"r1", 0.0, {{"r1", Eigen::Vector2d(0, 5), 9.0}}});
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
}

// Coordination: a frontier near a peer's claim (within peer_influence_m, here 10 m) is worth less, so a robot
// takes one farther away that is otherwise worth less.
TEST(ExplorerTest, AFrontierNearAPeersClaimIsWorthLess) {
  const FrontierSet set = Set({Cluster(4, 0, 2.0), Cluster(15, 0, 1.0)});
  Explorer alone;
  EXPECT_EQ(alone.Decide(set).target.target_M, Eigen::Vector2d(4, 0));
  ExplorerOptions coordinated;
  coordinated.peer_influence_m = 10.0;
  Explorer teammate(coordinated);
  const ExplorerDecision d = teammate.Decide(set, TeamView{"r2", 0.0, {{"r1", Eigen::Vector2d(0, 0), 5.0}}});
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(15, 0))
      << "(4, 0) is worth 2.0 * 4 / 10 = 0.8 next to r1's target";
  EXPECT_NEAR(d.target.utility, 1.0, 1e-12);
}

// A frontier the robot stood on and whose unknown stayed unseen (below its lidar's lowest beam) is not driven
// to again; one farther than visited_radius_m from it is.
TEST(ExplorerTest, AReachedTargetIsNotDrivenToAgain) {
  Explorer explorer;
  ExplorerDecision d = explorer.Decide(Set({Cluster(5, 0, 3.0), Cluster(0, 5, 1.0)}));
  ASSERT_EQ(d.target.target_M, Eigen::Vector2d(5, 0));
  explorer.Reached();
  EXPECT_FALSE(explorer.current().has_value());
  ASSERT_EQ(explorer.visited().size(), 1u);
  d = explorer.Decide(Set({Cluster(5.5, 0, 3.0), Cluster(0, 5, 1.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_M, Eigen::Vector2d(0, 5));
  explorer.Reached();
  d = explorer.Decide(Set({Cluster(5.5, 0, 3.0), Cluster(0, 5.2, 1.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kComplete);
  EXPECT_EQ(d.reason,
            "exploration complete: no reachable frontier (0 seen but unreachable, 0 given up on, 2 reached "
            "but still "
            "unseen beyond)");
  d = explorer.Decide(Set({Cluster(7, 0, 3.0)}));
  EXPECT_EQ(d.kind, ExplorerDecision::Kind::kGoTo) << "2 m from a reached target: a new frontier";
  explorer.Reached();
  explorer.Reached();  // no current target: nothing more
  EXPECT_EQ(explorer.visited().size(), 3u);
}

// Places on different levels are different places: the pocket under a landing reached, and the landing 1.6 m
// above it failed, bar neither the landing nor the floor above; at the same height they do.
TEST(ExplorerTest, ReachedAndFailedTargetsBarOnlyTheirOwnLevel) {
  auto at_height = [](FrontierCluster c, double z_m) {
    c.target_ground_z_m = z_m;
    return c;
  };
  Explorer explorer;
  ExplorerDecision d = explorer.Decide(Set({Cluster(22.5, 7.2, 3.0)}));  // the pocket, z 0
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  explorer.Reached();
  EXPECT_EQ(explorer.visited().at(0), Eigen::Vector3d(22.5, 7.2, 0.0));
  d = explorer.Decide(Set({at_height(Cluster(22.6, 7.0, 2.0), 1.6), Cluster(22.6, 7.0, 1.0)}));
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_ground_z_m, 1.6) << "the landing above the pocket is a new place";
  explorer.Fail("no path: the flight is not on the map yet", 10.0);
  EXPECT_EQ(explorer.failed().at(0).target_ground_z_m, 1.6);
  d = explorer.Decide(Set({at_height(Cluster(22.6, 7.1, 2.0), 1.7), at_height(Cluster(22.6, 7.1, 1.0), 3.2)}),
                      {"r1", 20.0, {}});
  ASSERT_EQ(d.kind, ExplorerDecision::Kind::kGoTo);
  EXPECT_EQ(d.target.target_ground_z_m, 3.2) << "the landing is barred, floor 2 above it is not";
  d = explorer.Decide(Set({at_height(Cluster(22.6, 7.1, 2.0), 1.7)}), {"r1", 30.0, {}});
  EXPECT_EQ(d.reason, "a frontier given up on once, retried before its time: no other reachable frontier")
      << "the landing, 0.1 m off, is the failed place";
  ExplorerOptions bad;
  bad.same_place_dz_m = 0.0;
  std::string why;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("same_place_dz_m"), std::string::npos) << why;
}

}  // namespace
}  // namespace cairn::nav
