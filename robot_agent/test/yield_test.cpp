// Get-out-of-the-way: the policy (DecideYield), the asking robot's choice (YieldAsker) on
// builtin:narrow's grid, and a parked robot yielding to one driving through its 2 m tunnel with every robot
// the shipping agent stepped on a simulated clock in process (RobotAgent::Stepped over an InProcessTeam),
// peer states at 5 Hz and yield requests as over DDS, scored on the simulator's ground truth. The same over
// real processes and DDS is tests/yield_integration_test.

#include "cairn/agent/team/yield.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "agent_team.h"
#include "cairn/agent/communication/in_process_link.h"
#include "cairn/nav/traversability.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/platform_profile.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::agent {
namespace {

using team_testing::AgentTeam;

std::shared_ptr<const nav::TraversabilityGrid> NarrowGrid() {
  static const auto grid = std::make_shared<const nav::TraversabilityGrid>(sim::MakeBuiltinWorld("narrow"));
  return grid;
}

core::BaseState At(double x, double y, double yaw = 0.0) {
  core::BaseState s;
  s.x_m = x;
  s.y_m = y;
  s.yaw_rad = yaw;
  return s;
}

// ya at (4, 5) driving the south tunnel to (30, 5).
YieldCommand FromYa(double x_m = 4.0) {
  YieldCommand c;
  c.sender_id = "ya";
  c.request_id = 1;
  c.passing_id = "ya";
  c.passing_radius_m = 0.3;
  c.keep_clear_M = {{x_m, 5.0}, {30.0, 5.0}};
  return c;
}

TEST(YieldPolicyTest, BadOptionsAndRequestsAreNamed) {
  std::vector<std::string> modes;
  EXPECT_EQ(ParseYieldModes("idle, waypoint explore", &modes), "");
  EXPECT_EQ(modes, (std::vector<std::string>{"idle", "waypoint", "explore"}));
  EXPECT_NE(ParseYieldModes("idle manual", &modes).find("yield.modes: 'manual' cannot yield"),
            std::string::npos);
  EXPECT_NE(ParseYieldModes("smart_joystick", &modes).find("'smart_joystick' cannot yield"),
            std::string::npos);
  EXPECT_NE(ParseYieldModes("idle;waypoint", &modes).find("';' is not part of a mode name"),
            std::string::npos);
  EXPECT_EQ(ParseYieldModes("", &modes), "");
  EXPECT_TRUE(modes.empty()) << "an empty policy: the robot never yields";
  YieldOptions o;
  std::string why;
  EXPECT_TRUE(o.IsValid(&why)) << why;
  o.margin_m = -1;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("yield.margin_m = -1"), std::string::npos) << why;
  o = YieldOptions{};
  o.modes = {"manual"};
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("'manual' cannot yield"), std::string::npos) << why;

  YieldCommand c = FromYa();
  EXPECT_EQ(CheckYieldCommand(c), "");
  c.passing_radius_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(CheckYieldCommand(c).find("passing_radius_m = nan must be in (0, 5]"), std::string::npos)
      << CheckYieldCommand(c);
  c = FromYa();
  c.keep_clear_M.clear();
  EXPECT_NE(CheckYieldCommand(c).find("keep_clear_M has 0 points (1..32)"), std::string::npos);
  c = FromYa();
  c.keep_clear_M[1].y() = std::numeric_limits<double>::infinity();
  EXPECT_NE(CheckYieldCommand(c).find("keep_clear_M[1]"), std::string::npos);
  c = FromYa();
  c.passing_id = std::string("y\x01", 2);
  EXPECT_NE(CheckYieldCommand(c).find("passing_id"), std::string::npos);
}

// yb at (14, 5) in `mode`, not asking anyone.
YieldSituation Situation(const std::string& mode, const nav::TraversabilityGrid* grid) {
  return YieldSituation{"yb", mode, At(14, 5), 0.3, grid, YieldStatus{}, false, ""};
}

