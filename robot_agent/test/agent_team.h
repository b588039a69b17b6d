// Wheeled robots in a built-in world, each the shipping agent (RobotAgent) stepped in process on one
// simulated clock and talking over an InProcessTeam, with one operator's basestation ("op") holding every
// robot's control lock: the scenario tests' team (convoy, get out of the way). Commands go the way the
// console's do (command interface, the service that owns them, the mode, the reply); peer states, claims and
// yield requests go between the robots as the agents send them.
#pragma once

#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "cairn/agent/communication/in_process_link.h"
#include "cairn/agent/modes/waypoint_mode.h"
#include "cairn/agent/robot_agent.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent::team_testing {

/// goto's command as the console sends it: to (x_m, y_m), frame M, on the level nearest z_m (NaN: the
/// robot's).
inline GoalCommand MapGoal(double x_m, double y_m, double z_m = std::numeric_limits<double>::quiet_NaN()) {
  GoalCommand goal;
  goal.frame_id = "map";
  goal.x_m = x_m;
  goal.y_m = y_m;
  goal.z_m = z_m;
  return goal;
}

class AgentTeam {
 public:
  static constexpr double kCycleS = 0.02;
  /// The simulated lidar's columns per beam in these scenarios: half the shipping 1800 (0.4 degree azimuth
  /// steps, as a 16-beam lidar in its 20 Hz mode), which halves the simulator's ray casting and the map
  /// insertion, the larger part of a scenario's CPU. A scenario that needs the denser scan (a staircase seen
  /// from afar) sets it back through `configure_sim`.
  static constexpr int kLidarPointsPerBeam = 900;

  /// Robots `starts` (id, start pose in frame W = M) in `world`, with peers.margin_m `peer_margin_m`
  /// (metres); `configure`, if set, edits each robot's options last, and `configure_sim` its simulated
  /// platform's (e.g. rockfalls; the lidar has kLidarPointsPerBeam columns before it). The operator takes
  /// every robot's lock.
  AgentTeam(const std::string& world, const std::vector<std::pair<std::string, core::PlanarPose>>& starts,
            double peer_margin_m = nav::PeerAvoidanceOptions{}.margin_m,
            const std::function<void(AgentOptions*)>& configure = {},
            const std::function<void(sim::SimulatedPlatformOptions*)>& configure_sim = {}) {
    for (const auto& [id, start] : starts) {
      AgentOptions options;
      options.robot_id = id;
      options.SetPlatform("wheeled");
      options.peers.avoidance.margin_m = peer_margin_m;
      options.perception.camera_rate_hz = 0;  // nobody looks at the frames here
      if (configure) configure(&options);
      sim::SimulatedPlatformOptions sim_options;
      sim_options.world = world;
      sim_options.start_W = start;
      sim::ApplyPlatformProfile(options.navigation.platform, &sim_options);
      sim_options.lidar.points_per_beam = kLidarPointsPerBeam;
      if (configure_sim) configure_sim(&sim_options);
      platforms_.push_back(std::make_shared<sim::SimulatedPlatform>(sim_options));
      ids_.push_back(id);
      robots_.push_back(RobotAgent::Stepped(options, platforms_.back(), links_.Join(id), clock_));
      ever_in_contact_.push_back(false);
      alive_.push_back(true);
    }
    base_ = std::make_unique<InProcessBase>(&links_, "op");
    for (const std::string& id : ids_) {
      const std::uint32_t request = base_->Send(id, ControlCommand{});
      const std::optional<CommandReply> reply = base_->Reply(id, request);
      if (!reply || reply->result != CommandResult::kAccepted)
        throw std::runtime_error("control of " + id +
                                 " not granted: " + (reply ? reply->reason : "no reply"));
    }
  }

  std::size_t size() const { return robots_.size(); }
  RobotAgent& robot(std::size_t i) { return *robots_.at(i); }
  const RobotModes& modes(std::size_t i) const { return robots_.at(i)->modes(); }
  sim::SimulatedPlatform& platform(std::size_t i) { return *platforms_.at(i); }
  /// Ground truth: robot i's true pose.
  sim::UnicycleState truth(std::size_t i) const { return platforms_.at(i)->TrueState(); }
  bool ever_in_contact(std::size_t i) const { return ever_in_contact_.at(i); }
  InProcessTeam& links() { return links_; }
  InProcessBase& base() { return *base_; }
  double now_s() const { return now_s_; }

