// A fleet in process for console tests: robots whose views the test sets, and a record of every command the
// console sends, answered as the test says (accepted by default). No DDS, no waiting: a wait's condition is
// checked once against the views as they are.
#pragma once

#include <cmath>
#include <functional>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/base/fleet.h"
#include "cairn/base/operator_text.h"

namespace cairn::base::testing {

class FakeFleet : public Fleet {
 public:
  explicit FakeFleet(std::string base_id) : base_id_(std::move(base_id)) {}

  /// Adds (or replaces) robot `id` in `mode`, held by `holder` ("" = free), at (x_m, y_m) in the map frame.
  void AddRobot(const std::string& id, const std::string& mode = "idle", const std::string& holder = "",
                double x_m = 0.0, double y_m = 0.0) {
    std::lock_guard<std::mutex> lock(mutex_);
    RobotView& v = robots_[id];
    v.robot_id = id;
    v.platform = "wheeled";
    v.announced = true;
    cairn_msgs::RobotState s;
    s.robot_id(id);
    s.platform("wheeled");
    s.mode(mode);
    s.holder_id(holder);
    s.holder_alive(!holder.empty());
    s.pose_MB().position().x_m(x_m);
    s.pose_MB().position().y_m(y_m);
    s.pose_MB().orientation().w(1.0);
    v.state = s;
    v.last_seen = v.state_received = v.whole_state_received = core::SteadyClock::now();
  }
  /// Robot `id` discovered (its participant announced) before any state of it was heard.
  void AnnounceRobot(const std::string& id) {
    std::lock_guard<std::mutex> lock(mutex_);
    RobotView& v = robots_[id];
    v.robot_id = id;
    v.announced = true;
    v.state.reset();
    v.last_seen = core::SteadyClock::now();
  }
  /// Changes robot `id`'s view as its next state would (`change` gets the view; the robot must be known).
  void Mutate(const std::string& id, const std::function<void(RobotView&)>& change) {
    std::lock_guard<std::mutex> lock(mutex_);
    change(robots_.at(id));
  }
  /// What a robot asked to yield does at once, as its next state shows it (none: it never answers).
  void AnswerYieldsWith(std::function<void(cairn_msgs::RobotState&)> answer) {
    std::lock_guard<std::mutex> lock(mutex_);
    yield_answer_ = std::move(answer);
  }
  /// The next commands to `id` are refused with `reason` (the robot's words); "" accepts them again.
  void RefuseCommandsTo(const std::string& id, const std::string& reason) {
    std::lock_guard<std::mutex> lock(mutex_);
    refusals_[id] = reason;
  }
  /// An event for the console to print.
  void RaiseEvent(const std::string& message) {
    std::lock_guard<std::mutex> lock(mutex_);
    OperatorEvent e;
    e.kind = "test";
    e.message = message;
    e.time = std::chrono::system_clock::now();
    pending_events_.push_back(e);
  }
  /// Every command sent so far, one line each: "SendWaypoint r1 12 4 tol=0 z=nan".
  std::vector<std::string> sent() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return sent_;
  }

