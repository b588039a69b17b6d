#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <thread>
#include <utility>

#include "cairn/core/component.h"
#include "cairn/core/config.h"
#include "cairn/core/dds.h"
#include "cairn/core/peer_input.h"
#include "cairn/core/voxel_grid.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::core {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// The word-wise column scan against a voxel-by-voxel one, on columns that straddle 64-bit words (z = 70 and
// 130 voxels: columns start at every bit offset) with sparse and dense occupancy.
TEST(VoxelGrid, ForEachOccupiedVisitsExactlyTheOccupiedVoxels) {
  std::mt19937 random(11);
  for (const int nz : {1, 63, 64, 65, 130}) {
    VoxelGrid grid("test", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(7, 5, nz));
    std::bernoulli_distribution occupied(0.1);
    std::vector<Eigen::Vector3i> expected;
    for (int ix = 0; ix < 7; ++ix) {
      for (int iy = 0; iy < 5; ++iy) {
        for (int iz = 0; iz < nz; ++iz) {
          if (!occupied(random)) continue;
          grid.SetOccupied({ix, iy, iz});
          expected.emplace_back(ix, iy, iz);
        }
      }
    }
    std::vector<Eigen::Vector3i> visited;
    grid.ForEachOccupied([&](const Eigen::Vector3i& index) { visited.push_back(index); });
    ASSERT_EQ(visited.size(), expected.size()) << "nz " << nz;
    for (std::size_t i = 0; i < visited.size(); ++i) ASSERT_EQ(visited[i], expected[i]) << "nz " << nz;
  }
}

// FreeColumns against voxel-by-voxel clearing, on a full grid whose column runs start and end at every bit
// offset of a 64-bit word: the runs' voxels are free afterwards, every other voxel still occupied.
TEST(VoxelGrid, FreeColumnsFreesExactlyTheRunOfColumns) {
  for (const int nz : {1, 7, 64, 70, 130}) {
    for (int ix = 0; ix < 3; ++ix) {
      for (int first = 0; first < 6; ++first) {
        for (int last = first - 1; last < 6; ++last) {
          VoxelGrid grid("test", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(3, 6, nz));
          for (int x = 0; x < 3; ++x) {
            for (int y = 0; y < 6; ++y) {
              for (int z = 0; z < nz; ++z) grid.SetOccupied({x, y, z});
            }
          }
          grid.FreeColumns(ix, first, last);
          for (int x = 0; x < 3; ++x) {
            for (int y = 0; y < 6; ++y) {
              const bool freed = x == ix && y >= first && y <= last;
              for (int z = 0; z < nz; ++z) {
                ASSERT_EQ(grid.IsOccupiedIndex({x, y, z}), !freed)
                    << "nz " << nz << " FreeColumns(" << ix << ", " << first << ", " << last << ") voxel ("
                    << x << ", " << y << ", " << z << ")";
              }
            }
          }
        }
      }
    }
  }
  VoxelGrid grid("test", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(3, 6, 4));
  EXPECT_THROW(grid.FreeColumns(3, 0, 1), std::out_of_range);
  EXPECT_THROW(grid.FreeColumns(0, -1, 1), std::out_of_range);
  EXPECT_THROW(grid.FreeColumns(0, 2, 6), std::out_of_range);
}

TEST(VoxelGrid, HighestOccupiedInColumnMatchesAVoxelByVoxelScan) {
  std::mt19937 random(7);
  for (const int nz : {1, 64, 70, 130}) {
    for (const double density : {0.0, 0.02, 0.5}) {
      VoxelGrid grid("test", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(5, 4, nz));
      std::bernoulli_distribution occupied(density);
      for (int ix = 0; ix < 5; ++ix) {
        for (int iy = 0; iy < 4; ++iy) {
          for (int iz = 0; iz < nz; ++iz) grid.SetOccupied({ix, iy, iz}, occupied(random));
        }
      }
      for (int ix = 0; ix < 5; ++ix) {
        for (int iy = 0; iy < 4; ++iy) {
          for (int from = -1; from <= nz + 2; ++from) {
            int expected = -1;
            for (int iz = std::min(from, nz - 1); iz >= 0; --iz) {
              if (grid.IsOccupiedIndex({ix, iy, iz})) {
                expected = iz;
                break;
              }
            }
            ASSERT_EQ(grid.HighestOccupiedInColumn(ix, iy, from), expected)
                << "nz " << nz << " density " << density << " column (" << ix << ", " << iy << ") from "
                << from;
          }
        }
      }
    }
  }
  VoxelGrid grid("test", Eigen::Vector3d::Zero(), 0.1, Eigen::Vector3i(2, 2, 8));
  grid.SetOccupied({1, 1, 3});
  EXPECT_EQ(grid.HighestOccupiedInColumn(1, 1, 100), 3);
  EXPECT_EQ(grid.HighestOccupiedInColumn(2, 1, 7), -1) << "outside the grid";
  EXPECT_EQ(grid.HighestOccupiedInColumn(-1, 0, 7), -1) << "outside the grid";
}

