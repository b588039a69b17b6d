#include "cairn/base/fleet_events.h"

#include <gtest/gtest.h>

#include "cairn/base/fleet.h"

namespace cairn::base {
namespace {

RobotView Robot(const std::string& id, double x_m, double y_m) {
  RobotView v;
  v.robot_id = id;
  cairn_msgs::RobotState s;
  s.robot_id(id);
  s.pose_MB().position().x_m(x_m);
  s.pose_MB().position().y_m(y_m);
  v.state = s;
  return v;
}

std::vector<std::string> Kinds(const std::vector<OperatorEvent>& events) {
  std::vector<std::string> kinds;
  kinds.reserve(events.size());
  for (const auto& e : events) kinds.push_back(e.kind);
  return kinds;
}

// A mission paused by a transient condition and resumed; an exploration that completes and one that stops; a
// convoy follower forming and holding. Each is told once.
TEST(FleetEventDetector, MissionsPauseResumeAndEndAndConvoysFormAndHold) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  r1.state->explore_task_id(4);
  r1.state->explore_state("exploring");
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.state->mission_state("paused");
  r1.state->mission_kind("explore");
  r1.state->mission_reason("IsComponentUp: perception is down");
  r1.state->explore_state("paused");
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"mission_paused"}));
  EXPECT_EQ(events[0].reason, "IsComponentUp: perception is down");
  EXPECT_EQ(events[0].message, "r1 explore paused: IsComponentUp: perception is down (it resumes by itself)");
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "told once";
  r1.state->mission_state("");
  r1.state->mission_reason("resumed after 4.2 s paused: IsComponentUp: perception is down");
  r1.state->explore_state("exploring");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"mission_resumed"}));
  r1.state->explore_state("complete");
  r1.state->explored_m2(812.5);
  r1.state->explore_targets_reached(31);
  r1.state->explore_targets_failed(2);
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"exploration_complete"}));
  EXPECT_NE(events[0].message.find("812.5 m²"), std::string::npos) << events[0].message;
  EXPECT_NE(events[0].message.find("2 given up"), std::string::npos) << events[0].message;
  r1.state->explore_task_id(5);
  r1.state->explore_state("exploring");
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.state->explore_state("stopped");
  r1.state->explore_reason("paused for 61 s (mission.resume_within_s 60) and not resumed: IsLocalized: lost");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"exploration_stopped"}));
  // A paused mission that ends without resuming is told by how it ends, not as resumed.
  r1.state->mission_state("paused");
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"mission_paused"}));
  r1.state->mission_state("");
  r1.state->mission_reason("dropped: an operator's command came");
  EXPECT_TRUE(detector.Observe({r1}).empty());

  RobotView r2 = Robot("r2", 10, 0);
  r2.state->convoy_state("none");
  EXPECT_TRUE(detector.Observe({r2}).empty());
  r2.state->convoy_state("following");
  r2.state->convoy_ahead_ids({"r1"});
  events = detector.Observe({r2});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"convoy_formed"}));
  EXPECT_EQ(events[0].other, "r1");
  r2.state->convoy_state("holding");
  r2.state->convoy_reason("the gap to r1 is 2.1 m, under 3.0 m");
  events = detector.Observe({r2});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"convoy_holding"}));
  EXPECT_EQ(events[0].reason, "the gap to r1 is 2.1 m, under 3.0 m");
  r2.state->convoy_state("following");
  EXPECT_TRUE(detector.Observe({r2}).empty()) << "following again after holding is its normal course";
}

TEST(FleetEventDetector, FirstSightIsABaselineThenEachChangeIsToldOnce) {
  FleetEventDetector detector;
  RobotView r2 = Robot("r2", 0, 0);
  r2.state->nav_goal_id(7);
  r2.state->nav_status(cairn_msgs::NAV_STATUS_ARRIVED);  // old news when this basestation starts
  EXPECT_TRUE(detector.Observe({r2}).empty());

  r2.state->nav_goal_id(8);
  r2.state->nav_status(cairn_msgs::NAV_STATUS_ACTIVE);
  EXPECT_TRUE(detector.Observe({r2}).empty());
  r2.state->nav_status(cairn_msgs::NAV_STATUS_ARRIVED);
  r2.state->nav_goal_M().x_m(30);
  r2.state->nav_goal_M().y_m(10);
  auto events = detector.Observe({r2});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"arrived"}));
  EXPECT_EQ(events[0].message, "r2 arrived at (30.00, 10.00) (goal #8)");
  EXPECT_TRUE(detector.Observe({r2}).empty()) << "told once";

  r2.state->nav_goal_id(9);
  r2.state->nav_status(cairn_msgs::NAV_STATUS_FAILED);
  r2.state->nav_reason("blocked: no progress for 10 s");
  events = detector.Observe({r2});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"goal_abandoned"}));
  EXPECT_EQ(events[0].reason, "blocked: no progress for 10 s");
}

