// The command interface's rules without DDS: who may command (the lock; a stop from anyone), one answer per
// command (retries from the reply cache, applied once), goals checked before planning and answered after it,
// the stick to the running mode only, and the holder's processes coming and going.
#include "cairn/agent/command/command_interface.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "cairn/agent/modes/modes.h"
#include "cairn/core/build_paths.h"

namespace cairn::agent {
namespace {

const std::string kTree = cairn::core::SourceDir() + "/config/mode_tree.xml";
const core::SteadyTime kT0 = core::SteadyTime{} + std::chrono::seconds(100);

// A mode that records the sticks it gets.
class StickMode : public ModeModule {
 public:
  StickMode(const std::string& name, const std::string& channel)
      : ModeModule(name, MuxChannelOptions{channel, 0.5}) {}
  ModeOutput Step(const ModeInputs&) override { return {}; }
  void OnOperatorTwist(const OperatorTwist& twist, core::SteadyTime) override { sticks.push_back(twist); }
  std::vector<OperatorTwist> sticks;
};

CommandSender OpA(const std::string& writer = "wA") { return CommandSender{"opA", "pA", writer}; }
CommandSender OpB() { return CommandSender{"opB", "pB", "wB"}; }

// One robot's command interface on the shipped tree, with recording hooks.
struct Robot {
  Robot() {
    ModeRegistry r;
    r.Emplace<IdleMode>();
    manual = &r.Emplace<StickMode>("manual", "teleop");
    joystick = &r.Emplace<StickMode>("smart_joystick", "smart_joystick");
    r.Emplace<StickMode>("waypoint", "waypoint");
    r.Emplace<StickMode>("explore", "explore");
    r.Emplace<StickMode>("convoy", "convoy");
    r.Emplace<StickMode>("yield", "yield");
    modes = std::make_unique<ModeControl>(kTree, std::move(r), "r1");
    CommandInterface::Hooks hooks;
    hooks.conditions = [this] { return Conditions(); };
    hooks.send = [this](const CommandReply& reply) { replies.push_back(reply); };
    hooks.plan_goal = [this](const GoalCommand& goal) { planned.push_back(goal); };
    hooks.start_goal = [this](const GoalCommand&, const nav::GlobalPlan&) {
      has_goal = true;  // as WaypointMode::Start: the tree decides with the new goal in place
      const ModeDecision d = modes->Request("waypoint", Conditions());
      if (!d.accepted) {
        has_goal = false;
        return CommandOutcome{false, d.reason, 0};
      }
      return CommandOutcome{true, "path 5.0 m, ETA 5 s", 42};
    };
    hooks.start_explore = [this](const ExploreCommand& c) {
      explored.push_back(c);
      has_task = true;  // as ExploreMode::Start: the tree decides with the task in place
      const ModeDecision d = modes->Request("explore", Conditions());
      if (!d.accepted) {
        has_task = false;
        return CommandOutcome{false, d.reason, 0};
      }
      return CommandOutcome{true, "exploring 9", 9};
    };
    hooks.convoy = [this](const ConvoyCommand& c) {
      convoys.push_back(c);
      return c.stop ? CommandOutcome{true, "left the convoy", 0}
                    : CommandOutcome{true, "following " + c.ahead_ids.front(), 0};
    };
    hooks.restart_component = [this](const std::string& component, const std::string& by) {
      if (component != "perception") return std::string("no component \"" + component + "\"");
      restarts.push_back(component + " by " + by);
      return std::string();
    };
    command = std::make_unique<CommandInterface>("r1", ControlLockOptions{}, modes.get(), "waypoint", hooks);
  }
  ModeConditions Conditions() {
    ModeConditions c;
    command->FillConditions(&c);
    c.localized = true;
    c.local_planner_healthy = planner_healthy;
    c.local_planner_problem = "no obstacle input for 1.2 s";
    c.has_waypoint_goal = has_goal;
    c.has_explore_task = has_task;
    c.mapping_healthy = mapping_healthy;
    c.mapping_problem = "no lidar scan for 3.5 s";
    return c;
  }
  void Take(const CommandSender& who) {
    command->OnControl(ControlCommand{who, 1, ControlAction::kRequest, "", ""}, kT0);
  }
  const CommandReply& last() const { return replies.back(); }

