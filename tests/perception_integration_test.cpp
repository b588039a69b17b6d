// Perception over DDS, multi-process: a legged robot drives to the built-in staircase; the basestation is
// told about the staircase once and lists it; a camera snapshot is a valid JPEG; map telemetry stays within
// its budget; a basestation that joins late gets the same map as the early one and as the robot's own (at the
// coarse resolution); malformed peer messages are dropped without touching the fleet map. All processes run
// in this test's private network namespace (tests/netns_run.sh).
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <set>
#include <tuple>

#include "cairn/core/build_paths.h"
#include "cairn/perception/jpeg.h"
#include "cairn/perception/occupancy_map.h"
#include "integration_util.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using ::cairn::testing::ChildProcess;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

// Records every map update on the wire (time, bytes) and can inject raw perception messages as a peer.
class MapTap {
 public:
  explicit MapTap(int domain) {
    core::ParticipantOptions options;
    options.domain_id = domain;
    options.name = "test-map-tap";
    participant_ = std::make_unique<core::Participant>(options);
    reader_ = std::make_unique<core::Reader<cairn_msgs::MapUpdatePubSubType>>(
        *participant_, "cairn/map_update", "cairn.map", [this](const cairn_msgs::MapUpdate& m, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          if (m.robot_id() == "leg1" && m.kind() == 0) deltas_.emplace_back(Clock::now(), m.data().size());
        });
    map_writer_ = std::make_unique<core::Writer<cairn_msgs::MapUpdatePubSubType>>(
        *participant_, "cairn/map_update", "cairn.map");
    staircase_writer_ = std::make_unique<core::Writer<cairn_msgs::StaircaseDetectionPubSubType>>(
        *participant_, "cairn/staircase", "cairn.latched");
  }
  std::vector<std::pair<Clock::time_point, std::size_t>> Deltas() {
    std::lock_guard<std::mutex> lock(mutex_);
    return deltas_;
  }
  core::Writer<cairn_msgs::MapUpdatePubSubType>& map_writer() { return *map_writer_; }
  core::Writer<cairn_msgs::StaircaseDetectionPubSubType>& staircase_writer() { return *staircase_writer_; }

 private:
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Reader<cairn_msgs::MapUpdatePubSubType>> reader_;
  std::unique_ptr<core::Writer<cairn_msgs::MapUpdatePubSubType>> map_writer_;
  std::unique_ptr<core::Writer<cairn_msgs::StaircaseDetectionPubSubType>> staircase_writer_;
  std::mutex mutex_;
  std::vector<std::pair<Clock::time_point, std::size_t>> deltas_;
};

using VoxelSet = std::map<std::tuple<int, int, int>, perception::CoarseState>;

// Coarse voxels of a .bt file, `levels` levels above its resolution.
VoxelSet LoadCoarse(const std::string& path, int levels) {
  const perception::OccupancyMap map = perception::OccupancyMap::LoadBt(path);
  VoxelSet set;
  for (const auto& v : map.CoarseSnapshot(levels)) set[{v.ix, v.iy, v.iz}] = v.state;
  return set;
}

std::size_t Differences(const VoxelSet& a, const VoxelSet& b) {
  std::size_t differ = 0;
  for (const auto& [k, state] : a) {
    auto it = b.find(k);
    differ += it == b.end() || it->second != state;
  }
  for (const auto& [k, state] : b) differ += a.count(k) == 0;
  return differ;
}

