// Convoy: the follower's trail (ConvoyTrail) on made-up paths, and a leader driven by waypoints
// through builtin:tunnels' X junction with three followers behind it, every robot the shipping agent stepped
// on a simulated clock in process (RobotAgent::Stepped over an InProcessTeam: the operator's commands through
// the command interface, peer states at 5 Hz as over cairn/peer_state). The convoy over real processes and
// DDS is tests/convoy_integration_test (when the operator's commands exist).

#include "cairn/agent/team/convoy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "agent_team.h"
#include "cairn/agent/modes/convoy_mode.h"
#include "cairn/nav/platform.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using team_testing::AgentTeam;

// Feeds `trail` the robot ahead driving `path` (metres, frame M) at 1 m/s from t = 0, one pose per 0.1 s;
// returns the time of the last pose.
double DriveAhead(ConvoyTrail* trail, const std::vector<Eigen::Vector3d>& path) {
  double t = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const double d = (path[i + 1] - path[i]).norm();
    for (double s = 0; s < d; s += 0.1, t += 0.1)
      trail->OnAhead(path[i] + (s / d) * (path[i + 1] - path[i]), t);
  }
  trail->OnAhead(path.back(), t);
  return t;
}

TEST(ConvoyTrailTest, BadOptionsAreNamed) {
  ConvoyOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.spacing_m = 0.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("convoy.spacing_m = 0.5"), std::string::npos) << why;
  o = ConvoyOptions{};
  o.lost_after_s = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("convoy.lost_after_s"), std::string::npos) << why;
  EXPECT_THROW(ConvoyTrail{o}, std::invalid_argument);
}

// Around an L corner the follower's way goes through the corner the robot ahead drove, never the chord, and
// ends kTargetBeyondM past the spacing point (1.5 m short of the robot ahead along it); the speed asked is
// the gain times the spacing error (the robot ahead at rest).
TEST(ConvoyTrailTest, TheWayFollowsTheDrivenCornerAndEndsAtTheSpacing) {
  ConvoyTrail trail(ConvoyOptions{});
  const double t = DriveAhead(&trail, {{0, 0, 0}, {10, 0, 0}, {10, 10, 0}});
  const ConvoyDecision c = trail.Next({-1, 0, 0}, t);
  ASSERT_EQ(c.kind, ConvoyDecision::Kind::kFollow) << c.reason;
  // Breadcrumbs 0.2 m apart cut a corner by less than 0.1 m of length.
  EXPECT_NEAR(c.gap_m, 21.0, 0.1);
  ASSERT_GE(c.path_M.size(), 3u);
  EXPECT_NEAR((c.path_M.back() - Eigen::Vector3d(10, 8.5, 0)).norm(), 0.0, 0.1)
      << c.path_M.back().transpose();
  EXPECT_NEAR(c.speed_mps, ConvoyOptions{}.gap_gain_per_s * (c.gap_m - 3.0), 1e-9);
  const std::vector<Eigen::Vector3d> driven = {{-1, 0, 0}, {0, 0, 0}, {10, 0, 0}, {10, 10, 0}};
  for (const Eigen::Vector3d& p : c.path_M) EXPECT_LT(DistanceToPath2D(driven, p), 0.01) << p.transpose();
  // The corner is on the way: some point within a breadcrumb of (10, 0).
  EXPECT_TRUE(std::any_of(c.path_M.begin(), c.path_M.end(), [](const Eigen::Vector3d& p) {
    return (p - Eigen::Vector3d(10, 0, 0)).norm() < 0.2;
  }));
}