  StickMode* manual = nullptr;
  StickMode* joystick = nullptr;
  std::unique_ptr<ModeControl> modes;
  std::unique_ptr<CommandInterface> command;
  std::vector<CommandReply> replies;
  std::vector<GoalCommand> planned;
  std::vector<ExploreCommand> explored;
  std::vector<ConvoyCommand> convoys;
  std::vector<std::string> restarts;
  bool planner_healthy = true;
  bool has_goal = false;
  bool has_task = false;
  bool mapping_healthy = true;
};

GoalCommand Goal(const CommandSender& who, uint32_t id, double x = 5.0, double y = 1.0) {
  return GoalCommand{who, id, "map", x, y, 0.0};
}

TEST(CommandInterface, OnlyTheHoldersCommandsRunAndOthersAreToldWhoHoldsTheLock) {
  Robot r;
  r.Take(OpA());
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().holder_id, "opA");
  r.Take(OpB());
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason.rfind("robot r1 is locked by basestation opA: asked opA to hand it over", 0), 0u)
      << r.last().reason;

  r.command->OnMode(ModeCommand{OpB(), 7, "manual"});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  EXPECT_EQ(r.last().reason,
            "basestation opB does not hold the control lock: robot r1 is locked by basestation opA");
  EXPECT_EQ(r.last().requester_participant, "pB") << "the reply goes to the process that asked";
  EXPECT_EQ(r.command->lock().discarded(), 1u);
  EXPECT_EQ(r.modes->mode(), "idle");

  r.command->OnMode(ModeCommand{OpA(), 2, "manual"});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted) << r.last().reason;
  EXPECT_EQ(r.last().mode, "manual");
  EXPECT_EQ(r.last().valid_modes, (std::vector<std::string>{"idle", "manual"}));
  EXPECT_TRUE(r.last().goal_acceptable);
  EXPECT_EQ(r.last().kind, CommandKind::kMode);
}

TEST(CommandInterface, ARetryIsAnsweredFromTheCacheAndAppliedOnce) {
  Robot r;
  r.Take(OpA());
  r.command->OnMode(ModeCommand{OpA(), 5, "manual"});
  ASSERT_EQ(r.modes->mode(), "manual");
  r.command->OnStop(StopCommand{OpB(), 1});
  ASSERT_EQ(r.modes->mode(), "idle");
  const std::size_t before = r.replies.size();
  r.command->OnMode(ModeCommand{OpA(), 5, "manual"});  // the same writer's retry
  ASSERT_EQ(r.replies.size(), before + 1);
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().mode, "manual") << "the reply first given";
  EXPECT_EQ(r.modes->mode(), "idle") << "a retry is not applied again";
  // Another process with the same base id and request id is another command: it runs.
  r.command->OnMode(ModeCommand{OpA("wA2"), 5, "manual"});
  EXPECT_EQ(r.modes->mode(), "manual");
}

TEST(CommandInterface, AStopFromAnyoneStopsAndLeavesTheLockWhereItIs) {
  Robot r;
  r.Take(OpA());
  r.command->OnMode(ModeCommand{OpA(), 2, "manual"});
  r.command->OnStop(StopCommand{OpB(), 9});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().reason, "stopped (was manual): zero twist, mode idle");
  EXPECT_EQ(r.modes->mode(), "idle");
  EXPECT_FALSE(r.modes->last_output().forwarding);
  EXPECT_EQ(r.command->lock().holder_id(), "opA");
  EXPECT_EQ(r.command->stops().count, 1u);
  EXPECT_EQ(r.command->stops().by, "opB");
  EXPECT_GT(r.command->stops().at.sec, 0);
}

TEST(CommandInterface, AReleaseStopsTheRobot) {
  Robot r;
  r.Take(OpA());
  r.command->OnMode(ModeCommand{OpA(), 2, "manual"});
  r.command->OnControl(ControlCommand{OpB(), 3, ControlAction::kRelease, "", ""}, kT0);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "only the holder releases: robot r1 is locked by basestation opA");
  EXPECT_EQ(r.modes->mode(), "manual");
  r.command->OnControl(ControlCommand{OpA(), 3, ControlAction::kRelease, "", ""}, kT0);
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().kind, CommandKind::kControlRelease);
  EXPECT_EQ(r.modes->mode(), "idle");
}