  const std::string& base_id() const override { return base_id_; }
  std::vector<RobotView> Robots() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<RobotView> out;
    for (const auto& [id, v] : robots_) out.push_back(v);
    return out;
  }
  std::optional<RobotView> Robot(const std::string& robot_id) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = robots_.find(robot_id);
    if (it == robots_.end()) return std::nullopt;
    return it->second;
  }
  bool WaitForRobot(const std::string& robot_id, double) const override { return Knows(robot_id); }
  std::optional<RobotView> WaitUntil(const std::string& robot_id, double,
                                     const std::function<bool(const RobotView&)>& predicate) const override {
    const auto view = Robot(robot_id);
    if (view && predicate(*view)) return view;
    return std::nullopt;
  }
  CommandOutcome RequestControl(const std::string& robot_id) override {
    return Answer(robot_id, "RequestControl " + robot_id, [&](RobotView& v) {
      v.state->holder_id(base_id_);
      v.state->holder_alive(true);
    });
  }
  CommandOutcome ReleaseControl(const std::string& robot_id) override {
    return Answer(robot_id, "ReleaseControl " + robot_id, [&](RobotView& v) { v.state->holder_id(""); });
  }
  CommandOutcome HandOverControl(const std::string& robot_id, const std::string& to_base_id) override {
    return Answer(robot_id, "HandOverControl " + robot_id + " " + to_base_id, [&](RobotView& v) {
      v.state->holder_id(to_base_id);
      v.state->control_requester_id("");
    });
  }
  CommandOutcome DenyControl(const std::string& robot_id, const std::string& to_base_id) override {
    return Answer(robot_id, "DenyControl " + robot_id + " " + to_base_id,
                  [&](RobotView& v) { v.state->control_requester_id(""); });
  }
  CommandOutcome RequestMode(const std::string& robot_id, const std::string& mode) override {
    return Answer(robot_id, "RequestMode " + robot_id + " " + mode,
                  [&](RobotView& v) { v.state->mode(mode); });
  }
  CommandOutcome SendWaypoint(const std::string& robot_id, double x_m, double y_m, double tolerance_m,
                              double z_m) override {
    return Answer(robot_id,
                  "SendWaypoint " + robot_id + " " + Num(x_m) + " " + Num(y_m) + " tol=" + Num(tolerance_m) +
                      " z=" + Num(z_m),
                  [&](RobotView& v) { v.state->mode("waypoint"); });
  }
  CommandOutcome SendExplore(const std::string& robot_id, const std::optional<Eigen::AlignedBox2d>& region_M,
                             double min_z_m, double max_z_m, double home_after_silence_s) override {
    std::string region = "none";
    if (region_M) {
      region = Num(region_M->min().x()) + "," + Num(region_M->min().y()) + "," + Num(region_M->max().x()) +
               "," + Num(region_M->max().y());
    }
    return Answer(robot_id,
                  "SendExplore " + robot_id + " region=" + region + " z=" + Num(min_z_m) + ".." +
                      Num(max_z_m) + " home_after=" + Num(home_after_silence_s),
                  [&](RobotView& v) { v.state->mode("explore"); });
  }
  CommandOutcome SendConvoy(const std::string& robot_id, const std::vector<std::string>& ahead_ids) override {
    std::string ahead;
    for (const auto& id : ahead_ids) ahead += " " + id;
    return Answer(robot_id, "SendConvoy " + robot_id + ahead,
                  [&](RobotView& v) { v.state->mode(ahead_ids.empty() ? "idle" : "convoy"); });
  }
  std::string SendYield(const std::string& robot_id, const std::string& passing_id, double passing_radius_m,
                        const std::vector<Eigen::Vector2d>& keep_clear_M) override {
    Record("SendYield " + robot_id + " for " + passing_id + " radius=" + Num(passing_radius_m) +
           " points=" + std::to_string(keep_clear_M.size()));
    std::function<void(cairn_msgs::RobotState&)> answer;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      answer = yield_answer_;
    }
    if (answer) Mutate(robot_id, [&](RobotView& v) { answer(*v.state); });
    return "";
  }
  CommandOutcome SendHome(const std::string& robot_id,
                          const std::optional<Eigen::Vector3d>& point_M) override {
    return Answer(robot_id,
                  "SendHome " + robot_id + (point_M ? " " + Num(point_M->x()) + " " + Num(point_M->y()) : ""),
                  [&](RobotView& v) { v.state->mode("waypoint"); });
  }
  CommandOutcome Stop(const std::string& robot_id) override {
    return Answer(robot_id, "Stop " + robot_id, [&](RobotView& v) { v.state->mode("idle"); });
  }
  CommandOutcome Restart(const std::string& robot_id, const std::string& component) override {
    return Answer(robot_id, "Restart " + robot_id + " " + component, [](RobotView&) {});
  }
  bool PublishTeleop(const std::string& robot_id, double linear_x_mps, double angular_z_radps,
                     double linear_y_mps) override {
    Record("PublishTeleop " + robot_id + " " + Num(linear_x_mps) + " " + Num(angular_z_radps) + " " +
           Num(linear_y_mps));
    return true;
  }
  PathAnswer RequestPath(const std::string& robot_id, const std::string&, double, double, double,
                         double) override {
    Record("RequestPath " + robot_id);
    PathAnswer answer;
    answer.result = outcome::kRefused;
    answer.reason = "the fake fleet plans no paths";
    return answer;
  }
  FleetPerception& perception() override {
    throw std::logic_error("the fake fleet has no perception telemetry (map, camera, staircases)");
  }
  std::vector<OperatorEvent> TakeEvents() override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<OperatorEvent> out;
    out.swap(pending_events_);
    return out;
  }
  bool HasEvents() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return !pending_events_.empty();
  }
  std::vector<OperatorEvent> RecentEvents() const override { return {}; }
  std::vector<std::string> RobotIds() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<std::string> ids;
    for (const auto& [id, v] : robots_) ids.push_back(id);
    return ids;
  }
  bool Knows(const std::string& robot_id) const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return robots_.count(robot_id) > 0;
  }
  // Discovery ended long ago: nothing waits for it.
  core::SteadyTime started() const override { return started_; }
  core::SteadyTime discovery_end() const override { return started_; }
  std::string UnknownRobotReason(const std::string& robot_id) const override {
    return "unknown robot '" + robot_id + "'";
  }

 private:
  static std::string Num(double v) {
    if (std::isnan(v)) return "nan";
    std::ostringstream out;
    out << v;
    return out.str();
  }
  void Record(const std::string& line) {
    std::lock_guard<std::mutex> lock(mutex_);
    sent_.push_back(line);
  }
  // Records `line`; accepts (applying `apply` to the robot's state) unless the robot is unknown or refuses.
  CommandOutcome Answer(const std::string& robot_id, const std::string& line,
                        const std::function<void(RobotView&)>& apply) {
    std::lock_guard<std::mutex> lock(mutex_);
    sent_.push_back(line);
    CommandOutcome o;
    const auto it = robots_.find(robot_id);
    if (it == robots_.end()) {
      o.result = outcome::kTimedOut;
      o.reason = "no answer from " + robot_id;
      return o;
    }
    o.answered = true;
    const auto refusal = refusals_.find(robot_id);
    if (refusal != refusals_.end() && !refusal->second.empty()) {
      o.result = outcome::kRefused;
      o.reason = o.robot_reason = refusal->second;
    } else {
      apply(it->second);
      o.ok = true;
      o.result = outcome::kAccepted;
      o.goal_id = ++goal_ids_;
    }
    o.holder_id = it->second.state->holder_id();
    o.mode = it->second.state->mode();
    it->second.whole_state_received = core::SteadyClock::now();
    return o;
  }

  const std::string base_id_;
  const core::SteadyTime started_ = core::SteadyClock::now() - std::chrono::seconds(60);
  mutable std::mutex mutex_;
  std::map<std::string, RobotView> robots_;
  std::map<std::string, std::string> refusals_;
  std::function<void(cairn_msgs::RobotState&)> yield_answer_;
  std::vector<std::string> sent_;
  std::vector<OperatorEvent> pending_events_;
  uint32_t goal_ids_ = 0;
};

}  // namespace cairn::base::testing
