// Bad input at the process boundary: flags, config and world files. Each must end the process with a
// non-zero exit code and a message naming the value, and never start a robot.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "cairn/core/build_paths.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;

const std::string kAgent = cairn::core::BinaryDir() + "/robot_agent/cairn_agent";
const std::string kBase = cairn::core::BinaryDir() + "/basestation/cairn_base";

struct Outcome {
  int exit_code = -1;
  std::string stdout_text;
  std::string stderr_text;
};

Outcome RunProcess(const std::vector<std::string>& argv) {
  const std::string err = ::testing::TempDir() + "/cli_stderr.txt";
  testing::ChildProcess child(argv, err);
  child.CloseStdin();
  Outcome outcome;
  while (auto line = child.ReadLine(20s)) outcome.stdout_text += *line + "\n";
  const auto status = child.Wait(20s);
  if (status && WIFEXITED(*status)) outcome.exit_code = WEXITSTATUS(*status);
  std::ifstream in(err);
  std::stringstream text;
  text << in.rdbuf();
  outcome.stderr_text = text.str();
  return outcome;
}

std::string WriteFile(const std::string& name, const std::string& bytes) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

void ExpectRefused(const Outcome& o, const std::string& needle) {
  EXPECT_NE(o.exit_code, 0);
  EXPECT_EQ(o.stdout_text.find("READY"), std::string::npos) << "the agent started despite bad input";
  EXPECT_NE((o.stderr_text + o.stdout_text).find(needle), std::string::npos)
      << "expected '" << needle << "' in:\n"
      << o.stderr_text << o.stdout_text;
}

TEST(AgentCli, RefusesBadFlagsNamingTheValue) {
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--domain", "300"}), "--domain 300 is out of range");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--domain", "x1"}),
                "--domain 'x1' is not an integer");
  // ' 150' was taken while '150 ' was refused; a missing --map-save folder was found at exit (exit
  // 0).
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--domain", " 150"}),
                "--domain ' 150' is not an integer");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--domain", "150 "}),
                "--domain '150 ' is not an integer");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--map-save",
                            "/nonexistent/dir/map.bt"}),
                "--map-save '/nonexistent/dir/map.bt': its folder '/nonexistent/dir' does not exist");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--map-save",
                            ::testing::TempDir()}),
                "is a directory, not a file");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--start", "1,nan"}), "'nan' is not a finite number");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--platform", "hover"}),
                "platform 'hover' is not supported");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r 1"}), "robot id 'r 1'");
  ExpectRefused(RunProcess({kAgent}), "--robot-id is required");
  // The fault-injection test hook names the part at fault.
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--inject-fault", "lidar:throw:5"}),
                "no component \"lidar\" (the components are platform, perception");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--inject-fault", "perception:crash:5"}),
                "kind \"crash\" is not throw, hang or stuck");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--inject-fault", "perception:throw:-1"}),
                "AFTER_S \"-1\" is not a number of seconds >= 0");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--inject-fault", "mux:hang:5"}),
                "a hang of mux would hang the control cycle");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--start", "-50,-50",
                            "--domain", "71"}),
                "is not free ground");
}

TEST(AgentCli, RefusesMissingOrCorruptWorldsAndConfigs) {
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "/nonexistent/map.bt"}),
                "/nonexistent/map.bt");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:atlantis"}), "atlantis");
  const std::string corrupt = WriteFile("corrupt.bt", "# Octomap OcTree binary file\nthis is not a tree\n");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", corrupt}), corrupt);
  const std::string config = WriteFile("bad.yaml", "mux:\n  teleop_timeout_s: fast\n");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--config", config}),
                "mux.teleop_timeout_s = 'fast' is not a number");
  // A key written twice was accepted (the first one read, the second silently ignored).
  const std::string twice = WriteFile("twice.yaml",
                                      "mux:\n  teleop_timeout_s: 0.5\nexplore:\n  settle_s: 1\n"
                                      "mux:\n  teleop_timeout_s: 2\n");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--config", twice}),
                "twice.yaml: mux appears twice (line 5): remove one");
  const std::string tree = WriteFile("tree.xml",
                                     "<root BTCPP_format=\"4\"><BehaviorTree ID=\"T\"><Nope/>"
                                     "</BehaviorTree></root>");
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--mode-tree", tree}),
                "Nope");
  // A branch naming a channel the mux does not have is refused at load, naming branch and channel
  // (it used to load, and `stop` then left the twist on).
  std::ifstream shipped(cairn::core::SourceDir() + "/config/mode_tree.xml");
  std::string xml((std::istreambuf_iterator<char>(shipped)), std::istreambuf_iterator<char>());
  const std::string teleop = R"(channel="teleop")";
  ASSERT_NE(xml.find(teleop), std::string::npos);
  xml.replace(xml.find(teleop), teleop.size(), R"(channel="warp")");
  const std::string warp = WriteFile("warp_tree.xml", xml);
  const Outcome refused =
      RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--mode-tree", warp});
  ExpectRefused(refused, "branch 'manual'");
  ExpectRefused(refused, "mux channel 'warp', which the mux does not have");
  const std::string profiles =
      WriteFile("wide.xml",
                "<?xml version=\"1.0\"?><dds xmlns=\"http://www.eprosima.com/XMLSchemas/"
                "fastRTPS_Profiles\"><profiles><participant profile_name=\"cairn.loopback\">"
                "<rtps></rtps></participant></profiles></dds>");
  ExpectRefused(
      RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--dds-profiles", profiles}),
      "not loopback-only");
}