  /// Robot i's process is gone: it is no longer stepped and nothing more comes from it.
  void Stop(std::size_t i) { alive_.at(i) = false; }
  bool alive(std::size_t i) const { return alive_.at(i); }
  const std::string& id(std::size_t i) const { return ids_.at(i); }

  /// One control cycle of every live robot, kCycleS later, each waiting (wall time) for the plan its next
  /// step needs; then `each`, if set.
  void StepOnce(const std::function<void()>& each = {}) {
    now_s_ += kCycleS;
    for (std::size_t i = 0; i < robots_.size(); ++i) {
      if (!alive_[i]) continue;
      robots_[i]->Step(now_s_);
      while (robots_[i]->planning()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
      ever_in_contact_[i] = ever_in_contact_[i] || platforms_[i]->ReadStatus().in_contact;
    }
    if (each) each();
  }
  /// Cycles for `seconds` of simulated time.
  void StepFor(double seconds, const std::function<void()>& each = {}) {
    for (const double end = now_s_ + seconds - 1e-9; now_s_ < end;) StepOnce(each);
  }  /// Steps until robot i's waypoint goal is no longer active or `limit_s` of simulated time has passed,
  /// calling `each` after every cycle; returns the goal as it ended.
  WaypointGoal DriveGoal(std::size_t i, double limit_s, const std::function<void()>& each = {}) {
    const double end_s = now_s_ + limit_s;
    while (modes(i).waypoint().goal().status == GoalStatus::kActive && now_s_ < end_s) StepOnce(each);
    return modes(i).waypoint().goal();
  }

  /// Sends `command` from the operator to robot i and cycles the team until it is answered (at most 100
  /// cycles): "" when accepted, else the reply's reason (or "no reply").
  template <class Command>
  std::string Ask(std::size_t i, Command command) {
    const std::optional<CommandReply> reply = Send(i, std::move(command));
    if (!reply) return "no reply";
    return reply->result == CommandResult::kAccepted ? "" : reply->reason;
  }
  /// `command` sent to robot i and its reply, stepping until it comes (at most 100 cycles); nullopt: none.
  template <class Command>
  std::optional<CommandReply> Send(std::size_t i, Command command) {
    const std::uint32_t request = base_->Send(ids_.at(i), std::move(command));
    for (int cycle = 0; cycle < 100; ++cycle) {
      if (std::optional<CommandReply> reply = base_->Reply(ids_.at(i), request)) return reply;
      StepOnce();
    }
    return std::nullopt;
  }
  /// goto: robot i to (x_m, y_m), frame M.
  std::string Goto(std::size_t i, double x_m, double y_m) { return Ask(i, MapGoal(x_m, y_m)); }
  /// explore: robot i explores `task`.
  std::string Explore(std::size_t i, const ExploreTask& task) {
    ExploreCommand explore;
    explore.frame_id = "map";
    explore.task = task;
    return Ask(i, explore);
  }
  /// convoy: robot i follows `ahead_ids` (nearest first, the leader last).
  std::string Follow(std::size_t i, std::vector<std::string> ahead_ids) {
    ConvoyCommand convoy;
    convoy.ahead_ids = std::move(ahead_ids);
    return Ask(i, convoy);
  }

 private:
  // Declared first: the links outlive the agents that hold them.
  InProcessTeam links_;
  std::shared_ptr<core::SimulatedClock> clock_ = std::make_shared<core::SimulatedClock>();
  std::vector<std::string> ids_;
  std::vector<std::shared_ptr<sim::SimulatedPlatform>> platforms_;
  std::vector<std::unique_ptr<RobotAgent>> robots_;
  std::vector<bool> ever_in_contact_;
  std::vector<bool> alive_;
  std::unique_ptr<InProcessBase> base_;
  double now_s_ = 0.0;
};

}  // namespace cairn::agent::team_testing