// Within spacing + hold band it holds; the robot ahead not heard for lost_after_s is lost, as is one never
// heard after lost_after_s from the start.
TEST(ConvoyTrailTest, HoldsAtTheSpacingAndIsLostWhenTheRobotAheadFallsSilent) {
  ConvoyTrail trail(ConvoyOptions{});
  trail.Relinked(0.0);
  ConvoyDecision c = trail.Next({0, 0, 0}, 1.0);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kHold);
  EXPECT_TRUE(std::isnan(c.gap_m));
  c = trail.Next({0, 0, 0}, 2.5);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kLost) << "never heard within lost_after_s";

  const double t = DriveAhead(&trail, {{0, 0, 0}, {3.3, 0, 0}});
  c = trail.Next({0, 0, 0}, t);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kHold) << c.reason;
  EXPECT_NEAR(c.gap_m, 3.3, 0.05);
  // Moving, the robot ahead is followed as soon as speed matching asks for a speed: 3.3 m at its 0.5 m/s.
  trail.OnAhead({3.3, 0, 0}, t, 0.5);
  c = trail.Next({0, 0, 0}, t);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kFollow) << c.reason;
  EXPECT_NEAR(c.speed_mps, 0.5 + 0.8 * 0.3, 0.05);
  // Too close (2.3 m) behind one that moves slowly: hold (the matched speed is below kMinSpeedMps).
  trail.OnAhead({3.3, 0, 0}, t, 0.1);
  c = trail.Next({1, 0, 0}, t);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kHold) << c.speed_mps;
  trail.OnAhead({4.0, 0, 0}, t + 0.1);
  c = trail.Next({0, 0, 0}, t + 0.1);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kFollow) << "4 m > 3 + 0.5";
  c = trail.Next({0, 0, 0}, t + 0.1 + 2.05);
  EXPECT_EQ(c.kind, ConvoyDecision::Kind::kLost);
  EXPECT_NE(c.reason.find("not heard for 2.0 s"), std::string::npos) << c.reason;
}

// A trail that turns back past the follower (a U through a side passage) is not a shortcut: the gap is along
// the trail, 22 m, not the 2 m straight across.
TEST(ConvoyTrailTest, ATrailLoopingBackPastTheFollowerIsNotAShortcut) {
  ConvoyTrail trail(ConvoyOptions{});
  const double t = DriveAhead(&trail, {{0, 0, 0}, {10, 0, 0}, {10, 2, 0}, {0, 2, 0}});
  const ConvoyDecision c = trail.Next({0, 0, 0}, t);
  ASSERT_EQ(c.kind, ConvoyDecision::Kind::kFollow);
  EXPECT_NEAR(c.gap_m, 22.0, 0.2);  // two corners, each cut by less than 0.1 m
  EXPECT_NEAR((c.path_M.back() - Eigen::Vector3d(1.5, 2, 0)).norm(), 0.0, 0.2) << c.path_M.back().transpose();
}

// An order a follower cannot take (a basestation's ConvoyRequest, through the command interface) is refused
// naming the id, and the robot stays out of convoy mode.
TEST(ConvoyModeTest, ABadOrderIsRefusedNamingTheId) {
  AgentTeam team("builtin:tunnels", {{"r2", {11.0, 20.0, 0.0}}});
  EXPECT_EQ(team.Follow(0, {}), "a convoy follower needs the robot ahead of it");
  EXPECT_EQ(team.Follow(0, {"r2"}), "robot r2 cannot follow itself");
  EXPECT_EQ(team.Follow(0, {"r1", "r0", "r1"}), "robot r1 is named twice ahead of r2");
  const std::string why = team.Follow(0, {"r1", "r\x1b[2J"});
  EXPECT_NE(why.find("robot id 'r?[2J'"), std::string::npos) << why;
  EXPECT_FALSE(team.modes(0).convoy().active());
}

// ---- The convoy through the X junction ------------------------------------------------------------------

// Wheeled robots r1, r2, ... in builtin:tunnels at `starts` (frame W = M at the start), the agents stepped in
// process.
std::unique_ptr<AgentTeam> MakeTeam(const std::vector<core::PlanarPose>& starts) {
  std::vector<std::pair<std::string, core::PlanarPose>> named;
  named.reserve(starts.size());
  for (const core::PlanarPose& start : starts)
    named.emplace_back("r" + std::to_string(named.size() + 1), start);
  return std::make_unique<AgentTeam>("builtin:tunnels", named);
}