// Parked idle at (14, 5) in the 2 m tunnel, yb's spot is in the bay (x 19..21), 1.1 m (both footprints and
// the 0.5 m margin) or more off ya's route; in manual control, or in a mode outside the policy, it refuses
// and says why; a drive limit short of the bay finds none.
TEST(YieldPolicyTest, AnIdleRobotStandsAsideInTheBayAndOneInManualControlRefuses) {
  const YieldOptions options;
  const auto grid = NarrowGrid();
  const YieldDecision idle = DecideYield(options, FromYa(), Situation("idle", grid.get()));
  ASSERT_TRUE(idle.accepted) << idle.refusal;
  EXPECT_NEAR(idle.clearance_m, 1.1, 1e-9);
  EXPECT_GE(idle.spot.p_W.x(), 19.0);
  EXPECT_LE(idle.spot.p_W.x(), 21.0);
  EXPECT_GE(idle.spot.p_W.y(), 6.1 - 1e-9);
  EXPECT_NEAR(idle.spot.drive_m, 6.6, 1.0);

  const YieldDecision manual = DecideYield(options, FromYa(), Situation("manual", grid.get()));
  EXPECT_FALSE(manual.accepted);
  EXPECT_EQ(manual.refusal, "in manual control: its operator drives it");
  EXPECT_EQ(DecideYield(options, FromYa(), Situation("smart_joystick", grid.get())).refusal,
            "driven by its operator (smart joystick)");
  EXPECT_EQ(DecideYield(options, FromYa(), Situation("convoy", grid.get())).refusal,
            "in mode convoy, which does not yield (yield.modes: idle, waypoint, explore)");
  EXPECT_EQ(DecideYield(options, FromYa(), Situation("idle", nullptr)).refusal,
            "no navigation map to find a spot on");
  // Head-on (both asked each other): the larger id gives way, unless the other already refused it; a robot
  // never yields to one that is getting out of its own way.
  YieldSituation head_on = Situation("waypoint", grid.get());
  head_on.asking = YieldStatus{YieldStatus::State::kAsking, "ya", "asked ya"};
  EXPECT_TRUE(DecideYield(options, FromYa(), head_on).accepted) << "yb > ya: yb gives way";
  head_on.own_id = "aa";
  EXPECT_EQ(DecideYield(options, FromYa(), head_on).refusal,
            "both asked each other: ya gives way (the larger id does, unless it cannot)");
  head_on.asking.state = YieldStatus::State::kBlocked;
  EXPECT_TRUE(DecideYield(options, FromYa(), head_on).accepted) << "ya refused aa: aa gives way if it can";
  head_on.passing_yields_to_me = true;
  EXPECT_EQ(DecideYield(options, FromYa(), head_on).refusal, "ya is getting out of aa's way");
  // Its operator ended the last yield for ya (a stop): not taken up again at once.
  YieldSituation stopped = Situation("idle", grid.get());
  stopped.ended_lately = "its last yield for ya was ended 3 s ago (stopped by op1): not again for 30 s";
  EXPECT_EQ(DecideYield(options, FromYa(), stopped).refusal, stopped.ended_lately);
  YieldOptions short_drive;
  short_drive.max_drive_m = 3.0;
  const YieldDecision none = DecideYield(short_drive, FromYa(), Situation("idle", grid.get()));
  EXPECT_FALSE(none.accepted);
  EXPECT_NE(
      none.refusal.find("no spot to stand aside on its map: no spot 1.1 m clear of the path within 3 m"),
      std::string::npos)
      << none.refusal;
}

Peer Parked(const std::string& id, double x, double y) {
  Peer p;
  p.robot_id = id;
  p.pose_M = At(x, y);
  p.footprint_radius_m = 0.3;
  p.mode = "idle";
  return p;
}

