#include "cairn/agent/modes/twist_mux.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace cairn::agent {
namespace {

using namespace std::chrono_literals;

TwistMux MakeMux() { return TwistMux({{"teleop", 0.5}, {"waypoint", 0.5}}); }

TEST(TwistMux, ForwardsOnlyTheSelectedChannel) {
  TwistMux mux = MakeMux();
  const auto t0 = core::SteadyClock::now();
  EXPECT_EQ(mux.Compute(t0).twist_B.linear_x_mps, 0.0);
  ASSERT_TRUE(mux.Select("teleop"));
  mux.Submit("teleop", {0.5, 0.1}, t0);
  mux.Submit("waypoint", {0.9, -0.3}, t0);
  const MuxOutput out = mux.Compute(t0 + 100ms);
  EXPECT_TRUE(out.forwarding);
  EXPECT_EQ(out.active_channel, "teleop");
  EXPECT_DOUBLE_EQ(out.twist_B.linear_x_mps, 0.5);
  EXPECT_DOUBLE_EQ(out.twist_B.angular_z_radps, 0.1);
  EXPECT_NE(out.reason.find("teleop fresh"), std::string::npos);
}

TEST(TwistMux, ZeroTwistWhenActiveSourceIsStale) {
  TwistMux mux = MakeMux();
  const auto t0 = core::SteadyClock::now();
  mux.Select("teleop");
  mux.Submit("teleop", {0.5, 0.0}, t0);
  EXPECT_TRUE(mux.Compute(t0 + 499ms).forwarding);
  const MuxOutput stale = mux.Compute(t0 + 600ms);
  EXPECT_FALSE(stale.forwarding);
  EXPECT_EQ(stale.twist_B.linear_x_mps, 0.0);
  EXPECT_NE(stale.reason.find("stale: no input for 0.60 s > 0.50 s"), std::string::npos) << stale.reason;
}

TEST(TwistMux, SwitchingDoesNotReplayOldInput) {
  TwistMux mux = MakeMux();
  const auto t0 = core::SteadyClock::now();
  mux.Submit("teleop", {0.5, 0.0}, t0);  // sent before manual mode was selected
  mux.Select("teleop");
  EXPECT_FALSE(mux.Compute(t0 + 10ms).forwarding);
  mux.Select("none");
  EXPECT_EQ(mux.Compute(t0).active_channel, "none");
}

TEST(TwistMux, RejectsBadInputAndConfig) {
  TwistMux mux = MakeMux();
  const auto t0 = core::SteadyClock::now();
  EXPECT_FALSE(mux.Submit("joystick", {0.1, 0.0}, t0));
  EXPECT_FALSE(mux.Select("joystick"));
  mux.Select("teleop");
  EXPECT_FALSE(mux.Submit("teleop", {std::nan(""), 0.0}, t0));
  EXPECT_FALSE(mux.Submit("teleop", {0.1, std::numeric_limits<double>::infinity()}, t0));
  EXPECT_FALSE(mux.Compute(t0).forwarding);
  EXPECT_THROW(TwistMux({{"none", 0.5}}), std::invalid_argument);
  EXPECT_THROW(TwistMux({{"a", 0.5}, {"a", 0.5}}), std::invalid_argument);
  EXPECT_THROW(TwistMux({{"a", 0.0}}), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
