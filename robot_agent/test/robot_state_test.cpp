// The robot's state on the wire (idl/include/cairn/msgs/robot_state.h): the 10 Hz pose split from the whole
// state and merged back, and when the whole state is sent.
#include "cairn/msgs/robot_state.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cairn::msgs {
namespace {

cairn_msgs::RobotState Moving(double x_m, double yaw_rad) {
  cairn_msgs::RobotState s;
  s.robot_id("r1");
  s.stamp().sec(100);
  s.pose_MB().position().x_m(x_m);
  s.pose_MB().position().y_m(-2.5);
  s.pose_MB().position().z_m(1.25);
  s.pose_MB().orientation().z(std::sin(yaw_rad / 2));
  s.pose_MB().orientation().w(std::cos(yaw_rad / 2));
  s.twist_B().linear_x_mps(0.75);
  s.twist_B().angular_z_radps(-0.5);
  s.cmd_twist_B().linear_x_mps(0.8);
  s.nav_distance_left_m(12.5);
  s.nav_eta_s(16.0);
  s.mode("waypoint");
  s.active_channel("waypoint");
  s.holder_id("opA");
  s.nav_status(cairn_msgs::NAV_STATUS_ACTIVE);
  s.nav_goal_id(7);
  s.local_planner_status("path");
  return s;
}

TEST(RobotPose, MergedIntoTheLastWholeStateGivesTheStateItCameFrom) {
  const cairn_msgs::RobotState before = Moving(1.0, 0.3);
  cairn_msgs::RobotState now = Moving(4.0, -2.9);  // moved on: only what RobotPose carries differs
  now.stamp().sec(101);
  now.nav_distance_left_m(9.5);
  now.in_contact(true);
  cairn_msgs::RobotState merged = before;
  MergePose(PoseOf(now), &merged);
  EXPECT_EQ(merged.stamp().sec(), 101u);
  EXPECT_DOUBLE_EQ(merged.pose_MB().position().x_m(), 4.0);
  EXPECT_DOUBLE_EQ(merged.pose_MB().position().z_m(), 1.25);
  EXPECT_NEAR(merged.pose_MB().orientation().z(), now.pose_MB().orientation().z(), 1e-12);
  EXPECT_NEAR(merged.pose_MB().orientation().w(), now.pose_MB().orientation().w(), 1e-12);
  EXPECT_FLOAT_EQ(static_cast<float>(merged.twist_B().angular_z_radps()), -0.5f);
  EXPECT_FLOAT_EQ(static_cast<float>(merged.nav_distance_left_m()), 9.5f);
  EXPECT_TRUE(merged.in_contact());
  EXPECT_EQ(merged.mode(), "waypoint");
  EXPECT_EQ(merged.holder_id(), "opA");
  EXPECT_TRUE(SlowPartOf(merged) == SlowPartOf(now));
}

TEST(RobotPose, SlowPartIgnoresWhatThePoseCarriesOnly) {
  const cairn_msgs::RobotState a = Moving(1.0, 0.3);
  EXPECT_TRUE(SlowPartOf(a) == SlowPartOf(Moving(7.0, 1.0)));
  cairn_msgs::RobotState b = a;
  b.local_planner_status("tight spot: 0.31 m");
  EXPECT_FALSE(SlowPartOf(a) == SlowPartOf(b));
  EXPECT_FALSE(UrgentChange(a, b)) << "a status text is not urgent";
  b = a;
  b.nav_status(cairn_msgs::NAV_STATUS_ARRIVED);
  EXPECT_TRUE(UrgentChange(a, b));
  b = a;
  b.holder_id("opB");
  EXPECT_TRUE(UrgentChange(a, b));
}

TEST(WholeStateSchedule, FirstAtOnceUrgentAtOnceTextsHalfASecondApartAndOnceASecond) {
  WholeStateSchedule schedule(0.5, 1.0);
  cairn_msgs::RobotState s = SlowPartOf(Moving(0.0, 0.0));
  EXPECT_TRUE(schedule.Due(s, 10.0)) << "the first";
  EXPECT_FALSE(schedule.Due(s, 10.1)) << "unchanged";
  EXPECT_FALSE(schedule.Due(s, 10.9));
  EXPECT_TRUE(schedule.Due(s, 11.0)) << "once a second";
  s.local_planner_status("tight spot: 0.31 m");
  EXPECT_FALSE(schedule.Due(s, 11.1)) << "a text waits 0.5 s after the last";
  s.local_planner_status("tight spot: 0.29 m");
  EXPECT_FALSE(schedule.Due(s, 11.4));
  EXPECT_TRUE(schedule.Due(s, 11.5)) << "its latest value, 0.5 s after the last";
  s.mode("idle");
  EXPECT_TRUE(schedule.Due(s, 11.6)) << "a mode change at once";
  EXPECT_FALSE(schedule.Due(s, 11.7));
  schedule.Request();
  EXPECT_TRUE(schedule.Due(s, 11.7)) << "requested (a command was answered)";
  EXPECT_FALSE(schedule.Due(s, 11.8));
}

}  // namespace
}  // namespace cairn::msgs