TEST(FleetEventDetector, JoinedOnceWithWhatItOffersThenLeftOrLostAndBack) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "its state came first: nothing to say until it announces";
  r1.announced = true;
  r1.platform = "wheeled";
  r1.version = "0.1.0";
  r1.capabilities = {"idle", "manual"};
  r1.sensors = {"lidar"};
  r1.map_resolution_m = 0.1;
  r1.link.link = "radio";
  r1.link.budget_kbps = 1000;
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"joined"}));
  EXPECT_EQ(events[0].message,
            "r1 joined: wheeled, cairn 0.1.0, modes idle manual, sensors lidar, map 0.10 m, link radio 1000 "
            "kbit/s");
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "told once";

  r1.lost = r1.left = true;
  r1.lost_reason = "its process exited";
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"left"}));
  EXPECT_EQ(events[0].message, "r1 left (its process exited)");
  r1.lost = r1.left = false;
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"back"}));
  r1.lost = true;
  r1.lost_reason = "liveliness lost";
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"lost"}));
  r1.left = true;  // the clean exit is told after the lapse, once
  r1.lost_reason = "its process exited";
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"left"}));
  EXPECT_TRUE(detector.Observe({r1}).empty());

  // A basestation that starts when the robot is already there hears that it joined.
  FleetEventDetector late;
  r1.lost = r1.left = false;
  EXPECT_EQ(Kinds(late.Observe({r1})), (std::vector<std::string>{"joined"}));
}

TEST(FleetEventDetector, OverBudgetOnceUntilBackUnderNinetyPercent) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  r1.link.budget_kbps = 100;
  r1.link.usage = {{"state", 30, 0}, {"camera", 80, 0}};
  r1.link.sent_kbps = 110;
  r1.link.over_budget = true;
  auto events = detector.Observe({r1});  // a present fact: told at first sight
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"over_budget"}));
  EXPECT_EQ(events[0].message,
            "r1 sends 110.0 kbit/s, over its link budget of 100.0 kbit/s (camera 80.0 kbit/s)");
  EXPECT_EQ(events[0].reason, "camera 80.0 kbit/s");
  r1.link.sent_kbps = 95;  // under the budget, not under 90 %: still the same episode
  r1.link.over_budget = false;
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.link.sent_kbps = 101;
  r1.link.over_budget = true;
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "no flapping at the edge";
  r1.link.sent_kbps = 50;
  r1.link.over_budget = false;
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.link.sent_kbps = 120;
  r1.link.over_budget = true;
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"over_budget"}));
}

TEST(FleetEventDetector, EachRecoveryAttemptIsToldAsItFails) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  r1.state->nav_goal_id(3);
  r1.state->nav_status(cairn_msgs::NAV_STATUS_ACTIVE);
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.state->nav_reason("recovering after: blocked: no progress for 10.0 s");
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"recovering"}));
  EXPECT_EQ(events[0].message, "r1 goal #3 recovering after: blocked: no progress for 10.0 s");
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "told once";
  r1.state->nav_reason(
      "recovering after: blocked: no progress for 10.0 s; attempt 1 (clear the local obstacle "
      "memory): blocked: no progress for 10.0 s");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"recovering"}));
  EXPECT_EQ(events[0].reason, "attempt 1 (clear the local obstacle memory): blocked: no progress for 10.0 s");
  r1.state->nav_status(cairn_msgs::NAV_STATUS_ARRIVED);
  r1.state->nav_reason("");
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"arrived"}));
}