TEST(PeerInput, IdsAreCheckedAsTheClisTakeThemAndLongOnesAreShownCut) {
  EXPECT_EQ(core::CheckId("base id", "opA_2-x"), "");
  EXPECT_EQ(core::CheckId("base id", std::string(64, 'a')), "");
  EXPECT_EQ(core::CheckId("base id", ""), "base id '' must be 1-64 characters of A-Z a-z 0-9 _ -");
  EXPECT_EQ(core::CheckId("robot id", "r 1"), "robot id 'r 1' must be 1-64 characters of A-Z a-z 0-9 _ -");
  EXPECT_EQ(core::CheckId("robot id", "r\x1b[2J"),
            "robot id 'r?[2J' must be 1-64 characters of A-Z a-z 0-9 _ -");
  EXPECT_EQ(core::CheckId("base id", std::string(100000, 'x')),
            "base id '" + std::string(64, 'x') +
                "...' (100000 characters) must be 1-64 characters of A-Z a-z 0-9 _ -");
}

TEST(PeerInput, AWarningLimiterAllowsOnePerKeyPerPeriodAndCountsTheRest) {
  core::WarningLimiter limiter(5.0);
  const core::SteadyTime t0 = core::SteadyClock::now();
  std::uint64_t suppressed = 99;
  EXPECT_TRUE(limiter.Allow("a", t0, &suppressed));
  EXPECT_EQ(suppressed, 0u);
  for (int i = 1; i <= 20; ++i) EXPECT_FALSE(limiter.Allow("a", t0 + std::chrono::milliseconds(50 * i)));
  EXPECT_TRUE(limiter.Allow("b", t0 + std::chrono::seconds(1)));  // keys are independent
  EXPECT_TRUE(limiter.Allow("a", t0 + std::chrono::seconds(5), &suppressed));
  EXPECT_EQ(suppressed, 20u);
  EXPECT_FALSE(limiter.Allow("a", t0 + std::chrono::seconds(6)));
  EXPECT_THROW(core::WarningLimiter(0.0), std::invalid_argument);
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

// A key written twice was read once and the other silently ignored.
TEST(Config, AKeyWrittenTwiceInOneMappingIsRefusedNamingItAndItsLine) {
  try {
    ConfigSection::LoadText("agent:\n  lock_keep_s: 5\n  name: r1\n  lock_keep_s: 9\n", "t.yaml");
    FAIL() << "a duplicate key was accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "t.yaml: agent.lock_keep_s appears twice (line 4): remove one");
  }
  EXPECT_NO_THROW(ConfigSection::LoadText("a:\n  x: 1\nb:\n  x: 2\nc: [{x: 1}, {x: 2}]\n", "t.yaml"));
  EXPECT_THROW(ConfigSection::LoadText("c: [{x: 1, x: 2}]\n", "t.yaml"), ConfigError);
}

// Nested aliases, each level naming the one before 9 times ("billion laughs"): a walk of the loaded tree
// visits 9^levels nodes. 9 levels of it hung the agent's start for minutes; any alias is refused at once.
std::string BillionLaughs(int levels) {
  std::string text = "a0: &a0 [\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\",\"lol\"]\n";
  for (int i = 1; i <= levels; ++i) {
    const std::string prev = "*a" + std::to_string(i - 1);
    text += "a" + std::to_string(i) + ": &a" + std::to_string(i) + " [";
    for (int k = 0; k < 9; ++k) text += (k == 0 ? "" : ",") + prev;
    text += "]\n";
  }
  return text;
}

TEST(Config, YamlAliasesAreRefusedAtOnceNamingFileLineAndAlias) {
  const auto start = std::chrono::steady_clock::now();
  try {
    ConfigSection::LoadText(BillionLaughs(9), "laughs.yaml");
    FAIL() << "nested aliases were accepted";
  } catch (const ConfigError& e) {
    EXPECT_STREQ(
        e.what(),
        "laughs.yaml:2:10: YAML alias '*a0' is not allowed (Cairn's config files refuse aliases: write the "
        "value out)");
  }
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 1.0);
  // A merge key is an alias too; an anchor alone is harmless.
  EXPECT_THROW(ConfigSection::LoadText("base: &b {x: 1}\nmux:\n  <<: *b\n", "m.yaml"), ConfigError);
  EXPECT_NO_THROW(ConfigSection::LoadText("mux: &m\n  teleop_timeout_s: 0.5\n", "m.yaml"));
  EXPECT_THROW(RejectYamlAliases("a: *undefined\n", "u.yaml"), ConfigError);
  EXPECT_NO_THROW(RejectYamlAliases("a: '*not an alias'\nb: x*y\n", "q.yaml"));
}

