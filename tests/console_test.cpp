// The operator console, through real cairn_agent and cairn_base processes in this test's private
// network namespace: the REPL on a pseudo-terminal (events above the line being typed, Tab completion,
// Ctrl-C), operator words, news without asking, forgiving input, named places, an e-stop anyone can use,
// and a second console attached to a running demo.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <utility>

#include "cairn/core/build_paths.h"
#include "cairn_msgsPubSubTypes.h"
#include "integration_util.h"
#include "process.h"
#include "pty_process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using ::cairn::testing::PtyProcess;
using nlohmann::json;
namespace msgs = cairn_msgs;

std::string Logs(const std::string& test) {
  std::string dir = cairn::core::BinaryDir() + "/test-logs/console/" + test;
  std::filesystem::create_directories(dir);
  return dir;
}

std::vector<std::unique_ptr<ChildProcess>> StartRobots(int count, int domain, const std::string& logs) {
  std::vector<std::unique_ptr<ChildProcess>> robots;
  for (int i = 1; i <= count; ++i) {
    const std::string id = "r" + std::to_string(i);
    robots.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{kAgent, "--robot-id", id, "--start", "slot:" + std::to_string(i - 1),
                                 "--domain", std::to_string(domain), "--config", kLightLidarConfig},
        logs + "/" + id + ".log"));
  }
  for (auto& r : robots) EXPECT_TRUE(r->WaitForLine("READY", 60s)) << "see " << logs;
  return robots;
}

std::string WritePlaces(const std::string& path) {
  std::ofstream(path) << "places:\n  junction: {x_m: 30.0, y_m: 20.0, z_m: 0.0}\n";
  return path;
}

// `./cairn console --base-id op2 --json -- COMMAND...` against the running demo: the exit code and the result
// line (event lines, which may follow it, skipped).
std::pair<int, std::string> AttachedConsole(const std::vector<std::string>& command, const std::string& log) {
  std::vector<std::string> argv = {
      cairn::core::SourceDir() + "/cairn", "console", "--base-id", "op2", "--json", "--"};
  argv.insert(argv.end(), command.begin(), command.end());
  ChildProcess console(argv, log);
  console.CloseStdin();
  std::string answer;
  while (auto line = console.ReadLine(20s)) {
    if (line->find("\"event\"") == std::string::npos) answer = *line;
  }
  const auto status = console.Wait(10s);
  return {status && WIFEXITED(*status) ? WEXITSTATUS(*status) : -1, answer};
}

bool HasEvent(const std::vector<json>& events, const std::string& kind, const std::string& robot) {
  for (const auto& e : events) {
    if (e.value("event", "") == kind && e.value("robot", "") == robot) return true;
  }
  return false;
}