// Get-out-of-the-way: the robot asked moving aside, refusing and back; the robot asking and
// blocked. Moving aside then standing aside is one event.
TEST(FleetEventDetector, EachStepOfAYieldIsToldOnceOnBothRobots) {
  FleetEventDetector detector;
  RobotView ya = Robot("ya", 0, 0), yb = Robot("yb", 10, 0);
  EXPECT_TRUE(detector.Observe({ya, yb}).empty());
  ya.state->yield_state("asking");
  ya.state->yield_peer_id("yb");
  ya.state->yield_reason("asked yb, 8.0 m ahead in a passage too narrow to pass, to get out of the way");
  yb.state->yield_state("moving_aside");
  yb.state->yield_peer_id("ya");
  yb.state->yield_reason("moving aside for ya to (19.5, 6.2), 6.0 m away");
  auto events = detector.Observe({ya, yb});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"yield_asking", "yield_moving_aside"}));
  EXPECT_EQ(events[0].other, "yb");
  EXPECT_EQ(events[1].message, "yb gets out of ya's way: moving aside for ya to (19.5, 6.2), 6.0 m away");
  yb.state->yield_state("aside");
  EXPECT_TRUE(detector.Observe({ya, yb}).empty()) << "standing aside is the same step";
  yb.state->yield_state("returning");
  EXPECT_TRUE(detector.Observe({ya, yb}).empty());
  yb.state->yield_state("");
  yb.state->yield_reason("back at (14.0, 5.0) after yielding to ya");
  events = detector.Observe({ya, yb});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"yield_returned"}));
  EXPECT_EQ(events[0].message, "yb: back at (14.0, 5.0) after yielding to ya");
  EXPECT_EQ(events[0].other, "ya");

  yb.state->yield_state("refused");
  yb.state->yield_reason("in manual control: its operator drives it");
  ya.state->yield_state("blocked");
  ya.state->yield_reason(
      "blocked by yb 7.8 m ahead; it refused to yield: in manual control: its operator drives it");
  events = detector.Observe({ya, yb});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"yield_blocked", "yield_refused"}));
  EXPECT_EQ(events[1].message, "yb refused to yield to ya: in manual control: its operator drives it");
  EXPECT_TRUE(detector.Observe({ya, yb}).empty()) << "told once";
}

// The grant of this basestation's own request-control reached it before the detector's first look at r1:
// the first whole state it received is the baseline, so the grant is still told; older news is not.
TEST(FleetEventDetector, ChangesAfterTheFirstWholeStateAreToldEvenBeforeTheFirstLook) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  r1.state->nav_goal_id(3);
  r1.state->nav_status(cairn_msgs::NAV_STATUS_ARRIVED);  // old news
  r1.first_state = r1.state;
  r1.state->holder_id("opA");
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"lock_granted"}));
  EXPECT_EQ(events[0].message, "r1 control granted to opA");
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "told once";

  // A robot first seen lost, then its state: no lost event for the first look, the baseline still applies.
  RobotView r2 = Robot("r2", 5, 0);
  r2.lost = true;
  std::optional<cairn_msgs::RobotState> state = r2.state;
  r2.state.reset();
  EXPECT_TRUE(detector.Observe({r2}).empty());
  r2.lost = false;
  r2.state = state;
  r2.first_state = state;
  r2.state->stops(1);
  r2.state->stopped_by("opB");
  EXPECT_EQ(Kinds(detector.Observe({r2})), (std::vector<std::string>{"back", "stopped"}));
}

// A request for a held lock is told once (with what the holder may answer), the answer once, in the robot's
// words; a grant is told as the handover, not as a lock taken.
TEST(FleetEventDetector, ARequestForTheLockAndItsAnswerAreToldOnce) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  r1.state->holder_id("opA");
  detector.Observe({r1});
  r1.state->control_requester_id("opB");
  r1.state->control_request_left_s(29.6);
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"control_requested"}));
  EXPECT_EQ(events[0].message,
            "r1: opB asks for control (held by opA): grant r1 opB or deny r1 opB within 30 s");
  EXPECT_EQ(events[0].other, "opB");
  r1.state->control_request_left_s(20.0);
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "a request is told once, not as its time runs down";

  r1.state->control_requester_id("");
  r1.state->holder_id("opB");
  r1.state->handovers(1);
  r1.state->handover_outcome("opA granted opB's request: opB holds the lock");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"control_handover"}));
  EXPECT_EQ(events[0].message, "r1: opA granted opB's request: opB holds the lock");
  EXPECT_EQ(events[0].other, "opB");

  r1.state->control_requester_id("opC");
  detector.Observe({r1});
  r1.state->control_requester_id("");
  r1.state->handovers(2);
  r1.state->handover_outcome("opC's request expired: opB did not answer within 30 s");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"control_handover"}));
  EXPECT_EQ(events[0].reason, "opC's request expired: opB did not answer within 30 s");
}