TEST(Config, AnOutputFileIsCheckedBeforeAnythingIsWritten) {
  EXPECT_EQ(CheckOutputFile("--map-save", ::testing::TempDir() + "/map.bt"), "");
  EXPECT_EQ(CheckOutputFile("--map-save", "map.bt"), "");  // the working folder
  EXPECT_EQ(CheckOutputFile("--map-save", "/nonexistent/map.bt"),
            "--map-save '/nonexistent/map.bt': its folder '/nonexistent' does not exist");
  EXPECT_EQ(CheckOutputFile("--map-save", "/"), "--map-save '/' is a directory, not a file");
  EXPECT_EQ(CheckOutputFile("--map-save", ""), "--map-save '' names no file");
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

TEST(Config, ReadFieldsReadsEachKnownKeyAndRefusesAnUnknownOne) {
  const auto config =
      ConfigSection::LoadText("a:\n  keep_s: .inf\n  count: 3\n  on: true\n  name: r1\n", "f.yaml");
  double keep_s = 1.0, absent_m = 2.5;
  int count = 0;
  bool on = false;
  std::string name;
  config.Section("a").ReadFields({{"keep_s", &keep_s, /*allow_infinity_in=*/true},
                                  {"count", &count},
                                  {"on", &on},
                                  {"name", &name},
                                  {"absent_m", &absent_m}});
  EXPECT_TRUE(std::isinf(keep_s));
  EXPECT_EQ(count, 3);
  EXPECT_TRUE(on);
  EXPECT_EQ(name, "r1");
  EXPECT_EQ(absent_m, 2.5) << "an absent key keeps its value";
  try {
    config.Section("a").ReadFields({{"keep_s", &keep_s}, {"count", &count}, {"on", &on}});
    FAIL() << "name is not among the fields";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("f.yaml: a.name is not a known setting"), std::string::npos)
        << e.what();
  }
  try {
    config.Section("a").ReadFields(
        {{"keep_s", &keep_s}, {"count", &count}, {"on", &on}, {"name", &name}});  // infinity not allowed
    FAIL() << "keep_s is infinite";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("a.keep_s"), std::string::npos) << e.what();
  }
}

