// Who may ask a robot to yield (CheckYieldSender): the passing robot must be heard; the sender is a heard
// robot asking for itself from the process of its peer states, or a basestation allowed to command the robot.
#include "cairn/agent/team/yield_sender.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

Peer Heard(const std::string& id) {
  Peer p;
  p.robot_id = id;
  return p;
}

YieldCommand Ask(const std::string& sender, const std::string& passing) {
  YieldCommand c;
  c.sender_id = sender;
  c.passing_id = passing;
  c.keep_clear_M = {{0.0, 0.0}};
  return c;
}

YieldOrigin PeerRobot() {
  YieldOrigin o;
  o.peer_robot = true;
  return o;
}

TEST(CheckYieldSender, APassingRobotNotHeardIsRefusedWhoeverAsks) {
  YieldOrigin commander;
  commander.secure = true;
  commander.commander_topic = true;
  for (const YieldOrigin& origin : {commander, PeerRobot()}) {
    const std::string why = CheckYieldSender("r1", Ask("r9", "r9"), origin, {Heard("r2")});
    EXPECT_EQ(
        why,
        "yield for r9 (asked by r9) refused: passing robot r9 is not heard by r1 (no peer state from it "
        "lately): a robot yields only to a robot it hears");
  }
}

TEST(CheckYieldSender, AHeardRobotAsksOnlyForItselfFromItsOwnProcess) {
  const std::vector<Peer> heard = {Heard("r2"), Heard("r3")};
  EXPECT_EQ(CheckYieldSender("r1", Ask("r2", "r2"), PeerRobot(), heard), "");
  EXPECT_NE(CheckYieldSender("r1", Ask("r2", "r3"), PeerRobot(), heard)
                .find("r2 may ask only for itself, not for r3"),
            std::string::npos);
  // The same ids from a process that is not r2's (peer_robot false): neither robot nor basestation.
  EXPECT_NE(CheckYieldSender("r1", Ask("r2", "r2"), YieldOrigin{}, heard)
                .find("sender r2 is neither a robot r1 hears (its peer states from the same process) nor a "
                      "basestation allowed to command r1"),
            std::string::npos);
}

TEST(CheckYieldSender, ABasestationMustBeAllowedToCommandTheRobot) {
  const std::vector<Peer> heard = {Heard("r2")};
  YieldOrigin announced;
  announced.announced_base = true;
  EXPECT_EQ(CheckYieldSender("r1", Ask("opA", "r2"), announced, heard), "");  // no security: every base may
  announced.secure = true;  // under security only on the robot's own topic (its commanders)
  const std::string why = CheckYieldSender("r1", Ask("opW", "r2"), announced, heard);
  EXPECT_NE(why.find("sender opW is neither"), std::string::npos) << why;
  EXPECT_NE(why.find("only its commanders may write"), std::string::npos) << why;
  YieldOrigin commander;
  commander.secure = true;
  commander.commander_topic = true;
  EXPECT_EQ(CheckYieldSender("r1", Ask("opA", "r2"), commander, heard), "");
  EXPECT_NE(CheckYieldSender("r1", Ask("rogue", "r2"), YieldOrigin{}, heard).find("sender rogue is neither"),
            std::string::npos);
}

}  // namespace
}  // namespace cairn::agent