TEST(FleetEventDetector, LocksStopsLossAndReturn) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  detector.Observe({r1});
  r1.state->holder_id("opA");
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"lock_granted"}));
  r1.state->holder_id("opB");
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"lock_taken"}));
  EXPECT_EQ(events[0].message, "r1 control taken by opB from opA");
  r1.state->holder_id("");
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"lock_released"}));
  r1.state->stops(1);
  r1.state->stopped_by("opC");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"stopped"}));
  EXPECT_EQ(events[0].message, "r1 stopped by opC");
  r1.lost = true;
  r1.lost_reason = "liveliness lost";
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"lost"}));
  EXPECT_EQ(events[0].message, "r1 lost (liveliness lost)");
  r1.lost = false;
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"back"}));
}

TEST(FleetEventDetector, ProximityWithHysteresis) {
  FleetEventOptions options;
  options.proximity_m = 1.5;
  options.proximity_clear_m = 2.5;
  FleetEventDetector detector(options);
  RobotView a = Robot("r1", 0, 0), b = Robot("r2", 5, 0);
  EXPECT_TRUE(detector.Observe({a, b}).empty());
  b.state->pose_MB().position().x_m(1.2);
  auto events = detector.Observe({a, b});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"proximity"}));
  EXPECT_NEAR(events[0].distance_m, 1.2, 1e-9);
  EXPECT_EQ(events[0].other, "r2");
  b.state->pose_MB().position().x_m(2.0);  // apart, but not past the clear distance
  EXPECT_TRUE(detector.Observe({a, b}).empty());
  b.state->pose_MB().position().x_m(1.0);
  EXPECT_TRUE(detector.Observe({a, b}).empty()) << "still the same encounter";
  b.state->pose_MB().position().x_m(3.0);
  detector.Observe({a, b});
  b.state->pose_MB().position().x_m(1.0);
  EXPECT_EQ(Kinds(detector.Observe({a, b})), (std::vector<std::string>{"proximity"})) << "a new encounter";
}

TEST(FleetEventDetector, EachComponentFailureAndRestartIsToldOnceAndARestartedAgentIsABaseline) {
  FleetEventDetector detector;
  RobotView r1 = Robot("r1", 0, 0);
  cairn_msgs::AgentHealth h;
  h.robot_id("r1");
  h.events(2);  // old news when this basestation starts
  h.last_event("perception restarted (restart 1)");
  h.last_event_kind("restarted");
  h.last_event_component("perception");
  r1.health = h;
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.health->events(3);
  r1.health->last_event("perception failed: injected fault; restart in 1.0 s");
  r1.health->last_event_kind("failed");
  auto events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"component_failed"}));
  EXPECT_EQ(events[0].other, "perception");
  EXPECT_EQ(events[0].message, "r1: perception failed: injected fault; restart in 1.0 s");
  EXPECT_TRUE(detector.Observe({r1}).empty()) << "told once";
  r1.health->events(4);
  r1.health->last_event("perception restarted after 1.0 s down (restart 2)");
  r1.health->last_event_kind("restarted");
  EXPECT_EQ(Kinds(detector.Observe({r1})), (std::vector<std::string>{"component_restarted"}));
  // The agent itself restarted: its count starts again; nothing to tell until it grows.
  r1.health->events(0);
  r1.health->last_event("");
  r1.health->last_event_kind("");
  EXPECT_TRUE(detector.Observe({r1}).empty());
  r1.health->events(1);
  r1.health->last_event("planning restarted by opA (restart 1)");
  r1.health->last_event_kind("restarted");
  r1.health->last_event_component("planning");
  events = detector.Observe({r1});
  ASSERT_EQ(Kinds(events), (std::vector<std::string>{"component_restarted"}));
  EXPECT_EQ(events[0].other, "planning");
}

TEST(FleetEventOptions, ValidatesNamingTheField) {
  std::string why;
  EXPECT_TRUE(FleetEventOptions{}.IsValid(&why));
  FleetEventOptions bad;
  bad.proximity_clear_m = 0.5;
  EXPECT_FALSE(bad.IsValid(&why));
  EXPECT_NE(why.find("proximity_clear_m"), std::string::npos) << why;
  EXPECT_THROW(FleetEventDetector{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace cairn::base
