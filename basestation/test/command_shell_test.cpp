// The console in process against a fake fleet: what each command sends to which robot, what it prints, and
// how it refuses malformed input (naming the argument and value) without sending anything.
#include "cairn/base/command_shell.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "fake_fleet.h"

namespace cairn::base {
namespace {

using Sent = std::vector<std::string>;

class CommandShellTest : public ::testing::Test {
 protected:
  CommandShellTest() : fleet_("op1"), shell_(fleet_, /*json=*/false, out_) {
    fleet_.AddRobot("r1", "idle", "op1", 1.0, 2.0);
    fleet_.AddRobot("r2", "idle", "op1", 4.0, 2.0);
    fleet_.AddRobot("r3", "idle", "op1", 7.0, 2.0);
  }
  // What the shell printed since the last call.
  std::string Printed() {
    std::string text = out_.str();
    out_.str("");
    return text;
  }

  testing::FakeFleet fleet_;
  std::ostringstream out_;
  CommandShell shell_;
};

TEST_F(CommandShellTest, GotoSendsTheWaypointAndReportsTheAnswer) {
  EXPECT_EQ(shell_.Execute("goto r1 12 4.5"), kOk);
  EXPECT_EQ(fleet_.sent(), (Sent{"SendWaypoint r1 12 4.5 tol=0 z=nan"}));
  EXPECT_NE(Printed().find("goto r1: accepted"), std::string::npos);
  EXPECT_EQ(shell_.Execute("goto r2 3,4 0.5 --z 2.5"), kOk);
  EXPECT_EQ(fleet_.sent().back(), "SendWaypoint r2 3 4 tol=0.5 z=2.5");
}

TEST_F(CommandShellTest, WordsAndTheirLineRunTheSameCommand) {
  EXPECT_EQ(shell_.Execute(std::vector<std::string>{"goto", "r1", "12", "4", "--z", "1.5"}), kOk);
  const std::string from_words = Printed();
  EXPECT_EQ(shell_.Execute("goto r1 12 4 --z 1.5"), kOk);
  EXPECT_EQ(Printed(), from_words);
  EXPECT_EQ(fleet_.sent(), (Sent{"SendWaypoint r1 12 4 tol=0 z=1.5", "SendWaypoint r1 12 4 tol=0 z=1.5"}));
  EXPECT_EQ(shell_.Execute(std::vector<std::string>{}), kOk);
}

TEST_F(CommandShellTest, MalformedCommandsNameTheArgumentAndSendNothing) {
  EXPECT_EQ(shell_.Execute("goto r1 twelve 4"), kUsage);
  EXPECT_NE(Printed().find("twelve"), std::string::npos);
  EXPECT_EQ(shell_.Execute("goto r1 1 2 --z"), kUsage);
  EXPECT_NE(Printed().find("--z needs a height"), std::string::npos);
  EXPECT_EQ(shell_.Execute("goto r1 1 2 --z 1e9"), kUsage);
  EXPECT_NE(Printed().find("Z_M '1e9'"), std::string::npos);
  EXPECT_EQ(shell_.Execute("gotoo r1 1 2"), kUsage);
  EXPECT_NE(Printed().find("unknown command 'gotoo' (did you mean goto?)"), std::string::npos);
  EXPECT_EQ(shell_.Execute("mode r1"), kUsage);
  EXPECT_NE(Printed().find("usage: mode R MODE"), std::string::npos);
  // An option the command does not take is named as one, with the nearest it takes.
  EXPECT_EQ(shell_.Execute("goto r1 1 2 --wiat"), kUsage);
  EXPECT_NE(Printed().find("unknown option --wiat for goto (did you mean --wait?)"), std::string::npos);
  EXPECT_EQ(shell_.Execute("status r1 --verbose"), kUsage);
  EXPECT_NE(Printed().find("unknown option --verbose for status; usage: status R"), std::string::npos);
  EXPECT_TRUE(fleet_.sent().empty());
}

TEST_F(CommandShellTest, ARefusalPrintsTheRobotsReasonAndExitsRefused) {
  fleet_.RefuseCommandsTo("r2", "manual is not valid now");
  EXPECT_EQ(shell_.Execute("mode r2 manual"), kRefused);
  const std::string printed = Printed();
  EXPECT_NE(printed.find("mode r2: refused"), std::string::npos) << printed;
  EXPECT_EQ(fleet_.sent(), (Sent{"RequestMode r2 manual"}));
  fleet_.RefuseCommandsTo("r2", "");
  EXPECT_EQ(shell_.Execute("mode r2 manual"), kOk);
}

// A robot is online once its state is heard (its control loop runs, so do its components), not when its
// participant is discovered: commands sent in between would find its parts still starting.
TEST_F(CommandShellTest, WaitOnlineWaitsForTheRobotsState) {
  fleet_.AnnounceRobot("r4");
  EXPECT_NE(shell_.Execute("wait r4 online 0"), kOk);
  fleet_.AddRobot("r4");
  EXPECT_EQ(shell_.Execute("wait r4 online 0"), kOk);
}

// The holder answers a request for its lock: grant and deny only the request that waits (a grant unasked is
// a handover, said so), handover to anyone; nothing is sent for a refusal made here.
TEST_F(CommandShellTest, GrantAndDenyAnswerTheRequestThatWaitsHandoverNeedsNone) {
  EXPECT_EQ(shell_.Execute("grant r1 op2"), kRefused);
  EXPECT_NE(
      Printed().find("grant r1: refused: no request for r1's lock waits (handover r1 op2 gives it unasked)"),
      std::string::npos);
  EXPECT_TRUE(fleet_.sent().empty());
  fleet_.Mutate("r1", [](RobotView& v) { v.state->control_requester_id("op2"); });
  EXPECT_EQ(shell_.Execute("deny r1 op3"), kRefused);
  EXPECT_NE(Printed().find("the request waiting for r1's lock is op2's"), std::string::npos);
  EXPECT_EQ(shell_.Execute("grant r1 op2"), kOk);
  EXPECT_EQ(fleet_.sent(), (Sent{"HandOverControl r1 op2"}));
  EXPECT_NE(Printed().find("grant r1: accepted"), std::string::npos);
  fleet_.Mutate("r2", [](RobotView& v) { v.state->control_requester_id("op3"); });
  EXPECT_EQ(shell_.Execute("deny r2 op3"), kOk);
  EXPECT_EQ(shell_.Execute("handover r3 op2"), kOk);
  EXPECT_EQ(fleet_.sent(), (Sent{"HandOverControl r1 op2", "DenyControl r2 op3", "HandOverControl r3 op2"}));
  EXPECT_EQ(shell_.Execute("handover r3"), kUsage);
  EXPECT_NE(Printed().find("usage: handover R BASE"), std::string::npos);
}

// Several robots in one command: each gets its own command, in parallel, and its own answer line.
TEST_F(CommandShellTest, StopAndExploreTakeSeveralRobots) {
  EXPECT_EQ(shell_.Execute("stop r1 r3"), kOk);
  Sent sent = fleet_.sent();
  std::sort(sent.begin(), sent.end());
  EXPECT_EQ(sent, (Sent{"Stop r1", "Stop r3"}));
  const std::string printed = Printed();
  EXPECT_NE(printed.find("stop r1: accepted"), std::string::npos) << printed;
  EXPECT_NE(printed.find("stop r3: accepted"), std::string::npos) << printed;
  EXPECT_EQ(shell_.Execute("stop r1 all"), kUsage);
  EXPECT_EQ(shell_.Execute("explore r1 r2 --wait"), kUsage);
  EXPECT_NE(Printed().find("--wait takes one robot"), std::string::npos);
  EXPECT_EQ(shell_.Execute("explore r1 r2"), kOk);
  const std::string explored = Printed();
  EXPECT_NE(explored.find("explore r1: accepted"), std::string::npos) << explored;
  EXPECT_NE(explored.find("explore r2: accepted"), std::string::npos) << explored;
}

TEST_F(CommandShellTest, RequestControlAndReleaseTakeSeveralRobots) {
  EXPECT_EQ(shell_.Execute("release r1 r2"), kOk);
  const std::string released = Printed();
  EXPECT_NE(released.find("release r1: accepted"), std::string::npos) << released;
  EXPECT_NE(released.find("release r2: accepted"), std::string::npos) << released;
  EXPECT_EQ(shell_.Execute("request-control r1 r2"), kOk);
  const std::string requested = Printed();
  EXPECT_NE(requested.find("request-control r1: accepted"), std::string::npos) << requested;
  EXPECT_NE(requested.find("request-control r2: accepted"), std::string::npos) << requested;
  Sent sent = fleet_.sent();
  std::sort(sent.begin(), sent.end());
  EXPECT_EQ(sent, (Sent{"ReleaseControl r1", "ReleaseControl r2", "RequestControl r1", "RequestControl r2"}));
  EXPECT_EQ(fleet_.Robot("r2")->state->holder_id(), "op1");
}

TEST_F(CommandShellTest, StopAllStopsEveryRobot) {
  EXPECT_EQ(shell_.Execute("stop all"), kOk);
  Sent sent = fleet_.sent();
  std::sort(sent.begin(), sent.end());
  EXPECT_EQ(sent, (Sent{"Stop r1", "Stop r2", "Stop r3"}));
}

TEST_F(CommandShellTest, AConvoyTellsEachFollowerTheRobotsAheadOfIt) {
  EXPECT_EQ(shell_.Execute("convoy r1 r2 r3"), kOk) << Printed();
  Sent sent = fleet_.sent();
  std::sort(sent.begin(), sent.end());
  EXPECT_EQ(sent, (Sent{"SendConvoy r2 r1", "SendConvoy r3 r2 r1"}));
  // What happens next is said before it happens.
  EXPECT_NE(Printed().find("each follower first drives to the trail of the robot ahead of it"),
            std::string::npos);

  // convoy-stop: the followers go idle and the leader drives on, said so; --stop-leader stops it too.
  fleet_.Mutate("r2", [](RobotView& v) { v.state->convoy_ahead_ids({"r1"}); });
  fleet_.Mutate("r3", [](RobotView& v) { v.state->convoy_ahead_ids({"r2", "r1"}); });
  EXPECT_EQ(shell_.Execute("convoy-stop r1"), kOk);
  EXPECT_NE(
      Printed().find("r1 keeps driving (its goal or its operator's stick): convoy-stop r1 --stop-leader"),
      std::string::npos);
  EXPECT_EQ(shell_.Execute("convoy-stop r1 --stop-leader"), kOk);
  EXPECT_EQ(fleet_.sent().back(), "Stop r1");
  EXPECT_NE(Printed().find("convoy-stop r1: accepted"), std::string::npos);
}

TEST_F(CommandShellTest, AConvoyOfRobotsThisBaseDoesNotHoldIsRefusedBeforeAnythingIsSent) {
  fleet_.AddRobot("r3", "idle", "op2", 7.0, 2.0);
  EXPECT_EQ(shell_.Execute("convoy r1 r2 r3"), kRefused);
  const std::string printed = Printed();
  EXPECT_NE(printed.find("r3"), std::string::npos) << printed;
  EXPECT_NE(printed.find("op2"), std::string::npos) << printed;
  EXPECT_TRUE(fleet_.sent().empty());
}

TEST_F(CommandShellTest, JsonAnswersCarryTheCommandRobotAndOutcome) {
  std::ostringstream out;
  CommandShell shell(fleet_, /*json=*/true, out);
  EXPECT_EQ(shell.Execute("explore r3 --region 0,0,10,5"), kOk);
  EXPECT_EQ(fleet_.sent(), (Sent{"SendExplore r3 region=0,0,10,5 z=nan..nan home_after=0"}));
  std::istringstream lines(out.str());
  std::string last;
  for (std::string line; std::getline(lines, line);) last = line;
  const auto answer = nlohmann::json::parse(last);
  EXPECT_EQ(answer.at("command"), "explore");
  EXPECT_EQ(answer.at("robot"), "r3");
  EXPECT_EQ(answer.at("ok"), true);
  EXPECT_EQ(answer.at("result"), "accepted");
}

// A robot asked to yield that is already clear of the route ends its yield within a cycle: the ended yield is
// its answer (not "did not answer"); a yield that ended before the request is not.
TEST_F(CommandShellTest, AYieldThatEndedAtOnceIsAnsweredAStaleOneIsNot) {
  fleet_.Mutate("r1", [](RobotView& v) {
    cairn_msgs::GlobalPath path;
    path.goal_id(7);
    for (double x : {1.0, 4.0, 12.0}) {
      cairn_msgs::Point p;
      p.x_m(x);
      p.y_m(2.0);
      path.path_M().push_back(p);
    }
    v.global_path = path;
  });
  const std::string back = "back at (4.0, 2.0) after yielding to r1";
  fleet_.AnswerYieldsWith([&](cairn_msgs::RobotState& s) {
    s.yield_peer_id("r1");
    s.yield_state("");
    s.yield_reason(back);
  });
  EXPECT_EQ(shell_.Execute("yield r2 for r1"), kOk);
  const std::string answered = Printed();
  EXPECT_NE(answered.find("yield r2: accepted: gets out of r1's way: " + back), std::string::npos)
      << answered;
  // The same ended yield again: nothing shows this request was heard.
  EXPECT_NE(shell_.Execute("yield r2 for r1"), kOk);
  const std::string stale = Printed();
  EXPECT_NE(stale.find("r2 did not answer within 5 s"), std::string::npos) << stale;
}

// `robots --json` gives each robot's task as the table does: its place counted over the whole fleet.
TEST_F(CommandShellTest, JsonRobotsCountAConvoyOverTheFleet) {
  fleet_.Mutate("r2", [](RobotView& v) { v.state->convoy_ahead_ids({"r1"}); });
  fleet_.Mutate("r3", [](RobotView& v) { v.state->convoy_ahead_ids({"r2", "r1"}); });
  std::ostringstream out;
  CommandShell shell(fleet_, /*json=*/true, out);
  EXPECT_EQ(shell.Execute("robots"), kOk);
  const auto answer = nlohmann::json::parse(out.str());
  std::map<std::string, std::string> task;
  for (const auto& robot : answer.at("robots")) task[robot.at("robot")] = robot.at("task");
  EXPECT_EQ(task["r1"], "leads a convoy of 3; idle");
  EXPECT_EQ(task["r2"], "convoy 2 of 3 behind r1");
  EXPECT_EQ(task["r3"], "convoy 3 of 3 behind r2");
}

TEST_F(CommandShellTest, EventsArePrintedAroundCommands) {
  fleet_.RaiseEvent("r2 arrived at (4.00, 2.00)");
  EXPECT_EQ(shell_.Execute("stop r1"), kOk);
  const std::string printed = Printed();
  EXPECT_NE(printed.find("] r2 arrived at (4.00, 2.00)"), std::string::npos) << printed;
  EXPECT_LT(printed.find("r2 arrived"), printed.find("stop r1"));
}

TEST_F(CommandShellTest, RobotsListsEveryRobotWithItsModeAndHolder) {
  fleet_.AddRobot("r2", "manual", "op2", 4.0, 2.0);
  EXPECT_EQ(shell_.Execute("robots"), kOk);
  const std::string printed = Printed();
  for (const char* expected :
       {"r1", "r2", "r3", "manual", "op2", "POSITION", "TASK", "(4.0, 2.0)", "driven (manual)"}) {
    EXPECT_NE(printed.find(expected), std::string::npos) << expected << " in\n" << printed;
  }
  // A robot near a named place is said to be there.
  EXPECT_EQ(shell_.Execute("place add dock 7.5 2"), kOk);
  Printed();
  EXPECT_EQ(shell_.Execute("robots"), kOk);
  const std::string named = Printed();
  EXPECT_NE(named.find("(7.0, 2.0) dock"), std::string::npos) << named;
  EXPECT_EQ(named.find("(1.0, 2.0) dock"), std::string::npos) << "r1 is 6.5 m from the dock: " << named;
}

}  // namespace
}  // namespace cairn::base
