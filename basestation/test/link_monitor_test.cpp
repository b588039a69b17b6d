#include "cairn/base/link_monitor.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <limits>

namespace cairn::base {
namespace {

using std::chrono::milliseconds;

TEST(LinkMonitor, ProbeRoundTripsPerRobotAndTheWorstOfTheLastTen) {
  LinkMonitor links;
  const core::SteadyTime t0{};
  EXPECT_EQ(links.View("r1", t0).rtt_ms, -1.0);  // never heard
  links.OnProbeSent(1, t0);
  links.OnProbeReply("r1", 1, t0 + milliseconds(12));
  links.OnProbeReply("r2", 1, t0 + milliseconds(250));
  EXPECT_NEAR(links.View("r1", t0 + milliseconds(300)).rtt_ms, 12.0, 1e-9);
  EXPECT_NEAR(links.View("r2", t0 + milliseconds(300)).rtt_ms, 250.0, 1e-9);
  links.OnProbeSent(2, t0 + milliseconds(1000));
  links.OnProbeReply("r1", 2, t0 + milliseconds(1005));
  const LinkView r1 = links.View("r1", t0 + milliseconds(1100));
  EXPECT_NEAR(r1.rtt_ms, 5.0, 1e-9);
  EXPECT_NEAR(r1.rtt_max_ms, 12.0, 1e-9);
  links.OnProbeReply("r1", 99, t0 + milliseconds(1200));  // a probe this base never sent
  EXPECT_NEAR(links.View("r1", t0 + milliseconds(1200)).rtt_ms, 5.0, 1e-9);
}

TEST(LinkMonitor, AStalledLinkShowsTheAgeOfTheOldestUnansweredProbe) {
  LinkMonitor links;
  const core::SteadyTime t0{};
  links.OnProbeSent(1, t0);
  links.OnProbeReply("r1", 1, t0 + milliseconds(10));
  for (std::uint32_t id = 2; id <= 6; ++id) links.OnProbeSent(id, t0 + milliseconds(1000 * (id - 1)));
  // Probe 2 went out at 1 s and is still unanswered at 5.5 s.
  EXPECT_NEAR(links.View("r1", t0 + milliseconds(5500)).probe_wait_s, 4.5, 1e-9);
  links.OnProbeReply("r1", 5, t0 + milliseconds(5600));  // the link is back: answers arrive (in order)
  EXPECT_EQ(links.View("r1", t0 + milliseconds(5700)).probe_wait_s, 0.0);  // probe 6 is 0.7 s old
}

TEST(LinkMonitor, LostStateSamplesFromSequenceGapsOverTenSeconds) {
  LinkMonitor links;
  const core::SteadyTime t0{};
  // 10 Hz for 5 s: sequence numbers 1..50 with every 5th missing (10 of 50 lost).
  for (std::uint64_t seq = 1; seq <= 50; ++seq) {
    if (seq % 5 == 0) continue;
    links.OnState("r1", "w1", seq, t0 + milliseconds(100 * seq));
  }
  links.OnState("r1", "w1", 51, t0 + milliseconds(5100));
  LinkView v = links.View("r1", t0 + milliseconds(5100));
  EXPECT_EQ(v.state_received, 41u);
  EXPECT_EQ(v.state_lost, 10u);
  EXPECT_NEAR(v.loss_pct, 100.0 * 10 / 51, 1e-9);
  // A duplicate or reordered sample changes nothing.
  links.OnState("r1", "w1", 30, t0 + milliseconds(5150));
  EXPECT_EQ(links.View("r1", t0 + milliseconds(5150)).state_received, 41u);
  // A restarted robot (new writer) starts from its own first sample: no gap against the old writer.
  links.OnState("r1", "w2", 1, t0 + milliseconds(5200));
  EXPECT_EQ(links.View("r1", t0 + milliseconds(5200)).state_lost, 10u);
  // Ten clean seconds later the recent loss is 0; the totals stay.
  for (std::uint64_t seq = 2; seq <= 110; ++seq)
    links.OnState("r1", "w2", seq, t0 + milliseconds(5200 + 100 * seq));
  v = links.View("r1", t0 + milliseconds(16200));
  EXPECT_EQ(v.loss_pct, 0.0);
  EXPECT_EQ(v.state_lost, 10u);
}

TEST(LinkMonitor, UsageAgainstTheStatedBudget) {
  LinkMonitor links;
  const core::SteadyTime t0{};
  links.OnInfo("r1", "radio", 100.0);
  links.OnUsage("r1", {{"command", 0.5, 100}, {"state", 40.0, 1000}, {"camera", std::nan(""), 0}});
  LinkView v = links.View("r1", t0);
  EXPECT_EQ(v.link, "radio");
  EXPECT_NEAR(v.sent_kbps, 40.5, 1e-9);
  EXPECT_EQ(v.usage[2].sent_kbps, 0.0);  // a NaN rate from a peer counts as nothing
  EXPECT_FALSE(v.over_budget);
  links.OnUsage("r1", {{"command", 0.5, 200}, {"map", 120.0, 5000}});
  EXPECT_TRUE(links.View("r1", t0).over_budget);
  links.OnInfo("r1", "lan", -5.0);  // no budget stated: never over it
  EXPECT_EQ(links.View("r1", t0).budget_kbps, 0.0);
  EXPECT_FALSE(links.View("r1", t0).over_budget);
}

}  // namespace
}  // namespace cairn::base