// The REPL on a terminal: an event prints above the line being typed and the line survives; Tab completes
// commands; Ctrl-C clears the line, cancels a wait (the robot drives on) and never ends the console.
TEST(Console, TerminalEventsAboveTheLineTabCompletionAndCtrlC) {
  const int domain = 81;
  const std::string logs = Logs("pty");
  Observer observer(domain);
  auto robots = StartRobots(2, domain, logs);
  PtyProcess console({kBase, "--base-id", "op1", "--domain", std::to_string(domain), "--places",
                      WritePlaces(logs + "/places.yaml")});
  ASSERT_TRUE(console.WaitFor("op1> ", 10s)) << console.output();
  console.Drain(2s);  // discovery

  // An event while a line is half typed: printed above it, and the line is redrawn as it was.
  console.Mark();
  console.Type("stat");
  ASSERT_TRUE(console.WaitFor("stat", 2s));
  ChildProcess other(
      {kBase, "--base-id", "op2", "--domain", std::to_string(domain), "--", "request-control", "r2"},
      logs + "/op2.log");
  ASSERT_TRUE(console.WaitFor("r2 control granted to op2", 10s)) << console.SinceMark();
  ASSERT_TRUE(console.WaitFor("op1> stat", 2s)) << "the half-typed line was lost: " << console.SinceMark();

  // Ctrl-C at the prompt clears the line; Tab completes a command.
  console.Mark();
  console.Type("\x03");
  ASSERT_TRUE(console.WaitFor("^C", 2s)) << console.SinceMark();
  console.Type("reque\t");  // the terminal shows only what completion adds: the command below proves it
  console.Drain(300ms);
  console.Type("r1\r");
  ASSERT_TRUE(console.WaitFor("request-control r1: accepted", 5s)) << console.SinceMark();

  // Ctrl-C during goto --wait stops the waiting, not the robot, and not the console.
  console.Mark();
  console.Type("goto r1 junction --wait\r");
  ASSERT_TRUE(console.WaitFor("goto r1: accepted", 10s)) << console.SinceMark();
  console.Drain(1500ms);
  console.Type("\x03");
  ASSERT_TRUE(console.WaitFor("goto r1: cancelled", 3s)) << console.SinceMark();
  ASSERT_TRUE(console.WaitFor("op1> ", 2s));
  EXPECT_TRUE(console.Running());
  // The robot drives on (unless a starved control loop tripped the local planner's staleness guard, which
  // stops it whatever the console does).
  const msgs::RobotState after_cancel = observer.FreshState("r1");
  if (after_cancel.nav_reason().find("IsLocalPlannerHealthy") == std::string::npos) {
    EXPECT_EQ(after_cancel.mode(), "waypoint") << "the robot drives on";
  }

  // The robots table: aligned columns, nothing run together.
  console.Mark();
  console.Type("robots\r");
  ASSERT_TRUE(console.WaitFor("LAST REFUSAL", 5s));
  console.Drain(500ms);
  std::istringstream table(console.SinceMark());
  std::vector<std::string> lines;
  for (std::string line; std::getline(table, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.rfind("ROBOT", 0) == 0 || line.rfind("r1 ", 0) == 0 || line.rfind("r2 ", 0) == 0)
      lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), 3u) << console.SinceMark();
  const std::size_t mode_col = lines[0].find("MODE"), holder_col = lines[0].find("HOLDER");
  EXPECT_EQ(lines[1].substr(mode_col, 8), "waypoint") << lines[1];
  EXPECT_EQ(lines[1].substr(holder_col, 3), "op1") << lines[1];
  EXPECT_EQ(lines[1][holder_col - 1], ' ') << "columns run together: " << lines[1];
  EXPECT_EQ(lines[2].substr(holder_col, 3), "op2") << lines[2];

  console.Type("stop r1\r");
  ASSERT_TRUE(console.WaitFor("stop r1: accepted", 5s));
  console.Type("quit\r");
  EXPECT_TRUE(console.Wait(5s).has_value());
}

