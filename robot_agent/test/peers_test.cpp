// Peer awareness: checks of a peer's state, the tracker's timeout, the obstacle points that stand
// for a peer, and the path ahead a robot tells its peers.
#include "cairn/agent/team/peers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cairn::agent {
namespace {

PeerBody Peer(const std::string& id, double x, double y, double z = 0.0) {
  PeerBody peer;
  peer.robot_id = id;
  peer.pose_M.x_m = x;
  peer.pose_M.y_m = y;
  peer.pose_M.z_m = z;
  peer.footprint_radius_m = 0.3;
  peer.mode = "idle";
  return peer;
}

TEST(PeersTest, OptionsOutOfRangeAreNamed) {
  std::string why;
  EXPECT_TRUE(PeerOptions{}.IsValid(&why)) << why;
  PeerOptions o;
  o.rate_hz = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "peers.rate_hz = 0 must be in (0, 50]");
  o = PeerOptions{};
  o.margin_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("peers.margin_m = nan"), std::string::npos) << why;
  EXPECT_THROW(PeerTracker("r1", o), std::invalid_argument);
  EXPECT_THROW(PeerTracker("", PeerOptions{}), std::invalid_argument);
}

TEST(PeersTest, BadPeerStatesAreRefusedNamingTheFieldAndValue) {
  EXPECT_EQ(CheckPeerBody(Peer("r2", 1, 2)), "");
  PeerBody p = Peer("r2", std::numeric_limits<double>::infinity(), 2);
  EXPECT_NE(CheckPeerBody(p).find("peer state from \"r2\": position (inf, 2, 0) must be finite"),
            std::string::npos)
      << CheckPeerBody(p);
  p = Peer("r2", 1e300, 2);
  EXPECT_NE(CheckPeerBody(p).find("position (1e+300, 2, 0)"), std::string::npos) << CheckPeerBody(p);
  p = Peer("r2", 1, 2);
  p.footprint_radius_m = 0;
  EXPECT_NE(CheckPeerBody(p).find("footprint_radius_m = 0 must be in (0, 5]"), std::string::npos);
  p = Peer("r2", 1, 2);
  p.pose_M.v_mps = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(CheckPeerBody(p).find("v_B_mps = nan"), std::string::npos) << CheckPeerBody(p);
  p = Peer("r2", 1, 2);
  p.path_ahead_M = {{1, 2, 0}, {2, std::numeric_limits<double>::quiet_NaN(), 0}};
  EXPECT_NE(CheckPeerBody(p).find("path_ahead_M[1] = (2, nan, 0)"), std::string::npos) << CheckPeerBody(p);
  p = Peer("", 1, 2);
  EXPECT_NE(CheckPeerBody(p).find("robot_id is empty"), std::string::npos);
  // Its answer to a yield request.
  p = Peer("r2", 1, 2);
  p.yield_state = "aside";
  p.yield_to_id = "r1";
  EXPECT_EQ(CheckPeerBody(p), "");
  p.yield_state = "dancing";
  EXPECT_NE(CheckPeerBody(p).find("yield_state = \"dancing\" is not"), std::string::npos) << CheckPeerBody(p);
  p.yield_state = "refused";
  p.yield_to_id = std::string("r\x7f", 2);
  EXPECT_NE(CheckPeerBody(p).find("yield_to_id"), std::string::npos) << CheckPeerBody(p);
  p.yield_to_id = "r1";
  p.yield_reason = std::string(600, 'x');
  EXPECT_NE(CheckPeerBody(p).find("yield_reason is 600 bytes (at most 512)"), std::string::npos);
}

TEST(PeersTest, TheTrackerKeepsTheNewestOfEachPeerForItsTimeoutAndIgnoresItself) {
  PeerTracker tracker("r1", PeerOptions{});  // timeout 1 s
  EXPECT_EQ(tracker.OnPeerState(Peer("r2", 1, 0), 10.0), "");
  EXPECT_EQ(tracker.OnPeerState(Peer("r3", 5, 0), 10.5), "");
  EXPECT_EQ(tracker.OnPeerState(Peer("r2", 2, 0), 10.6), "");  // newer
  EXPECT_EQ(tracker.OnPeerState(Peer("r1", 0, 0), 10.6), "");  // itself: ignored
  PeerBody bad = Peer("r4", 0, 0);
  bad.footprint_radius_m = -1;
  EXPECT_NE(tracker.OnPeerState(bad, 10.6), "");
  std::vector<PeerBody> live = tracker.Live(11.0);
  ASSERT_EQ(live.size(), 2u);
  EXPECT_EQ(live[0].robot_id, "r2");
  EXPECT_DOUBLE_EQ(live[0].pose_M.x_m, 2.0);
  EXPECT_EQ(live[1].robot_id, "r3");
  live = tracker.Live(11.55);  // r3 heard 1.05 s ago: forgotten
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].robot_id, "r2");
  EXPECT_TRUE(tracker.Live(12.0).empty());
}

TEST(PeersTest, APeerIsACircleOfPointsInTheRobotsBodyFrame) {
  PeerOptions options;  // margin 0.25
  core::BaseState robot;
  robot.x_m = 1.0;
  robot.y_m = 1.0;
  robot.yaw_rad = M_PI / 2;  // facing +y
  std::vector<Eigen::Vector3f> points_B;
  AppendPeerObstacles({Peer("r2", 1.0, 4.0)}, robot, 5.0, 0.3, options, &points_B);
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
  AppendPeerObstacles({Peer("r2", 1.0, 9.0), Peer("r3", 1.0, 3.0, 2.5)}, robot, 5.0, 0.3, options, &points_B);
  EXPECT_TRUE(points_B.empty());
}

TEST(PeersTest, AMovingPeerAlsoBlocksWhereItWillBe) {
  PeerOptions options;  // prediction 1 s
  PeerBody peer = Peer("r2", 5.0, 0.0);
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

TEST(PeersTest, ThePathAheadStartsAtTheNearestPointAndIsResampled) {
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
}  // namespace cairn::agent
