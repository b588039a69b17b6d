// Copyright Cairn authors.
#include "options.h"

#include <algorithm>
#include <iterator>
#include <optional>
#include <sstream>
#include <vector>

#include "robot_model.h"

namespace ros2_emulator {
namespace {

Pose2 ParseStart(const std::string& text) {
  std::vector<double> values;
  std::stringstream parts(text);
  for (std::string part; std::getline(parts, part, ',');) {
    const std::optional<double> value = ToDouble(part);
    if (!value) {
      throw UsageError("--start " + Quote(text) + ": " + Quote(part) +
                       " is not a finite number (expected X,Y,YAW: metres, metres, radians)");
    }
    values.push_back(*value);
  }
  if (values.size() != 3 || text.back() == ',') {
    throw UsageError("--start " + Quote(text) + " must be X,Y,YAW (metres, metres, radians), e.g. 1,0,0");
  }
  return {values[0], values[1], values[2]};
}

}  // namespace

std::string Usage() {
  return R"(cairn_ros2_robot_emulator: a differential-drive robot with a VLP-16-like lidar, presented as a ROS 2
driver stack would present it, on Eclipse Cyclone DDS (loopback only unless --interface: 127.0.0.1, no multicast).

Publishes  rt/points      sensor_msgs/PointCloud2 10 Hz, frame velodyne (best effort, keep last 5)
           rt/odom        nav_msgs/Odometry 50 Hz, odom -> base_link, drifting (reliable, keep last 10)
           rt/tf          tf2_msgs/TFMessage: odom -> base_link 50 Hz (+ map -> odom 10 Hz with --slam)
           rt/tf_static   base_link -> velodyne, once (reliable, transient local, keep last 1)
Subscribes rt/cmd_vel     geometry_msgs/Twist (linear.x m/s, angular.z rad/s; reliable, keep last 10);
                          no command for 0.5 s stops the robot.
Stamps are the wall clock (CLOCK_REALTIME). Prints READY on stdout once everything is up.

Usage: cairn_ros2_robot_emulator [flags]
  --world NAME          built-in world: corner (L-shaped corridor, default) or room (8 x 6 m room)
  --world-file FILE     walls from FILE instead: one 'x1 y1 x2 y2' (metres) a line, '#' comments
  --start X,Y,YAW       start pose in the world, metres, metres, radians (default: the world's; origin for
                        a world file)
  --domain N            DDS domain id 0..232 (default: ROS_DOMAIN_ID, else 0)
  --interface NAME      speak DDS on this network interface only, with multicast discovery there, as the
                        computers of a ROS 2 robot do (default: loopback only)
  --points-topic NAME   ROS name of the cloud topic (default /points)
  --odom-topic NAME     ROS name of the odometry topic (default /odom)
  --cmd-topic NAME      ROS name of the velocity command topic (default /cmd_vel)
  --cmd-type TYPE       twist (default) or twist_stamped (geometry_msgs/TwistStamped)
  --drift FACTOR        odometry drift multiplier, >= 0 (default 1: 0.002 rad/s yaw-rate bias while moving,
                        1 % distance scale error; 0 = perfect odometry)
  --slam                also publish map -> odom (10 Hz) making map -> base_link the ground truth
  --seed N              seed of the lidar range noise (sigma 0.01 m), default 1
  --truth-out FILE      write the truth every 20 ms: 't_s x_m y_m yaw_rad in_contact' (t_s: stamp clock)
  --help                this text
Exit codes: 0 after SIGINT/SIGTERM, 1 on a DDS failure, 2 on a bad flag or world file.
)";
}