// One vocabulary and operator words; news without asking; forgiving input; places; an e-stop for everyone.
TEST(Console, WordsEventsForgivingInputPlacesAndEStop) {
  const int domain = 82;
  const std::string logs = Logs("json");
  Observer observer(domain);
  auto robots = StartRobots(2, domain, logs);
  const std::string places = WritePlaces(logs + "/places.yaml");
  Base opA("opA", domain, logs, {"--places", places, "--proximity-m", "60"});
  Base opB("opB", domain, logs);
  ASSERT_TRUE(opA.Run("wait r1 online 5")["ok"]);
  ASSERT_TRUE(opA.Run("wait r2 online 5")["ok"]);
  ASSERT_TRUE(opB.Run("wait r1 online 5")["ok"]);
  ASSERT_TRUE(opB.Run("status r1")["ok"]);  // opB has seen r1 free: the grant below is news to it
  // ... and its event detector too, which compares the views it samples at 10 Hz.
  std::this_thread::sleep_for(300ms);

  // Operator words: a tree refusal says what to do, keeps the condition id, and lists the valid actions.
  ASSERT_TRUE(opA.Run("request-control r1")["ok"]);
  json r = opA.Run("mode r1 waypoint");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["reason"], "waypoint mode needs a goal: use goto r1 X Y") << r;
  EXPECT_EQ(r["condition"], "HasWaypointGoal") << r;
  EXPECT_NE(std::find(r["valid_actions"].begin(), r["valid_actions"].end(), "goto"), r["valid_actions"].end())
      << r;
  r = opB.Run("mode r1 manual");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_EQ(r["condition"], "lock") << r;
  EXPECT_EQ(r["valid_actions"], json::array({"request-control", "yield", "stop"}))
      << "a non-holder may only ask the holder for it, ask it to get out of the way (its policy decides) or "
         "stop it: "
      << r;
  r = opA.Run("help r1");
  EXPECT_NE(std::find(r["valid_actions"].begin(), r["valid_actions"].end(), "release"),
            r["valid_actions"].end())
      << r;

  // Forgiving input.
  r = opA.Run("gotoo r1 1 2");
  EXPECT_EQ(r["result"], "invalid") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("did you mean goto?"), std::string::npos) << r;
  r = opA.Run("teleop r1 80 0 0.5", 10s);
  EXPECT_EQ(r["result"], "accepted") << r;
  EXPECT_NE(r["notice"].get<std::string>().find("1.50 m/s is r1's largest speed: sent 1.50 (asked 80.00)"),
            std::string::npos)
      << r;
  std::this_thread::sleep_for(1s);
  r = opA.Run("snapshot r1 " + logs + "/frame.png");
  EXPECT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["format"], "png") << r;
  std::ifstream png(logs + "/frame.png", std::ios::binary);
  char signature[8] = {};
  png.read(signature, 8);
  EXPECT_EQ(std::string(signature + 1, 3), "PNG") << "not a PNG file";
  r = opA.Run("snapshot r1 " + logs + "/frame.gif");
  EXPECT_EQ(r["result"], "invalid") << r;
  // Past the discovery window after start (1.5 s), an unknown robot is refused at once from the live list.
  const auto asked = Clock::now();
  r = opA.Run("request-control r9");
  const double refusal_s = std::chrono::duration<double>(Clock::now() - asked).count();
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_NE(r["reason"].get<std::string>().find("did you mean r1 or r2?"), std::string::npos) << r;
  EXPECT_LT(refusal_s, 0.5) << "an unknown robot is refused at once from the live list";
  Figure("unknown_robot_refusal_s", refusal_s);

  // Places: add, list, drive to one by name; the file keeps it for the next console.
  const msgs::RobotState here = observer.FreshState("r1");
  char add[96];
  std::snprintf(add, sizeof(add), "place add start_r1 %.2f,%.2f", here.pose_MB().position().x_m(),
                here.pose_MB().position().y_m());
  EXPECT_TRUE(opA.Run(add)["ok"]);
  r = opA.Run("places");
  ASSERT_EQ(r["places"].size(), 2u) << r;
  r = opA.Run("goto r1 junction");
  EXPECT_EQ(r["result"], "accepted") << r;
  const uint32_t goal_id = r["goal_id"];
  {
    Base reader("opC", domain, logs, {"--places", places});
    r = reader.Run("places");
    EXPECT_EQ(r["places"].size(), 2u) << "the places file did not keep start_r1: " << r;
  }

  // E-stop for everyone: opB, who holds nothing, stops r1; opA is told who did it; the lock stays.
  std::this_thread::sleep_for(2s);
  r = opB.Run("stop r1");
  EXPECT_EQ(r["result"], "accepted") << r;
  std::this_thread::sleep_for(500ms);
  const msgs::RobotState stopped = observer.FreshState("r1");
  EXPECT_EQ(stopped.mode(), "idle");
  EXPECT_EQ(stopped.holder_id(), "opA");
  opA.Run("events 50");
  EXPECT_TRUE(HasEvent(opA.events(), "stopped", "r1")) << "opA was not told that opB stopped r1";
  EXPECT_TRUE(HasEvent(opA.events(), "goal_abandoned", "r1"))
      << "the cancelled goal " << goal_id << " was not reported";
  EXPECT_TRUE(HasEvent(opA.events(), "proximity", "r1")) << "robots 60 m apart raise no proximity event";
  EXPECT_TRUE(HasEvent(opB.events(), "lock_granted", "r1"));

  // News without asking: an arrival reaches opA while it does something else.
  ASSERT_TRUE(opA.Run("goto r1 start_r1 0.5")["ok"]);
  bool arrived = false, resent = false;
  for (int i = 0; i < 60 && !arrived; ++i) {
    opA.Run("sleep 0.5");
    arrived = HasEvent(opA.events(), "arrived", "r1");
    // A control loop starved for 0.5 s on this loaded 2-core machine trips the local planner's staleness
    // guard (the robot stops, as it must); that failure is news too. Send the goal once more then.
    const msgs::RobotState s = observer.FreshState("r1");
    if (!arrived && !resent && s.nav_status() == msgs::NAV_STATUS_FAILED &&
        s.nav_reason().find("IsLocalPlannerHealthy") != std::string::npos) {
      resent = opA.Run("goto r1 start_r1 0.5")["ok"];
    }
  }
  EXPECT_TRUE(arrived) << "no arrival event; events: " << json(opA.events()).dump() << "; state "
                       << observer.FreshState("r1").nav_status() << " "
                       << observer.FreshState("r1").nav_reason();

  // stop all stops every live robot; a robot killed is reported lost.
  r = opB.Run("stop all");
  EXPECT_TRUE(r["ok"]) << r;
  EXPECT_EQ(r["robots"].size(), 2u) << r;
  robots[1]->Signal(SIGKILL);
  bool lost = false;
  for (int i = 0; i < 20 && !lost; ++i) {
    opA.Run("sleep 0.5");
    lost = HasEvent(opA.events(), "lost", "r2");
  }
  EXPECT_TRUE(lost) << "no lost event for r2";
  r = opA.Run("events 100");
  EXPECT_GE(r["events"].size(), 5u) << r;
}

