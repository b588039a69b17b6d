#include <chrono>
#include <cstdio>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "cairn/core/component.h"
#include "cairn/core/config.h"
#include "cairn/core/dds.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::core {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

TEST(DomainId, AcceptsRangeAndNamesBadValues) {
  EXPECT_EQ(ParseDomainId("0"), 0);
  EXPECT_EQ(ParseDomainId("232"), 232);
  try {
    ParseDomainId("233");
    FAIL() << "233 accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("233"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("0..232"), std::string::npos);
  }
  EXPECT_THROW(ParseDomainId("-1"), std::invalid_argument);
  EXPECT_THROW(ParseDomainId("12abc"), std::invalid_argument);
  EXPECT_THROW(ParseDomainId(""), std::invalid_argument);
  ParticipantOptions options;
  options.domain_id = 300;
  EXPECT_THROW(Participant{options}, std::invalid_argument);
}

TEST(Config, ReadsValuesAndNamesFieldValueAndRule) {
  const auto config = ConfigSection::LoadText("agent:\n  lock_keep_s: 5\n  name: r1\n  on: true\n", "t.yaml");
  const auto agent = config.Section("agent");
  double keep = -1;
  std::string name;
  bool on = false;
  int missing = 7;
  agent.ReadDouble("lock_keep_s", &keep);
  agent.ReadString("name", &name);
  agent.ReadBool("on", &on);
  agent.ReadInt("absent", &missing);
  EXPECT_EQ(keep, 5.0);
  EXPECT_EQ(name, "r1");
  EXPECT_TRUE(on);
  EXPECT_EQ(missing, 7);
  EXPECT_NO_THROW(agent.RejectUnknownKeys({"lock_keep_s", "name", "on"}));
  try {
    agent.RejectUnknownKeys({"lock_keep_s", "name"});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("t.yaml: agent.on"), std::string::npos) << e.what();
  }
  const auto bad = ConfigSection::LoadText("x: abc\ny: .nan\n", "b.yaml");
  double x = 0;
  try {
    bad.ReadDouble("x", &x);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("b.yaml: x = 'abc' is not a number"), std::string::npos) << e.what();
  }
  EXPECT_THROW(bad.ReadDouble("y", &x), ConfigError);
  EXPECT_THROW(ConfigSection::LoadText("[1, 2", "c.yaml"), ConfigError);
  EXPECT_THROW(ConfigSection::LoadText("- 1\n- 2\n", "d.yaml"), ConfigError);
  EXPECT_THROW(ConfigSection::LoadFile("/nonexistent/cairn.yaml"), ConfigError);
}

class Recorder : public Component {
 public:
  Recorder(std::string name, std::vector<std::string>* log, bool fail_configure = false)
      : Component(name), log_(log), fail_(fail_configure) {}

 protected:
  void OnConfigure() override {
    log_->push_back(name() + ".configure");
    if (fail_) throw std::runtime_error("boom");
  }
  void OnActivate() override { log_->push_back(name() + ".activate"); }
  void OnDeactivate() override { log_->push_back(name() + ".deactivate"); }
  void OnCleanup() override { log_->push_back(name() + ".cleanup"); }

 private:
  std::vector<std::string>* log_;
  bool fail_;
};

TEST(Component, StartsInOrderAndStopsInReverse) {
  std::vector<std::string> log;
  Recorder a("a", &log), b("b", &log);
  ComponentManager manager;
  manager.Add(&a);
  manager.Add(&b);
  manager.StartAll();
  EXPECT_EQ(a.state(), LifecycleState::kActive);
  manager.StopAll();
  EXPECT_EQ(log, (std::vector<std::string>{"a.configure", "a.activate", "b.configure", "b.activate",
                                           "b.deactivate", "b.cleanup", "a.deactivate", "a.cleanup"}));
  EXPECT_EQ(b.state(), LifecycleState::kUnconfigured);
}

TEST(Component, FailedConfigureCleansUpEverything) {
  std::vector<std::string> log;
  Recorder a("a", &log), b("b", &log, /*fail_configure=*/true);
  ComponentManager manager;
  manager.Add(&a);
  manager.Add(&b);
  try {
    manager.StartAll();
    FAIL();
  } catch (const ComponentError& e) {
    EXPECT_NE(std::string(e.what()).find("b: configure failed: boom"), std::string::npos);
  }
  EXPECT_EQ(a.state(), LifecycleState::kUnconfigured);
  EXPECT_EQ(b.state(), LifecycleState::kUnconfigured);
  EXPECT_EQ(log.back(), "a.cleanup");
  EXPECT_EQ(manager.StaleComponents(SteadyClock::now(), 0.0).size(), 0u);
}

TEST(Participant, RefusesMissingFilesProfilesAndNetworkProfiles) {
  ParticipantOptions options;
  options.profiles_file = "/nonexistent/profiles.xml";
  EXPECT_THROW(Participant{options}, DdsError);
  options = ParticipantOptions{};
  options.participant_profile = "no.such.profile";
  try {
    Participant p{options};
    FAIL();
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("no.such.profile"), std::string::npos);
  }
  // A profile that keeps the built-in transports is refused before any participant exists.
  options = ParticipantOptions{};
  options.profiles_file = WriteTemp("net.xml",
                                    "<?xml version=\"1.0\"?><dds xmlns=\"http://www.eprosima.com/XMLSchemas/"
                                    "fastRTPS_Profiles\"><profiles><participant profile_name=\"wide\"><rtps>"
                                    "</rtps></participant></profiles></dds>");
  options.participant_profile = "wide";
  try {
    Participant p{options};
    FAIL();
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("not loopback-only"), std::string::npos) << e.what();
  }
}

TEST(Participant, LoopbackPublishSubscribeRoundTrip) {
  ParticipantOptions options;
  options.domain_id = 41;
  Participant a(options), b(options);
  std::atomic<int> received{0};
  std::string last_robot;
  std::mutex mutex;
  Reader<cairn_msgs::ModeRequestPubSubType> reader(b, "test/mode", "cairn.command",
                                                  [&](const cairn_msgs::ModeRequest& m, const auto&) {
                                                    std::lock_guard<std::mutex> lock(mutex);
                                                    last_robot = m.robot_id();
                                                    ++received;
                                                  });
  Writer<cairn_msgs::ModeRequestPubSubType> writer(a, "test/mode", "cairn.command");
  ASSERT_TRUE(writer.WaitForMatched(1, std::chrono::seconds(5)));
  ASSERT_TRUE(reader.WaitForMatched(1, std::chrono::seconds(5)));
  cairn_msgs::ModeRequest msg;
  msg.robot_id("r7");
  msg.mode("manual");
  ASSERT_TRUE(writer.Write(msg));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (received.load() == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ASSERT_EQ(received.load(), 1);
  std::lock_guard<std::mutex> lock(mutex);
  EXPECT_EQ(last_robot, "r7");
}

}  // namespace
}  // namespace cairn::core
