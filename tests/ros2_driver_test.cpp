// cairn_agent --driver ros2 against a ROS 2 robot that is not ours: cairn_ros2_robot_emulator, a
// differential-drive base with a 16-beam lidar on Eclipse Cyclone DDS (tools/ros2_robot_emulator), in this
// test's private network namespace. The operator drives it from cairn_base around a corner and an obstacle,
// stops it, explores a room with it to completion, and, when the robot's ROS 2 stack dies, the agent says the
// robot is not localized, naming the topic, and refuses the modes that need a pose. The emulator's ground
// truth (never seen by the agent) scores it.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cairn/core/build_paths.h"
#include "integration_util.h"
#include "process.h"
#include "ros2_msgsPubSubTypes.h"

namespace cairn {
namespace {

using namespace std::chrono_literals;
using namespace testing_util;
using nlohmann::json;

const std::string kEmulator =
    cairn::core::BinaryDir() + "/tools/ros2_robot_emulator/cairn_ros2_robot_emulator";

struct Truth {
  double t_s, x_m, y_m, yaw_rad;
  bool in_contact;
};

std::vector<Truth> ReadTruth(const std::string& path) {
  std::vector<Truth> truth;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    Truth t{};
    int contact = 0;
    if (fields >> t.t_s >> t.x_m >> t.y_m >> t.yaw_rad >> contact) {
      t.in_contact = contact != 0;
      truth.push_back(t);
    }
  }
  return truth;
}

// The emulated robot (ROS 2 domain `ros2_domain`, world `world`) and the agent driving it through its ROS 2
// topics (fleet domain `domain`), with an operator console.
class Ros2Robot {
 public:
  Ros2Robot(const std::string& test, const std::string& world, int domain, int ros2_domain)
      : logs_(FreshLogs("ros2_driver", test)), truth_file_(logs_ + "/truth.txt") {
    emulator_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{kEmulator, "--world", world, "--domain", std::to_string(ros2_domain),
                                 "--truth-out", truth_file_},
        logs_ + "/emulator.log");
    EXPECT_TRUE(emulator_->WaitForLine("READY", 30s)) << "the emulator did not start; see " << logs_;
    agent_ = std::make_unique<ChildProcess>(
        std::vector<std::string>{kAgent, "--robot-id", "r1", "--driver", "ros2", "--ros2-domain",
                                 std::to_string(ros2_domain), "--domain", std::to_string(domain)},
        logs_ + "/r1.log");
    EXPECT_TRUE(agent_->WaitForLine("READY", 60s)) << "the agent did not start; see " << logs_;
    op_ = std::make_unique<Base>("op1", domain, logs_);
    EXPECT_EQ(op_->Run("wait r1 online 20")["ok"], true);
    EXPECT_EQ(op_->Run("request-control r1")["ok"], true);
  }
  Base& op() { return *op_; }
  const std::string& logs() const { return logs_; }
  std::vector<Truth> truth() const { return ReadTruth(truth_file_); }
  void KillEmulator() { emulator_.reset(); }

 private:
  std::string logs_, truth_file_;
  std::unique_ptr<ChildProcess> emulator_, agent_;
  std::unique_ptr<Base> op_;
};

// geometry_msgs/Twist samples on rt/cmd_vel as a third party on the robot's ROS 2 domain hears them.
class CmdVelListener {
 public:
  struct Sample {
    Clock::time_point at;
    double v_mps, w_radps;
  };
  explicit CmdVelListener(int ros2_domain) {
    core::ParticipantOptions options;
    options.domain_id = ros2_domain;
    options.participant_profile = "cairn.ros2.loopback";
    options.name = "cmd_vel_listener";
    participant_ = std::make_unique<core::Participant>(options);
    reader_ = std::make_unique<core::Reader<geometry_msgs::msg::dds_::Twist_PubSubType>>(
        *participant_, "rt/cmd_vel", "ros2.reliable",
        [this](const geometry_msgs::msg::dds_::Twist_& m, const eprosima::fastdds::dds::SampleInfo&) {
          std::lock_guard<std::mutex> lock(mutex_);
          samples_.push_back({Clock::now(), m.linear().x(), m.angular().z()});
        });
  }
  std::vector<Sample> samples() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return samples_;
  }

 private:
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Reader<geometry_msgs::msg::dds_::Twist_PubSubType>> reader_;
  mutable std::mutex mutex_;
  std::vector<Sample> samples_;
};