// ./cairn console attaches a second operator to a running demo; the demo stops its robots when its own
// console ends on a closed stdin (no terminal to ask on).
// Handover between operators, each on a console of their own: op2's request for the robot op1 drives is
// told to op1 at once, with what it may answer; op1 denies, then grants, and op2 hears each answer; the robot
// drives on to its goal for its new holder. A request nobody answers expires, told to both; a holder hands a
// robot over unasked.
TEST(Console, HandoverBetweenOperatorsWithoutPolling) {
  const int domain = 84;
  const std::string logs = Logs("handover");
  Observer observer(domain);
  const std::string config = logs + "/agent.yaml";
  std::ofstream(config) << "command_interface:\n  handover_request_timeout_s: 4.0\n";
  ChildProcess robot({kAgent, "--robot-id", "r1", "--start", "slot:0", "--domain", std::to_string(domain),
                      "--config", config},
                     logs + "/r1.log");
  ASSERT_TRUE(robot.WaitForLine("READY", 60s)) << "see " << logs;
  auto console = [&](const std::string& base_id) {
    return std::make_unique<PtyProcess>(std::vector<std::string>{kBase, "--base-id", base_id, "--domain",
                                                                 std::to_string(domain), "--places",
                                                                 WritePlaces(logs + "/places.yaml")});
  };
  auto op1 = console("op1");
  auto op2 = console("op2");
  ASSERT_TRUE(op1->WaitFor("op1> ", 10s)) << op1->output();
  ASSERT_TRUE(op2->WaitFor("op2> ", 10s)) << op2->output();
  op1->Drain(2s);  // discovery
  op2->Drain(100ms);
  op1->Type("request-control r1\r");
  ASSERT_TRUE(op1->WaitFor("request-control r1: accepted", 10s)) << op1->SinceMark();
  op1->Type("goto r1 junction\r");
  ASSERT_TRUE(op1->WaitFor("goto r1: accepted", 10s)) << op1->SinceMark();
  const msgs::RobotState driving = observer.FreshState("r1");
  ASSERT_EQ(driving.mode(), "waypoint");

  // op2 asks: refused for now, op1 is told at once what it may answer.
  op1->Mark();
  op2->Mark();
  op2->Type("request-control r1\r");
  ASSERT_TRUE(
      op2->WaitFor("request-control r1: refused: robot r1 is locked by basestation op1: asked op1 to "
                   "hand it over",
                   5s))
      << op2->SinceMark();
  ASSERT_TRUE(op1->WaitFor("r1: op2 asks for control (held by op1): grant r1 op2 or deny r1 op2 within", 3s))
      << op1->SinceMark();
  op1->Type("deny r1 op2\r");
  ASSERT_TRUE(op1->WaitFor("deny r1: accepted", 5s)) << op1->SinceMark();
  ASSERT_TRUE(op2->WaitFor("r1: op1 denied op2's request for the lock", 3s)) << op2->SinceMark();

  // Asked again and granted: op2 holds r1, which drives on to the same goal.
  op1->Mark();
  op2->Mark();
  op2->Type("request-control r1\r");
  ASSERT_TRUE(op1->WaitFor("r1: op2 asks for control", 5s)) << op1->SinceMark();
  op1->Type("grant r1 op2\r");
  ASSERT_TRUE(op1->WaitFor("grant r1: accepted", 5s)) << op1->SinceMark();
  ASSERT_TRUE(op2->WaitFor("r1: op1 granted op2's request: op2 holds the lock", 3s)) << op2->SinceMark();
  const msgs::RobotState granted = observer.FreshState("r1");
  EXPECT_EQ(granted.holder_id(), "op2");
  EXPECT_EQ(granted.nav_goal_id(), driving.nav_goal_id()) << "a grant keeps the robot's goal";
  if (granted.nav_reason().find("IsLocalPlannerHealthy") == std::string::npos) {
    EXPECT_EQ(granted.mode(), "waypoint") << "a grant keeps the robot's mode";
  }

  // op1 asks back; op2 does not answer: after 4 s both are told it expired, and op2 still holds r1.
  op1->Mark();
  op2->Mark();
  op1->Type("request-control r1\r");
  ASSERT_TRUE(op2->WaitFor("r1: op1 asks for control (held by op2)", 5s)) << op2->SinceMark();
  ASSERT_TRUE(op1->WaitFor("r1: op1's request expired: op2 did not answer within 4 s", 8s))
      << op1->SinceMark();
  ASSERT_TRUE(op2->WaitFor("r1: op1's request expired", 3s)) << op2->SinceMark();
  EXPECT_EQ(observer.FreshState("r1").holder_id(), "op2");

  // Unasked: op2 hands r1 back to op1.
  op1->Mark();
  op2->Type("handover r1 op1\r");
  ASSERT_TRUE(op2->WaitFor("handover r1: accepted", 5s)) << op2->SinceMark();
  ASSERT_TRUE(op1->WaitFor("r1: op2 handed the lock over to op1", 3s)) << op1->SinceMark();
  EXPECT_EQ(observer.FreshState("r1").holder_id(), "op1");
}

