// The fault suite through real processes in this test's private network namespace: a robot agent's perception
// component is made to throw, and to hang (test hook --inject-fault). One that throws is restarted alone, the
// modes that need it are refused meanwhile and come back after, basestations are told, and the robot never
// moves. One that hangs is never started beside its hung loop: it stays down (escalated), or, supervised, the
// process restarts from its journal. An operator's restart is the lock holder's only.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include "cairn_msgsPubSubTypes.h"
#include "integration_util.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;
namespace msgs = cairn_msgs;

const std::string kWorld = "builtin:tunnels";

// A config whose restarts wait `backoff_s` (the window in which the degraded modes are checked).
std::string ConfigWithBackoff(const std::string& logs, double backoff_s) {
  std::string path = logs + "/agent.yaml";
  std::ofstream out(path);
  out << "health:\n  restart_backoff_s: " << backoff_s << "\n  restart_backoff_max_s: 60\n";
  return path;
}

// `health R` until `predicate(component's json)` holds for `name`, up to `timeout`; the last answer.
json WaitForComponent(Base& op, const std::string& robot, const std::string& name,
                      const std::function<bool(const json&)>& predicate, std::chrono::seconds timeout) {
  const auto deadline = Clock::now() + timeout;
  json last;
  while (Clock::now() < deadline) {
    last = op.Run("health " + robot);
    if (last["ok"] == true) {
      for (const json& c : last["components"]) {
        if (c["name"] == name && predicate(c)) return last;
      }
    }
    std::this_thread::sleep_for(200ms);
  }
  ADD_FAILURE() << name << " never reached the expected health; last: " << last.dump();
  return last;
}

json Component(const json& health, const std::string& name) {
  for (const json& c : health["components"]) {
    if (c["name"] == name) return c;
  }
  return json();
}

