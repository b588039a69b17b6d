// cairn_base --ros2-domain: the fleet as ROS 2 tools see it, read back by a subscriber that is not ours
// (cairn_ros2_echo on Eclipse Cyclone DDS, tools/ros2_robot_emulator), in this test's private network
// namespace: the robot's frame on /tf where the robot reports itself, its global path on /ROBOT/path, the
// fleet map on /cairn/fleet_map, its label on /cairn/markers and its camera frames, each decoded field by
// field against what Cairn's own topics say.
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "integration_util.h"
#include "process.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;

const std::string kEcho = std::string(CAIRN_BINARY_DIR) + "/tools/ros2_robot_emulator/cairn_ros2_echo";

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
  EXPECT_EQ(op.Run("stop r1")["ok"], true);
}

}  // namespace
}  // namespace cairn