TEST(Console, SecondConsoleAttachesToARunningDemo) {
  const std::string logs = Logs("demo");
  const std::string demo_logs = logs + "/demo-state";
  std::filesystem::remove_all(demo_logs);
  setenv("CAIRN_DEMO_LOGS", demo_logs.c_str(), 1);
  ChildProcess demo({"/bin/bash", cairn::core::SourceDir() + "/tools/demo.sh", cairn::core::BinaryDir(),
                     "--robots", "1", "--domain", "83"},
                    logs + "/demo.log");
  ASSERT_TRUE(demo.WaitForLine("demo: another operator can attach", 90s));
  ASSERT_TRUE(std::filesystem::exists(demo_logs + "/demo.env"));
  const auto [exit_code, answer] = AttachedConsole({"wait", "r1", "online", "10"}, logs + "/console.log");
  EXPECT_EQ(exit_code, 0) << answer;
  EXPECT_TRUE(json::parse(answer, nullptr, false).value("ok", false)) << answer;
  demo.WriteLine("robots");
  demo.CloseStdin();
  const auto demo_status = demo.Wait(30s);
  ASSERT_TRUE(demo_status && WIFEXITED(*demo_status));
  EXPECT_EQ(WEXITSTATUS(*demo_status), 0);
  EXPECT_FALSE(std::filesystem::exists(demo_logs + "/demo.env")) << "the demo left its attach record behind";
  unsetenv("CAIRN_DEMO_LOGS");
}

