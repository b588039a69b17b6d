// Exploration over DDS, multi-process: two wheeled robots that know nothing are sent exploring the
// west half of builtin:tunnels and its X junction (a region) from a basestation's CLI; only the lock's holder
// may send one, a malformed region is refused naming it, and the robots explore by themselves, sharing claims
// and coverage over cairn/explore_claim (never one frontier for two, neither mapping it all, the traffic
// measured), until each reports "exploration complete", then stand idle with their explored area and frontier
// count shown by `status` and `frontiers`; they never touch a wall. Scored against the world's ground truth.
// Then `home` brings it back to its start, and a robot exploring with --home-after-silence comes back by
// itself once no basestation is left. All processes run in this test's private network namespace
// (tests/netns_run.sh).
#include <filesystem>
#include <map>
#include <optional>
#include <thread>

#include "cairn/core/build_paths.h"
#include "cairn/nav/platform.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/builtin_worlds.h"
#include "integration_util.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using ::cairn::testing::ChildProcess;
using nlohmann::json;

// Ground-truth floor a wheeled robot can stand on inside the x-y box, m².
double TrueFloorM2(double x0, double y0, double x1, double y1) {
  const sim::World world = sim::MakeBuiltinWorld("tunnels");
  nav::TraversabilityOptions o;
  o.robot_radius_m = nav::GetPlatformProfile("wheeled").traversability.robot_radius_m;
  const nav::TraversabilityGrid truth(world, o);
  int free = 0;
  for (int iy = 0; iy < truth.ny(); ++iy) {
    for (int ix = 0; ix < truth.nx(); ++ix) {
      const Eigen::Vector2d c = truth.CellCenter(ix, iy);
      if (c.x() < x0 || c.x() > x1 || c.y() < y0 || c.y() > y1) continue;
      free += truth.State(ix, iy) == nav::CellState::kFree;
    }
  }
  return free * truth.cell_size_m() * truth.cell_size_m();
}