// Largest distance of the robot from `from` over its states since the observer started.
double MaxDisplacement(Observer& observer, const std::string& robot, const msgs::RobotState& from) {
  double worst = 0.0;
  for (const auto& s : observer.History(robot)) worst = std::max(worst, Distance(from, s));
  return worst;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

bool SawEvent(const Base& op, const std::string& kind, const std::string& component) {
  for (const json& e : op.events()) {
    if (e["event"] == kind && e.value("other", "") == component) return true;
  }
  return false;
}

TEST(ComponentFaults, PerceptionThatThrowsIsRestartedAloneItsModesWaitAndTheRobotNeverMoves) {
  const int domain = 89;
  const std::string logs = FreshLogs("component_faults", "throw");
  Observer observer(domain);
  auto agent =
      StartAgentIn(kWorld, "r1", domain, logs,
                   {"--config", ConfigWithBackoff(logs, 6.0), "--inject-fault", "perception:throw:14"});
  Base op("opA", domain, logs);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  // Smart joystick needs the robot to have heard this basestation's joystick (its agent info): a moment.
  json r;
  for (const auto until = Clock::now() + 10s; Clock::now() < until; std::this_thread::sleep_for(200ms)) {
    r = op.Run("mode r1 smart_joystick");
    if (r["ok"] == true || r.value("condition", "") != "IsJoystickAlive") break;
  }
  ASSERT_TRUE(r["ok"]) << r;
  const msgs::RobotState start = observer.FreshState("r1");
  // Its first health (at start) has no map yet: the one after the perception thread's first ticks.
  json health = WaitForComponent(
      op, "r1", "perception", [](const json& c) { return c["memory_bytes"].get<double>() > 0; }, 10s);
  ASSERT_TRUE(health["ok"]) << health;
  EXPECT_TRUE(health["all_up"]) << health;
  EXPECT_EQ(health["components"].size(), 8u) << health;
  EXPECT_GT(Component(health, "perception")["memory_bytes"].get<double>(), 0) << health;
  // The planner holds a copy of the navigation map (voxels, seen-free voxels, grids): megabytes, not zero.
  EXPECT_GT(Component(health, "planning")["memory_bytes"].get<double>(), 1e6) << health;

  // The fault: perception goes down; the robot leaves smart joystick (it needs perception) and stays put.
  health = WaitForComponent(
      op, "r1", "perception", [](const json& c) { return c["state"] == "down"; }, 30s);
  const auto down_at = Clock::now();
  EXPECT_NE(Component(health, "perception")["last_error"].get<std::string>().find("injected fault"),
            std::string::npos)
      << health;
  for (const std::string name :
       {"platform", "planning", "command_interface", "mode_tree", "mux", "navigation", "telemetry"}) {
    EXPECT_EQ(Component(health, name)["state"], "active") << name << ": " << health;
    EXPECT_EQ(Component(health, name)["restarts"], 0) << name << " was restarted too: " << health;
  }
  const msgs::RobotState degraded = observer.FreshState("r1");
  EXPECT_EQ(degraded.mode(), "idle");
  // The mode tree may see perception between its loop's throw and the health monitor marking it down:
  // "inactive" then, "down" after; either way the condition names perception.
  const std::string r1_log = ReadFile(logs + "/r1.log");
  EXPECT_TRUE(r1_log.find("smart_joystick no longer allowed: IsComponentUp: perception is down") !=
                  std::string::npos ||
              r1_log.find("smart_joystick no longer allowed: IsComponentUp: perception is inactive") !=
                  std::string::npos)
      << "see " << logs << "/r1.log";
  json status = op.Run("status r1");
  EXPECT_EQ(status.dump().find("smart_joystick"), std::string::npos) << "offered while down: " << status;
  // Refused while it is down, naming it; manual (no perception needed) is not.
  r = op.Run("mode r1 smart_joystick");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r.value("reason", "").find("perception is down"), std::string::npos) << r;
  r = op.Run("explore r1");
  EXPECT_FALSE(r["ok"]) << r;
  r = op.Run("mode r1 manual");
  EXPECT_TRUE(r["ok"]) << r;
  ASSERT_TRUE(op.Run("mode r1 idle")["ok"]);
  EXPECT_LT(std::chrono::duration<double>(Clock::now() - down_at).count(), 5.0)
      << "the checks above ran after the restart: lengthen restart_backoff_s";

  // Restarted alone after its back-off, with its map; smart joystick is valid again.
  health = WaitForComponent(
      op, "r1", "perception", [](const json& c) { return c["state"] == "active" && c["restarts"] == 1; },
      20s);
  const double down_s = std::chrono::duration<double>(Clock::now() - down_at).count();
  Figure("perception_down_s", down_s);
  EXPECT_GT(Component(health, "perception")["memory_bytes"].get<double>(), 0) << health;
  r = op.Run("mode r1 smart_joystick");
  EXPECT_TRUE(r["ok"]) << r;
  // Its loops beat again at their rate.
  std::this_thread::sleep_for(2500ms);
  health = op.Run("health r1");
  EXPECT_GT(Component(health, "perception")["loop_rate_hz"].get<double>(),
            0.5 * Component(health, "perception")["target_rate_hz"].get<double>())
      << health;
  ASSERT_TRUE(op.Run("mode r1 idle")["ok"]);
  op.Run("sleep 0.5");  // the events of the last seconds print before the next answer
  EXPECT_TRUE(SawEvent(op, "component_failed", "perception")) << "the operator was not told";
  EXPECT_TRUE(SawEvent(op, "component_restarted", "perception")) << "the operator was not told";
  const double moved_m = MaxDisplacement(observer, "r1", start);
  Figure("max_displacement_m", moved_m);
  EXPECT_LT(moved_m, 0.05) << "the robot moved";
}