namespace {

// The world (--world or --world-file, the built-in "corner" by default) and the start in it (--start, or the
// world's own), checked: the robot must not overlap a wall there.
void SetWorldAndStart(const std::optional<std::string>& world_name,
                      const std::optional<std::string>& world_file,
                      const std::optional<std::string>& start_text, EmulatorOptions* out) {
  EmulatorOptions& options = *out;
  if (world_name && world_file) throw UsageError("--world and --world-file exclude each other: give one");
  if (world_file) {
    try {
      options.world = LoadWorldFile(*world_file);
    } catch (const WorldFileError& e) {
      throw UsageError(std::string("--world-file: ") + e.what());
    }
  } else {
    const std::string name = world_name.value_or("corner");
    std::optional<World> world = BuiltinWorld(name);
    if (!world)
      throw UsageError("--world " + Quote(name) + " is not a built-in world (" + BuiltinWorldNames() + ")");
    options.world = *world;
  }
  options.start = start_text ? ParseStart(*start_text) : options.world.default_start;
  const RobotModelOptions model;
  if (!RobotModel::Fits(options.world, model, options.start)) {
    std::ostringstream why;
    why << (start_text ? "--start " + Quote(*start_text) : "the default start of world " + options.world.name)
        << ": the robot (a disk of radius " << model.radius_m << " m) would overlap a wall (nearest at "
        << DistanceToNearestWall(options.world, options.start.x_m, options.start.y_m) << " m)"
        << (start_text ? "" : "; give --start X,Y,YAW");
    throw UsageError(why.str());
  }
}

}  // namespace

EmulatorOptions ParseOptions(int argc, const char* const* argv, const char* ros_domain_id_env) {
  EmulatorOptions options;
  if (ros_domain_id_env != nullptr && *ros_domain_id_env != '\0') {
    options.domain_id = ParseDomain("ROS_DOMAIN_ID", ros_domain_id_env);
  }
  std::optional<std::string> world_name, world_file, start_text;
  for (int i = 1; i < argc; ++i) {
    const std::string flag = argv[i];
    // Flags without a value first; every other flag takes the next argument.
    if (flag == "--help" || flag == "-h") {
      options.help = true;
      return options;
    }
    if (flag == "--slam") {
      options.slam = true;
      continue;
    }
    static const char* const kValueFlags[] = {"--world",        "--world-file", "--start",     "--domain",
                                              "--points-topic", "--odom-topic", "--cmd-topic", "--cmd-type",
                                              "--drift",        "--seed",       "--truth-out", "--interface"};
    if (std::find(std::begin(kValueFlags), std::end(kValueFlags), flag) == std::end(kValueFlags)) {
      throw UsageError("unknown flag " + Quote(flag) + " (see --help)");
    }
    if (i + 1 >= argc) throw UsageError(flag + " needs a value (see --help)");
    const std::string value = argv[++i];
    if (flag == "--world") {
      world_name = value;
    } else if (flag == "--world-file") {
      world_file = value;
    } else if (flag == "--start") {
      start_text = value;
    } else if (flag == "--domain") {
      options.domain_id = ParseDomain("--domain", value);
    } else if (flag == "--interface") {
      options.interface_name = ParseInterfaceName(flag, value);
    } else if (flag == "--points-topic") {
      options.points_topic = RosTopicToDds(flag, value);
    } else if (flag == "--odom-topic") {
      options.odom_topic = RosTopicToDds(flag, value);
    } else if (flag == "--cmd-topic") {
      options.cmd_topic = RosTopicToDds(flag, value);
    } else if (flag == "--cmd-type") {
      if (value == "twist") {
        options.cmd_type = CmdType::kTwist;
      } else if (value == "twist_stamped") {
        options.cmd_type = CmdType::kTwistStamped;
      } else {
        throw UsageError("--cmd-type " + Quote(value) + " must be twist or twist_stamped");
      }
    } else if (flag == "--drift") {
      const std::optional<double> factor = ToDouble(value);
      if (!factor || *factor < 0.0) throw UsageError("--drift " + Quote(value) + " must be a number >= 0");
      options.drift_factor = *factor;
    } else if (flag == "--seed") {
      const std::optional<unsigned long long> seed = ToUnsigned(value, UINT64_MAX);
      if (!seed) throw UsageError("--seed " + Quote(value) + " must be a non-negative integer");
      options.seed = *seed;
    } else if (flag == "--truth-out") {
      if (value.empty()) throw UsageError("--truth-out '' needs a file name");
      options.truth_out = value;
    }
  }

  SetWorldAndStart(world_name, world_file, start_text, &options);
  return options;
}

}  // namespace ros2_emulator