// A control command holding a value no basestation sends (an unknown action) is refused with it, and the lock
// is neither taken nor released.
// A handover keeps what the robot does: the goal it drives stays, in its mode, now the new holder's; only the
// holder hands over, and the answer is not a mission command (a paused mission is not ended by it).
TEST(CommandInterface, AGrantHandsTheLockOverKeepingTheModeAndGoal) {
  Robot r;
  r.Take(OpA());
  r.command->OnGoal(Goal(OpA(), 2));
  ASSERT_EQ(r.planned.size(), 1u);
  r.command->OnGoalPlanned(r.planned.back(), nav::GlobalPlan{});
  ASSERT_EQ(r.modes->mode(), "waypoint");
  const std::uint64_t missions = r.command->mission_commands();

  r.Take(OpB());
  ASSERT_EQ(r.last().result, CommandResult::kDenied);
  ASSERT_TRUE(r.command->lock().pending_request().has_value());
  r.command->OnControl(ControlCommand{OpB(), 2, ControlAction::kHandover, "", "opB"}, kT0);
  EXPECT_EQ(r.last().kind, CommandKind::kControlHandover);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "only the holder hands over: robot r1 is locked by basestation opA");
  EXPECT_EQ(r.command->lock().holder_id(), "opA");

  r.command->OnControl(ControlCommand{OpA(), 3, ControlAction::kHandover, "", "opB"}, kT0);
  EXPECT_EQ(r.last().result, CommandResult::kAccepted) << r.last().reason;
  EXPECT_EQ(r.last().holder_id, "opB");
  EXPECT_EQ(r.modes->mode(), "waypoint") << "the goal is driven on for its new holder";
  EXPECT_TRUE(r.has_goal);
  EXPECT_EQ(r.command->mission_commands(), missions);
  EXPECT_EQ(r.command->lock().handover_outcome(), "opA granted opB's request: opB holds the lock");

  // The new holder commands; the old one is discarded.
  r.command->OnMode(ModeCommand{OpA(), 4, "idle"});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  r.command->OnMode(ModeCommand{OpB(), 3, "idle"});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);

  // A denial with no request waiting is refused, naming what is wrong.
  r.command->OnControl(ControlCommand{OpB(), 4, ControlAction::kDeny, "", "opA"}, kT0);
  EXPECT_EQ(r.last().kind, CommandKind::kControlDeny);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "no request from basestation opA waits for robot r1's lock");
}

TEST(CommandInterface, AMalformedControlCommandIsRefusedNamingTheValue) {
  Robot r;
  ControlCommand odd{OpB(), 1, ControlAction::kRequest,
                     "action 99 is none of REQUEST, RELEASE, HANDOVER, DENY (0-3)", ""};
  r.command->OnControl(odd, kT0);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "refused: action 99 is none of REQUEST, RELEASE, HANDOVER, DENY (0-3)");
  EXPECT_EQ(r.command->lock().holder_id(), "");
  r.Take(OpA());
  odd.request_id = 2;
  odd.action = ControlAction::kRelease;
  r.command->OnControl(odd, kT0);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.command->lock().holder_id(), "opA");
}

TEST(CommandInterface, AGoalIsCheckedBeforePlanningNamingFieldAndValue) {
  Robot r;
  r.Take(OpA());
  r.command->OnGoal(Goal(OpB(), 1));
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  GoalCommand odom = Goal(OpA(), 2);
  odom.frame_id = "odom";
  r.command->OnGoal(odom);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "goal frame_id 'odom' is not supported (use 'map')");
  r.command->OnGoal(Goal(OpA(), 3, std::numeric_limits<double>::quiet_NaN(), 1.0));
  EXPECT_EQ(r.last().reason, "goal (nan, 1) is not a finite point");
  GoalCommand wide = Goal(OpA(), 4);
  wide.tolerance_m = 7.0;
  r.command->OnGoal(wide);
  EXPECT_EQ(r.last().reason, "goal tolerance_m = 7.000000 must be in [0, 5]");
  // The mode could not be entered now: refused before planning, with the tree's reason.
  r.planner_healthy = false;
  r.command->OnGoal(Goal(OpA(), 5));
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "IsLocalPlannerHealthy: no obstacle input for 1.2 s");
  EXPECT_FALSE(r.last().goal_acceptable);
  EXPECT_TRUE(r.planned.empty());
}

