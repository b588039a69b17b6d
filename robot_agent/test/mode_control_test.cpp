// The mode tree running mode modules through the mux, without DDS: the registry's rules, the load-time check
// of the tree against the modules and the mux, switching (activate/deactivate), stop, and a new mode added as
// one module plus one subtree.
#include "cairn/agent/modes/mode_control.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>
#include <memory>

#include "cairn/agent/modes/modes.h"
#include "cairn/core/build_paths.h"
#include "mode_test_util.h"

namespace cairn::agent {
namespace {

const std::string kTree = cairn::core::SourceDir() + "/config/mode_tree.xml";
const core::SteadyTime kT0 = core::SteadyTime{} + std::chrono::seconds(100);

core::SteadyTime At(double s) {
  return kT0 + std::chrono::duration_cast<core::SteadyClock::duration>(std::chrono::duration<double>(s));
}

// A module that records what happens to it and drives a fixed twist.
class FakeMode : public ModeModule {
 public:
  FakeMode(const std::string& name, const std::string& channel, Twist2 twist = {0.3, 0.1})
      : ModeModule(name, MuxChannelOptions{channel, 0.5}), twist_(twist) {}
  void Activate(core::SteadyTime now) override {
    ++activations;
    activated_at = now;
  }
  void Deactivate(const std::string& why) override { deactivations.push_back(why); }
  ModeOutput Step(const ModeInputs& in) override {
    ++steps;
    ModeOutput out;
    out.twist_B = twist_;
    out.stamp = in.now;
    out.done = finish_next_step;
    return out;
  }
  void OnOperatorTwist(const OperatorTwist& twist, core::SteadyTime) override { sticks.push_back(twist); }

  int activations = 0;
  core::SteadyTime activated_at;
  int steps = 0;
  bool finish_next_step = false;
  std::vector<std::string> deactivations;
  std::vector<OperatorTwist> sticks;