struct ConvoyRun {
  std::vector<Eigen::Vector3d> leader_driven;  // the leader's true positions, 5 cm apart
  std::vector<double> spacing_error_m;  // on straight stretches, every follower, every 0.1 s, moving or not
  double worst_deviation_m = 0;         // a follower's true position from the leader's driven path
  Eigen::Vector3d worst_deviation_at_M = Eigen::Vector3d::Zero();  // where, and which follower (z: its index)
  double closest_m = std::numeric_limits<double>::infinity();      // any two robots' centres
  bool contact = false;
  bool leader_arrived = false;
  std::vector<ConvoyStatus> end_status;  // the followers' at the end
  std::vector<double> end_gap_m;         // consecutive robots along the driven path, at the end
  double wall_s = 0;
};

// Arc length of the projection of `p` onto `path` (x-y), metres.
double AlongPath(const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& p) {
  return ProjectOntoPath2D(path, p).along_m;
}

// Leader r1 at `starts[0]` drives by waypoints through `goals`; r2.. follow it in that order (the operator's
// convoy commands). Every robot steps at 50 Hz simulated and sends its peer state at 5 Hz, as the agent does.
// Runs until the leader arrived at its last goal and `settle_s` more, or `timeout_s`.
ConvoyRun RunConvoy(const std::vector<core::PlanarPose>& starts, const std::vector<Eigen::Vector2d>& goals,
                    double settle_s, double timeout_s) {
  const auto wall_start = std::chrono::steady_clock::now();
  ConvoyRun run;
  std::unique_ptr<AgentTeam> team = MakeTeam(starts);
  std::vector<std::string> ids;
  for (std::size_t i = 0; i < starts.size(); ++i) ids.push_back("r" + std::to_string(i + 1));
  // The convoy sits on the tunnel's centre line: its driven path starts at the last follower.
  run.leader_driven = {{starts.back().x_m, starts.back().y_m, 0.0}, {starts[0].x_m, starts[0].y_m, 0.0}};
  for (std::size_t i = 1; i < team->size(); ++i) {
    std::vector<std::string> ahead(ids.rbegin() + static_cast<std::ptrdiff_t>(ids.size() - i), ids.rend());
    EXPECT_EQ(team->Follow(i, ahead), "");
  }
  std::size_t next_goal = 0;
  double arrived_at_s = -1;
  for (int cycle = 1; team->now_s() < timeout_s; ++cycle) {
    if (!team->modes(0).waypoint().has_goal() && next_goal < goals.size()) {
      EXPECT_EQ(team->Goto(0, goals[next_goal].x(), goals[next_goal].y()), "") << "goal " << next_goal;
      ++next_goal;
    }
    team->StepOnce();
    std::vector<Eigen::Vector3d> at;
    for (std::size_t i = 0; i < team->size(); ++i) {
      const sim::UnicycleState s = team->truth(i);
      at.emplace_back(s.x_m, s.y_m, 0.0);
    }
    if ((at[0] - run.leader_driven.back()).head<2>().norm() >= 0.05) run.leader_driven.push_back(at[0]);
    for (std::size_t i = 0; i < at.size(); ++i) {
      for (std::size_t j = i + 1; j < at.size(); ++j)
        run.closest_m = std::min(run.closest_m, (at[i] - at[j]).head<2>().norm());
    }
    if (cycle % 5 == 0) {
      for (std::size_t i = 1; i < at.size(); ++i) {
        const double deviation = DistanceToPath2D(run.leader_driven, at[i]);
        if (deviation > run.worst_deviation_m) {
          run.worst_deviation_m = deviation;
          run.worst_deviation_at_M = {at[i].x(), at[i].y(), static_cast<double>(i)};
        }
        // Straight stretches: both robots more than 2 m from the junction's centre (the corner).
        const Eigen::Vector2d junction(30.0, 20.0);
        if ((at[i].head<2>() - junction).norm() > 2.0 && (at[i - 1].head<2>() - junction).norm() > 2.0) {
          const double gap = AlongPath(run.leader_driven, at[i - 1]) - AlongPath(run.leader_driven, at[i]);
          run.spacing_error_m.push_back(gap - ConvoyOptions{}.spacing_m);
        }
      }
    }
    if (next_goal == goals.size() && !team->modes(0).waypoint().has_goal() && arrived_at_s < 0) {
      arrived_at_s = team->now_s();
      run.leader_arrived = team->modes(0).waypoint().goal().status == GoalStatus::kArrived;
    }
    if (arrived_at_s >= 0 && team->now_s() >= arrived_at_s + settle_s) break;
  }
  for (std::size_t i = 0; i < team->size(); ++i) {
    run.contact = run.contact || team->ever_in_contact(i);
    if (i == 0) continue;
    run.end_status.push_back(team->modes(i).convoy().status());
    const sim::UnicycleState a = team->truth(i - 1), b = team->truth(i);
    run.end_gap_m.push_back(AlongPath(run.leader_driven, {a.x_m, a.y_m, 0}) -
                            AlongPath(run.leader_driven, {b.x_m, b.y_m, 0}));
  }
  run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  return run;
}
// Three followers behind a leader driven by waypoints from the main tunnel through the X junction into the
// north branch: on straight stretches every follower keeps within 1 m of the 3 m spacing along the leader's
// driven path, no follower strays 0.5 m from that path (it takes the corner the leader took), no two robots
// touch, nothing touches a wall, and at the end all hold at the spacing behind the stopped leader.
TEST(ConvoyTest, ThreeFollowersKeepTheSpacingOnTheLeadersPathThroughTheXJunction) {
  const ConvoyRun run = RunConvoy({{14.0, 20.0, 0.0}, {11.0, 20.0, 0.0}, {8.0, 20.0, 0.0}, {5.0, 20.0, 0.0}},
                                  {{30.0, 20.0}, {30.0, 32.0}}, 15.0, 150.0);
  ASSERT_TRUE(run.leader_arrived);
  ASSERT_FALSE(run.spacing_error_m.empty());
  std::vector<double> errors = run.spacing_error_m;
  std::sort(errors.begin(), errors.end());
  double mean = 0;
  for (double e : errors) mean += e / static_cast<double>(errors.size());
  const double p05 = errors[errors.size() / 20], p95 = errors[errors.size() * 19 / 20];
  std::printf(
      "  spacing error on straight stretches (%zu samples): mean %+.2f m, 5th %+.2f, 95th %+.2f, min %+.2f, "
      "max %+.2f; worst path deviation %.2f m (follower %d at %.1f, %.1f); closest robots %.2f m; %.0f s "
      "wall\n",
      errors.size(), mean, p05, p95, errors.front(), errors.back(), run.worst_deviation_m,
      static_cast<int>(run.worst_deviation_at_M.z()), run.worst_deviation_at_M.x(),
      run.worst_deviation_at_M.y(), run.closest_m, run.wall_s);
  EXPECT_GE(errors.front(), -1.0);
  EXPECT_LE(errors.back(), 1.0);
  EXPECT_LE(run.worst_deviation_m, 0.5);
  EXPECT_GT(run.closest_m, 2 * nav::GetPlatformProfile("wheeled").footprint_radius_m);
  EXPECT_FALSE(run.contact);
  for (std::size_t i = 0; i < run.end_status.size(); ++i) {
    EXPECT_EQ(run.end_status[i].state, ConvoyStatus::State::kHolding) << run.end_status[i].reason;
    EXPECT_NEAR(run.end_gap_m[i], 3.0, 1.0) << "r" << i + 2;
  }
}

