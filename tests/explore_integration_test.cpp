// Exploration over DDS, multi-process (issue 14): a wheeled robot that knows nothing is sent exploring the west
// half of builtin:tunnels and its X junction (a region) from a basestation's CLI; only the lock's holder may send it, a malformed
// region is refused naming it, and the robot explores by itself until it reports "exploration complete", then
// stands idle with its explored area and frontier count shown by `status` and `frontiers`; it never touches a
// wall. Scored against the world's ground truth. Then `home` brings it back to its start, and a robot exploring
// with --home-after-silence comes back by itself once no basestation is left. All processes run in this test's private network namespace
// (tests/netns_run.sh).
#include <filesystem>

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
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/explore";
  std::filesystem::remove_all(logs);
  std::filesystem::create_directories(logs);
  Observer observer(domain);
  Base op("opA", domain, logs);
  Base other("opB", domain, logs);
  auto robot = std::make_unique<ChildProcess>(
      std::vector<std::string>{kAgent, "--robot-id", "ex1", "--start", "4,20,0", "--domain", std::to_string(domain)},
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
  r = op.Run("status ex1");
  EXPECT_NE(std::find(r["valid_actions"].begin(), r["valid_actions"].end(), "explore"), r["valid_actions"].end())
      << "explore is a valid action for the holder: " << r;
  r = other.Run("explore ex1");
  EXPECT_EQ(r["result"], "refused") << r;

  // The west half of the main tunnel and the X junction (x < 32, the branches cut at y 15 and 25): explored
  // until no reachable frontier is left in it.
  const auto start = std::chrono::steady_clock::now();
  r = op.Run("explore ex1 --region 0,15,32,25 --wait 300", 320s);
  const double explore_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(r["ok"]) << r << "; see " << logs;
  EXPECT_NE(r["reason"].get<std::string>().find("exploration complete: no reachable frontier"), std::string::npos)
      << r;
  EXPECT_FALSE(op.progress_lines().empty()) << "--wait prints progress";

  r = op.Run("status ex1");

  ASSERT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["mode"], "idle") << r;
  const json e = r["exploration"];
  EXPECT_EQ(e["state"], "complete") << r;
  EXPECT_EQ(e["reachable_frontiers"], 0) << r;
  const double explored_m2 = e["explored_m2"].get<double>();
  const double truth_m2 = TrueFloorM2(0, 15, 32, 25);
  EXPECT_GE(explored_m2, 0.85 * truth_m2) << r;
  r = op.Run("frontiers ex1");
  ASSERT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["state"], "complete") << r;
  EXPECT_EQ(r["task_id"], e["task_id"]) << r;

  // It never touched a wall, and it stands still.
  for (const auto& s : observer.History("ex1")) {
    ASSERT_FALSE(s.in_contact()) << "contact at " << FormatState(s) << "\n" << TrackBeforeContact(observer.History("ex1"));
  }
  EXPECT_LT(std::abs(observer.FreshState("ex1").twist_B().linear_x_mps()), 0.05);
  Figure("explore_region_s", explore_s);
  Figure("explored_m2", explored_m2);
  Figure("true_floor_m2", truth_m2);

  // home brings it back to where it started, on its own map (from 16 m down the tunnel).
  r = op.Run("goto ex1 20 20 --wait 90", 100s);
  ASSERT_TRUE(r["ok"]) << r;
  const double away_m = std::hypot(observer.FreshState("ex1").pose_MB().position().x_m() - 4.0,
                                   observer.FreshState("ex1").pose_MB().position().y_m() - 20.0);
  r = op.Run("home ex1 --wait 120", 130s);
  ASSERT_TRUE(r["ok"]) << r;
  cairn_msgs::RobotState at = observer.FreshState("ex1");
  const double home_error_m = std::hypot(at.pose_MB().position().x_m() - 4.0, at.pose_MB().position().y_m() - 20.0);
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
  ASSERT_TRUE(home) << FormatState(at) << ", exploration " << at.explore_state() << ": " << at.explore_reason();
  EXPECT_EQ(at.explore_state(), "stopped");
  EXPECT_NE(at.explore_reason().find("no basestation heard for"), std::string::npos) << at.explore_reason();
  Figure("lost_link_home_s", std::chrono::duration<double>(Clock::now() - silent_since).count());
}

}  // namespace
}  // namespace cairn
