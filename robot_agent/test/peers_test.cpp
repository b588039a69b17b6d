// Peer awareness: the options, checks of a peer's state and the tracker's timeout (the geometry of peers as
// obstacles: nav/test/peer_obstacles_test.cpp).
#include "cairn/agent/team/peers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cairn::agent {
namespace {

Peer MakePeer(const std::string& id, double x, double y, double z = 0.0) {
  Peer peer;
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
  o.avoidance.margin_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("peers.margin_m = nan"), std::string::npos) << why;
  EXPECT_THROW(PeerTracker("r1", o), std::invalid_argument);
  EXPECT_THROW(PeerTracker("", PeerOptions{}), std::invalid_argument);
}

TEST(PeersTest, BadPeerStatesAreRefusedNamingTheFieldAndValue) {
  EXPECT_EQ(CheckPeer(MakePeer("r2", 1, 2)), "");
  Peer p = MakePeer("r2", std::numeric_limits<double>::infinity(), 2);
  EXPECT_NE(CheckPeer(p).find("peer state from \"r2\": position (inf, 2, 0) must be finite"),
            std::string::npos)
      << CheckPeer(p);
  p = MakePeer("r2", 1e300, 2);
  EXPECT_NE(CheckPeer(p).find("position (1e+300, 2, 0)"), std::string::npos) << CheckPeer(p);
  p = MakePeer("r2", 1, 2);
  p.footprint_radius_m = 0;
  EXPECT_NE(CheckPeer(p).find("footprint_radius_m = 0 must be in (0, 5]"), std::string::npos);
  p = MakePeer("r2", 1, 2);
  p.pose_M.v_mps = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(CheckPeer(p).find("v_B_mps = nan"), std::string::npos) << CheckPeer(p);
  p = MakePeer("r2", 1, 2);
  p.path_ahead_M = {{1, 2, 0}, {2, std::numeric_limits<double>::quiet_NaN(), 0}};
  EXPECT_NE(CheckPeer(p).find("path_ahead_M[1] = (2, nan, 0)"), std::string::npos) << CheckPeer(p);
  p = MakePeer("", 1, 2);
  EXPECT_NE(CheckPeer(p).find("robot_id is empty"), std::string::npos);
  // Its answer to a yield request.
  p = MakePeer("r2", 1, 2);
  p.yield_state = "aside";
  p.yield_to_id = "r1";
  EXPECT_EQ(CheckPeer(p), "");
  p.yield_state = "dancing";
  EXPECT_NE(CheckPeer(p).find("yield_state = \"dancing\" is not"), std::string::npos) << CheckPeer(p);
  p.yield_state = "refused";
  p.yield_to_id = std::string("r\x7f", 2);
  EXPECT_NE(CheckPeer(p).find("yield_to_id"), std::string::npos) << CheckPeer(p);
  p.yield_to_id = "r1";
  p.yield_reason = std::string(600, 'x');
  EXPECT_NE(CheckPeer(p).find("yield_reason is 600 bytes (at most 512)"), std::string::npos);
}

TEST(PeersTest, TheTrackerKeepsTheNewestOfEachPeerForItsTimeoutAndIgnoresItself) {
  PeerTracker tracker("r1", PeerOptions{});  // timeout 1 s
  EXPECT_EQ(tracker.OnPeerState(MakePeer("r2", 1, 0), 10.0), "");
  EXPECT_EQ(tracker.OnPeerState(MakePeer("r3", 5, 0), 10.5), "");
  EXPECT_EQ(tracker.OnPeerState(MakePeer("r2", 2, 0), 10.6), "");  // newer
  EXPECT_EQ(tracker.OnPeerState(MakePeer("r1", 0, 0), 10.6), "");  // itself: ignored
  Peer bad = MakePeer("r4", 0, 0);
  bad.footprint_radius_m = -1;
  EXPECT_NE(tracker.OnPeerState(bad, 10.6), "");
  std::vector<Peer> live = tracker.Live(11.0);
  ASSERT_EQ(live.size(), 2u);
  EXPECT_EQ(live[0].robot_id, "r2");
  EXPECT_DOUBLE_EQ(live[0].pose_M.x_m, 2.0);
  EXPECT_EQ(live[1].robot_id, "r3");
  live = tracker.Live(11.55);  // r3 heard 1.05 s ago: forgotten
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].robot_id, "r2");
  EXPECT_TRUE(tracker.Live(12.0).empty());
}

}  // namespace
}  // namespace cairn::agent