// A follower sent to a goal (peel) leaves the convoy and drives there: the convoy, deactivated after the
// waypoint mode set its goal (the agent's order), does not drop that goal from navigation.
TEST(ConvoyTest, AFollowerSentToAGoalLeavesTheConvoyAndArrives) {
  std::unique_ptr<AgentTeam> team = MakeTeam({{14.0, 20.0, 0.0}, {11.0, 20.0, 0.0}});
  ASSERT_EQ(team->Follow(1, {"r1"}), "");
  team->StepFor(1.0);
  EXPECT_EQ(team->modes(1).convoy().status().state, ConvoyStatus::State::kHolding)
      << team->modes(1).convoy().status().reason;
  ASSERT_EQ(team->Goto(1, 6.0, 20.0), "");
  EXPECT_FALSE(team->modes(1).convoy().active());
  EXPECT_TRUE(team->robot(1).navigation().has_goal()) << "the convoy's leaving dropped the waypoint's goal";
  team->StepFor(20.0);
  EXPECT_EQ(team->modes(1).waypoint().goal().status, GoalStatus::kArrived)
      << team->modes(1).waypoint().goal().reason;
  const sim::UnicycleState end = team->truth(1);
  EXPECT_LT(std::hypot(end.x_m - 6.0, end.y_m - 20.0), 0.5);
}