YieldAskInputs Driving(double x, const std::vector<Peer>& peers, double now_s) {
  YieldAskInputs in;
  in.pose_M = At(x, 5.0);
  in.radius_m = 0.3;
  for (double px = x + 1; px <= 30.0; px += 1.0) in.route_M.emplace_back(px, 5.0, 0.0);
  in.peers = peers;
  in.grid = [] { return NarrowGrid(); };
  in.now_s = now_s;
  return in;
}

// ya asks yb, parked in its tunnel within lookahead, once per ask_every_s, and holds standoff_m before its
// body; a refusal is shown as blocked with the peer's reason and asked again only after 5 x ask_every_s; a
// peer aside for ya, one off the route (in the bay) or one that can be passed (where the bay widens the
// tunnel) blocks nothing; with no route the status clears.
TEST(YieldAskerTest, AsksAParkedPeerInANarrowPassageHoldsBeforeItAndReportsARefusal) {
  const YieldOptions options;
  YieldAsker asker(options, "ya");
  Peer yb = Parked("yb", 14.0, 5.0);
  YieldAsk ask = asker.Update(Driving(4.0, {yb}, 0.0));
  EXPECT_FALSE(ask.request) << "10 m ahead: beyond lookahead_m (8 m)";
  ask = asker.Update(Driving(7.0, {yb}, 1.0));
  ASSERT_TRUE(ask.request);
  EXPECT_EQ(ask.to_id, "yb");
  EXPECT_EQ(ask.request->passing_id, "ya");
  EXPECT_EQ(ask.request->keep_clear_M.front(), Eigen::Vector2d(7.0, 5.0));
  EXPECT_EQ(CheckYieldCommand(*ask.request), "");
  EXPECT_TRUE(ask.hold_reason.empty()) << "7 m ahead: drives on toward it";
  EXPECT_EQ(asker.status().state, YieldStatus::State::kAsking);
  EXPECT_FALSE(asker.Update(Driving(8.0, {yb}, 2.0)).request) << "asked 1 s ago";
  ask = asker.Update(Driving(12.0, {yb}, 3.1));
  EXPECT_TRUE(ask.request) << "no answer in ask_every_s: again";
  EXPECT_FALSE(ask.hold_reason.empty()) << "1.4 m from its body: holds";

  yb.yield_state = "refused";
  yb.yield_to_id = "ya";
  yb.yield_reason = "in manual control: its operator drives it";
  ask = asker.Update(Driving(12.0, {yb}, 4.0));
  EXPECT_FALSE(ask.request);
  EXPECT_EQ(asker.status().state, YieldStatus::State::kBlocked);
  EXPECT_NE(asker.status().reason.find("it refused to yield: in manual control"), std::string::npos)
      << asker.status().reason;
  EXPECT_FALSE(ask.hold_reason.empty());
  EXPECT_FALSE(asker.Update(Driving(12.0, {yb}, 12.0)).request) << "after a refusal: 5 x 2 s";
  EXPECT_TRUE(asker.Update(Driving(12.0, {yb}, 13.2)).request);

  yb.yield_state = "moving_aside";
  ask = asker.Update(Driving(12.0, {yb}, 14.0));
  EXPECT_FALSE(ask.request);
  EXPECT_FALSE(ask.hold_reason.empty()) << "still on the route, moving aside: wait";
  yb.yield_state = "aside";
  ask = asker.Update(Driving(12.0, {yb}, 15.5));
  EXPECT_TRUE(ask.request)
      << "aside for ya but still on its route (its route changed): asked again, to move on";
  EXPECT_FALSE(ask.hold_reason.empty());
  Peer in_bay = Parked("yb", 20.0, 7.0);
  in_bay.yield_state = "aside";
  in_bay.yield_to_id = "ya";
  EXPECT_TRUE(asker.Update(Driving(12.0, {in_bay}, 16.0)).hold_reason.empty())
      << "aside in the bay: off the route";
  EXPECT_EQ(asker.status().state, YieldStatus::State::kNone);
  EXPECT_FALSE(asker.Update(Driving(14.0, {Parked("yc", 20.0, 5.0)}, 17.0)).request)
      << "beside the bay there is room to pass";
  YieldAskInputs none;
  EXPECT_FALSE(asker.Update(none).request);
  EXPECT_EQ(asker.status().state, YieldStatus::State::kNone);
}