 private:
  Twist2 twist_;
};

struct Modes {
  FakeMode* manual = nullptr;
  FakeMode* joystick = nullptr;
  FakeMode* waypoint = nullptr;
};

// The shipped modes' names and channels, with fake behaviour.
ModeRegistry FakeRegistry(Modes* modes) {
  ModeRegistry r;
  r.Emplace<IdleMode>();
  modes->manual = &r.Emplace<FakeMode>("manual", "teleop");
  modes->joystick = &r.Emplace<FakeMode>("smart_joystick", "smart_joystick");
  modes->waypoint = &r.Emplace<FakeMode>("waypoint", "waypoint");
  r.Emplace<FakeMode>("explore", "explore");
  r.Emplace<FakeMode>("convoy", "convoy");
  r.Emplace<FakeMode>("yield", "yield");
  return r;
}

// The holder also has a live joystick.
ModeConditions Held() {
  ModeConditions c = mode_testing::Held();
  c.joystick_alive = true;
  return c;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

std::string WriteTemp(const std::string& name, const std::string& text) {
  std::string path = ::testing::TempDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

// The error a ModeControl throws loading `tree` with `registry`, or "(loaded)".
std::string LoadError(const std::string& tree, ModeRegistry registry) {
  try {
    ModeControl control(tree, std::move(registry), "r1");
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(loaded)";
}

TEST(ModeRegistry, RefusesNullEmptyAndDuplicateModesAndConflictingChannels) {
  ModeRegistry r;
  EXPECT_THROW(r.Add(nullptr), std::invalid_argument);
  EXPECT_THROW(r.Emplace<FakeMode>("", "teleop"), std::invalid_argument);
  r.Emplace<FakeMode>("manual", "teleop");
  EXPECT_THROW(r.Emplace<FakeMode>("manual", "other"), std::invalid_argument);
  // Two modes may feed one channel, with the same staleness rule only.
  class SlowTeleop : public FakeMode {
   public:
    SlowTeleop() : FakeMode("slow", "teleop") {}
  };
  EXPECT_NO_THROW(r.Emplace<SlowTeleop>());
  class Conflicting : public ModeModule {
   public:
    Conflicting() : ModeModule("conflicting", MuxChannelOptions{"teleop", 2.0}) {}
    ModeOutput Step(const ModeInputs&) override { return {}; }
  };
  try {
    r.Emplace<Conflicting>();
    FAIL() << "a channel with two timeouts was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(
        std::string(e.what()).find("mode 'conflicting' declares mux channel 'teleop' with timeout_s = 2.000"),
        std::string::npos)
        << e.what();
  }
  EXPECT_EQ(r.names(), (std::vector<std::string>{"manual", "slow"}));
  EXPECT_EQ(r.Find("slow")->channel().name, "teleop");
  EXPECT_EQ(r.Find("warp"), nullptr);
}

TEST(ModeRegistry, MuxChannelsAreTheModulesChannelsOnceWithoutNone) {
  Modes m;
  const ModeRegistry r = FakeRegistry(&m);
  std::vector<std::string> names;
  for (const auto& c : r.MuxChannels()) names.push_back(c.name);
  EXPECT_EQ(names,
            (std::vector<std::string>{"teleop", "smart_joystick", "waypoint", "explore", "convoy", "yield"}));
  EXPECT_EQ(r.ModeChannels().at("idle"), "none");
  EXPECT_EQ(r.ModeChannels().at("manual"), "teleop");
}

TEST(ModeControl, TheShippedTreeLoadsWithTheBuiltInModes) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  EXPECT_EQ(control.mode(), "idle");
  EXPECT_EQ(control.active().name(), "idle");
  EXPECT_EQ(control.mux().channel_names(),
            (std::vector<std::string>{"convoy", "explore", "smart_joystick", "teleop", "waypoint", "yield"}));
  EXPECT_EQ(control.last_output().active_channel, "none");
}

// Activations are stamped by the clock the control is given (a simulated one in stepped runs), never by the
// machine's; a null clock is refused.
TEST(ModeControl, StampsActivationsWithTheClockItIsGiven) {
  Modes m;
  auto clock = std::make_shared<core::SimulatedClock>();
  clock->SetSeconds(42.5);
  ModeControl control(kTree, FakeRegistry(&m), "r1", clock);
  ASSERT_TRUE(control.Request("manual", Held()).accepted);
  EXPECT_EQ(m.manual->activated_at, clock->Now());
  clock->SetSeconds(43.0);
  ASSERT_TRUE(control.Request("smart_joystick", Held()).accepted);
  EXPECT_EQ(m.joystick->activated_at, clock->Now());
  EXPECT_DOUBLE_EQ(std::chrono::duration<double>(m.joystick->activated_at.time_since_epoch()).count(), 43.0);
  EXPECT_THROW(clock->SetSeconds(42.0), std::invalid_argument) << "a clock never runs backwards";
  EXPECT_THROW(clock->SetSeconds(std::nan("")), std::invalid_argument);
  Modes other;
  EXPECT_THROW(ModeControl(kTree, FakeRegistry(&other), "r1", nullptr), std::invalid_argument);
}

// Every mode the tree can select exists as a module, with that module's channel, on the mux.
TEST(ModeControl, RefusesATreeModeWithoutAModuleNamingFileLineModeAndBranch) {
  ModeRegistry r;
  r.Emplace<IdleMode>();
  r.Emplace<FakeMode>("manual", "teleop");
  r.Emplace<FakeMode>("waypoint", "waypoint");
  const std::string error = LoadError(kTree, std::move(r));
  EXPECT_NE(error.find("no mode module implements mode 'smart_joystick' (modules: idle, manual, waypoint)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("mode_tree.xml:"), std::string::npos) << "the file and line are named: " << error;
  EXPECT_NE(error.find("branch 'smart_joystick'"), std::string::npos) << error;
}

TEST(ModeControl, RefusesATreeChannelTheMuxLacks) {
  // The waypoint module feeds another channel, so the mux (built from the modules) has no "waypoint" input.
  ModeRegistry r;
  r.Emplace<IdleMode>();
  r.Emplace<FakeMode>("manual", "teleop");
  r.Emplace<FakeMode>("smart_joystick", "smart_joystick");
  r.Emplace<FakeMode>("waypoint", "goal");
  r.Emplace<FakeMode>("explore", "explore");
  r.Emplace<FakeMode>("convoy", "convoy");
  r.Emplace<FakeMode>("yield", "yield");
  const std::string error = LoadError(kTree, std::move(r));
  EXPECT_NE(error.find("branch 'waypoint'"), std::string::npos) << error;
  EXPECT_NE(error.find(
                "names mux channel 'waypoint', which the mux does not have (channels: none, convoy, explore, "
                "goal, smart_joystick, teleop, yield)"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("mode_tree.xml:"), std::string::npos) << "the file and line are named: " << error;
}

TEST(ModeManager, RefusesATreeChannelOtherThanItsModulesNamingModeAndChannels) {
  // The mux has both channels; the tree's manual selects one its module does not feed.
  const std::string error = [] {
    try {
      ModeManager tree(kTree, {"teleop", "smart_joystick", "waypoint", "explore", "convoy", "yield"},
                       {{"idle", "none"},
                        {"manual", "smart_joystick"},
                        {"smart_joystick", "smart_joystick"},
                        {"waypoint", "waypoint"},
                        {"explore", "explore"},
                        {"convoy", "convoy"},
                        {"yield", "yield"}});
    } catch (const bt::TreeError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  }();
  EXPECT_NE(
      error.find("branch 'manual' (SelectMode mode=\"manual\") selects mux channel 'teleop', but mode module "
                 "'manual' feeds channel 'smart_joystick'"),
      std::string::npos)
      << error;
  EXPECT_NE(error.find("mode_tree.xml:"), std::string::npos) << error;
}

TEST(ModeControl, NeedsAnIdleModuleFeedingNone) {
  ModeRegistry no_idle;
  no_idle.Emplace<FakeMode>("manual", "teleop");
  EXPECT_NE(LoadError(kTree, std::move(no_idle)).find("no module for the fail-safe mode 'idle'"),
            std::string::npos);
  ModeRegistry driving_idle;
  driving_idle.Emplace<FakeMode>("idle", "teleop");
  EXPECT_NE(LoadError(kTree, std::move(driving_idle)).find("'idle' must feed channel 'none', not 'teleop'"),
            std::string::npos);
}

TEST(ModeControl, TheAcceptedModesModuleRunsAndOnlyItsChannelReachesTheDriver) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  ASSERT_TRUE(control.Request("manual", Held()).accepted);
  EXPECT_EQ(&control.active(), m.manual);
  EXPECT_EQ(m.manual->activations, 1);
  EXPECT_FALSE(control.Step(ModeInputs{At(0), 0.0, {}}));
  EXPECT_EQ(m.manual->steps, 1);
  EXPECT_EQ(m.waypoint->steps, 0) << "only the running mode steps";
  const MuxOutput out = control.Compute(At(0.01));
  EXPECT_TRUE(out.forwarding) << out.reason;
  EXPECT_EQ(out.active_channel, "teleop");
  EXPECT_DOUBLE_EQ(out.twist_B.linear_x_mps, 0.3);
  // The stick goes to the running mode only.
  control.OnOperatorTwist(OperatorTwist{0.5, 0.0, 0.2}, At(0.02));
  EXPECT_EQ(m.manual->sticks.size(), 1u);
  EXPECT_TRUE(m.joystick->sticks.empty());
  // A switch deactivates the mode left, saying which mode came.
  ASSERT_TRUE(control.Request("smart_joystick", Held()).accepted);
  EXPECT_EQ(m.manual->deactivations, (std::vector<std::string>{"mode switched to smart_joystick"}));
  EXPECT_EQ(m.joystick->activations, 1);
  EXPECT_EQ(control.Compute(At(0.03)).reason, "smart_joystick stale: no input since selected: zero twist");
  // Asking for the running mode again switches nothing.
  ASSERT_TRUE(control.Request("smart_joystick", Held()).accepted);
  EXPECT_EQ(m.joystick->activations, 1);
}

TEST(ModeControl, ARefusedRequestSwitchesNothing) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  const ModeDecision d = control.Request("waypoint", Held());  // no goal
  EXPECT_FALSE(d.accepted);
  EXPECT_NE(d.reason.find("HasWaypointGoal"), std::string::npos) << d.reason;
  EXPECT_EQ(control.active().name(), "idle");
  EXPECT_EQ(m.waypoint->activations, 0);
  EXPECT_FALSE(control.IsValid("waypoint", Held()));
  ModeConditions with_goal = Held();
  with_goal.has_waypoint_goal = true;
  EXPECT_TRUE(control.IsValid("waypoint", with_goal));
  EXPECT_EQ(control.mode(), "idle") << "IsValid must not switch";
}

TEST(ModeControl, ALostConditionDropsToIdleAndTellsTheModuleWhy) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  ASSERT_TRUE(control.Request("manual", Held()).accepted);
  ModeConditions lost = Held();
  lost.holder_alive = false;
  EXPECT_FALSE(control.Recheck(lost).accepted);
  EXPECT_EQ(control.active().name(), "idle");
  ASSERT_EQ(m.manual->deactivations.size(), 1u);
  EXPECT_NE(m.manual->deactivations[0].find("manual no longer allowed: IsHolderAlive"), std::string::npos)
      << m.manual->deactivations[0];
  EXPECT_EQ(control.Compute(At(0)).active_channel, "none");
}

TEST(ModeControl, StopDeactivatesEveryModuleAndZeroesTheCommandAtOnce) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  ASSERT_TRUE(control.Request("manual", Held()).accepted);
  control.Step(ModeInputs{At(0), 0.0, {}});
  ASSERT_TRUE(control.Compute(At(0)).forwarding);
  control.Stop("stopped by opB");
  EXPECT_EQ(control.mode(), "idle");
  EXPECT_EQ(control.active().name(), "idle");
  EXPECT_FALSE(control.last_output().forwarding);
  EXPECT_EQ(control.last_output().active_channel, "none");
  for (const FakeMode* mode : {m.manual, m.joystick, m.waypoint}) {
    EXPECT_EQ(mode->deactivations.back(), "stopped by opB") << mode->name();
  }
  EXPECT_EQ(control.tree().last_refusal(), "") << "an operator's stop is no fault";
  control.Stop("the mode tree refused idle", /*fault=*/true);
  EXPECT_EQ(control.tree().last_refusal(), "the mode tree refused idle");
}

TEST(ModeControl, AModeWhoseTaskEndedGoesIdleThroughTheTree) {
  Modes m;
  ModeControl control(kTree, FakeRegistry(&m), "r1");
  ModeConditions with_goal = Held();
  with_goal.has_waypoint_goal = true;
  ASSERT_TRUE(control.Request("waypoint", with_goal).accepted);
  m.waypoint->finish_next_step = true;
  ASSERT_TRUE(control.Step(ModeInputs{At(0), 0.0, {}}));
  control.GoIdle(Held());
  EXPECT_EQ(control.mode(), "idle");
  EXPECT_EQ(control.channel(), "none");
  EXPECT_EQ(m.waypoint->deactivations, (std::vector<std::string>{"mode switched to idle"}));
}

// Lesson L5: a new mode is one module and one subtree; the mux gets its channel from the module.
TEST(ModeControl, ANewModeIsOneModuleAndOneSubtree) {
  std::string xml = ReadFile(kTree);
  const std::string anchor = R"(<ReactiveSequence name="waypoint">)";
  ASSERT_NE(xml.find(anchor), std::string::npos);
  xml.insert(xml.find(anchor), R"(<ReactiveSequence name="dock">
                <IsModeRequested mode="dock"/>
                <IsControlHeld/>
                <IsLocalized/>
                <SelectMode mode="dock" channel="dock"/>
            </ReactiveSequence>
            )");
  const std::string tree = WriteTemp("dock_tree.xml", xml);
  Modes m;
  ModeRegistry r = FakeRegistry(&m);
  FakeMode& dock = r.Emplace<FakeMode>("dock", "dock", Twist2{0.1, 0.0});
  ModeControl control(tree, std::move(r), "r1");
  EXPECT_EQ(control.tree().known_modes(),
            (std::vector<std::string>{"idle", "manual", "smart_joystick", "dock", "waypoint", "explore",
                                      "convoy", "yield"}));
  ASSERT_TRUE(control.Request("dock", Held()).accepted);
  control.Step(ModeInputs{At(0), 0.0, {}});
  const MuxOutput out = control.Compute(At(0));
  EXPECT_EQ(out.active_channel, "dock");
  EXPECT_DOUBLE_EQ(out.twist_B.linear_x_mps, 0.1);
  EXPECT_EQ(dock.steps, 1);
  // Without its module, the same tree is refused at load.
  Modes m2;
  EXPECT_NE(LoadError(tree, FakeRegistry(&m2)).find("no mode module implements mode 'dock'"),
            std::string::npos);
}

TEST(ManualMode, DrivesTheLastStickOfThisModeWithItsArrivalTime) {
  ManualMode manual(0.5);
  EXPECT_EQ(manual.channel().name, "teleop");
  EXPECT_FALSE(manual.Step(ModeInputs{At(0), 0.0, {}}).twist_B) << "no stick yet";
  manual.OnOperatorTwist(OperatorTwist{0.4, 0.3, -0.2}, At(1));
  const ModeOutput out = manual.Step(ModeInputs{At(1.2), 1.2, {}});
  ASSERT_TRUE(out.twist_B);
  EXPECT_DOUBLE_EQ(out.twist_B->linear_x_mps, 0.4);
  EXPECT_DOUBLE_EQ(out.twist_B->angular_z_radps, -0.2);
  EXPECT_EQ(out.stamp, At(1)) << "the mux judges the stick's age, not the step's";
  manual.Deactivate("stopped by opB");
  EXPECT_FALSE(manual.Step(ModeInputs{At(1.3), 1.3, {}}).twist_B)
      << "a stick from before a stop never replays";
}

}  // namespace
}  // namespace cairn::agent