TEST(ComponentFaults, PerceptionThatDoesNotStopIsNeverRunTwiceAndOnlyTheHolderRestarts) {
  const int domain = 90;
  const std::string logs = FreshLogs("component_faults", "hang");
  Observer observer(domain);
  auto agent =
      StartAgentIn(kWorld, "r1", domain, logs,
                   {"--config", ConfigWithBackoff(logs, 2.0), "--inject-fault", "perception:hang:10"});
  Base op("opA", domain, logs);
  Base other("opB", domain, logs);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  const msgs::RobotState start = observer.FreshState("r1");

  // The hang: 3 missed deadlines of 3 s, then its loops are asked to stop; the hung one does not. Not
  // supervised, the agent keeps perception down (never two perception loops on one map) and says why.
  json health = WaitForComponent(
      op, "r1", "perception", [](const json& c) { return c["state"] == "down"; }, 60s);
  op.Run("sleep 3");  // past the stop's grace period and a back-off: a restart would have come by now
  health = op.Run("health r1");
  EXPECT_EQ(Component(health, "perception")["state"], "down") << "restarted beside its hung loop: " << health;
  EXPECT_EQ(Component(health, "perception")["restarts"], 0) << health;
  EXPECT_NE(Component(health, "perception")["last_error"].get<std::string>().find("stalled"),
            std::string::npos)
      << health;
  EXPECT_TRUE(SawEvent(op, "component_escalated", "perception")) << "the operator was not told";
  json r = op.Run("mode r1 smart_joystick");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r.value("reason", "").find("not restarted in this process"), std::string::npos) << r;
  r = op.Run("restart r1 perception");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r.value("reason", "").find("restart the agent"), std::string::npos) << r;
  const std::string log = ReadFile(logs + "/r1.log");
  EXPECT_NE(log.find("not started again while it runs"), std::string::npos) << "see " << logs << "/r1.log";

  // An operator's restart: the holder's only, of a component that exists.
  r = other.Run("restart r1 planning");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_EQ(r["result"], "refused") << r;
  r = op.Run("restart r1 lidar");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r.value("reason", "").find("the components are platform, perception, planning"),
            std::string::npos)
      << r;
  r = op.Run("restart r1 planning");
  EXPECT_TRUE(r["ok"]) << r;
  health = WaitForComponent(
      op, "r1", "planning", [](const json& c) { return c["restarts"] == 1; }, 10s);
  EXPECT_EQ(Component(health, "planning")["state"], "active") << health;
  // The restarted planning thread plans.
  r = op.Run("plan r1 5 0");
  EXPECT_TRUE(r.contains("ok")) << r;
  EXPECT_NE(r.value("result", ""), "timed_out") << r;
  const double moved_m = MaxDisplacement(observer, "r1", start);
  EXPECT_LT(moved_m, 0.05) << "the robot moved";
}