struct YieldRun {
  double ya_s = -1, ye_s = -1;  // from the goto to arrival, simulated seconds
  double closest_m = std::numeric_limits<double>::infinity();
  bool moved_aside = false, aside_in_bay = false, contact = false, ya_arrived = false;
  std::string yb_mode, yb_reason;
  Eigen::Vector2d yb_end = Eigen::Vector2d::Zero(), yb_parked = Eigen::Vector2d::Zero();
};

// yb drives from `yb_start` to `park` and stays there (idle); then ya drives the south tunnel from (4, 5) to
// (30, 5) through yb, and ye the empty north tunnel from (4, 15) to (30, 15) at the same time. Every robot
// is the agent stepped at 50 Hz simulated, sending its peer state at 5 Hz and its yield requests as it does
// over DDS. Scored on the simulator's ground truth.
YieldRun RunYield(const core::PlanarPose& yb_start, const Eigen::Vector2d& park) {
  AgentTeam team("builtin:narrow", {{"ya", {4.0, 5.0, 0.0}}, {"yb", yb_start}, {"ye", {4.0, 15.0, 0.0}}});
  const RobotModes& ya = team.modes(0);
  const RobotModes& yb = team.modes(1);
  const RobotModes& ye = team.modes(2);
  YieldRun run;
  EXPECT_EQ(team.Goto(1, park.x(), park.y()), "");
  while (yb.waypoint().has_goal() && team.now_s() < 60) team.StepOnce();
  EXPECT_LT(team.now_s(), 60) << "yb parks";
  team.StepFor(1.0);  // at rest
  run.yb_parked = {team.truth(1).x_m, team.truth(1).y_m};
  EXPECT_EQ(team.Goto(0, 30.0, 5.0), "");
  EXPECT_EQ(team.Goto(2, 30.0, 15.0), "");
  const double start_s = team.now_s();
  while (team.now_s() < start_s + 150) {
    team.StepOnce();
    const double t = team.now_s();
    if (run.ya_s < 0 && !ya.waypoint().has_goal()) run.ya_s = t - start_s;
    if (run.ye_s < 0 && !ye.waypoint().has_goal()) run.ye_s = t - start_s;
    const sim::UnicycleState a = team.truth(0), b = team.truth(1);
    run.closest_m = std::min(run.closest_m, std::hypot(a.x_m - b.x_m, a.y_m - b.y_m));
    const YieldStatus::State s = yb.yield().status().state;
    run.moved_aside = run.moved_aside || s == YieldStatus::State::kMovingAside;
    run.aside_in_bay =
        run.aside_in_bay || (s == YieldStatus::State::kAside && b.y_m > 5.9 && b.x_m > 19 && b.x_m < 21);
    if (run.ya_s > 0 && run.ye_s > 0 && yb.control().mode() == "idle") break;
  }
  for (std::size_t i = 0; i < team.size(); ++i) run.contact = run.contact || team.ever_in_contact(i);
  run.ya_arrived = ya.waypoint().goal().status == GoalStatus::kArrived;
  run.yb_mode = yb.control().mode();
  run.yb_reason = yb.yield().status().reason;
  run.yb_end = {team.truth(1).x_m, team.truth(1).y_m};
  std::printf(
      "FIGURE yield_in_process yb parked at (%.0f, %.0f): ya %.1f s through yb, ye %.1f s through the "
      "empty tunnel: %.1f s lost (x%.2f); closest %.2f m\n",
      park.x(), park.y(), run.ya_s, run.ye_s, run.ya_s - run.ye_s, run.ya_s / run.ye_s, run.closest_m);
  return run;
}

