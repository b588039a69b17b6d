// The console's command table: what help, usage errors, completion and "did you mean" read.
#include "../src/command_table.h"

#include <gtest/gtest.h>

#include <set>
#include <sstream>
#include <stdexcept>

#include "../src/shell_util.h"

namespace cairn::base {
namespace {

TEST(CommandTable, EveryCommandOnceWithItsSynopsisAndHelp) {
  std::set<std::string> names;
  for (const CommandSpec& spec : CommandTable()) {
    EXPECT_TRUE(names.insert(spec.name).second) << spec.name << " is in the table twice";
    EXPECT_EQ(spec.usage.rfind(spec.name, 0), 0u) << spec.name << ": the synopsis starts with the name";
    EXPECT_FALSE(spec.help.empty()) << spec.name;
    EXPECT_LE(spec.min_args, spec.max_args) << spec.name;
    // A command whose first word is a robot has at least one word, but `links [R]`, `help [R]`.
    if (spec.first == FirstArgument::kRobot && spec.usage.find(" [R]") == std::string::npos &&
        spec.usage.find(" [LEADER]") == std::string::npos) {
      EXPECT_GE(spec.min_args, 1u) << spec.name;
    }
    EXPECT_EQ(FindCommand(spec.name), &spec);
    EXPECT_EQ(UsageOf(spec.name), "usage: " + spec.usage);
  }
  EXPECT_GE(names.size(), 30u);
  EXPECT_EQ(FindCommand("gotoo"), nullptr);
  EXPECT_THROW(UsageOf("gotoo"), std::logic_error);
}

TEST(CommandTable, OptionsAreReadFromTheSynopsis) {
  EXPECT_EQ(OptionsOf(*FindCommand("goto")), (std::vector<std::string>{"--z", "--wait"}));
  EXPECT_EQ(OptionsOf(*FindCommand("explore")),
            (std::vector<std::string>{"--region", "--z-range", "--home-after-silence", "--wait"}));
  EXPECT_TRUE(OptionsOf(*FindCommand("status")).empty());
}

TEST(CommandTable, HelpListsEveryCommandWithinItsWidth) {
  const std::string help = CommandHelp(104);
  for (const CommandSpec& spec : CommandTable()) {
    EXPECT_NE(help.find("\n  " + spec.usage), std::string::npos) << spec.name << " missing from help";
  }
  std::istringstream lines(help);
  for (std::string line; std::getline(lines, line);) {
    // A synopsis longer than the width stands alone; every other line fits.
    bool long_synopsis = false;
    for (const CommandSpec& spec : CommandTable()) long_synopsis |= line == "  " + spec.usage;
    if (!long_synopsis) {
      EXPECT_LE(line.size(), 104u) << line;
    }
  }
  // The help of a long synopsis starts on the next line, at the help column.
  EXPECT_NE(help.find("[--wait [TIMEOUT_S]]\n                                      R explores by itself"),
            std::string::npos)
      << help;
  EXPECT_NE(help.find("  robots                              the fleet:"), std::string::npos) << help;
}

}  // namespace
}  // namespace cairn::base

namespace cairn::base {
namespace {

// A wait on a robot goes on through a short loss (a state gap on a lossy link) and fails once the robot stays
// lost for the grace, or at once when its process exited.
TEST(LostRobotGrace, AShortLossIsWaitedThroughALongOneOrAnExitEndsTheWait) {
  shell::LostRobotGrace grace(5.0);
  RobotView v;
  v.robot_id = "r1";
  const core::SteadyTime t0 = core::SteadyClock::now();
  EXPECT_EQ(grace.Check(v, t0), "");
  v.lost = true;
  v.lost_reason = "no state for 0.8 s";
  EXPECT_EQ(grace.Check(v, t0 + std::chrono::seconds(1)), "");
  EXPECT_EQ(grace.Check(v, t0 + std::chrono::seconds(4)), "");
  v.lost = false;  // back: the grace starts again at the next loss
  EXPECT_EQ(grace.Check(v, t0 + std::chrono::seconds(5)), "");
  v.lost = true;
  EXPECT_EQ(grace.Check(v, t0 + std::chrono::seconds(6)), "");
  EXPECT_EQ(grace.Check(v, t0 + std::chrono::seconds(11)), "robot lost for 5.0 s (no state for 0.8 s)");
  shell::LostRobotGrace exited(5.0);
  v.left = true;
  v.lost_reason = "its process exited";
  EXPECT_EQ(exited.Check(v, t0), "robot lost (its process exited)");
}

}  // namespace
}  // namespace cairn::base