TEST(CommandInterface, AGoalIsAnsweredOnceItsPlanIsDoneAndARetryMeanwhileIsIgnored) {
  Robot r;
  r.Take(OpA());
  const std::size_t before = r.replies.size();
  r.command->OnGoal(Goal(OpA(), 6));
  ASSERT_EQ(r.planned.size(), 1u);
  EXPECT_EQ(r.replies.size(), before) << "no answer before the plan";
  r.command->OnGoal(Goal(OpA(), 6));
  EXPECT_EQ(r.planned.size(), 1u) << "a retry while planning is not planned again";
  EXPECT_EQ(r.replies.size(), before);
  r.command->OnGoalPlanned(r.planned[0], nav::GlobalPlan{});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().reason, "path 5.0 m, ETA 5 s");
  EXPECT_EQ(r.last().goal_id, 42u);
  EXPECT_EQ(r.last().mode, "waypoint");
  r.command->OnGoal(Goal(OpA(), 6));
  EXPECT_EQ(r.planned.size(), 1u) << "a retry after the answer is answered from the cache";
  EXPECT_EQ(r.last().goal_id, 42u);
}

// Home R is a goal to the robot's start (its level too), or to the point sent; its answer is a home
// answer, and it is the holder's only.
TEST(CommandInterface, HomeIsAGoalToTheStartOrThePointSent) {
  Robot r;
  core::BaseState start;
  start.x_m = 4.0;
  start.y_m = 20.0;
  start.z_m = 0.1;
  r.command->OnHome(HomeCommand{OpA(), 1, "map", false, 0, 0, std::nan("")}, start);
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  EXPECT_EQ(r.last().kind, CommandKind::kHome);
  r.Take(OpA());
  r.command->OnHome(HomeCommand{OpA(), 2, "map", false, 0, 0, std::nan("")}, start);
  ASSERT_EQ(r.planned.size(), 1u);
  EXPECT_EQ(r.planned[0].x_m, 4.0);
  EXPECT_EQ(r.planned[0].y_m, 20.0);
  EXPECT_EQ(r.planned[0].z_m, 0.1);
  EXPECT_EQ(r.planned[0].kind, CommandKind::kHome);
  r.command->OnGoalPlanned(r.planned[0], nav::GlobalPlan{});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().kind, CommandKind::kHome);
  EXPECT_EQ(r.last().request_id, 2u);
  r.command->OnHome(HomeCommand{OpA(), 3, "map", true, 7.5, -2.0, std::nan("")}, start);
  ASSERT_EQ(r.planned.size(), 2u);
  EXPECT_EQ(r.planned[1].x_m, 7.5);
  EXPECT_EQ(r.planned[1].y_m, -2.0);
  r.command->OnHome(HomeCommand{OpA(), 4, "odom", false, 0, 0, std::nan("")}, start);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_NE(r.last().reason.find("odom"), std::string::npos) << r.last().reason;
  EXPECT_EQ(r.planned.size(), 2u);
}

TEST(CommandInterface, AGoalWhoseLockMovedWhileItWasPlannedIsDiscarded) {
  Robot r;
  r.Take(OpA());
  r.command->OnGoal(Goal(OpA(), 6));
  ASSERT_EQ(r.planned.size(), 1u);
  r.command->OnControl(ControlCommand{OpA(), 7, ControlAction::kRelease, "", ""}, kT0);
  r.Take(OpB());
  r.command->OnGoalPlanned(r.planned[0], nav::GlobalPlan{});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  EXPECT_EQ(r.last().base_id, "opA");
  EXPECT_EQ(r.modes->mode(), "idle");
}

TEST(CommandInterface, TheHoldersFiniteStickReachesTheRunningModeOnly) {
  Robot r;
  r.Take(OpA());
  r.command->OnMode(ModeCommand{OpA(), 2, "manual"});
  r.command->OnTeleop(TeleopCommand{"opB", OperatorTwist{0.5, 0.0, 0.0}}, kT0);
  EXPECT_TRUE(r.manual->sticks.empty());
  EXPECT_EQ(r.command->lock().discarded(), 1u);
  r.command->OnTeleop(TeleopCommand{"opA", OperatorTwist{std::nan(""), 0.0, 0.0}}, kT0);
  EXPECT_TRUE(r.manual->sticks.empty()) << "a non-finite stick is dropped";
  r.command->OnTeleop(TeleopCommand{"opA", OperatorTwist{0.5, 0.0, 0.1}}, kT0);
  ASSERT_EQ(r.manual->sticks.size(), 1u);
  EXPECT_DOUBLE_EQ(r.manual->sticks[0].vx_mps, 0.5);
  EXPECT_TRUE(r.joystick->sticks.empty());
}