void ExpectYielded(const YieldRun& run) {
  ASSERT_GT(run.ya_s, 0) << "ya arrives; yb: " << run.yb_reason;
  ASSERT_GT(run.ye_s, 0);
  EXPECT_TRUE(run.ya_arrived);
  EXPECT_TRUE(run.moved_aside);
  EXPECT_TRUE(run.aside_in_bay) << "yb stood aside in the bay";
  EXPECT_EQ(run.yb_mode, "idle");
  EXPECT_EQ(run.yb_reason.find("back at"), 0u) << run.yb_reason;
  EXPECT_LT((run.yb_end - run.yb_parked).norm(), 0.5) << "yb returned to where it stood";
  EXPECT_GT(run.closest_m, 0.6) << "never touching";
  EXPECT_FALSE(run.contact);
  EXPECT_LT(run.ya_s - run.ye_s, 40.0) << "the yield costs a bounded wait, not a stall";
}

// yb parked west of the bay (ya's side): it drives on east, ahead of ya, into the bay.
TEST(YieldTest, ARobotParkedBeforeTheBayDrivesOnIntoItAndReturns) {
  ExpectYielded(RunYield({26.0, 5.0, M_PI}, {14.0, 5.0}));
}

// yb parked east of the bay: it drives toward ya, into the bay, while ya holds short of it.
TEST(YieldTest, ARobotParkedBeyondTheBayBacksIntoItWhileTheOtherHolds) {
  ExpectYielded(RunYield({16.0, 5.0, 0.0}, {24.0, 5.0}));
}

// yb, idle at (24, 5), hears ya once (a peer state at (12, 5), as a robot passing out of radio range), is
// asked by it to clear the south tunnel and drives toward the bay; a rock then falls on the bay, so its way
// to the spot fails. Having left where it stood, yb waits where it stopped (it does not end the yield out of
// place), and once ya counts as gone it drives back.
TEST(YieldTest, ARobotStoppedShortOfItsSpotWaitsThereAndReturns) {
  AgentTeam team("builtin:narrow", {{"yb", {24.0, 5.0, M_PI}}});
  const RobotModes& yb = team.modes(0);
  team.StepFor(2.0);  // a map first
  const Eigen::Vector2d parked(team.truth(0).x_m, team.truth(0).y_m);
  // ya is not stepped here: its link sends what it would (a robot yields only to a robot it hears).
  const std::shared_ptr<InProcessLink> ya = team.links().Join("ya");
  Peer ya_state;
  ya_state.robot_id = "ya";
  ya_state.pose_M.x_m = 12.0;
  ya_state.pose_M.y_m = 5.0;
  ya_state.footprint_radius_m = 0.3;
  ya_state.mode = "waypoint";
  // The request makes the idle yb listen to its peers first; it decides once ya could be heard, and ya's
  // states (5 Hz) stop once it moves aside (ya passes out of radio range).
  ya->Send("yb", FromYa(12.0));
  const double asked_s = team.now_s();
  for (int cycle = 0; team.now_s() < asked_s + 5 && yb.yield().status().state == YieldStatus::State::kNone;
       ++cycle) {
    if (cycle % 10 == 0) ya->SendPeerState(ya_state);
    team.StepOnce();
  }
  ASSERT_EQ(yb.yield().status().state, YieldStatus::State::kMovingAside) << yb.yield().status().reason;
  auto moved_m = [&] { return (Eigen::Vector2d(team.truth(0).x_m, team.truth(0).y_m) - parked).norm(); };
  while (team.now_s() < 30 && moved_m() < 0.6 &&
         yb.yield().status().state == YieldStatus::State::kMovingAside)
    team.StepOnce();
  ASSERT_GE(moved_m(), 0.6) << yb.yield().status().reason;
  team.platform(0).DropRock(Eigen::AlignedBox2d(Eigen::Vector2d(18.5, 5.8), Eigen::Vector2d(21.5, 8.0)), 1.5);
  bool waited_short = false;
  std::string short_reason;
  const double rock_s = team.now_s();
  while (team.now_s() < rock_s + 60 && yb.control().mode() != "idle") {
    team.StepOnce();
    if (yb.yield().status().state == YieldStatus::State::kAside &&
        yb.yield().status().reason.find("short of the spot") != std::string::npos) {
      waited_short = true;
      short_reason = yb.yield().status().reason;
    }
  }
  std::printf("yb aside: %s; at the end: %s\n", short_reason.c_str(), yb.yield().status().reason.c_str());
  EXPECT_TRUE(waited_short) << yb.yield().status().reason;
  EXPECT_EQ(yb.control().mode(), "idle");
  EXPECT_EQ(yb.yield().status().reason.find("back at"), 0u) << yb.yield().status().reason;
  EXPECT_LT(moved_m(), 0.5) << "yb returned to where it stood";
  EXPECT_FALSE(team.ever_in_contact(0));
}