TEST(ExploreOverDds, ARobotExploresARegionUntilCompleteAndStandsIdle) {
  const int domain = 66;
  const std::string logs = cairn::core::BinaryDir() + "/test-logs/explore";
  std::filesystem::remove_all(logs);
  std::filesystem::create_directories(logs);
  Observer observer(domain);
  Base op("opA", domain, logs);
  Base other("opB", domain, logs);
  auto robot = std::make_unique<ChildProcess>(
      std::vector<std::string>{kAgent, "--robot-id", "ex1", "--start", "4,20,0", "--domain",
                               std::to_string(domain), "--config", kLightLidarConfig},
      logs + "/ex1.log");
  ASSERT_TRUE(robot->WaitForLine("READY", 60s)) << "see " << logs;
  ASSERT_TRUE(op.Run("wait ex1 online 5")["ok"]);

  // Only the lock's holder sends a robot exploring; a region with swapped corners never leaves the CLI.
  json r = op.Run("explore ex1");
  EXPECT_FALSE(r["ok"]) << r;
  ASSERT_TRUE(op.Run("request-control ex1")["ok"]);
  r = op.Run("explore ex1 --region 16,16,0,24");
  EXPECT_EQ(r["result"], "invalid") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("--region '16,16,0,24'"), std::string::npos) << r;
  // The holder's valid actions come with the robot's next mode-tree state (a control cycle after the grant,
  // later on a loaded machine; a robot just started also waits for its perception's first cycle, which the
  // tree requires): within a few seconds.
  auto wait_explore_valid = [&](const std::string& robot) {
    bool explore_valid = false;
    json status;
    for (int attempt = 0; attempt < 50 && !explore_valid; ++attempt) {
      if (attempt > 0) std::this_thread::sleep_for(100ms);
      status = op.Run("status " + robot);
      explore_valid = std::find(status["valid_actions"].begin(), status["valid_actions"].end(), "explore") !=
                      status["valid_actions"].end();
    }
    EXPECT_TRUE(explore_valid) << "explore is a valid action for the holder of " << robot
                               << " within 5 s: " << status;
  };
  wait_explore_valid("ex1");
  r = other.Run("explore ex1");
  EXPECT_EQ(r["result"], "refused") << r;

  // A second robot, 3 m down the tunnel: the two share the region. Each tells the other what it goes for and,
  // every few seconds, the floor it has seen (cairn/explore_claim), so neither explores the other's branch.
  auto robot2 = std::make_unique<ChildProcess>(
      std::vector<std::string>{kAgent, "--robot-id", "ex2", "--start", "7,20,0", "--domain",
                               std::to_string(domain), "--config", kLightLidarConfig},
      logs + "/ex2.log");
  ASSERT_TRUE(robot2->WaitForLine("READY", 60s)) << "see " << logs;
  ASSERT_TRUE(op.Run("wait ex2 online 5")["ok"]);
  ASSERT_TRUE(op.Run("request-control ex2")["ok"]);
  wait_explore_valid("ex2");

  // The west half of the main tunnel and the X junction (x < 32, the branches cut at y 15 and 25): explored
  // until no reachable frontier is left in it.
  const auto start = std::chrono::steady_clock::now();
  r = op.Run("explore ex2 --region 0,15,32,25");
  ASSERT_TRUE(r["ok"]) << r;
  r = op.Run("explore ex1 --region 0,15,32,25 --wait 300", 320s);
  const double explore_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(r["ok"]) << r << "; see " << logs;
  EXPECT_NE(r["reason"].get<std::string>().find("exploration complete: no reachable frontier"),
            std::string::npos)
      << r;
  EXPECT_FALSE(op.progress_lines().empty()) << "--wait prints progress";
  for (auto deadline = Clock::now() + 240s;
       Clock::now() < deadline && observer.FreshState("ex2").explore_state() == "exploring";) {
    std::this_thread::sleep_for(200ms);
  }
  const double team_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  std::vector<double> own_m2, peer_seen_m2;
  for (const char* id : {"ex1", "ex2"}) {
    r = op.Run(std::string("status ") + id);
    ASSERT_TRUE(r["ok"]) << r;
    EXPECT_EQ(r["mode"], "idle") << r;
    const json e = r["exploration"];
    EXPECT_EQ(e["state"], "complete") << r;
    own_m2.push_back(e["explored_m2"].get<double>());
    peer_seen_m2.push_back(e["peer_seen_m2"].get<double>());
  }
  // Each mapped the region (they drive the same tunnel: the lidar sees it all) and heard what the other had
  // seen (the peer's coverage bitmap over DDS: no gain in it for its frontiers).
  const double truth_m2 = TrueFloorM2(0, 15, 32, 25);
  EXPECT_GE(std::max(own_m2[0], own_m2[1]), 0.85 * truth_m2) << own_m2[0] << ", " << own_m2[1];
  EXPECT_GE(std::min(peer_seen_m2[0], peer_seen_m2[1]), 0.5 * truth_m2)
      << peer_seen_m2[0] << ", " << peer_seen_m2[1];
  r = op.Run("frontiers ex1");
  ASSERT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["state"], "complete") << r;

  // Never two claims on one frontier: replaying every claim as a third party heard it, whenever both robots
  // held a target the two lay apart, except for moments when both chose at once, before either heard the
  // other (then the robot with the smaller id keeps it and the other leaves it at its next cycle).
  const auto claims = observer.Claims();
  std::map<std::string, cairn_msgs::ExploreClaim> held;
  int both = 0, conflicts = 0;
  double longest_conflict_s = 0.0;
  double conflict_since_s = -1.0;  // seconds after the first claim heard; -1: no conflict now
  for (const auto& heard : claims) {
    const double at_s = std::chrono::duration<double>(heard.at - claims.front().at).count();
    held[heard.claim.robot_id()] = heard.claim;
    const auto a = held.find("ex1"), b = held.find("ex2");
    const bool two = a != held.end() && b != held.end() && a->second.active() && a->second.has_target() &&
                     b->second.active() && b->second.has_target();
    const bool conflict = two && std::hypot(a->second.target_x_m() - b->second.target_x_m(),
                                            a->second.target_y_m() - b->second.target_y_m()) < 1.5;
    both += two;
    if (conflict && conflict_since_s < 0) {
      ++conflicts;
      conflict_since_s = at_s;
    } else if (!conflict && conflict_since_s >= 0) {
      longest_conflict_s = std::max(longest_conflict_s, at_s - conflict_since_s);
      conflict_since_s = -1.0;
    }
  }
  EXPECT_GT(claims.size(), 20u) << "claims heard";
  EXPECT_GT(both, 10) << "both robots held targets at once";
  EXPECT_LT(conflict_since_s, 0) << "a conflict never resolved";
  EXPECT_LT(longest_conflict_s, 0.5) << conflicts << " conflicts";
  Figure("claim_conflicts", conflicts);
  Figure("claim_conflict_longest_s", longest_conflict_s);

  // What the claims cost on the radio: the agents count what they send per topic class.
  r = op.Run("links");
  ASSERT_TRUE(r["ok"]) << r;
  double team_bits_per_s = 0;
  for (const auto& robot_link : r["robots"]) {
    for (const auto& usage : robot_link["usage"]) {
      if (usage["topic_class"] == "team")
        team_bits_per_s += 8.0 * usage["sent_bytes"].get<double>() / team_s / 2;
    }
  }
  EXPECT_GT(team_bits_per_s, 0) << r;
  EXPECT_LT(team_bits_per_s, 20000) << "claims and coverage must fit a radio: " << r;

  // Neither touched a wall, and they stand still.
  for (const char* id : {"ex1", "ex2"}) {
    for (const auto& s : observer.History(id)) {
      ASSERT_FALSE(s.in_contact()) << "contact at " << FormatState(s) << "\n"
                                   << TrackBeforeContact(observer.History(id));
    }
    EXPECT_LT(std::abs(observer.FreshState(id).twist_B().linear_x_mps()), 0.05);
  }
  Figure("explore_region_s", explore_s);
  Figure("team_done_s", team_s);
  Figure("explored_m2_ex1", own_m2[0]);
  Figure("explored_m2_ex2", own_m2[1]);
  Figure("peer_seen_m2_ex1", peer_seen_m2[0]);
  Figure("peer_seen_m2_ex2", peer_seen_m2[1]);
  Figure("true_floor_m2", truth_m2);
  Figure("claim_traffic_bits_per_s_per_robot", team_bits_per_s);
  Figure("target_pairs", both);
  robot2.reset();  // ex1 alone from here

  // home brings it back to where it started, on its own map (from 16 m down the tunnel).
  r = op.Run("goto ex1 20 20 --wait 90", 100s);
  ASSERT_TRUE(r["ok"]) << r;
  const double away_m = std::hypot(observer.FreshState("ex1").pose_MB().position().x_m() - 4.0,
                                   observer.FreshState("ex1").pose_MB().position().y_m() - 20.0);
  r = op.Run("home ex1 --wait 120", 130s);
  ASSERT_TRUE(r["ok"]) << r;
  cairn_msgs::RobotState at = observer.FreshState("ex1");
  const double home_error_m =
      std::hypot(at.pose_MB().position().x_m() - 4.0, at.pose_MB().position().y_m() - 20.0);
  EXPECT_LT(home_error_m, 1.0) << FormatState(at);
  Figure("home_from_m", away_m);
  Figure("home_error_m", home_error_m);

  // Lost link: exploring with --home-after-silence 3, the robot hears no basestation once both are gone, and
  // drives back to its start by itself.
  r = op.Run("explore ex1 --home-after-silence 3");
  ASSERT_TRUE(r["ok"]) << r;
  for (auto deadline = Clock::now() + 60s; Clock::now() < deadline;) {
    at = observer.FreshState("ex1");
    if (std::hypot(at.pose_MB().position().x_m() - 4.0, at.pose_MB().position().y_m() - 20.0) > 6.0) break;
    std::this_thread::sleep_for(200ms);
  }
  ASSERT_GT(std::hypot(at.pose_MB().position().x_m() - 4.0, at.pose_MB().position().y_m() - 20.0), 6.0)
      << "the robot set out exploring: " << FormatState(at);
  EXPECT_EQ(at.explore_state(), "exploring") << FormatState(at);
  op.Kill();
  other.Kill();
  const auto silent_since = Clock::now();
  bool home = false;
  for (auto deadline = Clock::now() + 120s; Clock::now() < deadline && !home;) {
    at = observer.FreshState("ex1");
    home = at.mode() == "idle" && at.nav_status() == cairn_msgs::NAV_STATUS_ARRIVED &&
           std::hypot(at.pose_MB().position().x_m() - 4.0, at.pose_MB().position().y_m() - 20.0) < 1.0;
    std::this_thread::sleep_for(200ms);
  }
  ASSERT_TRUE(home) << FormatState(at) << ", exploration " << at.explore_state() << ": "
                    << at.explore_reason();
  EXPECT_EQ(at.explore_state(), "stopped");
  EXPECT_NE(at.explore_reason().find("no basestation heard for"), std::string::npos) << at.explore_reason();
  Figure("lost_link_home_s", std::chrono::duration<double>(Clock::now() - silent_since).count());
}

}  // namespace
}  // namespace cairn