// The demo on a terminal, as an operator uses it: a three-robot mission from one console without polling
// (arrivals print by themselves), watch until a key is pressed, quit asks before stopping the robots, a
// second console attaches while they keep running, and Ctrl-C in the demo's terminal stops them.
TEST(Console, ThreeRobotMissionFromTheDemoConsoleWithoutPolling) {
  const std::string logs = Logs("demo_pty");
  const std::string demo_logs = logs + "/demo-state";
  std::filesystem::remove_all(demo_logs);
  setenv("CAIRN_DEMO_LOGS", demo_logs.c_str(), 1);
  PtyProcess demo({"/bin/bash", cairn::core::SourceDir() + "/tools/demo.sh", cairn::core::BinaryDir(),
                   "--robots", "3", "--domain", "84"});
  ASSERT_TRUE(demo.WaitFor("op1> ", 120s)) << demo.output();
  demo.Drain(2s);
  auto run = [&](const std::string& line, const std::string& expect) {
    demo.Mark();
    demo.Type(line + "\r");
    EXPECT_TRUE(demo.WaitFor(expect, 15s)) << line << " ->\n" << demo.SinceMark();
  };
  run("place add door 9,20", "place: accepted");
  for (const char* r : {"r1", "r2", "r3"}) run(std::string("request-control ") + r, "accepted");
  const auto sent = Clock::now();
  run("goto r1 door", "goto r1: accepted");
  run("goto r2 junction", "goto r2: accepted");
  run("goto r3 south_bend", "goto r3: accepted");
  demo.Mark();
  const std::map<std::string, std::string> goals = {{"r1", "door"}, {"r2", "junction"}, {"r3", "south_bend"}};
  std::set<std::string> arrived;
  std::map<std::string, int> resent;
  for (auto deadline = Clock::now() + 90s; arrived.size() < 3 && Clock::now() < deadline;) {
    demo.Drain(200ms);
    const std::string news = demo.SinceMark();
    for (const auto& [robot, place] : goals) {
      if (news.find(robot + " arrived at") != std::string::npos) arrived.insert(robot);
      // Three robots stalled on this loaded 2-core machine trip the staleness guard (the robot stops, and the
      // console says so: news too; the stalls are an open problem, see docs/PERFORMANCE.md). Send that goal
      // again, at most twice, once per failure line seen.
      std::size_t failures = 0;
      for (std::size_t at = news.find(robot + "'s obstacle sensing is not ready"); at != std::string::npos;
           at = news.find(robot + "'s obstacle sensing is not ready", at + 1)) {
        ++failures;
      }
      if (!arrived.count(robot) && resent[robot] < 2 && static_cast<int>(failures) > resent[robot]) {
        ++resent[robot];
        demo.Type("goto " + robot + " " + place + "\r");
      }
    }
  }
  EXPECT_EQ(arrived.size(), 3u) << "arrival news missing:\n" << demo.SinceMark();
  Figure("three_robot_mission_s", std::chrono::duration<double>(Clock::now() - sent).count());

  // watch: the table refreshed in place until a key is pressed.
  demo.Mark();
  demo.Type("watch 0.5\r");
  ASSERT_TRUE(demo.WaitFor("press any key to stop", 10s)) << demo.SinceMark();
  demo.Drain(1200ms);
  // The prompt is drawn again only once watch has ended (and has swallowed what came with the key): an event
  // printed before the mark redraws it too, and a command typed on that one was lost with the key.
  demo.Mark();
  demo.Type("x");
  EXPECT_TRUE(demo.WaitFor("op1> ", 5s)) << "watch did not end on a key press";
  run("status r2", "control   held by op1 (this basestation)");

  // quit asks; N keeps the robots running for other consoles.
  demo.Mark();
  demo.Type("quit\r");
  ASSERT_TRUE(demo.WaitFor("Stop robots r1 r2 r3 and end the demo? [y/N]", 10s)) << demo.SinceMark();
  demo.Type("n\r");
  ASSERT_TRUE(demo.WaitFor("keep running", 5s)) << demo.SinceMark();
  const auto [exit_code, answer] = AttachedConsole({"wait", "r3", "online", "5"}, logs + "/console.log");
  EXPECT_EQ(exit_code, 0) << answer;
  EXPECT_TRUE(json::parse(answer, nullptr, false).value("ok", false))
      << "robots stopped with the console: " << answer;

  // Ctrl-C in the demo's terminal stops them.
  demo.Type("\x03");
  const auto status = demo.Wait(30s);
  ASSERT_TRUE(status.has_value()) << demo.output();
  EXPECT_FALSE(std::filesystem::exists(demo_logs + "/demo.env"));
  std::ifstream r1_log(demo_logs + "/r1.log");
  const std::string r1_text((std::istreambuf_iterator<char>(r1_log)), std::istreambuf_iterator<char>());
  EXPECT_NE(r1_text.find("shutting down"), std::string::npos) << "r1 did not shut down cleanly";
  unsetenv("CAIRN_DEMO_LOGS");
}

}  // namespace
}  // namespace cairn
