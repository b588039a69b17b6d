#include "cairn/agent/communication/link_usage.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

std::vector<SentTraffic> Sent(std::uint64_t command_bytes, std::uint64_t camera_bytes) {
  return {{"command", command_bytes, command_bytes / 100}, {"camera", camera_bytes, camera_bytes / 1000}};
}

TEST(LinkUsageMeter, RatesOverTheWindowInKbitPerSecond) {
  LinkUsageMeter meter(2.0);
  std::vector<SentRate> rates = meter.Update(10.0, Sent(0, 0));
  ASSERT_EQ(rates.size(), 2u);
  EXPECT_EQ(rates[0].sent_kbps, 0.0);  // one reading: no rate yet
  // 1 s later: 1250 bytes of commands = 10 kbit/s, 125000 bytes of camera = 1000 kbit/s.
  rates = meter.Update(11.0, Sent(1250, 125000));
  EXPECT_DOUBLE_EQ(rates[0].sent_kbps, 10.0);
  EXPECT_DOUBLE_EQ(rates[1].sent_kbps, 1000.0);
  EXPECT_EQ(rates[1].total.bytes, 125000u);
  EXPECT_EQ(rates[1].total.samples, 125u);
  EXPECT_EQ(rates[1].total.topic_class, "camera");
  // The camera stops: its rate falls as the window slides past the busy second, to 0 once it has.
  rates = meter.Update(12.0, Sent(2500, 125000));
  EXPECT_DOUBLE_EQ(rates[1].sent_kbps, 500.0);  // 125000 bytes over 10 -> 12 s
  rates = meter.Update(13.0, Sent(3750, 125000));
  EXPECT_DOUBLE_EQ(rates[1].sent_kbps, 0.0);  // from the 11 s reading
  EXPECT_DOUBLE_EQ(rates[0].sent_kbps, 10.0);
}

TEST(LinkUsageMeter, NewClassesCountFromZeroAndARestartResets) {
  LinkUsageMeter meter(2.0);
  meter.Update(0.0, {{"command", 1000, 1}});
  std::vector<SentRate> rates = meter.Update(1.0, {{"command", 2000, 2}, {"map", 500, 1}});
  EXPECT_DOUBLE_EQ(rates[0].sent_kbps, 8.0);
  EXPECT_DOUBLE_EQ(rates[1].sent_kbps, 4.0);
  // Counters that went down (a new process): no negative or huge rate, a fresh window.
  rates = meter.Update(2.0, {{"command", 10, 1}, {"map", 0, 0}});
  EXPECT_EQ(rates[0].sent_kbps, 0.0);
  rates = meter.Update(3.0, {{"command", 135, 2}, {"map", 0, 0}});
  EXPECT_DOUBLE_EQ(rates[0].sent_kbps, 1.0);
}

TEST(LinkUsageMeter, RefusesABadWindowNamingIt) {
  try {
    LinkUsageMeter meter(0.0);
    FAIL() << "a 0 s window was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("window_s = 0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace cairn::agent