TEST(CommandInterface, TheHoldersJoystickAndLivelinessComeFromItsProcesses) {
  Robot r;
  r.Take(OpA());
  ModeConditions c;
  r.command->FillConditions(&c);
  EXPECT_EQ(c.holder_id, "opA");
  EXPECT_TRUE(c.holder_alive);
  EXPECT_FALSE(c.joystick_alive) << "no process of opA announced a joystick";
  r.command->OnBaseAnnounced(BaseAnnouncement{"infoA", "pA", "opA", true});
  r.command->FillConditions(&c);
  EXPECT_TRUE(c.joystick_alive);
  r.command->OnMode(ModeCommand{OpA(), 2, "smart_joystick"});
  ASSERT_EQ(r.modes->mode(), "smart_joystick") << r.last().reason;
  // Its only process's liveliness lapses: the holder is lost and the operator-driven mode stops.
  r.command->OnBaseLiveliness(WriterLiveliness{"infoA", true, false, false}, kT0);
  r.command->FillConditions(&c);
  EXPECT_FALSE(c.holder_alive);
  EXPECT_FALSE(c.joystick_alive);
  EXPECT_EQ(r.modes->mode(), "idle");
  EXPECT_EQ(r.command->lock().holder_id(), "opA") << "the lock is kept for lock_keep_s (forever by default)";
  // It comes back.
  r.command->OnBaseLiveliness(WriterLiveliness{"infoA", false, false, true}, kT0);
  r.command->FillConditions(&c);
  EXPECT_TRUE(c.holder_alive);
  EXPECT_TRUE(c.joystick_alive);
  // It leaves the domain.
  r.command->OnParticipantsGone({"pA"}, kT0);
  r.command->FillConditions(&c);
  EXPECT_FALSE(c.holder_alive);
  EXPECT_FALSE(c.joystick_alive);
}

// Explore R is the holder's; a bad frame or region is refused naming it; the tree's refusal names
// the failed condition (mapping); an accepted one answers with the task id and the robot explores.
TEST(CommandInterface, ExploreIsTheHoldersCheckedAndDecidedByTheTree) {
  Robot r;
  ExploreCommand explore{OpA(), 1, "map", {}};
  r.command->OnExplore(explore);
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded) << "no lock held: " << r.last().reason;
  r.Take(OpA());
  explore.request_id = 2;
  explore.frame_id = "odom";
  r.command->OnExplore(explore);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "frame_id 'odom' must be 'map'");
  explore.request_id = 3;
  explore.frame_id = "map";
  explore.task.region_M = Eigen::AlignedBox2d();
  explore.task.region_M->min() << 5, 0;
  explore.task.region_M->max() << 1, 4;
  r.command->OnExplore(explore);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_NE(r.last().reason.find("x0 must be below x1"), std::string::npos) << r.last().reason;
  EXPECT_TRUE(r.explored.empty()) << "a bad task never reaches the mode";
  explore.request_id = 4;
  explore.task.region_M->min() << 0, 0;
  r.mapping_healthy = false;
  r.command->OnExplore(explore);
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "IsMappingHealthy: no lidar scan for 3.5 s");
  EXPECT_EQ(r.modes->mode(), "idle");
  explore.request_id = 5;
  r.mapping_healthy = true;
  r.command->OnExplore(explore);
  EXPECT_EQ(r.last().result, CommandResult::kAccepted) << r.last().reason;
  EXPECT_EQ(r.last().kind, CommandKind::kExplore);
  EXPECT_EQ(r.last().goal_id, 9u);
  EXPECT_EQ(r.modes->mode(), "explore");
  ExploreCommand other{OpB(), 1, "map", {}};
  r.command->OnExplore(other);
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded) << "only the holder explores";
  EXPECT_EQ(r.modes->mode(), "explore");
}