// Radios falling silent: r3 no longer hears r2 and re-links to r1, two spacings behind it (r2 may still be in
// line, and is); then nobody hears the leader r1: r2 and r3, with nothing further ahead to follow, stop as
// lost. Nobody touches anybody.
TEST(ConvoyTest, AFollowerReLinksPastASilentRobotAndStopsWhenNoneAheadIsHeard) {
  std::unique_ptr<AgentTeam> team = MakeTeam({{14.0, 20.0, 0.0}, {11.0, 20.0, 0.0}, {8.0, 20.0, 0.0}});
  ASSERT_EQ(team->Follow(1, {"r1"}), "");
  ASSERT_EQ(team->Follow(2, {"r2", "r1"}), "");
  ASSERT_EQ(team->Goto(0, 27.0, 20.0), "");
  double closest_m = std::numeric_limits<double>::infinity();
  auto measure = [&] {
    for (std::size_t i = 0; i < 3; ++i) {
      for (std::size_t j = i + 1; j < 3; ++j) {
        const sim::UnicycleState a = team->truth(i), b = team->truth(j);
        closest_m = std::min(closest_m, std::hypot(a.x_m - b.x_m, a.y_m - b.y_m));
      }
    }
  };
  team->StepFor(3.0, measure);
  EXPECT_EQ(team->modes(2).convoy().status().ahead_id, "r2");
  team->links().SetHeard("r2", "r3", false);  // r3 no longer hears r2
  team->StepFor(4.0, measure);
  const ConvoyStatus& r3 = team->modes(2).convoy().status();
  EXPECT_EQ(r3.ahead_id, "r1") << r3.reason;
  EXPECT_EQ(r3.ahead_ids, (std::vector<std::string>{"r1"}));
  EXPECT_EQ(team->modes(1).convoy().status().state, ConvoyStatus::State::kFollowing)
      << team->modes(1).convoy().status().reason;
  team->links().SetHeard("r1", "r2", false);  // nobody hears the leader
  team->links().SetHeard("r1", "r3", false);
  team->StepFor(4.0, measure);
  for (std::size_t i = 1; i < 3; ++i) {
    const ConvoyStatus& s = team->modes(i).convoy().status();
    EXPECT_EQ(s.state, ConvoyStatus::State::kLost) << "r" << i + 1 << ": " << s.reason;
    EXPECT_NE(s.reason.find("r1 lost: the robot ahead was not heard"), std::string::npos) << s.reason;
    EXPECT_LT(std::abs(team->truth(i).v_mps), 0.05) << "r" << i + 1 << " stopped";
  }
  EXPECT_GT(closest_m, 2.0) << "r3 kept two spacings behind r1, r2 between them";
  for (std::size_t i = 0; i < 3; ++i) EXPECT_FALSE(team->ever_in_contact(i));
}

}  // namespace
}  // namespace cairn::agent
