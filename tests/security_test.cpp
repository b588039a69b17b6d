// DDS Security (issue 15), through real cairn_agent and cairn_base processes started with --secure, in this
// test's private network namespace, with the keys `./cairn keys` makes (tools/keys.sh):
//  - a participant without a certificate from the fleet's CA neither discovers a robot, nor reads its state,
//    nor reaches it with a command; one with a certificate from another CA does no better;
//  - permissions say who commands which robot: a basestation given r2 only cannot command r1 (refused in the
//    basestation, naming its permissions; its writer on r1's command topics cannot even be made, and a
//    command for r1 sent on its own robot's topic never reaches r1) but may stop it (an e-stop), and an
//    observer reads states but commands nothing, not even stop; the robot never moves;
//  - discovery with security against without it, in the same run (figures).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "cairn/core/dds.h"
#include "cairn/msgs/stamp.h"
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

// `./cairn keys DIR ARGS` into a fresh DIR; fails the test when it does not exit 0.
std::string MakeKeys(const std::string& dir, const std::string& args) {
  std::filesystem::remove_all(dir);
  const std::string command =
      std::string(CAIRN_SOURCE_DIR) + "/cairn keys " + dir + " " + args + " 2>" + dir + ".log";
  const int status = std::system(command.c_str());
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << command << " failed; see " << dir << ".log";
  return dir;
}

std::unique_ptr<ChildProcess> StartAgent(const std::string& id, int domain, const std::string& logs,
                                         const std::vector<std::string>& extra = {}) {
  return StartAgentIn(kWorld, id, domain, logs, extra);
}

// A test participant: plain (no keys) or with the identity `identity` of the fleet in `keys`. It reads robot
// states and can try to command.
class Peer {
 public:
  Peer(int domain, const std::string& keys = "", const std::string& identity = "") {
    core::ParticipantOptions options;
    options.domain_id = domain;
    options.name = "test-peer";
    options.security.dir = keys;
    options.security.identity = identity;
    participant_ = std::make_unique<core::Participant>(options);
    states_ = std::make_unique<core::Reader<msgs::RobotStatePubSubType>>(
        *participant_, "cairn/robot_state", "cairn.latched", [this](const msgs::RobotState& s, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          last_[s.robot_id()] = s;
          ++states_heard_;
        });
  }
  ~Peer() { states_.reset(); }
  core::Participant& participant() { return *participant_; }
  int states_heard() const { return states_heard_.load(); }
  std::optional<msgs::RobotState> Last(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = last_.find(robot);
    if (it == last_.end()) return std::nullopt;
    return it->second;
  }
  // A control request writer on `topic`. @throws core::DdsError when the access control refuses to make it.
  std::unique_ptr<core::Writer<msgs::ControlRequestPubSubType>> ControlWriter(const std::string& topic) {
    return std::make_unique<core::Writer<msgs::ControlRequestPubSubType>>(*participant_, topic,
                                                                          "cairn.command");
  }

 private:
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Reader<msgs::RobotStatePubSubType>> states_;
  std::mutex mutex_;
  std::map<std::string, msgs::RobotState> last_;
  std::atomic<int> states_heard_{0};
};

msgs::ControlRequest Grab(const std::string& robot, const std::string& base_id, uint32_t request_id) {
  msgs::ControlRequest m;
  m.robot_id(robot);
  m.base_id(base_id);
  m.request_id(request_id);
  m.action(msgs::CONTROL_ACTION_REQUEST);
  return m;
}

// Seconds from starting a basestation process to its first answer that `robot` is online.
double SecondsToOnline(const std::string& base_id, int domain, const std::string& logs,
                       const std::string& robot, const std::vector<std::string>& extra) {
  const auto start = Clock::now();
  Base base(base_id, domain, logs, extra);
  const json r = base.Run("wait " + robot + " online 20", 30s);
  EXPECT_TRUE(r["ok"]) << base_id << " never saw " << robot << ": " << r;
  return std::chrono::duration<double>(Clock::now() - start).count();
}

TEST(Security, ANodeWithoutAValidCertificateNeitherDiscoversNorReadsNorWrites) {
  const int domain = 81;
  const std::string logs = FreshLogs("security", "outsider");
  const std::string keys = MakeKeys(logs + "/keys", "--robots r1 --commander opA=r1");
  const std::string other_ca = MakeKeys(logs + "/other_keys", "--robots r1 --commander opA=r1");
  auto agent = StartAgent("r1", domain, logs, {"--secure", keys});
  Base op("opA", domain, logs, {"--secure", keys});
  json r = op.Run("wait r1 online 20", 30s);
  ASSERT_TRUE(r["ok"]) << "the secure basestation does not see the secure robot: " << r;

  Peer plain(domain);                    // no security at all
  Peer forged(domain, other_ca, "opA");  // the holder's id, from another CA
  const std::string r1_control = core::CommandTopicFor("cairn/control_request", "r1", true);
  auto plain_writer = plain.ControlWriter(r1_control);
  auto plain_shared_writer = plain.ControlWriter("cairn/control_request");  // the topic without security
  auto forged_writer = forged.ControlWriter(r1_control);                    // its own CA lets it
  const auto deadline = Clock::now() + 6s;
  for (uint32_t id = 1; Clock::now() < deadline; ++id) {  // try to take r1 for 6 s from all three
    plain_writer->Write(Grab("r1", "rogue", id));
    plain_shared_writer->Write(Grab("r1", "rogue", id));
    forged_writer->Write(Grab("r1", "opA", id));
    std::this_thread::sleep_for(200ms);
  }
  EXPECT_EQ(plain.states_heard(), 0) << "a participant without a certificate read r1's state";
  EXPECT_EQ(forged.states_heard(), 0) << "a participant with another CA's certificate read r1's state";
  EXPECT_EQ(plain_writer->matched(), 0) << "r1's command reader matched a writer without a certificate";
  EXPECT_EQ(plain_shared_writer->matched(), 0);
  EXPECT_EQ(forged_writer->matched(), 0) << "r1's command reader matched a writer of another CA";
  r = op.Run("status r1");
  EXPECT_EQ(r["holder"], "") << "an outsider took the lock: " << r;
  // The fleet itself works: its basestation takes the lock and commands r1.
  r = op.Run("request-control r1");
  EXPECT_TRUE(r["ok"]) << r;
  r = op.Run("mode r1 manual");
  EXPECT_TRUE(r["ok"]) << r;

  // Discovery time, with and without security, in this run: a basestation process started until it sees r1.
  const double secure_s = SecondsToOnline("opA", domain, logs + "/again", "r1", {"--secure", keys});
  auto plain_agent = StartAgent("r1", domain + 1, logs + "/plain");
  const double plain_s = SecondsToOnline("opA", domain + 1, logs + "/plain", "r1", {});
  Figure("discovery_secure_s", secure_s);
  Figure("discovery_plain_s", plain_s);
  Figure("discovery_secure_over_plain", secure_s / plain_s);
}

