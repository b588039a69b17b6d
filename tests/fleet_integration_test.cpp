// Multi-process integration test of the walking skeleton: 2 cairn_agent processes, 2 cairn_base processes
// and this test as a DDS observer, all in this test's private network namespace (tests/netns_run.sh).
#include <gtest/gtest.h>
#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>

#include "cairn/core/build_paths.h"
#include "cairn/core/dds.h"
#include "cairn/nav/astar.h"
#include "cairn/nav/sampling.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/world.h"
#include "cairn_msgsPubSubTypes.h"
#include "integration_util.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;
using Clock = std::chrono::steady_clock;
struct WorldCase {
  std::string name;
  std::string spec;  // world spec; a path relative to the repository root for shared data
  int domain;
};

class FleetIntegration : public ::testing::TestWithParam<WorldCase> {};

TEST_P(FleetIntegration, ArbitrationWaypointsTeleopSilenceAndLoss) {
  const WorldCase& world_case = GetParam();
  std::string spec = world_case.spec;
  if (spec.rfind("builtin:", 0) != 0) {
    spec = cairn::core::SourceDir() + "/" + spec;
    if (!std::filesystem::exists(spec)) GTEST_SKIP() << spec << " is absent (a checkout without data/)";
  }
  const int domain = world_case.domain;
  const std::string logs = cairn::core::BinaryDir() + "/test-logs/" + world_case.name;
  std::filesystem::create_directories(logs);
  // State at 50 Hz so that the stop after teleop silence is timed to 20 ms.
  const std::string config = logs + "/agent.yaml";
  std::ofstream(config) << "telemetry:\n  state_rate_hz: 50\n" << std::ifstream(kLightLidarConfig).rdbuf();

  // The same traversability the agents use (their defaults) to pick a goal 10-25 m away by path.
  const sim::World world = sim::LoadWorld(spec);
  const nav::TraversabilityGrid grid(world, nav::TraversabilityOptions{});

  Observer observer(domain);
  std::vector<std::unique_ptr<ChildProcess>> agents;
  for (int i = 1; i <= 2; ++i) {
    const std::string id = "r" + std::to_string(i);
    agents.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{kAgent, "--robot-id", id, "--world", spec, "--start",
                                 "slot:" + std::to_string(i - 1), "--domain", std::to_string(domain),
                                 "--config", config},
        logs + "/" + id + ".log"));
  }
  for (auto& agent : agents)
    ASSERT_TRUE(agent->WaitForLine("READY", 60s)) << "agent did not start; see " << logs;

  // Discovery: a fresh basestation sees both robots within 2 s of its start.
  const auto base_start = Clock::now();
  Base opA("opA", domain, logs);
  ASSERT_TRUE(opA.Run("wait r1 online 2")["ok"]);
  ASSERT_TRUE(opA.Run("wait r2 online 2")["ok"]);
  const double discovery_s = std::chrono::duration<double>(Clock::now() - base_start).count();
  EXPECT_LT(discovery_s, 2.0);
  Figure("discovery_s", discovery_s);
  Base opB("opB", domain, logs);
  ASSERT_TRUE(opB.Run("wait r1 online 2")["ok"]);

  const cairn_msgs::RobotState start = observer.FreshState("r1");
  const Eigen::Vector2d p_start(start.pose_MB().position().x_m(), start.pose_MB().position().y_m());
  std::optional<Eigen::Vector2d> goal;
  for (const auto& c : nav::SampleFreeStarts(grid, 40, 2.0, 1234)) {
    const nav::PlanResult plan = nav::PlanPath(grid, p_start, c.head<2>(), nav::AStarOptions{});
    if (plan.status == nav::PlanResult::Status::kSuccess && plan.length_m >= 10 && plan.length_m <= 25) {
      goal = c.head<2>();
      break;
    }
  }
  ASSERT_TRUE(goal) << "no goal 10-25 m from the start in " << spec;

  // Arbitration: opA gets control; opB is denied and told the holder.
  json r = opA.Run("request-control r1");
  EXPECT_TRUE(r["ok"]) << r;
  r = opB.Run("request-control r1");
  EXPECT_FALSE(r["ok"]);
  EXPECT_EQ(r["result"], "refused");
  EXPECT_EQ(r["holder"], "opA");
  EXPECT_NE(r["reason"].get<std::string>().find("locked by basestation opA"), std::string::npos) << r;

  // opB's goto and teleop are discarded and the robot does not move.
  char gx[32], gy[32];
  std::snprintf(gx, sizeof(gx), "%.2f", goal->x());
  std::snprintf(gy, sizeof(gy), "%.2f", goal->y());
  r = opB.Run(std::string("goto r1 ") + gx + " " + gy);
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["condition"], "lock") << r;
  r = opB.Run("teleop r1 0.5 0 1.0");
  EXPECT_FALSE(r["ok"]) << r;
  std::this_thread::sleep_for(500ms);
  const cairn_msgs::RobotState after_b = observer.FreshState("r1");
  EXPECT_LT(Distance(start, after_b), 0.01);
  EXPECT_GE(after_b.discarded_commands(), 2u);
  EXPECT_EQ(after_b.mode(), "idle");

  // opA's goto arrives within 0.3 m; the global path is published and progress is reported on the way.
  r = opA.Run(std::string("goto r1 ") + gx + " " + gy);
  ASSERT_TRUE(r["ok"]) << r;
  EXPECT_NE(r["reason"].get<std::string>().find("ETA"), std::string::npos) << r;
  const auto goal_id = r["goal_id"];
  EXPECT_GT(goal_id.get<uint32_t>(), 0u) << r;
  r = opA.Run("path r1");
  EXPECT_TRUE(r["ok"]) << r;
  EXPECT_GE(r["path"].size(), 2u) << r;
  EXPECT_GT(r["length_m"].get<double>(), 9.0) << r;
  EXPECT_EQ(r["goal_id"], goal_id) << r;
  r = opA.Run("wait r1 arrived 120", 130s);
  EXPECT_TRUE(r["ok"]) << r;
  const auto& progress = opA.progress_lines();
  ASSERT_FALSE(progress.empty()) << "no progress lines while driving";
  EXPECT_GT(progress.front()["eta_s"].get<double>(), 0.0);
  EXPECT_LT(progress.back()["distance_left_m"].get<double>(),
            progress.front()["distance_left_m"].get<double>());
  Figure("progress_lines", static_cast<double>(progress.size()));
  const cairn_msgs::RobotState arrived = observer.FreshState("r1");
  const double miss_m = std::hypot(arrived.pose_MB().position().x_m() - goal->x(),
                                   arrived.pose_MB().position().y_m() - goal->y());
  EXPECT_LT(miss_m, 0.3);
  Figure("goal_miss_m", miss_m);
  for (const auto& s : observer.History("r1")) EXPECT_FALSE(s.in_contact()) << "r1 touched occupied space";

  // opA releases; opB gets control.
  EXPECT_TRUE(opA.Run("release r1")["ok"]);
  r = opB.Run("request-control r1");
  EXPECT_TRUE(r["ok"]) << r;

  // Bad goals are refused with a reason, and the robot does not move.
  const cairn_msgs::RobotState before_bad = observer.FreshState("r1");
  r = opB.Run("goto r1 1000 1000");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("navigation.map_max_extent_m = 200"), std::string::npos) << r;
  r = opB.Run("goto r1 nan 3");
  EXPECT_EQ(r["result"], "invalid") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("X 'nan' is not a finite number"), std::string::npos) << r;
  // A goal inside a wall the robot has seen (the one nearest to it): refused on the robot's own map.
  std::optional<Eigen::Vector2d> blocked;
  const Eigen::Vector2d here(before_bad.pose_MB().position().x_m(), before_bad.pose_MB().position().y_m());
  for (int ix = 0; ix < grid.nx(); ++ix) {
    for (int iy = 0; iy < grid.ny(); ++iy) {
      if (grid.State(ix, iy) != nav::CellState::kObstacle) continue;
      if (!blocked || (grid.CellCenter(ix, iy) - here).norm() < (*blocked - here).norm()) {
        blocked = grid.CellCenter(ix, iy);
      }
    }
  }
  ASSERT_TRUE(blocked);
  char bx[64];
  std::snprintf(bx, sizeof(bx), "goto r1 %.3f %.3f", blocked->x(), blocked->y());
  r = opB.Run(bx);
  EXPECT_EQ(r["result"], "refused") << r;
  // ...at once, naming the nearest point where the robot fits.
  EXPECT_NE(r.dump().find("is inside an obstacle on r1's map"), std::string::npos) << r;
  EXPECT_NE(r.dump().find("; nearest free point ("), std::string::npos) << r;
  // A NaN goal straight on DDS (bypassing the CLI's checks) is refused by the robot itself.
  cairn_msgs::WaypointGoal nan_goal;
  nan_goal.robot_id("r1");
  nan_goal.base_id("opB");
  nan_goal.request_id(900000);
  nan_goal.frame_id("map");
  nan_goal.x_m(std::nan(""));
  nan_goal.y_m(1.0);
  observer.goals().Write(nan_goal);
  std::this_thread::sleep_for(300ms);
  const cairn_msgs::RobotState after_bad = observer.FreshState("r1");
  EXPECT_LT(Distance(before_bad, after_bad), 0.01);
  EXPECT_EQ(after_bad.mode(), "idle");

  // Teleop followed by silence: the mux zeroes the command within 0.6 s of the last twist, and the robot is
  // at rest by then plus its braking time at the platform's deceleration limit.
  r = opB.Run("teleop r1 0.3 0 1.0");
  ASSERT_TRUE(r["ok"]) << r;
  const auto last = observer.LastTeleop("r1");
  ASSERT_TRUE(last);
  const double last_twist_s = WallSeconds(last->stamp());
  std::this_thread::sleep_for(1500ms);
  double moved_m = 0, zero_cmd_s = -1, rest_s = -1;
  const auto history = observer.History("r1");
  for (std::size_t i = 1; i < history.size(); ++i) {
    if (WallSeconds(history[i].stamp()) < last_twist_s - 0.9) continue;
    moved_m += Distance(history[i - 1], history[i]);
    const double t = WallSeconds(history[i].stamp()) - last_twist_s;
    if (t > 0 && zero_cmd_s < 0 && history[i].cmd_twist_B().linear_x_mps() == 0.0) zero_cmd_s = t;
    if (t > 0 && rest_s < 0 && std::abs(history[i].twist_B().linear_x_mps()) < 1e-6) rest_s = t;
  }
  EXPECT_GT(moved_m, 0.1) << "teleop did not move the robot";
  ASSERT_GT(zero_cmd_s, 0);
  EXPECT_LE(zero_cmd_s, 0.6);
  ASSERT_GT(rest_s, 0);
  EXPECT_LE(rest_s, 0.6 + 0.3 / 1.0 + 0.02);  // 0.3 m/s at the wheeled limit of 1 m/s^2, one 20 ms cycle
  Figure("stop_command_after_silence_s", zero_cmd_s);
  Figure("at_rest_after_silence_s", rest_s);

  // An agent killed with SIGKILL is shown lost within 3 s.
  agents[1]->Signal(SIGKILL);
  const auto killed = Clock::now();
  r = opA.Run("wait r2 lost 3");
  EXPECT_TRUE(r["ok"]) << r;
  const double lost_after_s = std::chrono::duration<double>(Clock::now() - killed).count();
  EXPECT_LT(lost_after_s, 3.0);
  Figure("sigkill_to_lost_s", lost_after_s);
  r = opA.Run("robots");
  bool listed_lost = false;
  for (const auto& robot : r["robots"]) {
    if (robot["robot"] == "r2") listed_lost = robot["lost"].get<bool>();
  }
  EXPECT_TRUE(listed_lost) << r;

  // The holder's basestation dies (SIGKILL) while r1 is in manual mode: the robot stops (idle, zero twist)
  // and keeps the lock (lock_keep_s defaults to forever, as in the paper), so opA is still denied.
  r = opB.Run("mode r1 manual");
  ASSERT_TRUE(r["ok"]) << r;
  opB.Kill();
  const auto lost_holder = Clock::now();
  bool stopped = false;
  while (Clock::now() - lost_holder < 5s && !stopped) {
    const auto s = observer.FreshState("r1");
    stopped = !s.holder_alive() && s.mode() == "idle" && s.cmd_twist_B().linear_x_mps() == 0.0;
  }
  EXPECT_TRUE(stopped) << "r1 did not stop after its holder's liveliness was lost";
  Figure("holder_loss_to_stop_s", std::chrono::duration<double>(Clock::now() - lost_holder).count());
  const auto after_loss = observer.FreshState("r1");
  EXPECT_EQ(after_loss.holder_id(), "opB");
  r = opA.Run("request-control r1");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["holder"], "opB");
  r = opA.Run("mode r1 manual");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["condition"], "lock") << r;
}

