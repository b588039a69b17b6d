// DDS Security, through real cairn_agent and cairn_base processes started with --secure, in this
// test's private network namespace, with the keys `./cairn keys` makes (tools/keys.sh):
//  - a participant without a certificate from the fleet's CA neither discovers a robot, nor reads its state,
//    nor reaches it with a command; one with a certificate from another CA does no better;
//  - permissions say who commands which robot: a basestation given r2 only cannot command r1 (refused in the
//    basestation, naming its permissions; its writer on r1's command topics cannot even be made, and a
//    command for r1 sent on its own robot's topic never reaches r1) but may stop it (an e-stop), and an
//    observer reads states but commands nothing, not even stop; the robot never moves;
//  - discovery with security against without it, in the same run (figures);
//  - a base id (or robot id) is bound to the certificate that sends it: an allowed commander of r1 sending
//    commands, teleop and announcements under another commander's base id is dropped, counted in the
//    robot's health and logged naming both; yield requests come only from robots (for themselves) and from
//    r1's commanders, and only for a robot r1 hears, with security and without it.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cairn/core/build_paths.h"
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
      cairn::core::SourceDir() + "/cairn keys " + dir + " " + args + " 2>" + dir + ".log";
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
  // A writer of `PubSubT` on `topic` with QoS `profile`. @throws core::DdsError as ControlWriter.
  template <class PubSubT>
  std::unique_ptr<core::Writer<PubSubT>> WriterOf(const std::string& topic,
                                                  const std::string& profile = "cairn.command") {
    return std::make_unique<core::Writer<PubSubT>>(*participant_, topic, profile);
  }
  // Waits up to `timeout` for a state of `robot` that satisfies `pred`; the last one heard otherwise.
  template <class Pred>
  std::optional<msgs::RobotState> WaitFor(const std::string& robot, std::chrono::milliseconds timeout,
                                          Pred pred) {
    const auto deadline = Clock::now() + timeout;
    std::optional<msgs::RobotState> last;
    while (Clock::now() < deadline) {
      last = Last(robot);
      if (last && pred(*last)) return last;
      std::this_thread::sleep_for(50ms);
    }
    return last;
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
  // opB's first command to r1 is an e-stop, sent while its stop writer may still be matching r1's reader
  // under DDS Security (seconds on a loaded machine): a generous answer window.
  Base op_b("opB", domain, logs, {"--secure", keys, "--command-timeout", "10"});
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

msgs::YieldRequest AskToYield(const std::string& robot, const std::string& sender, const std::string& passing,
                              uint32_t request_id) {
  msgs::YieldRequest m;
  m.robot_id(robot);
  m.sender_id(sender);
  m.request_id(request_id);
  m.action(msgs::YIELD_ACTION_ASK);
  m.passing_id(passing);
  m.passing_radius_m(0.3f);
  // A route through where the robot stands (slot 0 of builtin:tunnels), as a blocked robot would send.
  for (double x : {-3.0, 0.0, 3.0, 6.0}) {
    msgs::PeerPathPoint q;
    q.x_m(static_cast<float>(x));
    q.y_m(0.0f);
    m.keep_clear_M().push_back(q);
  }
  return m;
}

// Writes one `PubSubT` sample for r1 carrying base id `base_id` on r1's own command topic `topic` from `peer`
// (fields other than the ids left at their defaults); false when the writer did not match r1.
template <class PubSubT, class Peer>
bool SendAs(Peer& peer, const std::string& topic, const std::string& base_id) {
  auto writer = peer.template WriterOf<PubSubT>(core::CommandTopicFor(topic, "r1", true));
  if (!writer->WaitForMatched(1, std::chrono::milliseconds(10000))) return false;
  typename PubSubT::type m;
  m.robot_id("r1");
  m.base_id(base_id);
  m.request_id(7);
  writer->Write(m);
  return writer->WaitForAcknowledgments(std::chrono::milliseconds(2000));
}

// r1's health as `base` shows it, once it counts at least `forged` forged senders (or after 8 s).
json HealthWithForged(Base& base, std::uint64_t forged) {
  const auto deadline = Clock::now() + 8s;
  json r = base.Run("health r1");
  while (r.value("forged_senders", std::uint64_t{0}) < forged && Clock::now() < deadline) {
    std::this_thread::sleep_for(500ms);
    r = base.Run("health r1");
  }
  return r;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// Attacker: op3, an allowed commander of r1, sends as op1 (the holder). Every message it sends under op1's
// base id is dropped by r1 (the lock, the mode, the stick, the announcement), counted in r1's health and
// logged naming op1 and op3; op3 under its own id is still heard. Yield requests under security: an observer
// cannot even make a writer; a robot's certificate may ask only as itself and only for a robot r1 hears; r1's
// commander asks on r1's own topic, also only for a robot r1 hears. r1 never moves.
TEST(Security, ASenderIdIsBoundToItsCertificateAndYieldsNeedAHeardRobot) {
  const int domain = 85;
  const std::string logs = FreshLogs("security", "forged_sender");
  const std::string keys =
      MakeKeys(logs + "/keys", "--robots r1,r2,r3 --commander op1=r1 --commander op3=r1 --observer opW");
  auto agent = StartAgent("r1", domain, logs, {"--secure", keys});
  Base op1("op1", domain, logs, {"--secure", keys});
  ASSERT_TRUE(op1.Run("wait r1 online 20", 30s)["ok"]);
  ASSERT_TRUE(op1.Run("request-control r1")["ok"]);
  ASSERT_TRUE(op1.Run("mode r1 manual")["ok"]);

  Peer op3(domain, keys, "op3");
  // The PKI-DH handshake admits a participant only with the GUID prefix of its certificate's subject: what r1
  // checks a sender id against.
  const auto& prefix = op3.participant().get()->guid().guidPrefix;
  EXPECT_TRUE(core::GuidPrefixHoldsIdentity(prefix, "op3"));
  EXPECT_FALSE(core::GuidPrefixHoldsIdentity(prefix, "op1"));
  const auto before = op3.WaitFor("r1", 10s, [](const msgs::RobotState& s) { return s.mode() == "manual"; });
  ASSERT_TRUE(before && before->holder_id() == "op1") << "op3 does not see r1 held by op1 in manual";

  auto control = op3.ControlWriter(core::CommandTopicFor("cairn/control_request", "r1", true));
  auto mode =
      op3.WriterOf<msgs::ModeRequestPubSubType>(core::CommandTopicFor("cairn/mode_request", "r1", true));
  auto teleop = op3.WriterOf<msgs::TeleopTwistPubSubType>(core::CommandTopicFor("cairn/teleop", "r1", true),
                                                          "cairn.teleop");
  auto announce = op3.WriterOf<msgs::AgentInfoPubSubType>("cairn/base_info", "cairn.latched");
  ASSERT_TRUE(control->WaitForMatched(1, 10s) && mode->WaitForMatched(1, 10s) &&
              teleop->WaitForMatched(1, 10s))
      << "r1's command readers did not match op3's writers (op3 may command r1)";
  msgs::AgentInfo as_op1;
  as_op1.agent_id("op1");
  as_op1.kind(msgs::AGENT_KIND_BASESTATION);
  as_op1.platform("basestation");
  as_op1.capabilities({"joystick"});
  announce->Write(as_op1);
  for (uint32_t id = 1; id <= 30; ++id) {  // 3 s: release op1's lock, idle r1, drive it, all as op1
    msgs::ControlRequest release = Grab("r1", "op1", id);
    release.action(msgs::CONTROL_ACTION_RELEASE);
    control->Write(release);
    msgs::ModeRequest idle;
    idle.robot_id("r1");
    idle.base_id("op1");
    idle.request_id(id);
    idle.mode("idle");
    mode->Write(idle);
    msgs::TeleopTwist twist;
    twist.robot_id("r1");
    twist.base_id("op1");
    twist.sequence_number(id);
    twist.stamp(cairn::msgs::WallStampNow());
    twist.twist().linear_x_mps(0.8);
    teleop->Write(twist);
    std::this_thread::sleep_for(100ms);
  }
  json r = op1.Run("status r1");
  EXPECT_EQ(r["holder"], "op1") << "op3 released op1's lock under op1's id: " << r;
  EXPECT_EQ(r["mode"], "manual") << "op3 set r1's mode under op1's id: " << r;
  const auto after = op3.Last("r1");
  ASSERT_TRUE(after);
  EXPECT_LT(Distance(*before, *after), 0.02) << "op3's teleop under op1's id drove r1";
  // Counted in r1's health (sent every 2 s) and named in its log.
  // 30 releases and 30 modes (reliable), 30 twists (best effort: most of them), 1 announcement.
  // Every other command reader checks the same way (one each: a goal, an exploration, home, a convoy, a
  // restart, and a stop, which op3 may send under its own id).
  EXPECT_TRUE(SendAs<msgs::WaypointGoalPubSubType>(op3, "cairn/waypoint_goal", "op1"));
  EXPECT_TRUE(SendAs<msgs::ExploreRequestPubSubType>(op3, "cairn/explore_request", "op1"));
  EXPECT_TRUE(SendAs<msgs::HomeRequestPubSubType>(op3, "cairn/home_request", "op1"));
  EXPECT_TRUE(SendAs<msgs::ConvoyRequestPubSubType>(op3, "cairn/convoy_request", "op1"));
  EXPECT_TRUE(SendAs<msgs::RestartRequestPubSubType>(op3, "cairn/restart_request", "op1"));
  EXPECT_TRUE(SendAs<msgs::StopRequestPubSubType>(op3, "cairn/stop_request", "op1"));
  r = HealthWithForged(op1, 86);
  EXPECT_GE(r.value("forged_senders", std::uint64_t{0}), 86u) << r;
  const std::string last = r.value("last_forged_sender", "");
  EXPECT_NE(last.find("'op1'"), std::string::npos) << last;
  EXPECT_NE(last.find("'op3'"), std::string::npos) << last;
  const std::string log = ReadAll(logs + "/r1.log");
  EXPECT_NE(
      log.find(
          "forged message dropped: cairn/mode_request: base id 'op1' sent under the certificate of 'op3'"),
      std::string::npos)
      << "see " << logs << "/r1.log";
  for (const std::string topic : {"cairn/control_request", "cairn/teleop", "cairn/base_info",
                                  "cairn/waypoint_goal", "cairn/explore_request", "cairn/home_request",
                                  "cairn/convoy_request", "cairn/restart_request", "cairn/stop_request"}) {
    EXPECT_NE(
        log.find("forged message dropped: " + topic + ": base id 'op1' sent under the certificate of 'op3'"),
        std::string::npos)
        << topic << "; see " << logs << "/r1.log";
  }
  // op3 under its own id is heard: the lock refuses it, naming op1.
  Base op3_base("op3", domain, logs, {"--secure", keys});
  ASSERT_TRUE(op3_base.Run("wait r1 online 20", 30s)["ok"]);
  r = op3_base.Run("request-control r1");
  EXPECT_FALSE(r["ok"]) << r;
  EXPECT_NE(r.dump().find("op1"), std::string::npos) << r;

  // Yield requests. r1 idle (it would yield in that mode), and it never drove.
  ASSERT_TRUE(op1.Run("mode r1 idle")["ok"]);
  Peer observer(domain, keys, "opW");
  EXPECT_THROW(observer.WriterOf<msgs::YieldRequestPubSubType>("cairn/yield_request"), core::DdsError)
      << "an observer may ask robots to yield";
  EXPECT_THROW(observer.WriterOf<msgs::YieldRequestPubSubType>(
                   core::CommandTopicFor("cairn/yield_request", "r1", true)),
               core::DdsError);
  // A robot's certificate (r2, not running) asks for a robot that does not exist, then as r3 for itself.
  Peer r2(domain, keys, "r2");
  auto r2_yield = r2.WriterOf<msgs::YieldRequestPubSubType>("cairn/yield_request");
  ASSERT_TRUE(r2_yield->WaitForMatched(1, 10s));
  const auto asks_until = [&](auto& writer, const msgs::YieldRequest& m, const std::string& reason) {
    const auto deadline = Clock::now() + 8s;
    std::optional<msgs::RobotState> s;
    while (Clock::now() < deadline) {
      writer->Write(m);
      s = op3.WaitFor("r1", 1s, [&](const msgs::RobotState& x) {
        return x.yield_state() == "refused" && x.yield_reason().find(reason) != std::string::npos;
      });
      if (s && s->yield_reason().find(reason) != std::string::npos) return s->yield_reason();
    }
    return s ? s->yield_state() + ": " + s->yield_reason() : std::string("no state");
  };
  std::string why = asks_until(r2_yield, AskToYield("r1", "r2", "r9", 1), "r9 is not heard");
  EXPECT_NE(why.find("passing robot r9 is not heard by r1"), std::string::npos) << why;
  const std::uint64_t forged_before = op1.Run("health r1").value("forged_senders", std::uint64_t{0});
  for (uint32_t id = 2; id <= 6; ++id) r2_yield->Write(AskToYield("r1", "r3", "r3", id));  // r2 as r3
  // r1's commander asks on r1's own topic: heard, but refused for a robot r1 does not hear.
  Peer op1_peer(domain, keys, "op1");
  auto op1_yield = op1_peer.WriterOf<msgs::YieldRequestPubSubType>(
      core::CommandTopicFor("cairn/yield_request", "r1", true));
  ASSERT_TRUE(op1_yield->WaitForMatched(1, 10s));
  why = asks_until(op1_yield, AskToYield("r1", "op1", "r8", 1), "r8 is not heard");
  EXPECT_NE(why.find("(asked by op1) refused: passing robot r8 is not heard"), std::string::npos) << why;
  r = HealthWithForged(op1, forged_before + 5);
  EXPECT_GE(r.value("forged_senders", std::uint64_t{0}), forged_before + 5) << "r2 asking as r3: " << r;
  const auto end = op3.Last("r1");
  ASSERT_TRUE(end);
  EXPECT_EQ(end->mode(), "idle");
  EXPECT_LT(Distance(*before, *end), 0.02) << "r1 moved for a forged or unheard yield";

  // What robots publish (states, peer states, claims, maps, staircases), no basestation may.
  for (Peer* base : {&observer, &op3}) {
    EXPECT_THROW(base->WriterOf<msgs::PeerStatePubSubType>("cairn/peer_state", "cairn.state"),
                 core::DdsError);
    EXPECT_THROW(base->WriterOf<msgs::ExploreClaimPubSubType>("cairn/explore_claim", "cairn.latched"),
                 core::DdsError);
    EXPECT_THROW(base->WriterOf<msgs::RobotStatePubSubType>("cairn/robot_state", "cairn.latched"),
                 core::DdsError);
    EXPECT_THROW(base->WriterOf<msgs::MapUpdatePubSubType>("cairn/map_update", "cairn.latched"),
                 core::DdsError);
    EXPECT_THROW(base->WriterOf<msgs::StaircaseDetectionPubSubType>("cairn/staircase", "cairn.latched"),
                 core::DdsError);
  }
  // A robot's certificate may, but only under its own id: r2's peer state and explore claim as r3 are dropped
  // (r1 reads claims once it explores).
  ASSERT_TRUE(op1.Run("explore r1")["ok"]);
  auto peer_state = r2.WriterOf<msgs::PeerStatePubSubType>("cairn/peer_state", "cairn.state");
  auto claim = r2.WriterOf<msgs::ExploreClaimPubSubType>("cairn/explore_claim", "cairn.latched");
  const auto claim_deadline = Clock::now() + 10s;
  while (claim->matched() == 0 && Clock::now() < claim_deadline) std::this_thread::sleep_for(100ms);
  ASSERT_GT(claim->matched(), 0) << "r1 exploring never read explore claims";
  ASSERT_GT(peer_state->matched(), 0);
  msgs::PeerState as_r3;
  as_r3.robot_id("r3");
  as_r3.mode("idle");
  as_r3.footprint_radius_m(0.3f);
  msgs::ExploreClaim claim_r3;
  claim_r3.robot_id("r3");
  claim_r3.active(true);
  for (int i = 0; i < 5; ++i) {
    peer_state->Write(as_r3);
    claim->Write(claim_r3);
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(op1.Run("stop r1")["ok"]);
  // Basestations check the robot id too: r2's certificate publishing r1's state far off and a staircase of
  // r1's is dropped (op1 keeps r1 where it is) and logged.
  auto state = r2.WriterOf<msgs::RobotStatePubSubType>("cairn/robot_state", "cairn.latched");
  auto stairs = r2.WriterOf<msgs::StaircaseDetectionPubSubType>("cairn/staircase", "cairn.latched");
  ASSERT_TRUE(state->WaitForMatched(1, 10s) && stairs->WaitForMatched(1, 10s));
  msgs::RobotState far_off = op3.Last("r1").value_or(msgs::RobotState{});
  far_off.pose_MB().position().x_m(far_off.pose_MB().position().x_m() + 50.0);
  msgs::StaircaseDetection staircase;
  staircase.robot_id("r1");
  staircase.staircase_id(1);
  staircase.num_steps(5);
  for (int i = 0; i < 10; ++i) {
    state->Write(far_off);
    stairs->Write(staircase);
    std::this_thread::sleep_for(100ms);
  }
  r = op1.Run("status r1");
  ASSERT_TRUE(r.contains("x_m")) << r;
  EXPECT_GT(std::abs(r["x_m"].get<double>() - far_off.pose_MB().position().x_m()), 40.0)
      << "op1 took r2's state of r1: " << r;
  const std::string base_log = ReadAll(logs + "/op1.log");
  for (const std::string topic : {"cairn/robot_state", "cairn/staircase"}) {
    EXPECT_NE(base_log.find("a forged message dropped: " + topic + ": robot id 'r1'"), std::string::npos)
        << topic << "; see " << logs << "/op1.log";
  }
  const std::string robot_log = ReadAll(logs + "/r1.log");
  for (const std::string topic : {"cairn/peer_state", "cairn/explore_claim"}) {
    EXPECT_NE(robot_log.find("forged message dropped: " + topic +
                             ": robot id 'r3' sent under the certificate of 'r2'"),
              std::string::npos)
        << topic << "; see " << logs << "/r1.log";
  }
}

// Without security any process may send anything; still, a robot yields only for a robot it hears, and only
// when asked by that robot's own process (its peer states) or by an announced basestation. The idle robot
// that drove 5.8 m aside for a robot that does not exist now stays.
TEST(Security, WithoutSecurityAYieldNeedsAHeardRobotAndAKnownSender) {
  const int domain = 87;
  const std::string logs = FreshLogs("security", "plain_yield");
  auto r1 = StartAgent("r1", domain, logs);
  ChildProcess r2({kAgent, "--robot-id", "r2", "--world", kWorld, "--start", "slot:1", "--domain",
                   std::to_string(domain)},
                  logs + "/r2.log");
  ASSERT_TRUE(r2.WaitForLine("READY", 60s)) << "r2 did not start; see " << logs;
  Peer rogue(domain);
  const auto before = rogue.WaitFor("r1", 10s, [](const msgs::RobotState&) { return true; });
  ASSERT_TRUE(before) << "no state from r1";
  auto yield = rogue.WriterOf<msgs::YieldRequestPubSubType>("cairn/yield_request");
  ASSERT_TRUE(yield->WaitForMatched(2, 10s));
  const auto asks_until = [&](const msgs::YieldRequest& m, const std::string& reason) {
    const auto deadline = Clock::now() + 8s;
    std::optional<msgs::RobotState> s;
    while (Clock::now() < deadline) {
      yield->Write(m);
      s = rogue.WaitFor("r1", 1s, [&](const msgs::RobotState& x) {
        return x.yield_state() == "refused" && x.yield_reason().find(reason) != std::string::npos;
      });
      if (s && s->yield_reason().find(reason) != std::string::npos) return s->yield_reason();
    }
    return s ? s->yield_state() + ": " + s->yield_reason() : std::string("no state");
  };
  // For a robot that does not exist, asked by it or by anyone.
  std::string why = asks_until(AskToYield("r1", "r9", "r9", 1), "r9 is not heard");
  EXPECT_NE(why.find("passing robot r9 is not heard by r1"), std::string::npos) << why;
  why = asks_until(AskToYield("r1", "rogue", "r9", 2),
                   "(asked by rogue) refused: passing robot r9 is not heard");
  EXPECT_NE(why.find("(asked by rogue) refused: passing robot r9 is not heard"), std::string::npos) << why;
  // For r2, which r1 hears, from a process that is neither r2's nor an announced basestation's.
  why = asks_until(AskToYield("r1", "r2", "r2", 3), "sender r2 is neither");
  EXPECT_NE(why.find("sender r2 is neither a robot r1 hears"), std::string::npos) << why;
  why = asks_until(AskToYield("r1", "rogue", "r2", 4), "sender rogue is neither");
  EXPECT_NE(why.find("nor a basestation allowed to command r1"), std::string::npos) << why;
  // But any process may publish peer states as any robot, and r1 then hears that robot: a request for the
  // made-up r5 gets past "not heard" (and is refused for its sender).
  auto peer_state = rogue.WriterOf<msgs::PeerStatePubSubType>("cairn/peer_state", "cairn.state");
  msgs::PeerState as_r5;
  as_r5.robot_id("r5");
  as_r5.mode("idle");
  as_r5.x_MB_m(40.0);
  as_r5.y_MB_m(20.0);
  as_r5.footprint_radius_m(0.3f);
  const auto forged_deadline = Clock::now() + 8s;
  std::optional<msgs::RobotState> heard_r5;
  while (!heard_r5 && Clock::now() < forged_deadline) {
    peer_state->Write(as_r5);
    yield->Write(AskToYield("r1", "rogue", "r5", 5));
    heard_r5 = rogue.WaitFor("r1", 300ms, [](const msgs::RobotState& x) {
      return x.yield_reason().find("yield for r5 (asked by rogue) refused: sender rogue is neither") == 0;
    });
    if (heard_r5 && heard_r5->yield_reason().find("yield for r5") != 0) heard_r5.reset();
  }
  EXPECT_TRUE(heard_r5) << "r1 did not take a forged peer state for a heard robot";
  const std::string log = ReadAll(logs + "/r1.log");
  EXPECT_NE(log.find("passing robot r9 is not heard"), std::string::npos) << "see " << logs << "/r1.log";
  const auto end = rogue.Last("r1");
  ASSERT_TRUE(end);
  EXPECT_EQ(end->mode(), "idle");
  EXPECT_LT(Distance(*before, *end), 0.02) << "r1 moved for a yield nobody could ask";
}

}  // namespace
}  // namespace cairn