TEST(CommandInterface, ConvoyIsTheHoldersAndAMalformedOneIsRefusedNamingTheValue) {
  Robot r;
  r.Take(OpA());
  r.command->OnConvoy(ConvoyCommand{OpB(), 3, false, {"r0"}, ""});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  EXPECT_EQ(r.last().kind, CommandKind::kConvoy);
  EXPECT_TRUE(r.convoys.empty());
  r.command->OnConvoy(
      ConvoyCommand{OpA(), 4, false, {}, "cairn/convoy_request: action = 7 is not FOLLOW (0) or STOP (1)"});
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_NE(r.last().reason.find("action = 7"), std::string::npos) << r.last().reason;
  EXPECT_TRUE(r.convoys.empty()) << "a malformed request never reaches the mode";
  r.command->OnConvoy(ConvoyCommand{OpA(), 5, false, {"r0", "rL"}, ""});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted) << r.last().reason;
  EXPECT_EQ(r.last().reason, "following r0");
  ASSERT_EQ(r.convoys.size(), 1u);
  EXPECT_EQ(r.convoys[0].ahead_ids, (std::vector<std::string>{"r0", "rL"}));
}

TEST(CommandInterface, RestartIsTheHoldersAndNamesAnUnknownComponent) {
  Robot r;
  r.command->OnRestart(RestartCommand{OpA(), 1, "perception"});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded) << "nobody holds the lock: not even that";
  r.Take(OpA());
  r.command->OnRestart(RestartCommand{OpB(), 1, "perception"});
  EXPECT_EQ(r.last().result, CommandResult::kDiscarded);
  EXPECT_TRUE(r.restarts.empty());
  r.command->OnRestart(RestartCommand{OpA(), 2, "lidar"});
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "no component \"lidar\"");
  r.command->OnRestart(RestartCommand{OpA(), 4, std::string(100000, 'x')});
  EXPECT_EQ(r.last().result, CommandResult::kDenied);
  EXPECT_EQ(r.last().reason, "component name of 100000 characters is not [a-z_]{1,64}");
  r.command->OnRestart(RestartCommand{OpA(), 3, "perception"});
  EXPECT_EQ(r.last().result, CommandResult::kAccepted);
  EXPECT_EQ(r.last().kind, CommandKind::kRestart);
  EXPECT_EQ(r.last().reason, "restarting perception");
  r.command->OnRestart(RestartCommand{OpA(), 3, "perception"});  // a retry: answered, not applied again
  EXPECT_EQ(r.restarts, (std::vector<std::string>{"perception by opA"}));
}

TEST(CommandInterface, NeedsEveryHookAndValidLockOptions) {
  Robot r;
  EXPECT_THROW(
      CommandInterface("r1", ControlLockOptions{}, r.modes.get(), "waypoint", CommandInterface::Hooks{}),
      std::invalid_argument);
  CommandInterface::Hooks hooks;
  hooks.conditions = [] { return ModeConditions{}; };
  hooks.send = [](const CommandReply&) {};
  hooks.plan_goal = [](const GoalCommand&) {};
  hooks.start_goal = [](const GoalCommand&, const nav::GlobalPlan&) { return CommandOutcome{}; };
  EXPECT_THROW(CommandInterface("r1", ControlLockOptions{}, r.modes.get(), "waypoint", hooks),
               std::invalid_argument)
      << "start_explore is required";
  hooks.start_explore = [](const ExploreCommand&) { return CommandOutcome{}; };
  EXPECT_THROW(CommandInterface("r1", ControlLockOptions{}, r.modes.get(), "waypoint", hooks),
               std::invalid_argument)
      << "convoy is required";
  hooks.convoy = [](const ConvoyCommand&) { return CommandOutcome{}; };
  EXPECT_THROW(CommandInterface("r1", ControlLockOptions{}, r.modes.get(), "waypoint", hooks),
               std::invalid_argument)
      << "restart_component is required";
  hooks.restart_component = [](const std::string&, const std::string&) { return std::string(); };
  EXPECT_THROW(CommandInterface("r1", ControlLockOptions{}, nullptr, "waypoint", hooks),
               std::invalid_argument);
  ControlLockOptions bad;
  bad.lock_keep_s = -1.0;
  EXPECT_THROW(CommandInterface("r1", bad, r.modes.get(), "waypoint", hooks), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
