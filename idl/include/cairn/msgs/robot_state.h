// A robot's state goes out as two messages (idl/cairn_msgs.idl): RobotState, whole, when it changes and once
// a second (reliable, latched), and RobotPose, what changes every control cycle, at 10 Hz (best effort). The
// robot splits them here and every reader merges them here.
#pragma once

#include <cmath>
#include <optional>
#include <utility>

#include "cairn_msgs.h"

namespace cairn::msgs {

/// The 10 Hz part of `state`: planar pose (x, y, z, yaw of base B in map M, from pose_MB's quaternion),
/// measured and commanded forward speed and yaw rate, distance and time left, contact.
inline cairn_msgs::RobotPose PoseOf(const cairn_msgs::RobotState& state) {
  cairn_msgs::RobotPose pose;
  pose.robot_id(state.robot_id());
  pose.stamp(state.stamp());
  const cairn_msgs::Pose& p = state.pose_MB();
  pose.x_MB_m(p.position().x_m());
  pose.y_MB_m(p.position().y_m());
  pose.z_MB_m(p.position().z_m());
  const cairn_msgs::Quaternion& q = p.orientation();
  pose.yaw_MB_rad(
      std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z())));
  pose.v_B_mps(static_cast<float>(state.twist_B().linear_x_mps()));
  pose.w_B_radps(static_cast<float>(state.twist_B().angular_z_radps()));
  pose.cmd_v_B_mps(static_cast<float>(state.cmd_twist_B().linear_x_mps()));
  pose.cmd_w_B_radps(static_cast<float>(state.cmd_twist_B().angular_z_radps()));
  pose.nav_distance_left_m(static_cast<float>(state.nav_distance_left_m()));
  pose.nav_eta_s(static_cast<float>(state.nav_eta_s()));
  pose.in_contact(state.in_contact());
  return pose;
}

/// Applies `pose` to the last whole state of the same robot: what RobotPose carries replaces the state's
/// (pose_MB becomes planar: roll and pitch zero, as the robot sends it), the rest stays. The link usage is
/// cleared: it belongs to the whole state it came with (once a second).
inline void MergePose(const cairn_msgs::RobotPose& pose, cairn_msgs::RobotState* state) {
  state->stamp(pose.stamp());
  cairn_msgs::Pose& p = state->pose_MB();
  p.position().x_m(pose.x_MB_m());
  p.position().y_m(pose.y_MB_m());
  p.position().z_m(pose.z_MB_m());
  p.orientation().x(0.0);
  p.orientation().y(0.0);
  p.orientation().z(std::sin(pose.yaw_MB_rad() / 2));
  p.orientation().w(std::cos(pose.yaw_MB_rad() / 2));
  state->twist_B(cairn_msgs::Twist());
  state->twist_B().linear_x_mps(pose.v_B_mps());
  state->twist_B().angular_z_radps(pose.w_B_radps());
  state->cmd_twist_B(cairn_msgs::Twist());
  state->cmd_twist_B().linear_x_mps(pose.cmd_v_B_mps());
  state->cmd_twist_B().angular_z_radps(pose.cmd_w_B_radps());
  state->nav_distance_left_m(pose.nav_distance_left_m());
  state->nav_eta_s(pose.nav_eta_s());
  state->in_contact(pose.in_contact());
  state->link_usage().clear();
}

/// Applies a whole state that arrived to a reader's view of the robot (`*view`, empty before the first one):
/// the whole state replaces the view, except that a resent one older than the pose last applied keeps that
/// pose.
inline void ApplyWholeState(const cairn_msgs::RobotState& whole,
                            std::optional<cairn_msgs::RobotState>* view) {
  cairn_msgs::RobotState merged = whole;
  if (*view && (*view)->stamp().sec() + 1e-9 * (*view)->stamp().nanosec() >
                   whole.stamp().sec() + 1e-9 * whole.stamp().nanosec()) {
    MergePose(PoseOf(**view), &merged);
  }
  *view = std::move(merged);
}