// Interrupted is not ended: an exploration whose perception throws pauses (its task kept under its id, the
// operator told), and resumes by itself once perception is back; an operator's stop then ends it for good.
TEST(ComponentFaults, AnExplorationPausedByARestartingPartResumesByItself) {
  const int domain = 92;
  const std::string logs = FreshLogs("component_faults", "mission_paused");
  Observer observer(domain);
  auto agent =
      StartAgentIn(kWorld, "r1", domain, logs,
                   {"--config", ConfigWithBackoff(logs, 3.0), "--inject-fault", "perception:throw:10"});
  Base op("opA", domain, logs);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  json r = op.Run("explore r1");
  ASSERT_TRUE(r["ok"]) << r;
  const uint32_t task_id = r["goal_id"].get<uint32_t>();  // the exploration task id
  // Paused while perception is down: explore_state "paused" under the same task id, with the reason.
  msgs::RobotState s;
  const auto deadline = Clock::now() + 40s;
  while (Clock::now() < deadline && s.mission_state() != "paused") {
    s = observer.FreshState("r1");
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_EQ(s.mission_state(), "paused") << "see " << logs << "/r1.log";
  const auto paused_at = Clock::now();
  EXPECT_EQ(s.mission_kind(), "explore");
  EXPECT_EQ(s.explore_state(), "paused");
  EXPECT_EQ(s.explore_task_id(), task_id);
  EXPECT_NE(s.mission_reason().find("perception"), std::string::npos) << s.mission_reason();
  EXPECT_EQ(s.mode(), "idle");
  // Resumed by itself after the restart (3 s back-off), under the same task id.
  while (Clock::now() < paused_at + 30s && !(s.mission_state().empty() && s.mode() == "explore")) {
    s = observer.FreshState("r1");
    std::this_thread::sleep_for(50ms);
  }
  const double paused_s = std::chrono::duration<double>(Clock::now() - paused_at).count();
  Figure("exploration_paused_s", paused_s);
  EXPECT_EQ(s.mode(), "explore") << "not resumed; see " << logs << "/r1.log";
  EXPECT_EQ(s.explore_state(), "exploring");
  EXPECT_EQ(s.explore_task_id(), task_id);
  EXPECT_EQ(s.mission_reason().rfind("resumed after", 0), 0u) << s.mission_reason();
  auto saw = [&](const std::string& kind, const std::string& words) {
    for (const json& e : op.events()) {
      if (e["event"] == kind && e.dump().find(words) != std::string::npos) return true;
    }
    return false;
  };
  // The events reach the operator with the robot's next whole state (up to 0.5 s on a busy machine, more
  // when the state waits behind other traffic): read them for up to 10 s.
  for (const auto until = Clock::now() + 10s;
       Clock::now() < until && !saw("mission_resumed", "resumed after");)
    op.Run("sleep 0.5");
  EXPECT_TRUE(saw("mission_paused", "perception")) << "the operator was not told";
  EXPECT_TRUE(saw("mission_resumed", "resumed after")) << "the operator was not told";
  // An operator's stop ends it: it is not resumed.
  ASSERT_TRUE(op.Run("stop r1")["ok"]);
  std::this_thread::sleep_for(2500ms);
  s = observer.FreshState("r1");
  EXPECT_EQ(s.mode(), "idle");
  EXPECT_EQ(s.explore_state(), "stopped");
  EXPECT_TRUE(s.mission_state().empty());
}

// A convoy place is a mission too: a follower whose platform throws keeps its place (convoy_state "paused",
// the same robot ahead), resumes by itself once the platform is back, and follows the leader on, on the trail
// the leader drove meanwhile.
TEST(ComponentFaults, AConvoyFollowerWhosePlatformRestartsKeepsItsPlace) {
  const int domain = 95;
  const std::string logs = FreshLogs("component_faults", "convoy_paused");
  Observer observer(domain);
  // The default world's main tunnel (y = 20), the follower 3 m (the convoy spacing) behind the leader.
  auto start = [&](const std::string& id, const std::string& at, std::vector<std::string> extra) {
    std::vector<std::string> argv = {kAgent,     "--robot-id",          id, "--start", at,
                                     "--domain", std::to_string(domain)};
    argv.insert(argv.end(), extra.begin(), extra.end());
    auto agent = std::make_unique<ChildProcess>(argv, logs + "/" + id + ".log");
    EXPECT_TRUE(agent->WaitForLine("READY", 60s)) << id << " did not start; see " << logs;
    return agent;
  };
  auto leader = start("cl", "14,20,0", {});
  auto follower = start("c1", "11,20,0",
                        {"--config", ConfigWithBackoff(logs, 3.0), "--inject-fault", "platform:throw:12"});
  Base op("opA", domain, logs);
  ASSERT_TRUE(op.Run("wait cl online 10")["ok"]);
  ASSERT_TRUE(op.Run("wait c1 online 10")["ok"]);
  ASSERT_TRUE(op.Run("request-control cl c1")["ok"]);
  json r = op.Run("convoy cl c1");
  ASSERT_TRUE(r["ok"]) << r;
  msgs::RobotState s;
  for (const auto deadline = Clock::now() + 40s; Clock::now() < deadline && s.mission_state() != "paused";) {
    s = observer.FreshState("c1");
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_EQ(s.mission_state(), "paused") << "see " << logs << "/c1.log";
  EXPECT_EQ(s.mission_kind(), "convoy");
  EXPECT_EQ(s.convoy_state(), "paused") << s.convoy_reason();
  ASSERT_FALSE(s.convoy_ahead_ids().empty());
  EXPECT_EQ(s.convoy_ahead_ids().front(), "cl");
  EXPECT_NE(s.mission_reason().find("platform"), std::string::npos) << s.mission_reason();
  EXPECT_EQ(s.mode(), "idle");
  // The leader drives on while its follower waits; the follower resumes by itself and follows.
  ASSERT_TRUE(op.Run("goto cl 24 20")["ok"]);
  for (const auto until = Clock::now() + 30s;
       Clock::now() < until && !(s.mission_state().empty() && s.mode() == "convoy");) {
    s = observer.FreshState("c1");
    std::this_thread::sleep_for(50ms);
  }
  EXPECT_EQ(s.mode(), "convoy") << "not resumed; see " << logs << "/c1.log";
  EXPECT_EQ(s.mission_reason().rfind("resumed after", 0), 0u) << s.mission_reason();
  r = op.Run("wait cl arrived 60", 70s);
  ASSERT_TRUE(r["ok"]) << r;
  // Closed up behind the stopped leader: holding at the spacing (3 m, within 1 m) behind it.
  for (const auto until = Clock::now() + 30s; Clock::now() < until;) {
    s = observer.FreshState("c1");
    if (s.convoy_state() == "holding" && s.pose_MB().position().x_m() > 19.0) break;
    std::this_thread::sleep_for(200ms);
  }
  EXPECT_EQ(s.mode(), "convoy");
  EXPECT_EQ(s.convoy_state(), "holding") << s.convoy_reason();
  EXPECT_NEAR(s.pose_MB().position().x_m(), 21.0, 1.0) << "see " << logs << "/c1.log";
  auto told = [&](const std::string& kind) {
    return std::any_of(op.events().begin(), op.events().end(),
                       [&](const json& e) { return e["event"] == kind && e.value("robot", "") == "c1"; });
  };
  for (const auto until = Clock::now() + 10s; Clock::now() < until && !told("mission_resumed");)
    op.Run("sleep 0.5");
  EXPECT_TRUE(told("mission_paused")) << "the operator was not told";
  EXPECT_TRUE(told("mission_resumed")) << "the operator was not told";
  for (const auto& state : observer.History("c1")) EXPECT_FALSE(state.in_contact());
}

// Supervised, the agent whose perception does not stop leaves for a restart from its journal: it comes back
// with every part up, idle, with its lock holder.
TEST(ComponentFaults, ASupervisedAgentWhosePartDoesNotStopRestartsFromItsJournal) {
  const int domain = 91;
  const std::string logs = FreshLogs("component_faults", "supervised_hang");
  Observer observer(domain);
  ChildProcess supervisor({kAgent, "--robot-id", "r1", "--world", kWorld, "--start", "slot:0", "--domain",
                           std::to_string(domain), "--config", ConfigWithBackoff(logs, 2.0), "--journal",
                           logs + "/journal", "--inject-fault", "perception:hang:8", "--supervise"},
                          logs + "/r1.log");
  ASSERT_TRUE(supervisor.WaitForLine("READY", 60s)) << "see " << logs;
  Base op("opA", domain, logs);
  ASSERT_TRUE(op.Run("request-control r1")["ok"]);
  const auto requested = Clock::now();
  // Stalled after 8 s + 9 s, asked to stop, escalated: the process exits and its supervisor starts it again.
  ASSERT_TRUE(supervisor.WaitForLine("READY", 90s)) << "not started again; see " << logs << "/r1.log";
  Figure("request_to_restarted_s", std::chrono::duration<double>(Clock::now() - requested).count());
  // Back with every part up (the hang fires again only 8 s after this start), its holder kept.
  json health = WaitForComponent(
      op, "r1", "perception", [](const json& c) { return c["state"] == "active" && c["restarts"] == 0; },
      20s);
  EXPECT_TRUE(health["all_up"]) << health;
  msgs::RobotState back;
  const auto resumed = Clock::now();
  while (Clock::now() - resumed < 10s && !(back.holder_id() == "opA" && back.holder_alive())) {
    back = observer.FreshState("r1");
  }
  EXPECT_EQ(back.holder_id(), "opA");
  EXPECT_EQ(back.mode(), "idle");
  op.Run("sleep 0.5");  // the events of the last seconds print before the next answer
  EXPECT_TRUE(SawEvent(op, "component_escalated", "perception"))
      << "the operator was not told why it restarts";
  const std::string log = ReadFile(logs + "/r1.log");
  EXPECT_NE(log.find("restarting the process (supervised)"), std::string::npos) << "see " << logs;
  EXPECT_NE(log.find("asked for a restart: a part of it did not stop"), std::string::npos) << "see " << logs;
  EXPECT_NE(log.find("resumed from its journal"), std::string::npos) << "see " << logs;
}

}  // namespace
}  // namespace cairn
