// Shared pieces of the multi-process integration tests: a DDS observer, a basestation process driven in
// --json mode, and figure reporting. Everything runs in the test's private network namespace.
#pragma once

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/build_paths.h"
#include "cairn/core/dds.h"
#include "cairn/msgs/robot_state.h"
#include "cairn/msgs/stamp.h"
#include "cairn_msgsPubSubTypes.h"
#include "process.h"

namespace cairn::testing_util {

using namespace std::chrono_literals;
using ::cairn::testing::ChildProcess;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

const std::string kAgent = cairn::core::BinaryDir() + "/robot_agent/cairn_agent";
// The driving robots' agent config: the simulated lidar at half its columns (the file says why).
const std::string kLightLidarConfig = cairn::core::SourceDir() + "/tests/agent_light_lidar.yaml";
const std::string kBase = cairn::core::BinaryDir() + "/basestation/cairn_base";

using ::cairn::msgs::WallSeconds;

// Watches robot states and operator teleop over DDS, and can inject raw messages.
class Observer {
 public:
  explicit Observer(int domain) {
    core::ParticipantOptions options;
    options.domain_id = domain;
    options.name = "test-observer";
    participant_ = std::make_unique<core::Participant>(options);
    // Whole states (on change, at least once a second) and the 10 Hz poses applied to the last one, as a
    // basestation does: the history has an entry per whole state and per pose.
    states_ = std::make_unique<core::Reader<cairn_msgs::RobotStatePubSubType>>(
        *participant_, "cairn/robot_state", "cairn.latched",
        [this](const cairn_msgs::RobotState& s, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          std::optional<cairn_msgs::RobotState> view;
          if (auto it = latest_.find(s.robot_id()); it != latest_.end()) view = it->second;
          cairn::msgs::ApplyWholeState(s, &view);  // a resent, older whole state keeps the last pose
          latest_[s.robot_id()] = *view;
          history_[s.robot_id()].push_back(*view);
        });
    poses_ = std::make_unique<core::Reader<cairn_msgs::RobotPosePubSubType>>(
        *participant_, "cairn/robot_pose", "cairn.state",
        [this](const cairn_msgs::RobotPose& p, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          auto it = latest_.find(p.robot_id());
          if (it == latest_.end()) return;  // its whole state is on the way
          cairn::msgs::MergePose(p, &it->second);
          history_[p.robot_id()].push_back(it->second);
        });
    teleop_ = std::make_unique<core::Reader<cairn_msgs::TeleopTwistPubSubType>>(
        *participant_, "cairn/teleop", "cairn.teleop", [this](const cairn_msgs::TeleopTwist& t, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          last_teleop_[t.robot_id()] = t;
        });
    goals_ = std::make_unique<core::Writer<cairn_msgs::WaypointGoalPubSubType>>(
        *participant_, "cairn/waypoint_goal", "cairn.command");
    // Exploring robots' claims, as their peers hear them, with their arrival time.
    claims_ = std::make_unique<core::Reader<cairn_msgs::ExploreClaimPubSubType>>(
        *participant_, "cairn/explore_claim", "cairn.latched",
        [this](const cairn_msgs::ExploreClaim& c, const auto&) {
          std::lock_guard<std::mutex> lock(mutex_);
          claim_log_.push_back({Clock::now(), c});
        });
  }
  ~Observer() {  // the readers first: their callbacks use the maps and the mutex below
    claims_.reset();
    states_.reset();
    poses_.reset();
    teleop_.reset();
  }
  Observer(const Observer&) = delete;
  Observer& operator=(const Observer&) = delete;
  std::optional<cairn_msgs::RobotState> Latest(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = latest_.find(robot);
    if (it == latest_.end()) return std::nullopt;
    return it->second;
  }
  struct HeardClaim {
    Clock::time_point at;
    cairn_msgs::ExploreClaim claim;
  };
  std::vector<HeardClaim> Claims() {
    std::lock_guard<std::mutex> lock(mutex_);
    return claim_log_;
  }
  std::vector<cairn_msgs::RobotState> History(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    return history_[robot];
  }
  std::optional<cairn_msgs::TeleopTwist> LastTeleop(const std::string& robot) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = last_teleop_.find(robot);
    if (it == last_teleop_.end()) return std::nullopt;
    return it->second;
  }
  // A fresh state of `robot` (received after this call).
  cairn_msgs::RobotState FreshState(const std::string& robot) {
    std::size_t seen = History(robot).size();
    const auto deadline = Clock::now() + 3s;
    while (Clock::now() < deadline) {
      auto h = History(robot);
      if (h.size() > seen) return h.back();
      std::this_thread::sleep_for(10ms);
    }
    ADD_FAILURE() << "no state from " << robot;
    return {};
  }
  // The first state of `robot` received after this call for which `want` holds; the last one received (and a
  // failure naming `what`) if none does within `timeout`. Where a test reads what a command it just sent
  // changed: the robot's pose stream (merged into the last whole state here) can arrive before the whole
  // state that carries the change, on a loaded machine by a few hundred milliseconds.
  template <typename Predicate>
  cairn_msgs::RobotState StateWhere(const std::string& robot, Predicate want, const std::string& what,
                                    std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
    std::size_t next = History(robot).size();
    cairn_msgs::RobotState last;
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      const auto h = History(robot);
      for (; next < h.size(); ++next) {
        if (want(h[next])) return h[next];
        last = h[next];
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    ADD_FAILURE() << "no state of " << robot << " where " << what << " within " << timeout.count() << " ms";
    return last;
  }
  core::Writer<cairn_msgs::WaypointGoalPubSubType>& goals() { return *goals_; }

 private:
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<core::Reader<cairn_msgs::RobotStatePubSubType>> states_;
  std::unique_ptr<core::Reader<cairn_msgs::RobotPosePubSubType>> poses_;
  std::unique_ptr<core::Reader<cairn_msgs::ExploreClaimPubSubType>> claims_;
  std::vector<HeardClaim> claim_log_;
  std::unique_ptr<core::Reader<cairn_msgs::TeleopTwistPubSubType>> teleop_;
  std::unique_ptr<core::Writer<cairn_msgs::WaypointGoalPubSubType>> goals_;
  std::mutex mutex_;
  std::map<std::string, cairn_msgs::RobotState> latest_;
  std::map<std::string, std::vector<cairn_msgs::RobotState>> history_;
  std::map<std::string, cairn_msgs::TeleopTwist> last_teleop_;
};

// The state's yaw, radians in (-pi, pi], frame M (from its orientation quaternion).
inline double YawOf(const cairn_msgs::RobotState& s) {
  const auto& q = s.pose_MB().orientation();
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}

// One state as a line: stamp, pose (metres, degrees), measured and commanded twist, the mux's and
// navigation's reasons.
inline std::string FormatState(const cairn_msgs::RobotState& s) {
  const auto& p = s.pose_MB().position();
  const double yaw_deg = YawOf(s) * 180.0 / M_PI;
  char line[512];
  std::snprintf(line, sizeof(line),
                "  t %.2f (%.2f, %.2f, %.2f) yaw %.0f v %.2f w %.2f cmd %.2f %.2f%s mux '%s' nav '%.160s'\n",
                WallSeconds(s.stamp()), p.x_m(), p.y_m(), p.z_m(), yaw_deg, s.twist_B().linear_x_mps(),
                s.twist_B().angular_z_radps(), s.cmd_twist_B().linear_x_mps(),
                s.cmd_twist_B().angular_z_radps(), s.in_contact() ? " CONTACT" : "", s.mux_reason().c_str(),
                s.nav_reason().c_str());
  return line;
}

// The states of `history` up to the first one in contact (at most `count` of them, oldest first); "" when
// none is in contact. Printed by tests next to a contact failure, so that a rare one can be diagnosed from
// the log.
inline std::string TrackBeforeContact(const std::vector<cairn_msgs::RobotState>& history,
                                      std::size_t count = 25) {
  std::size_t first = history.size();
  for (std::size_t i = 0; i < history.size() && first == history.size(); ++i) {
    if (history[i].in_contact()) first = i;
  }
  if (first == history.size()) return "";
  std::string out = "the states before the first contact:\n";
  for (std::size_t i = first + 1 > count ? first + 1 - count : 0; i <= first; ++i)
    out += FormatState(history[i]);
  return out;
}

// A basestation process driven line by line in --json mode.
class Base {
 public:
  Base(const std::string& id, int domain, const std::string& log_dir,
       const std::vector<std::string>& extra = {})
      : process_(Args(id, domain, extra), log_dir + "/" + id + ".log") {}
  void Kill() { process_.Signal(SIGKILL); }
  /// Sends `sig` to the basestation process (SIGSTOP / SIGCONT freeze and resume it).
  void Signal(int sig) { process_.Signal(sig); }
  /// Progress lines seen so far (distance left, ETA).
  const std::vector<json>& progress_lines() const { return progress_lines_; }
  /// Event lines seen so far (e.g. {"event": "staircase", ...}).
  const std::vector<json>& events() const { return events_; }
  json Run(const std::string& command, std::chrono::milliseconds timeout = 30s) {
    process_.WriteLine(command);
    const auto deadline = Clock::now() + timeout;
    while (true) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
      const auto line = process_.ReadLine(std::max(left, std::chrono::milliseconds(1)));
      if (!line) {
        ADD_FAILURE() << "no answer to '" << command << "'";
        return json{{"ok", false}, {"result", "no answer"}};
      }
      json j = json::parse(*line);
      if (j.contains("progress")) {  // goto --wait / wait arrived progress lines precede the answer
        progress_lines_.push_back(j);
        continue;
      }
      if (j.contains("event")) {  // events (a new staircase) print between commands
        events_.push_back(j);
        continue;
      }
      return j;
    }
  }

