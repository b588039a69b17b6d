// The robot's health message (HealthReport): when it is due and what it carries of the last event.
#include "cairn/agent/communication/health_report.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

using std::chrono::milliseconds;

TEST(HealthReport, SentFirstThenEveryPeriodAndAtOnceAfterAnEvent) {
  core::HealthMonitor monitor;
  HealthReport report("r1", 2.0);
  const core::SteadyTime t0 = core::SteadyClock::now();
  auto first = report.MessageIfDue(t0, monitor, 3);
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->robot_id(), "r1");
  EXPECT_EQ(first->late_control_cycles(), 3u);
  EXPECT_EQ(first->events(), 0u);
  EXPECT_TRUE(first->last_event().empty());
  EXPECT_GT(first->rss_bytes(), 0u);
  // Not again within the period.
  EXPECT_FALSE(report.MessageIfDue(t0 + milliseconds(500), monitor, 3).has_value());
  // An event: at once, counted, with its kind, component and message.
  report.OnEvent({core::HealthEvent::Kind::kFailed, "perception", "perception failed: stalled"});
  auto after_event = report.MessageIfDue(t0 + milliseconds(600), monitor, 4);
  ASSERT_TRUE(after_event.has_value());
  EXPECT_EQ(after_event->events(), 1u);
  EXPECT_EQ(after_event->last_event(), "perception failed: stalled");
  EXPECT_EQ(after_event->last_event_component(), "perception");
  EXPECT_EQ(after_event->last_event_kind(), core::ToString(core::HealthEvent::Kind::kFailed));
  EXPECT_FALSE(report.MessageIfDue(t0 + milliseconds(700), monitor, 4).has_value());
  // The period after the last message.
  EXPECT_TRUE(report.MessageIfDue(t0 + milliseconds(2700), monitor, 4).has_value());
}

}  // namespace
}  // namespace cairn::agent