class Recorder : public Component {
 public:
  Recorder(std::string name, std::vector<std::string>* log, bool fail_configure = false)
      : Component(std::move(name)), log_(log), fail_(fail_configure) {}

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

// A profiles file whose participant "<name>" is the shipped loopback one plus `extra` inside <builtin> or
// <rtps>, and whose "<name>.writer" / "<name>.reader" profiles hold `endpoint` (inside <data_writer> or
// <data_reader>).
std::string LoopbackProfiles(const std::string& name, const std::string& builtin_extra,
                             const std::string& rtps_extra, const std::string& writer_extra = "",
                             const std::string& reader_extra = "") {
  const std::string udp = "<locator><udpv4><address>127.0.0.1</address></udpv4></locator>";
  // Each list once (Fast DDS refuses a repeated element): the shipped loopback list unless `extra` replaces
  // it.
  const auto list = [&udp](const std::string& tag, const std::string& extra) {
    return extra.find("<" + tag + ">") != std::string::npos ? std::string()
                                                            : "<" + tag + ">" + udp + "</" + tag + ">";
  };
  return WriteTemp(
      name + ".xml",
      "<?xml version=\"1.0\"?><dds xmlns=\"http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles\"><profiles>"
      "<transport_descriptors><transport_descriptor><transport_id>" +
          name +
          "_udp</transport_id>"
          "<type>UDPv4</type><interfaceWhiteList><address>127.0.0.1</address></interfaceWhiteList>"
          "</transport_descriptor></transport_descriptors>"
          "<participant profile_name=\"" +
          name + "\"><rtps><userTransports><transport_id>" + name +
          "_udp</transport_id></userTransports><useBuiltinTransports>false</useBuiltinTransports><builtin>" +
          list("metatrafficUnicastLocatorList", builtin_extra) + list("initialPeersList", builtin_extra) +
          builtin_extra + "</builtin>" + list("defaultUnicastLocatorList", rtps_extra) + rtps_extra +
          "</rtps></participant>"
          "<data_writer profile_name=\"" +
          name + ".writer\">" + writer_extra +
          "</data_writer>"
          "<data_reader profile_name=\"" +
          name + ".reader\">" + reader_extra +
          "</data_reader>"
          "</profiles></dds>");
}

void ExpectParticipantRefused(const std::string& name, const std::string& builtin_extra,
                              const std::string& rtps_extra, const std::string& needle) {
  ParticipantOptions options;
  options.profiles_file = LoopbackProfiles(name, builtin_extra, rtps_extra);
  options.participant_profile = name;
  try {
    Participant p{options};
    ADD_FAILURE() << name << ": a participant started";
  } catch (const DdsError& e) {
    EXPECT_NE(std::string(e.what()).find("not loopback-only: " + needle), std::string::npos)
        << name << ": " << e.what();
  }
}

TEST(Participant, RefusesLoopbackProfilesWithALocatorOutsideLoopback) {
  const auto udp = [](const std::string& a) {
    return "<locator><udpv4><address>" + a + "</address></udpv4></locator>";
  };
  // The baseline file itself is accepted (the checks below fail for the added locator, nothing else).
  {
    ParticipantOptions options;
    options.domain_id = 42;
    options.profiles_file = LoopbackProfiles("guard_ok", "", "");
    options.participant_profile = "guard_ok";
    EXPECT_NO_THROW(Participant{options});
  }
  ExpectParticipantRefused("guard_peer", "<initialPeersList>" + udp("10.0.0.5") + "</initialPeersList>", "",
                           "its initialPeersList holds 10.0.0.5:");
  ExpectParticipantRefused(
      "guard_meta",
      "<metatrafficUnicastLocatorList>" + udp("192.168.1.7") + "</metatrafficUnicastLocatorList>", "",
      "its metatrafficUnicastLocatorList holds 192.168.1.7:");
  ExpectParticipantRefused(
      "guard_metamc",
      "<metatrafficMulticastLocatorList>" + udp("239.255.0.1") + "</metatrafficMulticastLocatorList>", "",
      "its metatrafficMulticastLocatorList holds 239.255.0.1:");
  ExpectParticipantRefused("guard_default", "",
                           "<defaultUnicastLocatorList>" + udp("172.16.0.2") + "</defaultUnicastLocatorList>",
                           "its defaultUnicastLocatorList holds 172.16.0.2:");
  ExpectParticipantRefused(
      "guard_defaultmc", "",
      "<defaultMulticastLocatorList>" + udp("239.255.0.2") + "</defaultMulticastLocatorList>",
      "its defaultMulticastLocatorList holds 239.255.0.2:");
  ExpectParticipantRefused("guard_any", "",
                           "<defaultUnicastLocatorList>" + udp("0.0.0.0") + "</defaultUnicastLocatorList>",
                           "its defaultUnicastLocatorList holds 0.0.0.0:");
  ExpectParticipantRefused(
      "guard_server",
      "<discovery_config><discoveryProtocol>CLIENT</discoveryProtocol><discoveryServersList>"
      "<RemoteServer prefix=\"44.53.00.5f.45.50.52.4f.53.49.4d.41\"><metatrafficUnicastLocatorList>" +
          udp("10.9.9.9") +
          "</metatrafficUnicastLocatorList></RemoteServer></discoveryServersList></discovery_config>",
      "", "its discovery server's metatrafficUnicastLocatorList holds 10.9.9.9:");
}

TEST(Participant, RefusesEndpointProfilesWithALocatorOutsideLoopback) {
  const auto udp = [](const std::string& a) {
    return "<locator><udpv4><address>" + a + "</address></udpv4></locator>";
  };
  struct Case {
    std::string name, writer, reader, needle;
  };
  const Case cases[] = {
      {"guard_wuni", "<unicastLocatorList>" + udp("10.0.0.9") + "</unicastLocatorList>", "",
       "writer QoS profile 'guard_wuni.writer'"},
      {"guard_wmc", "<multicastLocatorList>" + udp("239.255.1.1") + "</multicastLocatorList>", "",
       "multicastLocatorList holds 239.255.1.1:"},
      {"guard_rremote", "", "<remoteLocatorList>" + udp("10.0.0.10") + "</remoteLocatorList>",
       "reader QoS profile 'guard_rremote.reader'"},
      {"guard_rmc", "", "<multicastLocatorList>" + udp("239.255.1.2") + "</multicastLocatorList>",
       "multicastLocatorList holds 239.255.1.2:"},
  };
  for (const Case& c : cases) {
    ParticipantOptions options;
    options.domain_id = 43;
    options.profiles_file = LoopbackProfiles(c.name, "", "", c.writer, c.reader);
    options.participant_profile = c.name;
    Participant participant(options);
    try {
      if (!c.writer.empty()) {
        Writer<cairn_msgs::ModeRequestPubSubType> writer(participant, "test/guard", c.name);
      } else {
        Reader<cairn_msgs::ModeRequestPubSubType> reader(participant, "test/guard", c.name,
                                                         [](const auto&, const auto&) {});
      }
      ADD_FAILURE() << c.name << ": the endpoint was created";
    } catch (const DdsError& e) {
      EXPECT_NE(std::string(e.what()).find(c.needle), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("not loopback-only"), std::string::npos) << e.what();
    }
  }
}

TEST(NetworkScope, ParsesSubnetsAndRefusesWhatIsNotACidrNamingIt) {
  const Ipv4Subnet s = ParseIpv4Subnet("10.77.0.9/24");
  EXPECT_EQ(s.network, 0x0A4D0000u);
  EXPECT_EQ(s.prefix_length, 24);
  EXPECT_TRUE(s.Contains(0x0A4D00FEu));
  EXPECT_FALSE(s.Contains(0x0A4E0001u));
  EXPECT_TRUE(ParseIpv4Subnet("0.0.0.0/0").Contains(0xC0A80101u));
  for (const std::string bad :
       {"10.77.0.0", "10.77.0.0/33", "10.77.0/24", "10.77.0.256/24", "ten/8", "10.77.0.0/", " 10.77.0.0/24",
        "10.77.0.0/24 ", "10..0.0/8", "10.77.0.0.1/24"}) {
    try {
      ParseIpv4Subnet(bad);
      ADD_FAILURE() << "accepted '" << bad << "'";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("'" + bad + "'"), std::string::npos) << e.what();
    }
  }
}