TEST(Security, PermissionsSayWhoCommandsWhichRobotAndAnObserverOnlyReads) {
  const int domain = 83;
  const std::string logs = FreshLogs("security", "permissions");
  const std::string keys =
      MakeKeys(logs + "/keys", "--robots r1,r2 --commander opA=r1 --commander opB=r2 --observer opW");
  auto agent = StartAgent("r1", domain, logs, {"--secure", keys});
  Base op_a("opA", domain, logs, {"--secure", keys});
  Base op_b("opB", domain, logs, {"--secure", keys});
  Base watcher("opW", domain, logs, {"--secure", keys});
  json r = op_a.Run("wait r1 online 20", 30s);
  ASSERT_TRUE(r["ok"]) << r;
  ASSERT_TRUE(op_a.Run("request-control r1")["ok"]);
  ASSERT_TRUE(op_a.Run("mode r1 manual")["ok"]);

  Peer observer(domain, keys, "opW");  // reads as the observer does
  const auto seen = Clock::now();
  while (!observer.Last("r1") && Clock::now() - seen < 10s) std::this_thread::sleep_for(50ms);
  ASSERT_TRUE(observer.Last("r1")) << "the observer's identity cannot read r1's state";
  const msgs::RobotState before = *observer.Last("r1");

  // The observer's basestation sees r1 and its holder, and is refused every command, naming why.
  r = watcher.Run("wait r1 online 20", 30s);
  EXPECT_TRUE(r["ok"]) << r;
  // Its first whole state may predate opA's grant: the state with the mode opA set has the holder too.
  r = watcher.Run("wait r1 mode=manual 10", 15s);
  EXPECT_TRUE(r["ok"]) << r;
  r = watcher.Run("status r1");
  EXPECT_EQ(r["holder"], "opA") << r;
  for (const std::string command : {"request-control r1", "stop r1", "mode r1 idle"}) {
    r = watcher.Run(command);
    EXPECT_EQ(r["result"], "refused") << command << ": " << r;
    EXPECT_NE(r.dump().find("no robot (an observer)"), std::string::npos) << r;
  }
  // opB (given r2) is refused r1, naming its permissions; opA, r1's commander, is not affected.
  r = op_b.Run("request-control r1");
  EXPECT_EQ(r["result"], "refused") << r;
  EXPECT_NE(r.dump().find("give it r2"), std::string::npos) << r;

  // Any commander may stop any robot (an e-stop: cairn/stop_request/* in every commander's permissions).
  r = op_b.Run("stop r1");
  EXPECT_TRUE(r["ok"]) << "a commander's e-stop of another's robot: " << r;
  r = watcher.Run("wait r1 mode=idle 5");  // stop ends in mode idle
  EXPECT_TRUE(r["ok"]) << r;
  ASSERT_TRUE(op_a.Run("mode r1 manual")["ok"]);

  // Below the basestation: DDS access control itself. Neither identity can make a command writer for r1 (the
  // robot's access control would refuse its endpoints anyway: a remote writer's topic is checked against the
  // writer's signed permissions).
  Peer as_b(domain, keys, "opB");
  const std::string r1_control = core::CommandTopicFor("cairn/control_request", "r1", true);
  EXPECT_THROW(as_b.ControlWriter(r1_control), core::DdsError);
  EXPECT_THROW(as_b.ControlWriter("cairn/control_request"), core::DdsError);
  EXPECT_THROW(observer.ControlWriter(r1_control), core::DdsError);
  EXPECT_THROW(observer.ControlWriter(core::CommandTopicFor("cairn/control_request", "r2", true)),
               core::DdsError);
  // opB's own robot's topic is allowed; a command for r1 written there never reaches r1.
  auto b_writer = as_b.ControlWriter(core::CommandTopicFor("cairn/control_request", "r2", true));
  for (uint32_t id = 1; id <= 10; ++id) {
    b_writer->Write(Grab("r1", "opB", id));
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_EQ(b_writer->matched(), 0);

  // r1 kept its holder and never moved.
  const msgs::RobotState after = observer.Last("r1").value_or(msgs::RobotState{});
  EXPECT_EQ(after.holder_id(), "opA");
  EXPECT_LT(Distance(before, after), 0.01) << "r1 moved";
  r = op_a.Run("mode r1 idle");
  EXPECT_TRUE(r["ok"]) << "r1's commander lost it: " << r;
}

}  // namespace
}  // namespace cairn