// World `corner`: an L-shaped corridor 2.5 m wide, the robot starts at (1, 0) facing +x (its odometry's
// origin); a 0.6 m box stands against the left wall at x = 6; the corridor turns left at x = 9.5..12.
TEST(Ros2Driver, DrivesTheEmulatedRobotAroundTheCornerAndStopsOnStop) {
  Ros2Robot robot("corner", "corner", 61, 41);
  CmdVelListener cmd_vel(41);
  Base& op = robot.op();
  // Odometry frame: the goal (9.75, 8) is (10.75, 8) in the world, 8 m up the second leg.
  json r = op.Run("goto r1 9.75 8 --wait 120", 130s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << robot.logs();
  std::vector<Truth> truth = robot.truth();
  ASSERT_FALSE(truth.empty());
  const Truth end = truth.back();
  const double miss_m = std::hypot(end.x_m - 10.75, end.y_m - 8.0);
  Figure("goal_miss_truth_m", miss_m);  // the odometry's drift (1 % scale, 0.002 rad/s bias) and tolerance
  EXPECT_LT(miss_m, 0.8) << "the robot stopped at (" << end.x_m << ", " << end.y_m << ") in the world";
  for (const Truth& t : truth) ASSERT_FALSE(t.in_contact) << "touched a wall at " << t.x_m << ", " << t.y_m;

  // Driving back, then a stop: zero twist on /cmd_vel at once, and the robot stands.
  ASSERT_EQ(op.Run("goto r1 2 0")["ok"], true);
  std::this_thread::sleep_for(4s);
  const auto stop_sent = Clock::now();
  r = op.Run("stop r1");
  const auto stop_answered = Clock::now();
  ASSERT_EQ(r["ok"], true) << r;
  std::this_thread::sleep_for(1500ms);
  const std::vector<CmdVelListener::Sample> samples = cmd_vel.samples();
  ASSERT_GT(samples.size(), 100u) << "the agent sends a twist every control cycle";
  bool moving_before = false;
  std::optional<Clock::time_point> first_zero;
  for (const auto& s : samples) {
    if (s.at < stop_sent) {
      moving_before = moving_before || std::abs(s.v_mps) > 0.05;
    } else if (!first_zero && s.v_mps == 0.0 && s.w_radps == 0.0) {
      first_zero = s.at;
    }
    // A twist the agent sent after it answered the stop is zero (one in flight may still come).
    if (s.at > stop_answered + 100ms) {
      EXPECT_EQ(s.v_mps, 0.0) << "a twist after the stop";
    }
  }
  EXPECT_TRUE(moving_before) << "the robot was driving when the stop came";
  ASSERT_TRUE(first_zero) << "no zero twist after the stop";
  Figure("stop_to_zero_cmd_vel_ms",
         std::chrono::duration<double, std::milli>(*first_zero - stop_sent).count());
  EXPECT_LT(*first_zero - stop_sent, 500ms);
  truth = robot.truth();
  ASSERT_GE(truth.size(), 10u);
  const Truth a = truth[truth.size() - 10], b = truth.back();
  EXPECT_LT(std::hypot(b.x_m - a.x_m, b.y_m - a.y_m), 0.01) << "still moving after the stop";

  // The robot's ROS 2 stack dies: not localized, naming the topic; modes that need a pose are refused.
  robot.KillEmulator();
  std::this_thread::sleep_for(1500ms);
  r = op.Run("mode r1 manual");
  EXPECT_EQ(r["ok"], false) << r;
  EXPECT_NE(r.dump().find("no odometry on /odom for"), std::string::npos) << r;
  r = op.Run("goto r1 5 0");
  EXPECT_EQ(r["ok"], false) << r;
}

// World `room`: a closed 8 x 6 m room with two boxes; the robot explores it to completion.
TEST(Ros2Driver, ExploresARoomToCompletion) {
  Ros2Robot robot("room", "room", 62, 42);
  json r = robot.op().Run("explore r1 --wait 240", 250s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << robot.logs();
  EXPECT_NE(r["reason"].get<std::string>().find("exploration complete"), std::string::npos) << r;
  r = robot.op().Run("status r1");
  const double explored_m2 = r["exploration"]["explored_m2"].get<double>();
  Figure("explored_m2", explored_m2);
  // 48 m² of room less the boxes and the 0.3 m the body keeps from the walls.
  EXPECT_GT(explored_m2, 25.0) << r;
  EXPECT_LT(explored_m2, 50.0) << r;
  for (const Truth& t : robot.truth())
    ASSERT_FALSE(t.in_contact) << "touched a wall at " << t.x_m << ", " << t.y_m;
}

}  // namespace
}  // namespace cairn