// The shipped mode tree with `copies` more manual branches in front of its own.
std::string ShippedTreeWithBranches(int copies) {
  std::ifstream shipped(cairn::core::SourceDir() + "/config/mode_tree.xml");
  std::string xml((std::istreambuf_iterator<char>(shipped)), std::istreambuf_iterator<char>());
  const std::string fallback = R"(<Fallback name="select_mode">)";
  std::string branches;
  for (int i = 0; i < copies; ++i) {
    branches += R"(<ReactiveSequence><IsModeRequested mode="manual"/><IsControlHeld/><IsHolderAlive/>)"
                R"(<SelectMode mode="manual" channel="teleop"/></ReactiveSequence>)";
  }
  xml.insert(xml.find(fallback) + fallback.size(), branches);
  return xml;
}

// Input built to exhaust the process: nested YAML aliases ("billion laughs", 9 levels: 9^9 nodes to walk) and
// mode trees of thousands of branches hung the agent at start, or stalled every component once running. Each
// is refused at once, naming the file and what is wrong.
TEST(AgentCli, RefusesInputBuiltToExhaustItWithinASecond) {
  std::string laughs = "a0: &a0 [\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\"]\n";
  for (int i = 1; i <= 9; ++i) {
    laughs += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
    for (int k = 0; k < 9; ++k) laughs += (k == 0 ? "*a" : ",*a") + std::to_string(i - 1);
    laughs += "]\n";
  }
  const std::string config = WriteFile("laughs.yaml", laughs);
  // The process's start (the world is built before the mode tree is read) counts in the trees' bound.
  auto timed = [](const std::vector<std::string>& argv, double bound_s = 1.0) {
    const auto start = std::chrono::steady_clock::now();
    Outcome o = RunProcess(argv);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    EXPECT_LT(s, bound_s) << "refused only after " << s << " s";
    return o;
  };
  ExpectRefused(timed({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--config", config}),
                config + ":2:10: YAML alias '*a0' is not allowed");
  // The basestation's one YAML file, its places.
  const std::string places = WriteFile("laughs_places.yaml", laughs + "places: {}\n");
  ExpectRefused(timed({kBase, "--base-id", "opA", "--domain", "72", "--places", places, "--", "robots"}),
                "places file " + places + ":2:10: YAML alias '*a0' is not allowed");
  for (const int copies : {3000, 10000}) {
    const std::string tree = WriteFile("wide_tree.xml", ShippedTreeWithBranches(copies));
    ExpectRefused(timed({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--mode-tree", tree}, 5.0),
                  "the document's trees have " + std::to_string(71 + 5 * copies) +
                      " nodes, more than the limit of 1000 (max_nodes)");
  }
  std::string deep = ShippedTreeWithBranches(0);
  std::string nested = "<AlwaysFailure/>";
  for (int i = 0; i < 40; ++i) nested = "<Inverter>" + nested + "</Inverter>";
  deep.insert(deep.find(R"(<Fallback name="select_mode">)") + 29, nested);
  ExpectRefused(timed({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--mode-tree",
                       WriteFile("deep_tree.xml", deep)},
                      5.0),
                "is at depth 33, deeper than the limit of 32 (max_depth)");
  std::string nonexistent = ShippedTreeWithBranches(0);
  const std::string perception = R"(<IsComponentUp component="perception"/>)";
  nonexistent.replace(nonexistent.find(perception), perception.size(),
                      R"(<IsComponentUp component="nonexistent"/>)");
  const Outcome refused = timed({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--mode-tree",
                                 WriteFile("nonexistent_tree.xml", nonexistent)},
                                5.0);
  ExpectRefused(refused, "IsComponentUp");
  ExpectRefused(refused,
                "component \"nonexistent\" is not a component of cairn_agent (its components: platform, "
                "perception");
}

// --secure: a folder that is not one, and a fleet folder without this id's identity, are named.
TEST(SecureFlag, RefusesAMissingFolderAndAMissingIdentityNamingThem) {
  ExpectRefused(
      RunProcess({kAgent, "--robot-id", "r1", "--world", "builtin:arena", "--secure", "/nonexistent/keys"}),
      "--secure '/nonexistent/keys' is not a folder");
  const std::string keys =
      (std::filesystem::path(::testing::TempDir()) / "cli_keys").lexically_normal().string();
  std::filesystem::remove_all(keys);
  const std::string make = cairn::core::SourceDir() + "/cairn keys " + keys + " --robots r1 2>/dev/null";
  ASSERT_EQ(std::system(make.c_str()), 0) << make;
  ExpectRefused(RunProcess({kAgent, "--robot-id", "r9", "--world", "builtin:arena", "--domain", "72",
                            "--secure", keys}),
                keys + "/r9/cert.pem' cannot be read");
  ExpectRefused(RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--secure", keys, "--", "robots"}),
                keys + "/opA/robots' cannot be read");
}

TEST(BaseCli, RefusesBadFlagsAndCommands) {
  ExpectRefused(RunProcess({kBase, "--base-id", "opA", "--domain", "233", "--", "robots"}),
                "--domain 233 is out of range");
  ExpectRefused(RunProcess({kBase, "--base-id", "op A", "--domain", "72", "--", "robots"}),
                "--base-id 'op A'");
  // A folder as --script ran nothing and exited 0.
  ExpectRefused(RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--script", ::testing::TempDir()}),
                "is a folder, not a file");
  Outcome o = RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--", "goto", "r1", "1", "inf"});
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.stdout_text.find("Y 'inf' is not a finite number"), std::string::npos) << o.stdout_text;
  o = RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--", "teleop", "r1", "0.5", "0", "-3"});
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.stdout_text.find("DURATION_S '-3' must be in (0, 600]"), std::string::npos) << o.stdout_text;
  o = RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--", "warp", "r1"});
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.stdout_text.find("unknown command 'warp'"), std::string::npos) << o.stdout_text;
  o = RunProcess(
      {kBase, "--base-id", "opA", "--domain", "72", "--command-timeout", "1", "--", "request-control", "r9"});
  EXPECT_EQ(o.exit_code, 1);
  EXPECT_NE(o.stdout_text.find("unknown robot 'r9'"), std::string::npos) << o.stdout_text;
  ExpectRefused(
      RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--discovery-wait", "0", "--", "robots"}),
      "--discovery-wait 0.000000 must be in (0, 60] s");
  // The GUI's flags.
  ExpectRefused(
      RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--gui", "--listen", "localhost:8080"}),
      "--listen 'localhost:8080': 'localhost' is not an IP address");
  ExpectRefused(
      RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--gui", "--listen", "127.0.0.1:80800"}),
      "port '80800' must be an integer in [0, 65535]");
  ExpectRefused(RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--listen", "127.0.0.1:9000"}),
                "--listen, --gui-root and --gui-map-kBps need --gui");
  ExpectRefused(RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--gui", "--listen", "127.0.0.1:0",
                            "--gui-root", "/nonexistent/web"}),
                "'/nonexistent/web/foxglove-schemas.json' cannot be read");
  // Found by fuzzing (fuzz/corpus/cli_line/stop_long_id): a stop, sent even to robots not seen, with a
  // 370-character id made Fast CDR throw out of the writer (a DDS key holds 255 bytes) and cairn_base abort.
  o = RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--", "stop", std::string(370, 'N')});
  EXPECT_EQ(o.exit_code, 2);
  EXPECT_NE(o.stdout_text.find("robot id '" + std::string(64, 'N') +
                               "...' (370 characters) must be 1-64 characters of A-Z a-z 0-9 _ -"),
            std::string::npos)
      << o.stdout_text << o.stderr_text;
  o = RunProcess({kBase, "--base-id", "opA", "--domain", "72", "--", "help"});
  EXPECT_EQ(o.exit_code, 0);
  EXPECT_NE(o.stdout_text.find("request-control R"), std::string::npos);
}

}  // namespace
}  // namespace cairn