// A participant QoS as a lan link on 10.77.0.0/24 would build it: UDPv4 whitelisted to the robot's address,
// unicast locators on it, a multicast discovery group.
eprosima::fastdds::dds::DomainParticipantQos LanQos(const std::string& whitelist, const std::string& peer,
                                                    const std::string& multicast) {
  using eprosima::fastrtps::rtps::IPLocator;
  using eprosima::fastrtps::rtps::Locator_t;
  eprosima::fastdds::dds::DomainParticipantQos qos;
  qos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->interfaceWhiteList.push_back(whitelist);
  qos.transport().user_transports.push_back(udp);
  const auto locator = Udpv4Locator;
  qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(locator(whitelist, 7410));
  if (!peer.empty()) qos.wire_protocol().builtin.initialPeersList.push_back(locator(peer, 7410));
  if (!multicast.empty())
    qos.wire_protocol().builtin.metatrafficMulticastLocatorList.push_back(locator(multicast, 7400));
  return qos;
}

// Tests run in a private network namespace: the host has lo 127.0.0.1 only.
TEST(LinkOptions, ALanLinkResolvesToTheOneAddressNamedAndRefusesAnythingElseNamingIt) {
  LinkOptions lan;
  lan.link = "lan";
  lan.subnet = "127.0.0.0/8";
  Ipv4Subnet subnet;
  EXPECT_EQ(ResolveLinkAddress(lan, &subnet), "127.0.0.1");
  EXPECT_EQ(subnet.text, "127.0.0.0/8");
  lan.subnet.clear();
  lan.interface_name = "lo";
  EXPECT_EQ(ResolveLinkAddress(lan, &subnet), "127.0.0.1");
  EXPECT_EQ(subnet.text, "127.0.0.1/8");  // the interface's own
  const auto refused = [](const LinkOptions& link, const std::string& needle) {
    Ipv4Subnet unused;
    try {
      ResolveLinkAddress(link, &unused);
      ADD_FAILURE() << "accepted, expected: " << needle;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  lan.interface_name.clear();
  lan.subnet = "10.99.0.0/24";
  refused(lan,
          "--subnet 10.99.0.0/24: no interface of this host has an IPv4 address there (seen: lo 127.0.0.1)");
  lan.subnet.clear();
  lan.interface_name = "eth7";
  refused(lan, "--interface 'eth7': no interface of this host has an IPv4 address there");
  lan.subnet = "10.99.0.0/24";
  lan.interface_name = "lo";
  refused(lan, "--interface 'lo' in --subnet 10.99.0.0/24: no interface");
  refused(LinkOptions{"lan", "", "", 0, ""}, "--link lan needs --subnet CIDR or --interface NAME");
  refused(LinkOptions{"wifi", "", "", 0, ""}, "--link 'wifi' must be loopback, lan or radio");
  refused(LinkOptions{"radio", "10.77.0.0/24", "", 0, ""},
          "--link-kbps 0.000000: a radio link needs its budget");
  refused(LinkOptions{"lan", "10.77.0.0/24", "", 1000, ""},
          "--link-kbps names a radio link's budget: add --link radio");
  refused(LinkOptions{"radio", "", "", 1000, ""}, "--link radio needs --subnet CIDR or --interface NAME");
  refused(LinkOptions{"loopback", "10.77.0.0/24", "", 0, ""}, "add --link lan");
  refused(LinkOptions{"lan", "10.77.0.0", "", 0, ""}, "subnet '10.77.0.0' must be an IPv4 CIDR");
  refused(LinkOptions{"lan", "10.77.0.0/24", "", 0, "10.77.0.2"},
          "--discovery-server '10.77.0.2' must be IPV4_ADDRESS:PORT, e.g. 10.77.0.2:11811");
  refused(LinkOptions{"lan", "10.77.0.0/24", "", 0, "10.77.0.2:70000"},
          "--discovery-server '10.77.0.2:70000'");
  refused(LinkOptions{"loopback", "", "", 0, "127.0.0.1:11811"},
          "--discovery-server names a server on a lan or radio link: add --link lan");
}

// A lan participant is built on the named address only: its QoS passes the guard for that subnet (the
// participant would not start otherwise) and it publishes and reads on it.
TEST(LinkOptions, ALanParticipantStartsOnTheNamedNetworkOnly) {
  ParticipantOptions options;
  options.domain_id = 44;
  options.link = LinkOptions{"lan", "127.0.0.0/8", "", 0, ""};
  Participant participant(options);
  ASSERT_EQ(participant.options().network.subnets.size(), 1u);
  EXPECT_EQ(participant.options().network.subnets[0].text, "127.0.0.0/8");
  EXPECT_TRUE(participant.options().network.multicast);
  eprosima::fastdds::dds::DomainParticipantQos qos;
  participant.get()->get_qos(qos);
  ASSERT_EQ(qos.transport().user_transports.size(), 1u);
  const auto* udp = dynamic_cast<const eprosima::fastdds::rtps::UDPv4TransportDescriptor*>(
      qos.transport().user_transports[0].get());
  ASSERT_NE(udp, nullptr);
  EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
  EXPECT_FALSE(qos.transport().use_builtin_transports);
  // The profile's socket buffers carry over (the ROS 2 driver's 4 MiB for clouds; the default profile none).
  EXPECT_EQ(udp->receiveBufferSize, 0u);
  ParticipantOptions ros2 = options;
  ros2.participant_profile = "cairn.ros2.loopback";
  Participant on_ros2_profile(ros2);
  on_ros2_profile.get()->get_qos(qos);
  ASSERT_EQ(qos.transport().user_transports.size(), 1u);
  udp = dynamic_cast<const eprosima::fastdds::rtps::UDPv4TransportDescriptor*>(
      qos.transport().user_transports[0].get());
  ASSERT_NE(udp, nullptr);
  EXPECT_EQ(udp->interfaceWhiteList, std::vector<std::string>{"127.0.0.1"});
  EXPECT_EQ(udp->receiveBufferSize, 4194304u);
  EXPECT_EQ(udp->sendBufferSize, 4194304u);
  // A lan link on a subnet this host has no address in never creates a participant.
  options.link.subnet = "10.99.0.0/24";
  EXPECT_THROW(Participant{options}, std::invalid_argument);
}

TEST(NetworkScope, ANamedSubnetAdmitsItsAddressesOnlyAndMulticastOnlyWhenNamed) {
  NetworkScope lan;
  lan.subnets.push_back(ParseIpv4Subnet("10.77.0.0/24"));
  std::string why;
  EXPECT_TRUE(WithinNetworkScope(LanQos("10.77.0.1", "10.77.0.2", ""), lan, &why)) << why;
  // The default scope (loopback) refuses the same profile, naming the whitelist entry.
  EXPECT_FALSE(WithinNetworkScope(LanQos("10.77.0.1", "", ""), NetworkScope{}, &why));
  EXPECT_NE(why.find("whitelist contains 10.77.0.1"), std::string::npos) << why;
  // An interface or a peer outside the named subnet.
  EXPECT_FALSE(WithinNetworkScope(LanQos("10.78.0.1", "", ""), lan, &why));
  EXPECT_NE(why.find("whitelist contains 10.78.0.1, outside loopback (127.0.0.0/8) and 10.77.0.0/24"),
            std::string::npos)
      << why;
  EXPECT_FALSE(WithinNetworkScope(LanQos("10.77.0.1", "192.168.1.20", ""), lan, &why));
  EXPECT_NE(why.find("initialPeersList holds 192.168.1.20:7410, outside loopback"), std::string::npos) << why;
  EXPECT_FALSE(WithinNetworkScope(LanQos("eth0", "", ""), lan, &why));
  EXPECT_NE(why.find("whitelist contains eth0"), std::string::npos) << why;
  // Multicast discovery: refused unless the scope names multicast, and then only multicast groups.
  EXPECT_FALSE(WithinNetworkScope(LanQos("10.77.0.1", "", "239.255.0.1"), lan, &why));
  EXPECT_NE(why.find("metatrafficMulticastLocatorList holds 239.255.0.1:7400"), std::string::npos) << why;
  lan.multicast = true;
  EXPECT_TRUE(WithinNetworkScope(LanQos("10.77.0.1", "", "239.255.0.1"), lan, &why)) << why;
  EXPECT_FALSE(WithinNetworkScope(LanQos("10.77.0.1", "", "10.77.0.255"), lan, &why));
  EXPECT_NE(why.find("not a UDPv4 multicast group"), std::string::npos) << why;
  // Built-in transports are never in scope.
  auto builtin = LanQos("10.77.0.1", "", "");
  builtin.transport().use_builtin_transports = true;
  EXPECT_FALSE(WithinNetworkScope(builtin, lan, &why));
  EXPECT_NE(why.find("built-in transports"), std::string::npos) << why;
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

// On a network link a writer's and a reader's 1 s liveliness lease (cairn.latched) is raised to 2 s, so that
// a lossy radio does not lapse it, and the two still match; loopback keeps the profile's 1 s.
TEST(LinkOptions, ANetworkLinkRaisesShortLivelinessLeasesAndItsEndpointsStillMatch) {
  const auto lease_s = [](const auto& qos) {
    const auto& d = qos.liveliness().lease_duration;
    return d.seconds + d.nanosec * 1e-9;
  };
  ParticipantOptions loopback;
  loopback.domain_id = 45;
  Participant on_loopback(loopback);
  EXPECT_DOUBLE_EQ(lease_s(on_loopback.WriterQos("cairn.latched.writer")), 1.0);
  EXPECT_DOUBLE_EQ(lease_s(on_loopback.ReaderQos("cairn.latched.reader")), 1.0);

  ParticipantOptions lan = loopback;
  lan.link = LinkOptions{"lan", "127.0.0.0/8", "", 0, ""};
  Participant a(lan), b(lan);
  EXPECT_DOUBLE_EQ(lease_s(a.WriterQos("cairn.latched.writer")), kNetworkLivelinessLeaseS);
  EXPECT_DOUBLE_EQ(lease_s(a.ReaderQos("cairn.latched.reader")), kNetworkLivelinessLeaseS);
  // The announcement period stays: eight assertions per lease.
  const auto period = a.WriterQos("cairn.latched.writer").liveliness().announcement_period;
  EXPECT_DOUBLE_EQ(period.seconds + period.nanosec * 1e-9, 0.25);
  // Profiles without a finite lease keep theirs.
  EXPECT_EQ(a.WriterQos("cairn.command.writer").liveliness().lease_duration,
            on_loopback.WriterQos("cairn.command.writer").liveliness().lease_duration);
  EXPECT_THROW(a.WriterQos("no.such.writer"), DdsError);

  std::atomic<int> received{0};
  Reader<cairn_msgs::ModeRequestPubSubType> reader(
      b, "test/latched", "cairn.latched", [&](const cairn_msgs::ModeRequest&, const auto&) { ++received; });
  Writer<cairn_msgs::ModeRequestPubSubType> writer(a, "test/latched", "cairn.latched");
  ASSERT_TRUE(writer.WaitForMatched(1, std::chrono::seconds(5)));
  ASSERT_TRUE(reader.WaitForMatched(1, std::chrono::seconds(5)));
  eprosima::fastdds::dds::DataWriterQos created;
  writer.get()->get_qos(created);
  EXPECT_DOUBLE_EQ(lease_s(created), kNetworkLivelinessLeaseS);
  cairn_msgs::ModeRequest msg;
  msg.robot_id("r7");
  ASSERT_TRUE(writer.Write(msg));
  EXPECT_TRUE(WaitForCount(received, 1, std::chrono::seconds(5)));
}

// A rebuilt participant (what the stall watchdog does after a SIGSTOP longer than the lease) comes back under
// a new GUID with every endpoint: its writers and readers match their peers again, a latched writer publishes
// its last sample again for them, and a writer used during the rebuild neither blocks nor fails.
TEST(Participant, ARebuildComesBackUnderANewIdWithEveryEndpointAndItsLatchedSample) {
  ParticipantOptions options;
  options.domain_id = 43;
  std::mutex mutex;
  std::vector<std::string> rebuilt_ids;
  ParticipantOptions rebuilt_options = options;
  rebuilt_options.on_rebuilt = [&](const std::string& id) {
    std::lock_guard<std::mutex> lock(mutex);
    rebuilt_ids.push_back(id);
  };
  Participant a(rebuilt_options), b(options);
  EXPECT_GT(a.stall_threshold_s(), 1.0);  // the shipped 2 s lease less its 250 ms announcements
  EXPECT_LT(a.stall_threshold_s(), 2.0);

  std::atomic<int> latched_received{0}, commands_received{0};
  std::string last_latched;
  Reader<cairn_msgs::ModeRequestPubSubType> latched_reader(
      b, "test/rebuild_latched", "cairn.latched", [&](const cairn_msgs::ModeRequest& m, const auto&) {
        std::lock_guard<std::mutex> lock(mutex);
        last_latched = m.robot_id();
        ++latched_received;
      });
  Reader<cairn_msgs::ModeRequestPubSubType> command_reader(
      a, "test/rebuild_command", "cairn.command",
      [&](const cairn_msgs::ModeRequest&, const auto&) { ++commands_received; });
  std::atomic<int> quiet_received{0};
  Reader<cairn_msgs::ModeRequestPubSubType> quiet_reader(
      b, "test/rebuild_quiet", "cairn.latched",
      [&](const cairn_msgs::ModeRequest&, const auto&) { ++quiet_received; });
  Writer<cairn_msgs::ModeRequestPubSubType> latched_writer(a, "test/rebuild_latched", "cairn.latched");
  Writer<cairn_msgs::ModeRequestPubSubType> quiet_writer(a, "test/rebuild_quiet", "cairn.latched");
  Writer<cairn_msgs::ModeRequestPubSubType> command_writer(b, "test/rebuild_command", "cairn.command");
  ASSERT_TRUE(latched_writer.WaitForMatched(1, std::chrono::seconds(5)));
  ASSERT_TRUE(quiet_writer.WaitForMatched(1, std::chrono::seconds(5)));
  ASSERT_TRUE(command_writer.WaitForMatched(1, std::chrono::seconds(5)));
  cairn_msgs::ModeRequest msg;
  for (const char* robot : {"r1", "r2"}) {
    msg.robot_id(robot);
    ASSERT_TRUE(latched_writer.Write(msg));
  }
  ASSERT_TRUE(WaitForCount(latched_received, 2, std::chrono::seconds(5)));
  ASSERT_TRUE(quiet_writer.Write(msg));  // written once, before the rebuild only
  ASSERT_TRUE(WaitForCount(quiet_received, 1, std::chrono::seconds(5)));
  ASSERT_TRUE(command_writer.Write(msg));
  ASSERT_TRUE(WaitForCount(commands_received, 1, std::chrono::seconds(5)));

  const std::string old_id = a.participant_id();
  std::atomic<bool> stop{false};
  std::atomic<int> refused{0};
  std::thread writing([&] {
    cairn_msgs::ModeRequest during;
    during.robot_id("r3");
    while (!stop) {
      if (!latched_writer.Write(during)) ++refused;
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  a.Rebuild("test");
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  stop = true;
  writing.join();
  EXPECT_EQ(refused.load(), 0);
  EXPECT_EQ(a.rebuilds(), 1);
  EXPECT_NE(a.participant_id(), old_id);
  {
    std::lock_guard<std::mutex> lock(mutex);
    ASSERT_EQ(rebuilt_ids.size(), 1u);
    EXPECT_EQ(rebuilt_ids[0], a.participant_id());
  }

  // Both directions match again, and the peer gets a latched writer's last sample from the new writer, also
  // from one not written since.
  EXPECT_TRUE(WaitForCount(quiet_received, 2, std::chrono::seconds(5)));
  ASSERT_TRUE(latched_writer.WaitMatchedWith(b.participant_id(),
                                             std::chrono::steady_clock::now() + std::chrono::seconds(5)));
  ASSERT_TRUE(command_writer.WaitMatchedWith(a.participant_id(),
                                             std::chrono::steady_clock::now() + std::chrono::seconds(5)));
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  const auto latest = [&] {
    std::lock_guard<std::mutex> lock(mutex);
    return last_latched;
  };
  while (latest() != "r3" && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_EQ(latest(), "r3");
  const int commands_before = commands_received.load();
  ASSERT_TRUE(command_writer.Write(msg));
  EXPECT_TRUE(WaitForCount(commands_received, commands_before + 1, std::chrono::seconds(5)));
  // A reader joining now gets the latched sample from the new writer too.
  std::atomic<int> late_received{0};
  Reader<cairn_msgs::ModeRequestPubSubType> late(
      b, "test/rebuild_quiet", "cairn.latched",
      [&](const cairn_msgs::ModeRequest&, const auto&) { ++late_received; });
  EXPECT_TRUE(WaitForCount(late_received, 1, std::chrono::seconds(5)));
}

}  // namespace
}  // namespace cairn::core
