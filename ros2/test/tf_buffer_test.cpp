// The transform tree: chains through a common ancestor, interpolation between samples, history limits and
// refusals, as tf2 behaves.
#include "cairn/ros2/tf_buffer.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cairn::ros2 {
namespace {

Eigen::Isometry3d Pose(double x, double y, double z, double yaw_rad) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, z);
  return T;
}

double Yaw(const Eigen::Isometry3d& T) { return std::atan2(T.linear()(1, 0), T.linear()(0, 0)); }

TEST(TfBuffer, ChainsMapOdomBaseAndTheStaticSensorMount) {
  TfBuffer tf;
  ASSERT_EQ(tf.Set("map", "odom", Pose(1, 0, 0, M_PI / 2), 100.0, false), "");
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(2, 0, 0, 0), 100.0, false), "");
  ASSERT_EQ(tf.Set("/base_link", "velodyne", Pose(0.1, 0, 0.5, 0), 0.0, true), "");  // leading '/' dropped
  std::string why;
  const auto T_map_velodyne = tf.Lookup("map", "velodyne", 100.0, &why);
  ASSERT_TRUE(T_map_velodyne) << why;
  // map -> odom turns 90 degrees: odom's x is map's y.
  EXPECT_TRUE(T_map_velodyne->translation().isApprox(Eigen::Vector3d(1, 2.1, 0.5), 1e-9))
      << T_map_velodyne->translation().transpose();
  EXPECT_NEAR(Yaw(*T_map_velodyne), M_PI / 2, 1e-9);
  // The other way round, and between siblings through their common ancestor.
  const auto T_velodyne_map = tf.Lookup("velodyne", "map", 100.0, &why);
  ASSERT_TRUE(T_velodyne_map);
  EXPECT_TRUE((*T_velodyne_map * *T_map_velodyne).isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  const auto T_base_velodyne = tf.Lookup("base_link", "velodyne", 12345.0, &why);  // static: any time
  ASSERT_TRUE(T_base_velodyne) << why;
  EXPECT_TRUE(T_base_velodyne->translation().isApprox(Eigen::Vector3d(0.1, 0, 0.5)));
}

TEST(TfBuffer, InterpolatesBetweenSamplesAndRefusesOutsideTheHistory) {
  TfBuffer tf(TfBufferOptions{10.0, 0.05});
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(0, 0, 0, 0), 10.0, false), "");
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(2, 0, 0, 1.0), 11.0, false), "");
  std::string why;
  const auto mid = tf.Lookup("odom", "base_link", 10.25, &why);
  ASSERT_TRUE(mid) << why;
  EXPECT_NEAR(mid->translation().x(), 0.5, 1e-9);
  EXPECT_NEAR(Yaw(*mid), 0.25, 1e-9);  // slerp
  // Just past the newest sample: within the tolerance it is used; beyond, refused with the times.
  EXPECT_TRUE(tf.Lookup("odom", "base_link", 11.04, &why));
  EXPECT_FALSE(tf.Lookup("odom", "base_link", 11.5, &why));
  EXPECT_NE(why.find("newer than its last sample"), std::string::npos) << why;
  EXPECT_FALSE(tf.Lookup("odom", "base_link", 9.0, &why));
  EXPECT_NE(why.find("older than its history"), std::string::npos) << why;
  // Samples arriving out of order are put in order; the same stamp replaces.
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(1, 0, 0, 0.5), 10.5, false), "");
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(4, 0, 0, 0), 11.0, false), "");
  const auto later = tf.Lookup("odom", "base_link", 10.75, &why);
  ASSERT_TRUE(later) << why;
  EXPECT_NEAR(later->translation().x(), 2.5, 1e-9);
  // The history is bounded: 10 s behind the newest sample.
  for (int k = 0; k < 30; ++k) tf.Set("odom", "base_link", Pose(k, 0, 0, 0), 12.0 + k, false);
  EXPECT_FALSE(tf.Lookup("odom", "base_link", 20.0, &why));
  EXPECT_TRUE(tf.Lookup("odom", "base_link", 35.0, &why)) << why;
  EXPECT_EQ(tf.NewestStamp("odom", "base_link"), 41.0);
}

TEST(TfBuffer, RefusesWhatATfTreeCannotHold) {
  TfBuffer tf;
  ASSERT_EQ(tf.Set("odom", "base_link", Pose(0, 0, 0, 0), 1.0, false), "");
  EXPECT_NE(tf.Set("map", "base_link", Pose(0, 0, 0, 0), 1.0, false).find("already has parent 'odom'"),
            std::string::npos);
  EXPECT_NE(tf.Set("base_link", "odom", Pose(0, 0, 0, 0), 1.0, false).find("would close a loop"),
            std::string::npos);
  EXPECT_NE(tf.Set("odom", "odom", Pose(0, 0, 0, 0), 1.0, false).find("to itself"), std::string::npos);
  EXPECT_NE(tf.Set("", "x", Pose(0, 0, 0, 0), 1.0, false).find("empty frame id"), std::string::npos);
  Eigen::Isometry3d sheared = Pose(0, 0, 0, 0);
  sheared.linear()(0, 1) = 0.5;
  EXPECT_NE(tf.Set("base_link", "cam", sheared, 1.0, true).find("not a rotation"), std::string::npos);
  Eigen::Isometry3d nan = Pose(0, 0, 0, 0);
  nan.translation().x() = std::nan("");
  EXPECT_NE(tf.Set("base_link", "cam", nan, 1.0, true).find("not finite"), std::string::npos);
  EXPECT_NE(tf.Set("odom", "base_link", Pose(0, 0, 0, 0), 1.0, true).find("already on /tf"),
            std::string::npos);
  std::string why;
  EXPECT_FALSE(tf.Lookup("base_link", "velodyne", 1.0, &why));
  EXPECT_EQ(why, "no transform from 'velodyne' to 'base_link' (frames known: base_link, odom)");
  EXPECT_THROW(TfBuffer(TfBufferOptions{0.0, 0.0}), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::ros2