// Head-on in the 2 m tunnel: ya drives east to (30, 5) while yb drives west to (4, 5). With the default peer
// margin (0.25 m) two wheeled robots squeeze past each other there; a team that keeps 0.6 m from peers
// cannot, so they stop before each other and one asks the other (both, at once: the larger id gives way). The
// one asked drives back to the nearest spot clear of the other's route (the bay or the west junction,
// whichever it can reach without passing the other), waits until the other has passed or stopped, and then
// drives on to its own goal, planned again from there (asking in turn, if the other now stands in its way).
// Exactly one gives way at first; both arrive; nobody touches.
TEST(YieldTest, HeadOnInATunnelOneGivesWayAndBothArrive) {
  AgentTeam team("builtin:narrow", {{"ya", {4.0, 5.0, 0.0}}, {"yb", {26.0, 5.0, M_PI}}},
                 /*peer_margin_m=*/0.6);
  const RobotModes& ya = team.modes(0);
  const RobotModes& yb = team.modes(1);
  ASSERT_EQ(team.Goto(0, 30.0, 5.0), "");
  ASSERT_EQ(team.Goto(1, 4.0, 5.0), "");
  double closest_m = std::numeric_limits<double>::infinity();
  bool yb_yielded = false, ya_yielded = false, both_at_once = false;
  auto at = [&](std::size_t i, double x, double y) {
    const sim::UnicycleState s = team.truth(i);
    return std::hypot(s.x_m - x, s.y_m - y) < 0.5 && team.modes(i).control().mode() == "idle";
  };
  while (team.now_s() < 200 && !(at(0, 30, 5) && at(1, 4, 5))) {
    team.StepOnce();
    const sim::UnicycleState a = team.truth(0), b = team.truth(1);
    closest_m = std::min(closest_m, std::hypot(a.x_m - b.x_m, a.y_m - b.y_m));
    both_at_once = both_at_once || (yb.yield().active() && ya.yield().active());
    yb_yielded = yb_yielded || yb.yield().active();
    ya_yielded = ya_yielded || ya.yield().active();
  }
  EXPECT_TRUE(ya_yielded || yb_yielded);
  EXPECT_FALSE(both_at_once) << "never both at once";
  EXPECT_EQ(ya.waypoint().goal().status, GoalStatus::kArrived) << ya.waypoint().goal().reason;
  EXPECT_EQ(yb.waypoint().goal().status, GoalStatus::kArrived) << yb.waypoint().goal().reason;
  EXPECT_TRUE(at(0, 30, 5)) << ya.yield().status().reason;
  EXPECT_TRUE(at(1, 4, 5)) << yb.yield().status().reason;
  EXPECT_GT(closest_m, 0.6);
  EXPECT_FALSE(team.ever_in_contact(0) || team.ever_in_contact(1));
  std::printf("FIGURE yield_head_on: both arrived after %.1f s (%s gave way first); closest %.2f m\n",
              team.now_s(), ya_yielded ? "ya" : "yb", closest_m);
}

