// Restart into the last known safe state, through real processes in this test's private network
// namespace: a cairn_agent run by its supervisor (--supervise --journal) is SIGKILLed in the middle of a
// goal; the supervisor starts it again with --resume, and the robot comes back idle where it was, with its
// lock's holder, its map reloaded and the old goal offered (never resumed by itself) until the holder resumes
// it.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cairn_msgsPubSubTypes.h"
#include "goal_util.h"
#include "integration_util.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;
namespace msgs = cairn_msgs;

const std::string kWorld = "builtin:tunnels";

// The supervisor's child (the agent itself), or -1.
pid_t ChildOf(pid_t supervisor) {
  std::ifstream children("/proc/" + std::to_string(supervisor) + "/task/" + std::to_string(supervisor) +
                         "/children");
  pid_t child = -1;
  children >> child;
  return child;
}

json ReadJournalJson(const std::string& dir) {
  std::ifstream in(dir + "/journal.json");
  if (!in) return json();
  return json::parse(in, nullptr, /*allow_exceptions=*/false);
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(Resume, AnAgentKilledMidGoalComesBackIdleWithItsLockMapAndGoalOfferedNeverResumed) {
  const int domain = 86;
  const std::string logs = FreshLogs("resume", "killed_mid_goal");
  const std::string journal = logs + "/journal";
  Observer observer(domain);
  ChildProcess supervisor(
      {kAgent, "--robot-id", "r1", "--world", kWorld, "--start", "slot:0", "--domain", std::to_string(domain),
       "--journal", journal, "--journal-map-every", "1", "--supervise"},
      logs + "/r1.log");
  ASSERT_TRUE(supervisor.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("opA", domain, logs);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  const msgs::RobotState start = observer.FreshState("r1");
  const Eigen::Vector2d goal = GoalAtPathLength(start, 25, 40);
  json r = op.Run(GotoCommand("r1", goal));
  ASSERT_TRUE(r["ok"]) << r;

  // Driving, with the goal and a map snapshot in the journal.
  const auto driving = Clock::now();
  json written;
  while (Clock::now() - driving < 30s) {
    written = ReadJournalJson(journal);
    const bool moved = Distance(start, observer.FreshState("r1")) > 3.0;
    if (moved && written.is_object() && written["goal"].is_object() && written["map_file"] == "map.bt") break;
    std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(written.is_object() && written["goal"].is_object() && written["map_file"] == "map.bt")
      << "journal: " << written.dump();
  EXPECT_EQ(written["holder_id"], "opA");
  EXPECT_EQ(written["mode"], "waypoint");

  const pid_t agent = ChildOf(supervisor.pid());
  ASSERT_GT(agent, 0) << "the supervisor runs no agent";
  const msgs::RobotState before_kill = observer.FreshState("r1");
  ASSERT_EQ(::kill(agent, SIGKILL), 0);
  const auto killed = Clock::now();
  ASSERT_TRUE(supervisor.WaitForLine("READY", 60s))
      << "the supervisor did not start the agent again; see " << logs;
  Figure("sigkill_to_ready_s", std::chrono::duration<double>(Clock::now() - killed).count());
  EXPECT_NE(ChildOf(supervisor.pid()), agent);

  // Back idle, at rest, where it was, with its holder (alive again once the basestation is heard) and the
  // goal offered.
  msgs::RobotState back;
  bool holder_alive = false;
  const auto resumed = Clock::now();
  while (Clock::now() - resumed < 10s && !holder_alive) {
    back = observer.FreshState("r1");
    holder_alive = back.holder_id() == "opA" && back.holder_alive();
  }
  EXPECT_TRUE(holder_alive) << "holder '" << back.holder_id() << "' alive " << back.holder_alive();
  Figure("sigkill_to_holder_alive_s", std::chrono::duration<double>(Clock::now() - killed).count());
  EXPECT_EQ(back.mode(), "idle");
  EXPECT_TRUE(back.has_resumable_goal());
  EXPECT_NEAR(back.resumable_goal_M().x_m(), goal.x(), 0.01);
  EXPECT_NEAR(back.resumable_goal_M().y_m(), goal.y(), 0.01);
  const double displaced_m = Distance(before_kill, back);
  EXPECT_LT(displaced_m, 1.0) << "the robot came back elsewhere";
  Figure("restart_position_error_m", displaced_m);
  const std::string log = ReadFile(logs + "/r1.log");
  EXPECT_NE(log.find("resumed from its journal: idle (was waypoint), lock with opA"), std::string::npos);
  EXPECT_NE(log.find("its map from " + journal + "/map.bt"), std::string::npos) << "map not reloaded";
  const std::size_t from = observer.History("r1").size();
  std::this_thread::sleep_for(3s);
  const auto history = observer.History("r1");
  double travel_m = 0;
  for (std::size_t i = from; i < history.size(); ++i)
    travel_m = std::max(travel_m, Distance(history[from], history[i]));
  EXPECT_LT(travel_m, 0.02) << "the robot resumed its goal by itself";
  r = op.Run("status r1");
  EXPECT_TRUE(r.contains("resumable_goal")) << r;
  EXPECT_NE(r["valid_actions"].dump().find("resume-goal"), std::string::npos) << r;

  // Nobody else may take it; its holder resumes the goal, and it arrives.
  Base other("opB", domain, logs);
  EXPECT_EQ(other.Run("request-control r1")["result"], "refused");
  r = op.Run("resume-goal r1 --wait 180", 200s);
  EXPECT_TRUE(r["ok"]) << r;
  EXPECT_NE(r.value("reason", "").find("arrived"), std::string::npos) << r;
  EXPECT_FALSE(observer.FreshState("r1").has_resumable_goal()) << "the offer stays after it was taken";
}

}  // namespace
}  // namespace cairn