/// `state` without what RobotPose carries, its stamp and its link usage: two states with equal slow parts
/// differ only in what the 10 Hz pose stream already sends.
inline cairn_msgs::RobotState SlowPartOf(cairn_msgs::RobotState state) {
  state.stamp(cairn_msgs::Time());
  state.pose_MB(cairn_msgs::Pose());
  state.twist_B(cairn_msgs::Twist());
  state.cmd_twist_B(cairn_msgs::Twist());
  state.nav_distance_left_m(0.0);
  state.nav_eta_s(0.0);
  state.in_contact(false);
  state.link_usage().clear();
  state.convoy_gap_m(
      0.0);  // changes every cycle while following: it rides on the whole states that go anyway
  state.mission_paused_s(0.0);        // grows while paused: it rides on the whole states that go anyway
  state.control_request_left_s(0.0);  // shrinks while a request waits: likewise
  // NaN (the robot's level) never equals itself: compared as 0, or every state would differ from the last.
  if (std::isnan(state.resumable_goal_M().z_m())) state.resumable_goal_M().z_m(0.0);
  return state;
}

/// True when `a` and `b` differ in what an operator or a script waits on: mode, mux channel, lock holder, its
/// liveness and process, goal id and status, operator stops, exploration task and state, convoy state and
/// order, yield state and peer, a request for its lock and the holder's answer. A robot sends such a change
/// at once; the rest of the slow part (reasons, status texts, counters) may wait up to half a second.
inline bool UrgentChange(const cairn_msgs::RobotState& a, const cairn_msgs::RobotState& b) {
  return a.mode() != b.mode() || a.active_channel() != b.active_channel() || a.holder_id() != b.holder_id() ||
         a.holder_alive() != b.holder_alive() || a.holder_participant() != b.holder_participant() ||
         a.nav_goal_id() != b.nav_goal_id() || a.nav_status() != b.nav_status() || a.stops() != b.stops() ||
         a.explore_task_id() != b.explore_task_id() || a.explore_state() != b.explore_state() ||
         a.mission_state() != b.mission_state() || a.convoy_state() != b.convoy_state() ||
         a.convoy_ahead_ids() != b.convoy_ahead_ids() || a.yield_state() != b.yield_state() ||
         a.yield_peer_id() != b.yield_peer_id() || a.control_requester_id() != b.control_requester_id() ||
         a.handovers() != b.handovers();
}

/// When a robot sends its whole state besides the 10 Hz pose: its first, after an urgent change
/// (UrgentChange) or a request (a command was answered) at once, after any other change of its slow part
/// `min_change_period_s` after the last one, and at least every `max_period_s`. Not thread-safe.
class WholeStateSchedule {
 public:
  /// Periods in seconds; min_change_period_s <= max_period_s.
  explicit WholeStateSchedule(double min_change_period_s = 0.5, double max_period_s = 1.0)
      : min_change_period_s_(min_change_period_s), max_period_s_(max_period_s) {}
  /// The next call to Due() returns true.
  void Request() { requested_ = true; }
  /// True if the whole state whose SlowPartOf is `slow` is due at `now_s` (seconds, a steady clock); then it
  /// counts as sent.
  bool Due(cairn_msgs::RobotState slow, double now_s) {
    bool due = requested_ || !last_ || now_s - last_sent_s_ >= max_period_s_;
    if (!due && !(slow == *last_)) {
      due = UrgentChange(slow, *last_) || now_s - last_sent_s_ >= min_change_period_s_;
    }
    if (!due) return false;
    requested_ = false;
    last_sent_s_ = now_s;
    last_ = std::move(slow);
    return true;
  }

 private:
  double min_change_period_s_;
  double max_period_s_;
  bool requested_ = false;
  double last_sent_s_ = 0.0;
  std::optional<cairn_msgs::RobotState> last_;  // slow part of the last whole state sent
};

}  // namespace cairn::msgs
