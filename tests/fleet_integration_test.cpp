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
    spec = std::string(CAIRN_SOURCE_DIR) + "/" + spec;
    if (!std::filesystem::exists(spec)) GTEST_SKIP() << spec << " is absent (a checkout without data/)";
  }
  const int domain = world_case.domain;
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/" + world_case.name;
  std::filesystem::create_directories(logs);
  // State at 50 Hz so that the stop after teleop silence is timed to 20 ms.
  const std::string config = logs + "/agent.yaml";
  std::ofstream(config) << "telemetry:\n  state_rate_hz: 50\n";

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
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/navigation";
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

// Navigation on the robot's own knowledge: a goal around a corner the robot has never seen, beyond
// its navigation map (started at start +- 10 m here), is accepted with a plan to the map's edge, the map
// grows over it and the goal is reached; a rockfall dropped into the simulated world mid-drive (in no map) is
// seen by the lidar, avoided by the local planner and planned around, with no contact.
TEST(NavigationOverDds, GoalInUnknownSpaceAndARockfallPlannedAround) {
  const int domain = 64;
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/rockfall";
  std::filesystem::create_directories(logs);
  const std::string config = logs + "/agent.yaml";
  {
    // The rock blocks the south two thirds of the 3 m main tunnel (y in [18.5, 21.5]) 10 m down the robot's
    // way, 6 s after the agent starts: the robot is then driving towards it.
    std::ofstream out(config);
    out << "simulation:\n  rockfalls: \"6:14,18.3,15.5,20.4,1.2\"\n"
        << "navigation:\n  map_half_extent_m: 10\n";
  }
  Observer observer(domain);
  ChildProcess agent({kAgent, "--robot-id", "r1", "--platform", "wheeled", "--start", "4,20,0", "--domain",
                      std::to_string(domain), "--config", config},
                     logs + "/r1.log");
  ASSERT_TRUE(agent.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("op", domain, logs);
  ASSERT_TRUE(op.Run("wait r1 online 3")["ok"]);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  // (30, 10) is down the south branch of the X junction at (30, 20): out of the lidar's sight from the start,
  // so accepted with a notice.
  json r = op.Run("goto r1 30 10");
  ASSERT_TRUE(r["ok"]) << r << " (see " << logs << ")";
  EXPECT_NE(r["reason"].get<std::string>().find("; goal in unmapped space: r1 will look"), std::string::npos)
      << r;
  r = op.Run("wait r1 arrived 120", 130s);
  EXPECT_TRUE(r["ok"]) << r << " (see " << logs << ")";
  const auto arrived = observer.FreshState("r1");
  EXPECT_LT(std::hypot(arrived.pose_MB().position().x_m() - 30.0, arrived.pose_MB().position().y_m() - 10.0),
            0.3);
  EXPECT_GE(arrived.nav_replans(), 1u) << "the path through the rock was never replanned";
  double passed_at_y = 1e9;  // the robot's lowest y beside the rock
  for (const auto& s : observer.History("r1")) {
    EXPECT_FALSE(s.in_contact()) << "r1 touched occupied space at (" << s.pose_MB().position().x_m() << ", "
                                 << s.pose_MB().position().y_m() << ")";
    const double x = s.pose_MB().position().x_m();
    if (x > 14.0 && x < 15.5) passed_at_y = std::min(passed_at_y, s.pose_MB().position().y_m());
  }
  EXPECT_GT(passed_at_y, 20.4 + 0.25) << "r1 did not keep north of the rock";
  EXPECT_LT(passed_at_y, 1e8) << "r1 never passed the rock";
  Figure("rock_pass_y_m", passed_at_y);
  Figure("replans", arrived.nav_replans());
  // The navigation map (x in [-6, 14] at first) grew over the goal.
  std::ifstream log(logs + "/r1.log");
  int growths = 0;
  for (std::string line; std::getline(log, line);)
    growths += line.find("navigation map grown") != std::string::npos;
  EXPECT_GE(growths, 1) << "the navigation map never grew (see " << logs << ")";
  Figure("nav_map_growths", growths);
}

// Narrow passages and recovery on the robot's own map: a 0.6 m wheeled robot in a room
// whose only way out is a 1.0 m doorway, sent to the corridor outside. As it comes within 4.3 m of the
// doorway a rock falls into it and boxes the robot in: its map (every wall of the room seen) holds no way
// out. The rock is cleared 4 s later, like a person or dust that moves on; the robot, stopped about 3 m short
// of the doorway, sees its floor again through the low beams and its map lets it through. (Closer than ~2.5 m
// a VLP-16 0.5 m up sees too little of the floor there to clear the rock's foot, which stays on its map as a
// step: a limit of any map built from rays; the recovery's back-up of 0.4 m does not get it that far.) The
// goal does not fail: the recovery tree runs (reported in the robot's state), and once the doorway is open
// again on its own map the robot drives through it and arrives, with no contact.
TEST(NavigationOverDds, ABoxedInRobotRecoversAndPassesAOneMetreDoorway) {
  const int domain = 66;
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/doorway";
  std::filesystem::create_directories(logs);
  const std::string config = logs + "/agent.yaml";
  {
    // The doorway at x = 9.1 in the corridor's south wall (y 5.8-6.0), the rock 0.15 m beyond it each side.
    std::ofstream out(config);
    out << "simulation:\n  rockfalls: \"near4.3:8.5,5.65,9.7,6.15,1.0:+4\"\n";
  }
  Observer observer(domain);
  // In the room south of the corridor (x 6.2-12.0, y 0.2-5.8), facing the doorway.
  ChildProcess agent({kAgent, "--robot-id", "r1", "--platform", "wheeled", "--world", "builtin:building",
                      "--start", "9.1,0.8,1.5708", "--domain", std::to_string(domain), "--config", config},
                     logs + "/r1.log");
  ASSERT_TRUE(agent.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("op", domain, logs);
  ASSERT_TRUE(op.Run("wait r1 online 5")["ok"]);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  json r = op.Run("goto r1 9.1 7.1 --wait 120", 130s);
  EXPECT_TRUE(r["ok"]) << r << " (see " << logs << ")";
  const auto arrived = observer.FreshState("r1");
  EXPECT_LT(std::hypot(arrived.pose_MB().position().x_m() - 9.1, arrived.pose_MB().position().y_m() - 7.1),
            0.3);
  std::string recovery_report;  // the longest report seen while the goal was active
  double closest_to_rock_m = 1e9;
  double door_x_m = 1e9;  // x where the robot crossed the wall's line y = 5.9
  double previous_y = -1e9;
  for (const auto& s : observer.History("r1")) {
    const double x = s.pose_MB().position().x_m();
    const double y = s.pose_MB().position().y_m();
    EXPECT_FALSE(s.in_contact()) << "r1 touched occupied space at (" << x << ", " << y << ")";
    if (s.nav_reason().rfind("recovering after:", 0) == 0 && s.nav_reason().size() > recovery_report.size()) {
      recovery_report = s.nav_reason();
    }
    if (recovery_report.empty()) {  // before the recovery: how close it came to the rock (which then stood)
      closest_to_rock_m =
          std::min(closest_to_rock_m, std::hypot(std::max({8.5 - x, 0.0, x - 9.7}), 5.65 - y));
    }
    if (previous_y < 5.9 && y >= 5.9) door_x_m = x;
    previous_y = y;
  }
  EXPECT_FALSE(recovery_report.empty())
      << "no recovery was reported: was the robot boxed in? (see " << logs << ")";
  std::printf("recovery report: %s\n", recovery_report.c_str());
  EXPECT_NEAR(door_x_m, 9.1, 0.2) << "r1 did not pass through the doorway's middle";
  Figure("door_crossing_x_m", door_x_m);
  Figure("closest_to_rock_before_recovery_m", closest_to_rock_m);
}

// Several floors on the robots' own maps: a legged robot sent to a room on floor 2 of
// the two-floor building, which its map has never seen, climbs the switchback stairwell with partial plans
// that grow with its map and arrives on floor 2; a wheeled robot that has seen the stairs is refused the
// upper floor naming their step.
TEST(NavigationOverDds, LeggedRobotReachesTheFloorAboveAndAWheeledOneIsRefused) {
  const int domain = 65;
  const std::string logs = std::string(CAIRN_BINARY_DIR) + "/test-logs/floors";
  std::filesystem::create_directories(logs);
  Observer observer(domain);
  ChildProcess legged({kAgent, "--robot-id", "r1", "--platform", "legged", "--world", "builtin:building",
                       "--start", "14,7.1,0", "--domain", std::to_string(domain)},
                      logs + "/r1.log");
  ASSERT_TRUE(legged.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("op", domain, logs);
  ASSERT_TRUE(op.Run("wait r1 online 5")["ok"]);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  // To the foot of the stairwell (through its 1.2 m entrance), then the room north of the corridor on floor 2
  // (z = 3.2): accepted with a partial plan up the steps the robot sees, extended as its map grows.
  json r = op.Run("goto r1 19.0 6.5 --wait 60", 70s);
  ASSERT_TRUE(r["ok"]) << r << " (see " << logs << ")";
  // A robot whose goal failed can be sent again and goes (section 3): an operator whose robot stopped on the
  // stairs sends the goal once more. It must arrive (30-33 s in 5 of 5 runs on 2026-11-23 at the first
  // attempt; the in-process bench from 20 corridor starts: docs/PERFORMANCE.md).
  const auto climb_start = Clock::now();
  int attempts = 0;
  do {
    ++attempts;
    // 120 s bounds an attempt, within the binary's ctest time-out; a goal without progress fails by itself
    // (navigation.stall_timeout_s) and its recovery tree runs.
    r = op.Run("goto r1 15.1 11.0 --z 3.2 --wait 120", 130s);
    if (!r["ok"]) {
      std::printf("r1 goal to floor 2, attempt %d: %s; its last 60 s:\n%s", attempts, r.dump().c_str(),
                  TrackTail(observer.History("r1"), 60.0, 3.0).c_str());
    }
  } while (!r["ok"] && attempts < 2);
  const double climb_s = std::chrono::duration<double>(Clock::now() - climb_start).count();
  const auto arrived = observer.FreshState("r1");
  const auto& p = arrived.pose_MB().position();
  EXPECT_TRUE(r["ok"]) << "r1 did not reach floor 2 in " << attempts << " attempts: " << r << " (see " << logs
                       << ")";
  if (r["ok"]) {
    EXPECT_LT(std::hypot(p.x_m() - 15.1, p.y_m() - 11.0), 0.3) << "see " << logs;
    EXPECT_NEAR(p.z_m(), 3.2, 0.15) << "r1 arrived, but not on floor 2 (see " << logs << ")";
  } else {
    EXPECT_FALSE(r.value("reason", "").empty()) << r;
    op.Run("stop r1");  // a timed-out goal may still be running: the wheeled robot's part needs the cores
  }
  Figure("legged_arrived_floor2", r["ok"] ? 1.0 : 0.0);
  Figure("legged_floor2_attempts", attempts);
  Figure("legged_floor2_s", climb_s);
  double highest_z = 0.0;
  for (const auto& s : observer.History("r1")) {
    EXPECT_FALSE(s.in_contact()) << "r1 touched occupied space at (" << s.pose_MB().position().x_m() << ", "
                                 << s.pose_MB().position().y_m() << ", " << s.pose_MB().position().z_m()
                                 << ")";
    highest_z = std::max(highest_z, s.pose_MB().position().z_m());
  }
  std::printf("%s", TrackBeforeContact(observer.History("r1")).c_str());
  Figure("legged_final_z_m", p.z_m());
  Figure("legged_highest_z_m", highest_z);
  EXPECT_GE(highest_z, 1.0) << "r1 did not climb five steps of the lower flight (see " << logs << ")";

  // The wheeled robot (started now: two agents mapping at once load this 2-core machine) goes to the foot of
  // the stairs, seeing them, then is refused the upper floor naming the step.
  ChildProcess wheeled({kAgent, "--robot-id", "r2", "--platform", "wheeled", "--world", "builtin:building",
                        "--start", "10,7.1,0", "--domain", std::to_string(domain)},
                       logs + "/r2.log");
  ASSERT_TRUE(wheeled.WaitForLine("READY", 60s)) << "see " << logs;
  ASSERT_TRUE(op.Run("wait r2 online 5")["ok"]);
  ASSERT_TRUE(op.Run("request-control r2")["ok"]);
  r = op.Run("goto r2 18.9 6.9 --wait 120", 130s);
  ASSERT_TRUE(r["ok"]) << r << " (see " << logs << ")";
  // Refused naming the step when r2's navigation map already shows the flight (every run so far), or, when
  // the map lags (a loaded machine), accepted toward the flight it has not seen and failed at the end of that
  // partial plan naming the step: either way the operator learns why and r2 stays downstairs.
  r = op.Run("goto r2 15.1 11.0 --z 3.2 --wait 60", 70s);
  EXPECT_FALSE(r["ok"]) << r;
  Figure("wheeled_refused_at_once", r["result"] == "refused" ? 1.0 : 0.0);
  EXPECT_LT(observer.FreshState("r2").pose_MB().position().z_m(), 0.2) << "r2 climbed";
  const std::string reason = r.value("reason", "");
  EXPECT_NE(reason.find("step"), std::string::npos) << reason;
  EXPECT_NE(reason.find("max_step_m 0.15"), std::string::npos) << reason;
}

}  // namespace
}  // namespace cairn
