#include "cairn/agent/control_lock.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

using namespace std::chrono_literals;

TEST(ControlLock, GrantsWhenFreeDeniesOthersNamingTheHolder) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  EXPECT_TRUE(lock.Request("opA", t0).accepted);
  EXPECT_TRUE(lock.Request("opA", t0).accepted) << "re-request by the holder is idempotent";
  const LockDecision denied = lock.Request("opB", t0);
  EXPECT_FALSE(denied.accepted);
  EXPECT_EQ(denied.holder_id, "opA");
  EXPECT_EQ(denied.reason, "robot r1 is locked by basestation opA");
  EXPECT_TRUE(lock.IsHolder("opA"));
  EXPECT_FALSE(lock.IsHolder("opB"));
  EXPECT_FALSE(lock.Request("", t0).accepted);
}

TEST(ControlLock, OnlyTheHolderReleases) {
  ControlLock lock("r1", {});
  EXPECT_FALSE(lock.Release("opA").accepted) << "nothing to release";
  lock.Request("opA", core::SteadyClock::now());
  const LockDecision by_b = lock.Release("opB");
  EXPECT_FALSE(by_b.accepted);
  EXPECT_NE(by_b.reason.find("locked by basestation opA"), std::string::npos);
  EXPECT_TRUE(lock.Release("opA").accepted);
  EXPECT_EQ(lock.holder_id(), "");
  EXPECT_TRUE(lock.Request("opB", core::SteadyClock::now()).accepted);
}

TEST(ControlLock, KeepsLockForeverAfterLivelinessLossByDefault) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.Request("opA", t0);
  lock.OnLivelinessLost("opB", t0);  // not the holder: ignored
  EXPECT_TRUE(lock.holder_alive());
  lock.OnLivelinessLost("opA", t0);
  EXPECT_FALSE(lock.holder_alive());
  EXPECT_FALSE(lock.Update(t0 + 24h));
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_FALSE(lock.Request("opB", t0 + 24h).accepted);
  lock.OnLivelinessRegained("opA");
  EXPECT_TRUE(lock.holder_alive());
}

TEST(ControlLock, FreesAfterLockKeepWhenConfigured) {
  ControlLockOptions options;
  options.lock_keep_s = 5.0;
  ControlLock lock("r1", options);
  const auto t0 = core::SteadyClock::now();
  lock.Request("opA", t0);
  EXPECT_FALSE(lock.Update(t0 + 10s)) << "holder alive: never freed";
  lock.OnLivelinessLost("opA", t0 + 10s);
  EXPECT_FALSE(lock.Update(t0 + 14s));
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_TRUE(lock.Update(t0 + 15s + 1ms));
  EXPECT_EQ(lock.holder_id(), "");
  EXPECT_TRUE(lock.Request("opB", t0 + 16s).accepted);
}

TEST(ControlLock, CountsDiscardedAndValidatesOptions) {
  ControlLock lock("r1", {});
  lock.CountDiscarded();
  lock.CountDiscarded();
  EXPECT_EQ(lock.discarded(), 2u);
  EXPECT_NE(lock.NotHolderReason("opB").find("free"), std::string::npos);
  std::string why;
  EXPECT_TRUE(ControlLockOptions{}.IsValid(&why));
  ControlLockOptions bad;
  bad.lock_keep_s = -1;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("lock_keep_s"), std::string::npos);
}

}  // namespace
}  // namespace cairn::agent
