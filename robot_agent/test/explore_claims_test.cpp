// Copyright Cairn authors.
#include "cairn/agent/team/explore_claims.h"

#include <gtest/gtest.h>

#include <limits>

namespace cairn::agent {
namespace {

nav::CoverageBitmap Bitmap(int nx, int ny) {
  nav::CoverageBitmap b;
  b.cell_m = 0.5;
  b.origin_cell = {-4, 2};
  b.nx = nx;
  b.ny = ny;
  b.bits.assign((static_cast<std::size_t>(nx) * ny + 7) / 8, 0);
  for (int k = 0; k < nx * ny; k += 3) b.bits[k / 8] |= static_cast<std::uint8_t>(1U << (k % 8));
  return b;
}

ExploreClaim Claim(const std::string& id, double x, double y) {
  ExploreClaim c;
  c.robot_id = id;
  c.task_id = 7;
  c.active = true;
  c.has_target = true;
  c.target_M = {x, y, 0.0};
  c.held_s = 2.0;
  c.lease_s = 6.0;
  return c;
}

TEST(ExploreClaimTest, CoverageBitsRoundTripAndBadFramesAreNamed) {
  const nav::CoverageBitmap bitmap = Bitmap(200, 120);
  const std::vector<std::uint8_t> frame = CompressCoverageBits(bitmap);
  EXPECT_LT(frame.size(), bitmap.bits.size());  // a regular pattern compresses
  nav::CoverageBitmap out = bitmap;
  out.bits.clear();
  std::string why;
  ASSERT_TRUE(DecompressCoverageBits(frame, &out, &why)) << why;
  EXPECT_EQ(out.bits, bitmap.bits);

  out.nx = 100;  // the header does not match the frame
  EXPECT_FALSE(DecompressCoverageBits(frame, &out, &why));
  EXPECT_NE(why.find("coverage_zstd"), std::string::npos) << why;
  out.nx = -3;
  EXPECT_FALSE(DecompressCoverageBits(frame, &out, &why));
  EXPECT_EQ(why, "coverage_nx = -3, coverage_ny = 120 must be >= 0 with at most 16777216 cells");
  std::vector<std::uint8_t> corrupt = frame;
  corrupt[corrupt.size() / 2] ^= 0xFF;
  out.nx = 200;
  EXPECT_FALSE(DecompressCoverageBits(corrupt, &out, &why));
  EXPECT_TRUE(out.bits.empty());
  EXPECT_FALSE(DecompressCoverageBits({1, 2, 3}, &out, &why));
  EXPECT_NE(why.find("no zstd frame"), std::string::npos) << why;
}

TEST(ExploreClaimTest, BadClaimsAreNamedAndChangeNothing) {
  ExploreTeam team("r1", ExploreTeamOptions{});
  ExploreClaim c = Claim("r2", 1.0, 2.0);
  c.target_M.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(team.OnPeerClaim(c, 0.0), "explore claim from \"r2\": target (nan, 2, 0) must be finite, metres");
  c = Claim("r2", 1.0, 2.0);
  c.lease_s = 0;
  EXPECT_EQ(team.OnPeerClaim(c, 0.0), "explore claim from \"r2\": lease_s = 0 must be in (0, 600]");
  c = Claim("r2", 1.0, 2.0);
  c.held_s = -1;
  EXPECT_EQ(team.OnPeerClaim(c, 0.0), "explore claim from \"r2\": held_s = -1 must be finite and >= 0");
  c = Claim("", 1.0, 2.0);
  EXPECT_EQ(team.OnPeerClaim(c, 0.0), "explore claim from \"\": robot_id is empty");
  c = Claim("r2", 1.0, 2.0);
  c.coverage = Bitmap(10, 10);
  c.coverage->bits.pop_back();
  EXPECT_EQ(team.OnPeerClaim(c, 0.0),
            "explore claim from \"r2\": coverage: bits has 12 bytes, 13 expected for 10 x 10 cells");
  c.coverage = Bitmap(10, 10);
  c.coverage->cell_m = 1.0;
  EXPECT_NE(team.OnPeerClaim(c, 0.0).find("differs from this robot's explore.coverage_cell_m"),
            std::string::npos);
  EXPECT_TRUE(team.LiveClaims(0.0).empty());
  EXPECT_TRUE(team.LivePeers(0.0).empty());
  EXPECT_EQ(team.Coverage(), nullptr);

  ExploreTeamOptions o;
  std::string why;
  o.lease_s = 0.5;  // shorter than a claim period: claims would flicker
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "explore.claim_lease_s = 0.5 must be in (1, 600]");
  o = ExploreTeamOptions{};
  o.coverage_period_s = 0.5;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_EQ(why, "explore.coverage_period_s = 0.5 must be in [1, 600]");
  EXPECT_THROW(ExploreTeam("", ExploreTeamOptions{}), std::invalid_argument);
}

TEST(ExploreClaimTest, ClaimsLiveForTheirLeaseAgeAndARobotIgnoresItsOwn) {
  ExploreTeam team("r1", ExploreTeamOptions{});
  EXPECT_EQ(team.OnPeerClaim(Claim("r2", 1.0, 2.0), 10.0), "");
  EXPECT_EQ(team.OnPeerClaim(Claim("r1", 5.0, 5.0), 10.0), "");  // its own: ignored
  std::vector<nav::PeerClaim> live = team.LiveClaims(12.0);
  ASSERT_EQ(live.size(), 1u);
  EXPECT_EQ(live[0].robot_id, "r2");
  EXPECT_DOUBLE_EQ(live[0].held_s, 4.0);       // 2 s when sent, 2 s since
  EXPECT_TRUE(team.LiveClaims(16.5).empty());  // not renewed within its 6 s lease: r2 is lost
  EXPECT_TRUE(team.LivePeers(16.5).empty());
  // A release drops the claim at once; the peer stays live.
  EXPECT_EQ(team.OnPeerClaim(Claim("r2", 1.0, 2.0), 20.0), "");
  ExploreClaim release = Claim("r2", 0, 0);
  release.active = false;
  release.has_target = false;
  EXPECT_EQ(team.OnPeerClaim(release, 20.5), "");
  EXPECT_TRUE(team.LiveClaims(20.5).empty());
  EXPECT_EQ(team.LivePeers(20.5), std::vector<std::string>{"r2"});
  EXPECT_EQ(team.ExploringPeers(20.5), 0);
  EXPECT_EQ(team.ExploringPeers(20.0), 0);
  // Coverage accumulates over peers.
  ExploreClaim with_coverage = Claim("r3", 0, 0);
  with_coverage.coverage = Bitmap(10, 10);
  EXPECT_EQ(team.OnPeerClaim(with_coverage, 21.0), "");
  ASSERT_NE(team.Coverage(), nullptr);
  EXPECT_EQ(team.Coverage()->size(), 34u);  // every third of 100 cells
  EXPECT_DOUBLE_EQ(team.PeerSeenM2(), 34 * 0.25);
  EXPECT_EQ(team.ExploringPeers(21.0), 1);  // r3
}

TEST(ExploreClaimTest, OwnClaimsGoOutAtTheirPeriodAtOnceOnANewTargetAndOnceAtTheEnd) {
  ExploreTeam team("r1", ExploreTeamOptions{});
  EXPECT_FALSE(team.ClaimDue(0.0, false, false, {0, 0}));  // never explored: silent
  EXPECT_TRUE(team.ClaimDue(0.0, true, true, {3, 0}));
  ExploreClaim c = team.MakeClaim(4, true, nav::PeerClaim{"r1", {3, 0}, 0.5}, 0.2);
  EXPECT_EQ(c.robot_id, "r1");
  EXPECT_TRUE(c.has_target);
  EXPECT_DOUBLE_EQ(c.target_M.z(), 0.2);
  EXPECT_DOUBLE_EQ(c.lease_s, 6.0);
  EXPECT_TRUE(team.CoverageDue(0.0));
  c.coverage = Bitmap(4, 4);
  team.Sent(c, 0.0);
  EXPECT_FALSE(team.ClaimDue(0.5, true, true, {3.2, 0}));
  EXPECT_TRUE(team.ClaimDue(0.5, true, true, {6, 0}));    // a new target: at once
  EXPECT_TRUE(team.ClaimDue(1.0, true, true, {3.2, 0}));  // the period
  EXPECT_FALSE(team.CoverageDue(4.9));
  EXPECT_TRUE(team.CoverageDue(5.0));
  EXPECT_TRUE(team.ClaimDue(0.5, false, false, {0, 0}));  // stopped: the release
  team.Sent(team.MakeClaim(4, false, std::nullopt, 0.0), 0.5);
  EXPECT_FALSE(team.ClaimDue(10.0, false, false, {0, 0}));  // ...once
}

}  // namespace
}  // namespace cairn::agent