 private:
  ChildProcess process_;
  std::vector<json> progress_lines_;
  std::vector<json> events_;

  static std::vector<std::string> Args(const std::string& id, int domain,
                                       const std::vector<std::string>& extra) {
    std::vector<std::string> args = {kBase, "--base-id", id, "--domain", std::to_string(domain), "--json"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
};

// Starts `cairn_agent --robot-id ID --world WORLD --start slot:0 --domain DOMAIN EXTRA...` (stderr into
// LOGS/ID.log) and waits for its READY line; a test failure when it does not come within 60 s.
inline std::unique_ptr<ChildProcess> StartAgentIn(const std::string& world, const std::string& id, int domain,
                                                  const std::string& logs,
                                                  const std::vector<std::string>& extra = {}) {
  std::vector<std::string> argv = {
      kAgent, "--robot-id", id, "--world", world, "--start", "slot:0", "--domain", std::to_string(domain)};
  argv.insert(argv.end(), extra.begin(), extra.end());
  auto agent = std::make_unique<ChildProcess>(argv, logs + "/" + id + ".log");
  if (!agent->WaitForLine("READY", 60s)) ADD_FAILURE() << "agent " << id << " did not start; see " << logs;
  return agent;
}

// An emptied folder build/test-logs/GROUP/TEST for a test's process logs.
inline std::string FreshLogs(const std::string& group, const std::string& test) {
  const std::string dir = cairn::core::BinaryDir() + "/test-logs/" + group + "/" + test;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

// Records a measured figure in the test report and prints it (for docs and closing notes).
inline void Figure(const std::string& name, double value) {
  ::testing::Test::RecordProperty(name, std::to_string(value));
  std::printf("FIGURE %s %s = %.3f\n", ::testing::UnitTest::GetInstance()->current_test_info()->name(),
              name.c_str(), value);
}

inline double Distance(const cairn_msgs::RobotState& a, const cairn_msgs::RobotState& b) {
  return std::hypot(a.pose_MB().position().x_m() - b.pose_MB().position().x_m(),
                    a.pose_MB().position().y_m() - b.pose_MB().position().y_m());
}

}  // namespace cairn::testing_util
