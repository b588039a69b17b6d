// cairn_base --ros2-domain: the fleet as ROS 2 tools see it, read back by a subscriber that is not ours
// (cairn_ros2_echo on Eclipse Cyclone DDS, tools/ros2_robot_emulator), in this test's private network
// namespace: the robot's frame on /tf where the robot reports itself, its global path on /ROBOT/path, the
// fleet map on /cairn/fleet_map, its label on /cairn/markers and its camera frames, each decoded field by
// field against what Cairn's own topics say.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>

#include "cairn/core/build_paths.h"
#include "cairn/ros2/raw_cdr.h"
#include "integration_util.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;

const std::string kEcho = cairn::core::BinaryDir() + "/tools/ros2_robot_emulator/cairn_ros2_echo";
const std::string kDecode = cairn::core::SourceDir() + "/basestation/web/test/decode_ros2_cdr.mjs";
const std::string kRos2Msgs = cairn::core::SourceDir() + "/ros2/cairn_msgs_ros2/msg";

// The first sample of /cairn/robot_state (cairn_msgs/msg/RobotState) heard on `ros2_domain` for `robot`, as
// raw CDR bytes (decoded below by Foxglove's reader, not by Cairn).
std::vector<std::uint8_t> RobotStateCdr(int ros2_domain) {
  core::ParticipantOptions options;
  options.domain_id = ros2_domain;
  options.participant_profile = "cairn.ros2.loopback";
  options.name = "raw_reader";
  core::Participant participant(options);
  std::mutex mutex;
  std::vector<std::uint8_t> payload;
  core::Reader<ros2::RawCdrPubSubType<ros2::RobotStateName>> reader(
      participant, "rt/cairn/robot_state", "ros2.reliable",
      [&](const ros2::RawCdrSample& s, const eprosima::fastdds::dds::SampleInfo&) {
        std::lock_guard<std::mutex> lock(mutex);
        if (payload.empty()) payload = s.payload;
      });
  for (const auto deadline = Clock::now() + 15s; Clock::now() < deadline;) {
    {
      std::lock_guard<std::mutex> lock(mutex);
      if (!payload.empty()) return payload;
    }
    std::this_thread::sleep_for(50ms);
  }
  return {};
}

// Every JSON line `cairn_ros2_echo ARGS...` prints until it exits (it stops after --count samples).
std::vector<json> Echo(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> argv = {kEcho};
  argv.insert(argv.end(), args.begin(), args.end());
  ChildProcess echo(argv, log);
  std::vector<json> samples;
  const auto deadline = Clock::now() + 40s;
  while (Clock::now() < deadline) {
    const std::optional<std::string> line = echo.ReadLine(1s);
    if (!line) {
      if (echo.Wait(0ms)) break;  // exited: all read
      continue;
    }
    if (line->empty() || (*line)[0] != '{') continue;  // READY
    samples.push_back(json::parse(*line));
  }
  return samples;
}