// The navigation layer over DDS in the built-in tunnels' room: the global path service (any platform), a
// legged robot up the staircase, a wheeled one refused with the step, smart joystick at a wall.
TEST(NavigationOverDds, StairsPathServiceAndSmartJoystick) {
  const int domain = 63;
  const std::string logs = cairn::core::BinaryDir() + "/test-logs/navigation";
  std::filesystem::create_directories(logs);
  Observer observer(domain);
  ChildProcess legged({kAgent, "--robot-id", "leg1", "--platform", "legged", "--start", "48,20,0", "--domain",
                       std::to_string(domain)},
                      logs + "/leg1.log");
  ChildProcess wheeled({kAgent, "--robot-id", "whl1", "--platform", "wheeled", "--start", "52,18,0",
                        "--domain", std::to_string(domain)},
                       logs + "/whl1.log");
  ASSERT_TRUE(legged.WaitForLine("READY", 60s)) << "see " << logs;
  ASSERT_TRUE(wheeled.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("op", domain, logs);
  ASSERT_TRUE(op.Run("wait leg1 online 3")["ok"]);
  ASSERT_TRUE(op.Run("wait whl1 online 3")["ok"]);

  // Path service: the robots plan on their own maps; a platform the planner does not serve is refused.
  json r = op.Run("plan whl1 54.5 23.8 --from 48,20 --platform legged");
  EXPECT_TRUE(r["ok"]) << r;
  Figure("plan_round_trip_ms", r["round_trip_ms"].get<double>());
  r = op.Run("plan whl1 54.5 23.8 --platform hovercraft");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r["reason"].get<std::string>().find("'hovercraft'"), std::string::npos) << r;

  // The wheeled robot never gets onto the platform: refused at once when its map already shows the stairs,
  // else the goal fails once it has seen them, naming the step; it never touches anything.
  ASSERT_TRUE(op.Run("request-control whl1")["ok"]);
  r = op.Run("goto whl1 54.5 23.8 --wait 90", 100s);
  EXPECT_FALSE(r["ok"]) << r;
  const std::string wheeled_reason = r["reason"].get<std::string>();
  EXPECT_TRUE(wheeled_reason.find("unreachable for platform wheeled") != std::string::npos ||
              wheeled_reason.find("step") != std::string::npos)
      << r;
  EXPECT_LT(observer.FreshState("whl1").pose_MB().position().z_m(), 0.15);
  for (const auto& s : observer.History("whl1"))
    EXPECT_FALSE(s.in_contact()) << "whl1 touched occupied space";
  std::printf("%s", TrackBeforeContact(observer.History("whl1")).c_str());
  // Now its map holds the staircase: its path service refuses its own platform with the step.
  r = op.Run("plan whl1 54.5 23.8 --from 48,20");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r["reason"].get<std::string>().find("unreachable for platform wheeled"), std::string::npos) << r;
  EXPECT_NE(r["reason"].get<std::string>().find(" m step"), std::string::npos) << r;

  // whl1 stands where its refused goal left it, at the foot of the flight: back to where it started, out of
  // leg1's way (robots keep clear of one another: leg1 would stop short of it).
  r = op.Run("goto whl1 52 18 --wait 60", 70s);
  EXPECT_TRUE(r["ok"]) << r;

  // The legged robot climbs to the top.
  ASSERT_TRUE(op.Run("request-control leg1")["ok"]);
  r = op.Run("goto leg1 54.5 23.8 --wait 90", 100s);
  EXPECT_TRUE(r["ok"]) << r;
  const auto top = observer.FreshState("leg1");
  EXPECT_NEAR(top.pose_MB().position().z_m(), 1.0, 0.11);
  for (const auto& s : observer.History("leg1"))
    EXPECT_FALSE(s.in_contact()) << "leg1 touched occupied space";
  std::printf("%s", TrackBeforeContact(observer.History("leg1")).c_str());
  Figure("stairs_top_z_m", top.pose_MB().position().z_m());

  // Smart joystick: where it started, full stick at the room's east wall (x ~ 56) for 8 s never touches it.
  // Face the east wall: the heading it arrives with depends on where the refused stairs goal left it (once it
  // came from the north and the stick drove it south).
  ASSERT_TRUE(op.Run("mode whl1 manual")["ok"]);
  if (const double yaw = YawOf(observer.FreshState("whl1")); std::abs(yaw) > 0.2) {
    char turn[96];
    std::snprintf(turn, sizeof(turn), "teleop whl1 0 %.2f %.2f", yaw > 0 ? -0.5 : 0.5, std::abs(yaw) / 0.5);
    EXPECT_TRUE(op.Run(turn, 20s)["ok"]);
  }
  EXPECT_LT(std::abs(YawOf(observer.FreshState("whl1"))), 0.5);
  r = op.Run("mode whl1 smart_joystick");
  ASSERT_TRUE(r["ok"]) << r;
  r = op.Run("teleop whl1 0.8 0 8", 20s);
  EXPECT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["mode"], "smart_joystick") << r;
  double max_x = 0;
  for (const auto& s : observer.History("whl1")) {
    EXPECT_FALSE(s.in_contact()) << "whl1 touched occupied space at x " << s.pose_MB().position().x_m();
    max_x = std::max(max_x, s.pose_MB().position().x_m());
  }
  std::printf("%s", TrackBeforeContact(observer.History("whl1")).c_str());
  EXPECT_GT(max_x, 53.0) << "smart joystick did not drive";
  Figure("joystick_wall_closest_x_m", max_x);
  r = op.Run("status whl1");
  EXPECT_EQ(r["mode"], "smart_joystick") << r;

  // A basestation without a joystick cannot enter smart joystick mode.
  ASSERT_TRUE(op.Run("release whl1")["ok"]);
  Base no_stick("opNoStick", domain, logs, {"--no-joystick"});
  ASSERT_TRUE(no_stick.Run("request-control whl1")["ok"]);
  r = no_stick.Run("mode whl1 smart_joystick");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["condition"], "IsJoystickAlive") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("smart joystick needs a joystick"), std::string::npos) << r;
}

INSTANTIATE_TEST_SUITE_P(Worlds, FleetIntegration,
                         ::testing::Values(WorldCase{"geb079", "data/geb079.bt", 61}),
                         [](const auto& info) { return info.param.name; });

}  // namespace
}  // namespace cairn
