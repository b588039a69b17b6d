// Peers as obstacles: the obstacle points that stand for a peer's body (where it is and where it will be),
// and the path ahead a robot tells its peers.
#include <gtest/gtest.h>

#include <cmath>

#include "cairn/nav/peers.h"

namespace cairn::nav {
namespace {

PeerBody MakeBody(const std::string& id, double x, double y, double z = 0.0) {
  PeerBody peer;
  peer.robot_id = id;
  peer.pose_M.x_m = x;
  peer.pose_M.y_m = y;
  peer.pose_M.z_m = z;
  peer.footprint_radius_m = 0.3;
  return peer;
}

TEST(PeerObstaclesTest, OptionsOutOfRangeAreNamed) {
  std::string why;
  EXPECT_TRUE(PeerAvoidanceOptions{}.IsValid(&why)) << why;
  PeerAvoidanceOptions o;
  o.prediction_s = 6;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "peers.prediction_s = 6 must be in [0, 5]");
}

TEST(PeerObstaclesTest, APeerIsACircleOfPointsInTheRobotsBodyFrame) {
  PeerAvoidanceOptions options;  // margin 0.25
  core::BaseState robot;
  robot.x_m = 1.0;
  robot.y_m = 1.0;
  robot.yaw_rad = M_PI / 2;  // facing +y
  std::vector<Eigen::Vector3f> points_B;
  AppendPeerObstacles({MakeBody("r2", 1.0, 4.0)}, robot, 5.0, 0.3, options, &points_B);
  ASSERT_GE(points_B.size(), 8u);
  // 3 m ahead of the robot (body +x), radius 0.3 + 0.25.
  for (const Eigen::Vector3f& p : points_B) {
    EXPECT_NEAR((p.head<2>() - Eigen::Vector2f(3.0f, 0.0f)).norm(), 0.55, 1e-4) << p.transpose();
    EXPECT_FLOAT_EQ(p.z(), 0.3f);
  }
  // Points about 0.1 m apart.
  EXPECT_NEAR(2 * M_PI * 0.55 / points_B.size(), 0.1, 0.02);

  // Beyond the range, on another floor: none.
  points_B.clear();
  AppendPeerObstacles({MakeBody("r2", 1.0, 9.0), MakeBody("r3", 1.0, 3.0, 2.5)}, robot, 5.0, 0.3, options,
                      &points_B);
  EXPECT_TRUE(points_B.empty());
}

TEST(PeerObstaclesTest, AMovingPeerAlsoBlocksWhereItWillBe) {
  PeerAvoidanceOptions options;  // prediction 1 s
  PeerBody peer = MakeBody("r2", 5.0, 0.0);
  peer.pose_M.yaw_rad = M_PI;  // driving toward -x at 1 m/s
  peer.pose_M.v_mps = 1.0;
  std::vector<Eigen::Vector3f> points_B;
  AppendPeerObstacles({peer}, core::BaseState{}, 10.0, 0.3, options, &points_B);
  // Three circles: now (x 5), in 0.5 s (x 4.5) and in 1 s (x 4).
  double nearest_x = 1e9;
  for (const Eigen::Vector3f& p : points_B) nearest_x = std::min(nearest_x, static_cast<double>(p.x()));
  EXPECT_NEAR(nearest_x, 4.0 - 0.55, 0.005);  // the circle's points are 0.1 m apart: its sag is 2 mm
  const std::size_t per_circle = points_B.size() / 3;
  EXPECT_EQ(points_B.size(), 3 * per_circle);

  // Turning at 0.5 rad/s: the predicted centre lies on its arc (radius 2 m), not on a straight line.
  peer.pose_M.w_radps = 0.5;
  points_B.clear();
  options.prediction_s = 2.0;
  AppendPeerObstacles({peer}, core::BaseState{}, 10.0, 0.3, options, &points_B);
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  for (std::size_t k = 2 * per_circle; k < points_B.size(); ++k) centre += points_B[k].head<2>();
  centre /= static_cast<float>(points_B.size() - 2 * per_circle);
  // Heading pi turning left at 0.5 rad/s for 2 s: the arc's centre is (5, -2); after 1 rad it is at
  // (5 - 2 sin 1, -2 + 2 cos 1).
  EXPECT_NEAR(centre.x(), 5.0 - 2 * std::sin(1.0), 1e-3);
  EXPECT_NEAR(centre.y(), -2.0 + 2 * std::cos(1.0), 1e-3);
}

TEST(PeerObstaclesTest, ThePathAheadStartsAtTheNearestPointAndIsResampled) {
  const std::vector<Eigen::Vector3d> path = {{0, 0, 0}, {4, 0, 0}, {4, 3, 1}};
  // From (1.2, 0.4): the nearest point is (1.2, 0); then every metre, around the corner, and the end.
  const std::vector<Eigen::Vector3d> ahead = PathAhead(path, {1.2, 0.4}, 1.0, 16);
  ASSERT_EQ(ahead.size(), 7u);
  EXPECT_TRUE(ahead[0].isApprox(Eigen::Vector3d(1.2, 0, 0)));
  EXPECT_TRUE(ahead[1].isApprox(Eigen::Vector3d(2.2, 0, 0)));
  EXPECT_TRUE(ahead[2].isApprox(Eigen::Vector3d(3.2, 0, 0)));
  EXPECT_TRUE(ahead[3].isApprox(Eigen::Vector3d(4.0, 0.2, 0.2 / 3)));
  EXPECT_TRUE(ahead[5].isApprox(Eigen::Vector3d(4.0, 2.2, 2.2 / 3)));
  EXPECT_TRUE(ahead[6].isApprox(Eigen::Vector3d(4, 3, 1)));
  // At most max_points.
  EXPECT_EQ(PathAhead(path, {0, 0}, 0.5, 4).size(), 4u);
  EXPECT_TRUE(PathAhead({}, {0, 0}, 1.0, 16).empty());
  EXPECT_EQ(PathAhead({{1, 1, 0}}, {0, 0}, 1.0, 16).size(), 1u);
}

}  // namespace
}  // namespace cairn::nav