TEST(PerceptionOverDds, StaircaseSnapshotMapBudgetAndLateJoiner) {
  const int domain = 64;
  const std::string logs = cairn::core::BinaryDir() + "/test-logs/perception";
  std::filesystem::remove_all(logs);
  std::filesystem::create_directories(logs);
  MapTap tap(domain);
  Base early("opEarly", domain, logs);
  const std::string robot_map = logs + "/leg1_robot.bt";
  auto robot = std::make_unique<ChildProcess>(
      std::vector<std::string>{kAgent, "--robot-id", "leg1", "--platform", "legged", "--start", "46.5,23.7,0",
                               "--domain", std::to_string(domain), "--map-save", robot_map},
      logs + "/leg1.log");
  ASSERT_TRUE(robot->WaitForLine("READY", 60s)) << "see " << logs;
  ASSERT_TRUE(early.Run("wait leg1 online 5")["ok"]);

  // Drive to the foot of the staircase; the robot maps, detects and streams on the way.
  ASSERT_TRUE(early.Run("request-control leg1")["ok"]);
  json r = early.Run("goto leg1 48.8 23.7 --wait 60", 70s);
  ASSERT_TRUE(r["ok"]) << r;

  // The staircase is announced once and listed with its geometry.
  json stairs;
  for (auto deadline = Clock::now() + 20s; Clock::now() < deadline;) {
    stairs = early.Run("stairs");
    if (!stairs["staircases"].empty()) break;
    std::this_thread::sleep_for(500ms);
  }
  ASSERT_EQ(stairs["staircases"].size(), 1u) << stairs;
  const json& s = stairs["staircases"][0];
  EXPECT_EQ(s["num_steps"], 5) << s;
  EXPECT_NEAR(s["rise_m"].get<double>(), 0.2, 0.01) << s;
  EXPECT_NEAR(s["run_m"].get<double>(), 0.5, 0.01) << s;
  EXPECT_NEAR(s["x_m"].get<double>(), 50.0, 0.1) << s;
  std::this_thread::sleep_for(2s);  // more detections merge into the same staircase: no second announcement
  early.Run("stairs");              // (events print between commands)
  std::vector<json> staircase_events;  // other news (lock granted, arrived) prints too
  for (const auto& e : early.events()) {
    if (e["event"] == "staircase") staircase_events.push_back(e);
  }
  ASSERT_EQ(staircase_events.size(), 1u) << json(early.events()).dump();
  EXPECT_EQ(staircase_events[0]["id"], s["id"]) << "the staircase listed is the one announced";
  EXPECT_EQ(staircase_events[0]["message"].get<std::string>().rfind(
                "new staircase " + std::to_string(s["id"].get<int>()) + ": ", 0),
            0u)
      << staircase_events[0];
  Figure("staircase_rise_m", s["rise_m"].get<double>());
  Figure("staircase_run_m", s["run_m"].get<double>());
  Figure("staircase_width_m", s["width_m"].get<double>());

  // A camera snapshot is a 320x240 JPEG.
  const std::string jpeg_path = logs + "/leg1.jpg";
  r = early.Run("snapshot leg1 " + jpeg_path);
  ASSERT_TRUE(r["ok"]) << r;
  std::ifstream file(jpeg_path, std::ios::binary);
  const std::vector<std::uint8_t> jpeg((std::istreambuf_iterator<char>(file)),
                                       std::istreambuf_iterator<char>());
  int width = 0;
  int height = 0;
  perception::ReadJpegSize(jpeg, &width, &height);
  EXPECT_EQ(width, 320);
  EXPECT_EQ(height, 240);
  Figure("snapshot_bytes", static_cast<double>(jpeg.size()));

  // Map telemetry within its budget (100 kbit/s, 1 s token bucket; 120 bytes of headers per message counted):
  // over every 5 s window, at most 100 kbit/s * (5 + 1) s.
  const auto deltas = tap.Deltas();
  ASSERT_GT(deltas.size(), 5u);
  double peak_bits = 0;
  double total_bits = 0;
  for (std::size_t i = 0; i < deltas.size(); ++i) {
    double bits = 0;
    for (std::size_t j = i; j < deltas.size() && deltas[j].first < deltas[i].first + 5s; ++j) {
      bits += (deltas[j].second + 120) * 8.0;
    }
    peak_bits = std::max(peak_bits, bits);
    total_bits += (deltas[i].second + 120) * 8.0;
  }
  const double span_s =
      std::chrono::duration<double>(deltas.back().first - deltas.front().first).count() + 0.5;
  EXPECT_LE(peak_bits, 100000.0 * 6.0);
  Figure("map_peak_5s_kbit_per_s", peak_bits / 5.0 / 1000.0);
  Figure("map_mean_kbit_per_s", total_bits / span_s / 1000.0);

  // The robot is at rest: its map stops changing (keyframes) and the telemetry drains. A late basestation
  // asks for a snapshot and ends with the same map as the early one.
  std::this_thread::sleep_for(3s);
  Base late("opLate", domain, logs);
  const std::string early_bt = logs + "/early_leg1.bt";
  const std::string late_bt = logs + "/late_leg1.bt";
  const std::string fleet_bt = logs + "/late_fleet.bt";
  r = late.Run("map leg1 --save " + late_bt);
  ASSERT_TRUE(r["ok"]) << r;
  Figure("late_map_voxels", r["voxels"].get<double>());
  r = early.Run("map leg1 --save " + early_bt);
  ASSERT_TRUE(r["ok"]) << r;
  r = late.Run("map fleet --save " + fleet_bt);
  ASSERT_TRUE(r["ok"]) << r;
  const VoxelSet early_map = LoadCoarse(early_bt, 0);
  const VoxelSet late_map = LoadCoarse(late_bt, 0);
  EXPECT_GT(early_map.size(), 1000u);
  EXPECT_EQ(Differences(early_map, late_map), 0u);
  EXPECT_EQ(Differences(late_map, LoadCoarse(fleet_bt, 0)), 0u);  // one robot: the fleet map is its map

  // Malformed peer messages are dropped: a corrupt payload claiming to be leg1's next delta, an unknown
  // encoding, a NaN staircase. The maps and the staircase list do not change.
  cairn_msgs::MapUpdate bad;
  bad.robot_id("leg1");
  bad.kind(0);
  bad.seq(1000000);
  bad.base_seq(999999);
  bad.chunk_count(1);
  bad.resolution_m(0.2);
  bad.encoding("cairn-coarse-zstd-v1");
  bad.data(std::vector<uint8_t>(64, 0xAB));
  ASSERT_TRUE(tap.map_writer().Write(bad));
  bad.encoding("gzip");
  ASSERT_TRUE(tap.map_writer().Write(bad));
  cairn_msgs::StaircaseDetection nan_stairs;
  nan_stairs.robot_id("rogue");
  nan_stairs.staircase_id(1);
  nan_stairs.rise_m(std::nan(""));
  nan_stairs.run_m(0.3);
  nan_stairs.width_m(1.0);
  nan_stairs.num_steps(4);
  ASSERT_TRUE(tap.staircase_writer().Write(nan_stairs));
  // Finite but absurd, x = 1e300, was announced to every operator.
  cairn_msgs::StaircaseDetection far_stairs = nan_stairs;
  far_stairs.staircase_id(2);
  far_stairs.rise_m(0.18);
  far_stairs.p_M_first_step().x_m(1e300);
  ASSERT_TRUE(tap.staircase_writer().Write(far_stairs));
  std::this_thread::sleep_for(1s);
  r = late.Run("map leg1 --save " + late_bt);
  ASSERT_TRUE(r["ok"]) << r;
  EXPECT_EQ(Differences(early_map, LoadCoarse(late_bt, 0)), 0u);
  EXPECT_EQ(late.Run("stairs")["staircases"].size(), 1u);

  // The robot's own map (saved at exit, full resolution, downsampled here) equals what the basestations hold.
  robot.reset();  // SIGTERM: the agent saves its map
  ASSERT_TRUE(std::filesystem::exists(robot_map)) << "see " << logs;
  const VoxelSet robot_coarse = LoadCoarse(robot_map, 1);
  const std::size_t differ = Differences(robot_coarse, early_map);
  Figure("robot_vs_basestation_differing_voxels", static_cast<double>(differ));
  EXPECT_EQ(differ, 0u) << robot_coarse.size() << " robot voxels, " << early_map.size()
                        << " basestation voxels";
}

}  // namespace
}  // namespace cairn
