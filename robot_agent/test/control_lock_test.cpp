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
  EXPECT_EQ(
      denied.reason,
      "robot r1 is locked by basestation opA: asked opA to hand it over (grant r1 opB or deny r1 opB there, "
      "within 30 s)");
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

// Handover between operators: a request for a held lock waits for the holder's answer. A grant hands it over
// (the requester's process speaks for it at once), a denial ends the request, both counted and told.
TEST(ControlLock, ARequestWaitsForTheHoldersGrantOrDenial) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  lock.OnParticipantAlive("opA", kReplA);
  ASSERT_TRUE(lock.Request("opA", kReplA, t0).accepted);
  EXPECT_FALSE(lock.Request("opB", kB, t0).accepted);
  ASSERT_TRUE(lock.pending_request().has_value());
  EXPECT_EQ(lock.pending_request()->base_id, "opB");
  EXPECT_DOUBLE_EQ(lock.PendingLeftS(t0 + 10s), 20.0);
  EXPECT_EQ(lock.handovers(), 0u);

  // Only the holder answers; a denial of someone who did not ask is refused, naming who waits.
  EXPECT_FALSE(lock.Handover("opB", "opB").accepted);
  EXPECT_FALSE(lock.Deny("opB", "opB").accepted);
  const LockDecision nobody = lock.Deny("opA", "opC");
  EXPECT_FALSE(nobody.accepted);
  EXPECT_EQ(nobody.reason, "no request from basestation opC waits for robot r1's lock");

  EXPECT_TRUE(lock.Deny("opA", "opB").accepted);
  EXPECT_FALSE(lock.pending_request().has_value());
  EXPECT_EQ(lock.holder_id(), "opA");
  EXPECT_EQ(lock.handovers(), 1u);
  EXPECT_EQ(lock.handover_outcome(), "opA denied opB's request for the lock");

  EXPECT_FALSE(lock.Request("opB", kB, t0 + 1s).accepted);  // asks again
  const LockDecision granted = lock.Handover("opA", "opB");
  ASSERT_TRUE(granted.accepted) << granted.reason;
  EXPECT_EQ(granted.holder_id, "opB");
  EXPECT_TRUE(lock.IsHolder("opB"));
  EXPECT_TRUE(lock.holder_alive());
  EXPECT_EQ(lock.holder_participant(), kB) << "the process that asked speaks for the new holder";
  EXPECT_FALSE(lock.pending_request().has_value());
  EXPECT_EQ(lock.handovers(), 2u);
  EXPECT_EQ(lock.handover_outcome(), "opA granted opB's request: opB holds the lock");
  EXPECT_FALSE(lock.Release("opA").accepted) << "the old holder no longer holds it";
}

// One request waits at a time; a second requester is told who waits and for how long. An unanswered request
// expires, and one whose process left is dropped.
TEST(ControlLock, OneRequestWaitsItExpiresOrIsDroppedWhenItsBasestationLeaves) {
  ControlLockOptions options;
  options.handover_request_timeout_s = 10.0;
  ControlLock lock("r1", options);
  const auto t0 = core::SteadyClock::now();
  const std::string kC = "01.0f.cc.cc.00.00.00.01.00.00.00.01";
  ASSERT_TRUE(lock.Request("opA", kReplA, t0).accepted);
  EXPECT_FALSE(lock.Request("opB", kB, t0).accepted);
  const LockDecision second = lock.Request("opC", kC, t0 + 4s);
  EXPECT_FALSE(second.accepted);
  EXPECT_NE(second.reason.find("basestation opB's request waits for its answer (6 s left)"),
            std::string::npos)
      << second.reason;
  EXPECT_EQ(lock.pending_request()->base_id, "opB");

  EXPECT_FALSE(lock.Update(t0 + 9s));
  EXPECT_TRUE(lock.pending_request().has_value());
  lock.Update(t0 + 10s + 1ms);
  EXPECT_FALSE(lock.pending_request().has_value());
  EXPECT_EQ(lock.handover_outcome(), "opB's request expired: opA did not answer within 10 s");
  EXPECT_EQ(lock.holder_id(), "opA");

  EXPECT_FALSE(lock.Request("opC", kC, t0 + 11s).accepted);  // now it may wait
  EXPECT_EQ(lock.pending_request()->base_id, "opC");
  lock.OnParticipantLost(kC, t0 + 12s);
  EXPECT_FALSE(lock.pending_request().has_value());
  EXPECT_EQ(lock.handover_outcome(), "opC's request was dropped: its basestation left");
  EXPECT_EQ(lock.handovers(), 2u);
}

// The holder hands the lock over unasked to a basestation that is running (announced, live), never to one
// the robot has not heard; a release while a request waits frees the lock and says so.
TEST(ControlLock, AHandoverUnaskedGoesOnlyToALiveBasestation) {
  ControlLock lock("r1", {});
  const auto t0 = core::SteadyClock::now();
  ASSERT_TRUE(lock.Request("opA", kReplA, t0).accepted);
  const LockDecision unknown = lock.Handover("opA", "opB");
  EXPECT_FALSE(unknown.accepted);
  EXPECT_NE(unknown.reason.find("no live basestation opB"), std::string::npos) << unknown.reason;
  EXPECT_FALSE(lock.Handover("opA", "opA").accepted);
  EXPECT_FALSE(lock.Handover("opA", "").accepted);
  lock.OnParticipantAlive("opB", kB);
  ASSERT_TRUE(lock.Handover("opA", "opB").accepted);
  EXPECT_EQ(lock.holder_participant(), kB);
  EXPECT_EQ(lock.handover_outcome(), "opA handed the lock over to opB");

  EXPECT_FALSE(lock.Request("opA", kReplA, t0 + 1s).accepted);
  ASSERT_TRUE(lock.Release("opB").accepted);
  EXPECT_EQ(lock.handover_outcome(), "opB released the lock while opA waited: it is free");
  EXPECT_FALSE(lock.pending_request().has_value());
  EXPECT_TRUE(lock.Request("opA", kReplA, t0 + 2s).accepted);
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
  ControlLockOptions no_wait;
  no_wait.handover_request_timeout_s = 0.0;
  EXPECT_FALSE(no_wait.IsValid(&why));
  EXPECT_EQ(why, "handover_request_timeout_s = 0.000000 must be in (0, 3600] seconds");
}

}  // namespace
}  // namespace cairn::agent
