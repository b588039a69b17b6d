#include "cairn/agent/command/control_lock.h"

#include <gtest/gtest.h>

namespace cairn::agent {
namespace {

using namespace std::chrono_literals;

// Participant ids as the agent forms them (GUID prefixes); any distinct strings do here.
const std::string kReplA = "01.0f.aa.aa.00.00.00.01.00.00.00.01";
const std::string kOneShotA = "01.0f.aa.aa.00.00.00.02.00.00.00.01";
const std::string kRestartedA = "01.0f.aa.aa.00.00.00.03.00.00.00.01";
const std::string kB = "01.0f.bb.bb.00.00.00.01.00.00.00.01";

TEST(ControlLock, GrantsWhenFreeDeniesOthersNamingTheHolder) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  EXPECT_TRUE(lock.Request("opA", kReplA, t0).accepted);
  EXPECT_TRUE(lock.Request("opA", kReplA, t0).accepted) << "re-request by the holder is idempotent";
  const LockDecision denied = lock.Request("opB", kB, t0);
  EXPECT_FALSE(denied.accepted);
  EXPECT_EQ(denied.holder_id, "opA");
  EXPECT_EQ(denied.reason, "robot r1 is locked by basestation opA");
  EXPECT_TRUE(lock.IsHolder("opA"));
  EXPECT_FALSE(lock.IsHolder("opB"));
  EXPECT_FALSE(lock.Request("", kB, t0).accepted);
  EXPECT_FALSE(lock.Request("opC", "", t0).accepted);
  EXPECT_EQ(lock.holder_participant(), kReplA);
}

// A robot restarted from its journal: the holder has the lock again, lost until one of its processes
// announces itself; others are refused meanwhile.
TEST(ControlLock, ARestoredHolderIsLostUntilItsProcessAnnouncesItself) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.Restore("opA", t0);
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_FALSE(lock.holder_alive());
  EXPECT_FALSE(lock.Request("opB", kB, t0).accepted);
  lock.OnParticipantAlive("opB", kB);
  EXPECT_FALSE(lock.holder_alive()) << "another id's process does not speak for the holder";
  lock.OnParticipantAlive("opA", kRestartedA);
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kRestartedA);
  // A process already announced before the restore speaks for the holder at once.
  ControlLock second("r1", {});
  second.OnParticipantAlive("opA", kReplA);
  second.Restore("opA", t0);
  EXPECT_TRUE(second.holder_alive());
  second.Restore("", t0);
  EXPECT_EQ(second.holder_id(), "");
  EXPECT_TRUE(second.Request("opB", kB, t0).accepted);
}

TEST(ControlLock, OnlyTheHolderReleases) {
  ControlLock lock("r1", {});
  EXPECT_FALSE(lock.Release("opA").accepted) << "nothing to release";
  lock.Request("opA", kReplA, core::SteadyClock::now());
  const LockDecision by_b = lock.Release("opB");
  EXPECT_FALSE(by_b.accepted);
  EXPECT_NE(by_b.reason.find("locked by basestation opA"), std::string::npos);
  EXPECT_TRUE(lock.Release("opA").accepted);
  EXPECT_EQ(lock.holder_id(), "");
  EXPECT_EQ(lock.holder_participant(), "");
  EXPECT_TRUE(lock.Request("opB", kB, core::SteadyClock::now()).accepted);
}

TEST(ControlLock, KeepsLockForeverAfterLivelinessLossByDefault) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  lock.OnParticipantAlive("opB", kB);
  lock.Request("opA", kReplA, t0);
  lock.OnParticipantLost(kB, t0);  // not the holder: ignored
  EXPECT_TRUE(lock.holder_alive());
  lock.OnParticipantLost(kReplA, t0);
  EXPECT_FALSE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), "");
  EXPECT_FALSE(lock.Update(t0 + 24h));
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_FALSE(lock.Request("opB", kB, t0 + 24h).accepted);
}

// A one-shot process with the holder's id that starts and exits leaves the holder alive.
TEST(ControlLock, AShortLivedSecondProcessWithTheHoldersIdLeavesItAlive) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  lock.Request("opA", kReplA, t0);
  lock.OnParticipantAlive("opA", kOneShotA);
  EXPECT_EQ(lock.holder_participants(), 2u);
  lock.OnParticipantLost(kOneShotA, t0 + 1s);
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kReplA);
  EXPECT_EQ(lock.holder_participants(), 1u);

  // Even when the one-shot spoke last (it sent a command), its exit hands the holder back to the REPL.
  lock.OnParticipantAlive("opA", kOneShotA);
  lock.NoteHolderCommand(kOneShotA);
  EXPECT_EQ(lock.holder_participant(), kOneShotA);
  lock.OnParticipantLost(kOneShotA, t0 + 2s);
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kReplA);
}

// The lock belongs to the basestation id: a holder that crashes and comes back finds its robot still locked
// to it, and the new process speaks for it.
TEST(ControlLock, SurvivesARestartOfTheHolder) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  lock.Request("opA", kReplA, t0);
  lock.OnParticipantLost(kReplA, t0 + 1s);  // SIGKILLed
  EXPECT_FALSE(lock.holder_alive());
  EXPECT_FALSE(lock.Request("opB", kB, t0 + 2s).accepted) << "nobody else takes a lost holder's robot";
  lock.OnParticipantAlive("opA", kRestartedA);
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kRestartedA);
  EXPECT_TRUE(lock.IsHolder("opA"));
  // A restart that announces itself only after the old process's loss is seen behaves the same, and one
  // that is seen before the loss simply takes over when the old one goes.
  lock.OnParticipantAlive("opA", kReplA);
  lock.NoteHolderCommand(kReplA);
  lock.OnParticipantLost(kReplA, t0 + 3s);
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kRestartedA);
}

// A process that speaks without ever announcing itself (its agent info not yet seen, or a tool that sends
// none) is live while it speaks and lost when it goes: the holder is not kept alive by it forever.
TEST(ControlLock, AnUnannouncedSpeakerIsLostWhenItGoes) {
  ControlLockOptions options;
  options.lock_keep_s = 5.0;
  ControlLock lock("r1", options);
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  lock.Request("opA", kReplA, t0);
  lock.NoteHolderCommand(kOneShotA);  // never announced
  EXPECT_EQ(lock.holder_participants(), 2u);
  lock.OnParticipantLost(kReplA, t0 + 1s);
  EXPECT_TRUE(lock.holder_alive());
  lock.OnParticipantLost(kOneShotA, t0 + 2s);  // participant discovery reports it gone
  EXPECT_FALSE(lock.holder_alive());
  EXPECT_TRUE(lock.Update(t0 + 7s + 1ms)) << "the lock is freed lock_keep_s after the last speaker left";
}

TEST(ControlLock, FreesAfterLockKeepWhenConfigured) {
  ControlLockOptions options;
  options.lock_keep_s = 5.0;
  ControlLock lock("r1", options);
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  lock.Request("opA", kReplA, t0);
  EXPECT_FALSE(lock.Update(t0 + 10s)) << "holder alive: never freed";
  lock.OnParticipantLost(kReplA, t0 + 10s);
  EXPECT_FALSE(lock.Update(t0 + 14s));
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_TRUE(lock.Update(t0 + 15s + 1ms));
  EXPECT_EQ(lock.holder_id(), "");
  EXPECT_TRUE(lock.Request("opB", kB, t0 + 16s).accepted);
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