TEST(Ros2Fleet, RobotsPathsAndTheMapReachAros2SubscriberThatIsNotOurs) {
  const int domain = 63, ros2_domain = 44;
  const std::string logs = FreshLogs("ros2_fleet", "tf_path_map");
  auto agent = StartAgentIn("builtin:tunnels", "r1", domain, logs);
  Observer observer(domain);
  Base op("op1", domain, logs, {"--ros2-domain", std::to_string(ros2_domain)});
  ASSERT_EQ(op.Run("wait r1 online 20")["ok"], true);
  ASSERT_EQ(op.Run("request-control r1")["ok"], true);
  // A far goal: the robot drives (its path stands) while the subscriber reads.
  json r = op.Run("goto r1 40 20");
  ASSERT_EQ(r["ok"], true) << r << "; see " << logs;
  std::this_thread::sleep_for(4s);  // the map grows and goes out (every 2 s)
  const std::vector<json> samples =
      Echo({"--domain", std::to_string(ros2_domain), "--count-each", "1", "--timeout-s", "20",
            "/tf:tf2_msgs/TFMessage", "/r1/path:nav_msgs/Path", "/cairn/fleet_map:sensor_msgs/PointCloud2",
            "/cairn/markers:visualization_msgs/MarkerArray",
            "/r1/camera/image/compressed:sensor_msgs/CompressedImage"},
           logs + "/echo.log");
  const cairn_msgs::RobotState s = observer.FreshState("r1");
  json tf, path, map, markers, camera;
  for (const json& m : samples) {
    if (m["topic"] == "/cairn/markers") markers = m;
    if (m["topic"] == "/r1/camera/image/compressed") camera = m;
    if (m["topic"] == "/tf") tf = m;
    if (m["topic"] == "/r1/path") path = m;
    if (m["topic"] == "/cairn/fleet_map") map = m;
  }
  ASSERT_FALSE(tf.is_null()) << "no /tf heard; see " << logs;
  ASSERT_FALSE(path.is_null()) << "no /r1/path heard (latched); see " << logs;
  ASSERT_FALSE(map.is_null()) << "no /cairn/fleet_map heard (latched); see " << logs;

  // /tf: map -> r1/base_link where the robot reports itself (it drives at most 1 m/s: within 2 m of its state
  // read just after), heading along the tunnel (+x: yaw within 30 degrees).
  ASSERT_EQ(tf["transforms"].size(), 1u) << tf;
  const json& t = tf["transforms"][0];
  EXPECT_EQ(t["frame_id"], "map");
  EXPECT_EQ(t["child_frame_id"], "r1/base_link");
  EXPECT_NEAR(t["translation"][0].get<double>(), s.pose_MB().position().x_m(), 2.0) << t;
  EXPECT_NEAR(t["translation"][1].get<double>(), s.pose_MB().position().y_m(), 0.5) << t;
  const double yaw_rad =
      2 * std::atan2(t["rotation"][2].get<double>(), t["rotation"][3].get<double>());  // about z only
  EXPECT_LT(std::abs(yaw_rad), 0.52) << t;
  EXPECT_NEAR(std::hypot(std::hypot(t["rotation"][0].get<double>(), t["rotation"][1].get<double>()),
                         std::hypot(t["rotation"][2].get<double>(), t["rotation"][3].get<double>())),
              1.0, 1e-6)
      << "a unit quaternion: " << t;
  EXPECT_NEAR(t["stamp"].get<double>(), msgs::WallSeconds(msgs::WallStampNow()), 30.0)
      << "a wall-clock stamp";

  // /r1/path: the global path to the goal, in map.
  EXPECT_EQ(path["frame_id"], "map");
  EXPECT_GE(path["poses"].get<int>(), 2) << path;
  EXPECT_TRUE(path["pose_frames_ok"].get<bool>());
  EXPECT_NEAR(path["last"][0].get<double>(), 40.0, 0.5) << path;
  EXPECT_NEAR(path["last"][1].get<double>(), 20.0, 0.5) << path;

  // /cairn/fleet_map: occupied voxel centres as FLOAT32 x, y, z, inside the tunnels' extent.
  EXPECT_EQ(map["frame_id"], "map");
  EXPECT_EQ(map["point_step"], 12);
  EXPECT_EQ(map["fields"].size(), 3u) << map;
  EXPECT_EQ(map["fields"][2]["name"], "z");
  EXPECT_EQ(map["fields"][2]["datatype"], 7);
  EXPECT_GT(map["points_read"].get<int>(), 200) << map;
  EXPECT_EQ(map["points_read"].get<int>(), map["width"].get<int>());
  EXPECT_GT(map["min"][0].get<double>(), -5.0) << map;
  EXPECT_LT(map["max"][0].get<double>(), 70.0) << map;
  EXPECT_GT(map["min"][2].get<double>(), -2.0) << map;
  EXPECT_LT(map["max"][2].get<double>(), 6.0) << map;

  // /cairn/markers: the robot's label (id and mode) above it; /r1/camera/image/compressed: a whole JPEG.
  ASSERT_FALSE(markers.is_null()) << "no /cairn/markers heard; see " << logs;
  bool labelled = false;
  for (const json& m : markers["markers"]) {
    labelled = labelled || (m["ns"] == "robots" && m["text"] == "r1 (waypoint)" && m["frame_id"] == "map");
  }
  EXPECT_TRUE(labelled) << markers;
  ASSERT_FALSE(camera.is_null()) << "no camera frame heard; see " << logs;
  EXPECT_EQ(camera["format"], "jpeg");
  EXPECT_EQ(camera["frame_id"], "r1/camera");
  EXPECT_TRUE(camera["jpeg_soi"].get<bool>()) << camera;
  EXPECT_GT(camera["data_bytes"].get<int>(), 500) << camera;

  // /cairn/robot_state: Cairn's own RobotState under ROS 2's name, decoded by Foxglove's ROS 2 reader from
  // the generated cairn_msgs/msg/RobotState.msg (a field out of order or of another size fails the decode).
  const std::vector<std::uint8_t> cdr = RobotStateCdr(ros2_domain);
  ASSERT_FALSE(cdr.empty()) << "no /cairn/robot_state heard; see " << logs;
  const std::string cdr_file = logs + "/robot_state.cdr";
  {
    std::ofstream out(cdr_file, std::ios::binary);
    out.write(reinterpret_cast<const char*>(cdr.data()), static_cast<std::streamsize>(cdr.size()));
  }
  ChildProcess decode({"/usr/bin/node", kDecode, kRos2Msgs, "cairn_msgs/msg/RobotState", cdr_file},
                      logs + "/decode.log");
  const std::optional<std::string> line = decode.ReadLine(30s);
  ASSERT_TRUE(line) << "the decoder printed nothing; see " << logs << "/decode.log";
  const json state = json::parse(*line);
  EXPECT_EQ(state["robot_id"], "r1") << state;
  EXPECT_EQ(state["platform"], "wheeled") << state;
  EXPECT_EQ(state["frame_id"], "map") << state;
  EXPECT_EQ(state["mode"], "waypoint") << state;
  EXPECT_EQ(state["holder_id"], "op1") << state;
  EXPECT_NEAR(state["nav_goal_m"]["x_m"].get<double>(), 40.0, 1e-9) << state;
  EXPECT_NEAR(state["nav_goal_m"]["y_m"].get<double>(), 20.0, 1e-9) << state;
  EXPECT_NEAR(state["pose_mb"]["position"]["y_m"].get<double>(), s.pose_MB().position().y_m(), 0.5) << state;
  EXPECT_NEAR(state["pose_mb"]["orientation"]["w"].get<double>(), s.pose_MB().orientation().w(), 0.2)
      << state;
  EXPECT_EQ(op.Run("stop r1")["ok"], true);
}

}  // namespace
}  // namespace cairn