// A peer state that says a robot stands in ya's 2 m tunnel at (14, 5), sent at 5 Hz by no robot at all (a
// forged one: it never answers a yield request) until `silent_after_s` (simulated seconds after ya's goto).
// ya, with navigation.max_hold_s `max_hold_s`, drives from (4, 5) to (30, 5). Returns ya's goal as it ended
// (or stood after 120 s), where ya got to and how long it was held.
struct ForgedBlockRun {
  WaypointGoal goal;
  double farthest_x_m = 0.0;  // ground truth
  double held_s = 0.0;
  double ended_s = -1.0;  // since the goto
};
ForgedBlockRun RunForgedBlock(double max_hold_s, double silent_after_s) {
  AgentTeam team("builtin:narrow", {{"ya", {4.0, 5.0, 0.0}}}, nav::PeerAvoidanceOptions{}.margin_m,
                 [&](AgentOptions* options) { options->navigation.max_hold_s = max_hold_s; });
  const RobotModes& ya = team.modes(0);
  const std::shared_ptr<InProcessLink> r9 = team.links().Join("r9");  // sends states, answers nothing
  team.StepFor(2.0);                                                  // a map first
  EXPECT_EQ(team.Goto(0, 30.0, 5.0), "");
  const double start_s = team.now_s();
  ForgedBlockRun run;
  for (int cycle = 1; team.now_s() < start_s + 120 && ya.waypoint().has_goal(); ++cycle) {
    team.StepOnce();
    if (cycle % 10 == 0 && team.now_s() - start_s < silent_after_s)
      r9->SendPeerState(Parked("r9", 14.0, 5.0));
    if (team.robot(0).navigation().local_status().rfind("held: ", 0) == 0) run.held_s += AgentTeam::kCycleS;
    run.farthest_x_m = std::max(run.farthest_x_m, team.truth(0).x_m);
  }
  if (!ya.waypoint().has_goal()) run.ended_s = team.now_s() - start_s;
  run.goal = ya.waypoint().goal();
  std::printf(
      "FIGURE forged_peer_block (max_hold_s %.0f, forged state for %.0f s): %s after %.1f s, held %.1f s, "
      "got to x %.2f: %s\n",
      max_hold_s, silent_after_s, run.goal.status == GoalStatus::kArrived ? "arrived" : "ended", run.ended_s,
      run.held_s, run.farthest_x_m, run.goal.reason.c_str());
  return run;
}
// The forged robot never moves and never answers: ya holds before it and asks, and after max_hold_s abandons
// the goal naming it, instead of waiting for good.
TEST(YieldTest, APeerThatNeverGetsOutOfTheWayHoldsARobotOnlyForItsBoundedWait) {
  const ForgedBlockRun run = RunForgedBlock(/*max_hold_s=*/20.0, /*silent_after_s=*/1e9);
  EXPECT_EQ(run.goal.status, GoalStatus::kFailed) << run.goal.reason;
  EXPECT_EQ(
      run.goal.reason.rfind("blocked by r9: held 20 s without progress (navigation.max_hold_s 20 s): ", 0),
      0u)
      << run.goal.reason;
  EXPECT_NEAR(run.held_s, 20.0, 0.5);
  EXPECT_GT(run.ended_s, 20.0);
  EXPECT_LT(run.ended_s, 60.0);
  EXPECT_LT(run.farthest_x_m, 14.0 - 0.6) << "never into the body the state claims";
}

// The forged state stops 15 s after the goto: past the peer timeout (its lease) it is ignored, and ya, held
// before it until then, drives on through where it claimed to stand and arrives.
TEST(YieldTest, APeerStatePastItsLeaseIsIgnored) {
  const ForgedBlockRun run = RunForgedBlock(/*max_hold_s=*/90.0, /*silent_after_s=*/15.0);
  EXPECT_EQ(run.goal.status, GoalStatus::kArrived) << run.goal.reason;
  EXPECT_GT(run.held_s, 1.0) << "held while the state was live";
  EXPECT_GT(run.farthest_x_m, 29.0);
}

}  // namespace
}  // namespace cairn::agent
