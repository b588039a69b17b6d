#include "cairn/bt/behavior_tree.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::bt {
namespace {

// What a test action saw.
struct ActionStats {
  int starts = 0;
  int running_ticks = 0;
  int halts = 0;
};

// Runs for `ticks` ticks (1 = completes in OnStart), then returns `result` ("SUCCESS" or "FAILURE").
class AsyncAction : public StatefulActionNode {
 public:
  AsyncAction(const std::string& name, const NodeConfig& config, ActionStats* stats)
      : StatefulActionNode(name, config), stats_(stats) {}

  static PortsList ProvidedPorts() {
    return {InputPort("ticks", 2, "ticks until done"), InputPort("result", "SUCCESS", "final status")};
  }

 protected:
  NodeStatus OnStart() override {
    ++stats_->starts;
    remaining_ = GetInput<int>("ticks").value_or(1) - 1;
    return Step();
  }
  NodeStatus OnRunning() override {
    ++stats_->running_ticks;
    --remaining_;
    return Step();
  }
  void OnHalted() override { ++stats_->halts; }

 private:
  NodeStatus Step() const {
    if (remaining_ > 0) return NodeStatus::kRunning;
    return GetInput<std::string>("result") == std::string("FAILURE") ? NodeStatus::kFailure
                                                                     : NodeStatus::kSuccess;
  }
  ActionStats* stats_;
  int remaining_ = 0;
};

// A node type registered with RegisterNodeType: halves distance_m into remaining_m.
class Approach : public SyncActionNode {
 public:
  Approach(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) {}
  static PortsList ProvidedPorts() {
    return {InputPort("distance_m", 2.0, "distance to go, metres"), OutputPort("remaining_m", "half of it")};
  }

 protected:
  NodeStatus Tick() override {
    const std::optional<double> distance_m = GetInput<double>("distance_m");
    if (!distance_m) return NodeStatus::kFailure;
    return SetOutput("remaining_m", *distance_m / 2.0) ? NodeStatus::kSuccess : NodeStatus::kFailure;
  }
};

// A condition without ProvidedPorts.
class AlwaysTrue : public ConditionNode {
 public:
  AlwaysTrue(const std::string& name, const NodeConfig& config) : ConditionNode(name, config) {}

 protected:
  NodeStatus Tick() override { return NodeStatus::kSuccess; }
};

class Exploding : public SyncActionNode {
 public:
  Exploding(const std::string& name, const NodeConfig& config) : SyncActionNode(name, config) {
    throw std::runtime_error("no motor driver");
  }

 protected:
  NodeStatus Tick() override { return NodeStatus::kSuccess; }
};

std::string Wrap(const std::string& body) {
  return "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"Main\">\n" + body + "\n</BehaviorTree>\n</root>\n";
}

class BehaviorTreeTest : public ::testing::Test {
 protected:
  BehaviorTreeTest() {
    factory_.RegisterBuilder("Async", NodeType::kAction, AsyncAction::ProvidedPorts(),
                             [this](const std::string& name, const NodeConfig& config) {
                               return std::make_unique<AsyncAction>(name, config, &stats_[name]);
                             });
    factory_.RegisterSimpleCondition(
        "Flag",
        [this](TreeNode& node) {
          ++condition_ticks_[node.name()];
          return node.GetInput<bool>("value").value_or(false) ? NodeStatus::kSuccess : NodeStatus::kFailure;
        },
        {InputPort("value", "the condition's result")});
    factory_.RegisterNodeType<Approach>("Approach");
    factory_.RegisterNodeType<AlwaysTrue>("AlwaysTrue");
  }

  Tree Load(const std::string& body) { return factory_.CreateTreeFromText(Wrap(body), blackboard_); }

  // The TreeError message of loading `xml`; fails the test if it loads.
  std::string ErrorOf(const std::string& xml) {
    try {
      factory_.CreateTreeFromText(xml, blackboard_);
    } catch (const TreeError& e) {
      return e.what();
    }
    ADD_FAILURE() << "expected a TreeError for:\n" << xml;
    return "";
  }

  std::vector<std::string> Statuses(const Tree& tree) {
    std::vector<std::string> out;
    tree.ForEachNode(
        [&](const TreeNode& node, int) { out.push_back(node.name() + "=" + ToString(node.status())); });
    return out;
  }

  TreeFactory factory_;
  std::shared_ptr<Blackboard> blackboard_ = Blackboard::Create();
  std::map<std::string, ActionStats> stats_;  // by node name; std::map keeps addresses stable
  std::map<std::string, int> condition_ticks_;
};

// True if `text` contains `part` (gtest prints both on failure).
bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// ---- Blackboard ------------------------------------------------------------------------------------------

TEST(BlackboardTest, ConvertsTextAndNumbers) {
  auto bb = Blackboard::Create();
  bb->Set("speed", "1.5");
  bb->Set("count", std::string("3"));
  bb->Set("flag", "true");
  bb->Set("n", 7);
  bb->Set("on", false);
  EXPECT_EQ(bb->Get<double>("speed"), 1.5);
  EXPECT_EQ(bb->Get<int>("speed"), std::nullopt);
  EXPECT_EQ(bb->Get<std::string>("speed"), "1.5");
  EXPECT_EQ(bb->Get<int>("count"), 3);
  EXPECT_EQ(bb->Get<double>("count"), 3.0);
  EXPECT_EQ(bb->Get<bool>("flag"), true);
  EXPECT_EQ(bb->Get<bool>("speed"), std::nullopt);
  EXPECT_EQ(bb->Get<double>("n"), 7.0);
  EXPECT_EQ(bb->Get<std::string>("n"), "7");
  EXPECT_EQ(bb->Get<std::string>("on"), "false");
  EXPECT_EQ(bb->Get<bool>("n"), std::nullopt);
  EXPECT_EQ(bb->Get<int>("missing"), std::nullopt);
  EXPECT_TRUE(bb->Has("n"));
  EXPECT_FALSE(bb->Has("missing"));
  bb->Erase("n");
  EXPECT_FALSE(bb->Has("n"));
  EXPECT_EQ(bb->Keys(), (std::vector<std::string>{"count", "flag", "on", "speed"}));
}

TEST(BlackboardTest, StoresArbitraryTypes) {
  struct Pose {
    double x_m;
  };
  auto bb = Blackboard::Create();
  bb->Set("pose", Pose{2.5});
  ASSERT_TRUE(bb->Get<Pose>("pose"));
  EXPECT_EQ(bb->Get<Pose>("pose")->x_m, 2.5);
  EXPECT_EQ(bb->Get<int>("pose"), std::nullopt);
  EXPECT_EQ(bb->Get<std::string>("pose"), std::nullopt);
}

TEST(BlackboardTest, StrictNumberParsing) {
  EXPECT_EQ(StringConverter<int>::Convert("-42"), -42);
  EXPECT_EQ(StringConverter<int>::Convert("4x"), std::nullopt);
  EXPECT_EQ(StringConverter<int>::Convert(""), std::nullopt);
  EXPECT_EQ(StringConverter<int>::Convert("99999999999"), std::nullopt);
  EXPECT_EQ(StringConverter<double>::Convert("-2e-3"), -2e-3);
  EXPECT_EQ(StringConverter<double>::Convert("1.5 "), std::nullopt);
  EXPECT_EQ(StringConverter<bool>::Convert("TRUE"), true);
  EXPECT_EQ(StringConverter<bool>::Convert("0"), false);
  EXPECT_EQ(StringConverter<bool>::Convert("yes"), std::nullopt);
}

TEST(BlackboardTest, ScopesRemappingAutoRemappingAndRootKeys) {
  auto parent = Blackboard::Create();
  auto child = Blackboard::Create(parent);
  child->AddRemapping("goal", "mission_goal");
  child->Set("goal", 3);
  EXPECT_EQ(parent->Get<int>("mission_goal"), 3);
  EXPECT_FALSE(parent->Has("goal"));
  child->Set("local", 1);
  EXPECT_FALSE(parent->Has("local"));
  parent->Set("shared", 5);
  EXPECT_FALSE(child->Has("shared"));
  child->EnableAutoRemapping(true);
  EXPECT_EQ(child->Get<int>("shared"), 5);
  child->Set("new_key", 6);  // not local: goes to the parent
  EXPECT_EQ(parent->Get<int>("new_key"), 6);
  child->Set("local", 2);  // local stays local
  EXPECT_EQ(child->Get<int>("local"), 2);
  EXPECT_FALSE(parent->Has("local"));
  auto grandchild = Blackboard::Create(child);
  grandchild->Set("@top", 9);
  EXPECT_EQ(parent->Get<int>("top"), 9);
  EXPECT_EQ(grandchild->Get<int>("@top"), 9);
  EXPECT_THROW(parent->AddRemapping("a", "b"), std::logic_error);
}

// ---- Small API pieces ------------------------------------------------------------------------------------

TEST(BehaviorTreeApiTest, ToStringAndPorts) {
  EXPECT_STREQ(ToString(NodeStatus::kIdle), "IDLE");
  EXPECT_STREQ(ToString(NodeStatus::kRunning), "RUNNING");
  EXPECT_STREQ(ToString(NodeStatus::kSuccess), "SUCCESS");
  EXPECT_STREQ(ToString(NodeStatus::kFailure), "FAILURE");
  EXPECT_STREQ(ToString(NodeType::kSubTree), "SubTree");
  const auto required = InputPort("mode", "requested mode");
  EXPECT_EQ(required.first, "mode");
  EXPECT_FALSE(required.second.has_default);
  EXPECT_EQ(required.second.description, "requested mode");
  EXPECT_EQ(InputPort("speed_mps", 0.5, "").second.default_value, "0.5");
  EXPECT_EQ(InputPort("n", 3, "").second.default_value, "3");
  EXPECT_EQ(InputPort("on", true, "").second.default_value, "true");
  EXPECT_EQ(InputPort("s", "x", "").second.default_value, "x");
  EXPECT_TRUE(InputPort("s", "x", "").second.has_default);
  EXPECT_EQ(OutputPort("o", "").second.direction, PortInfo::Direction::kOutput);
  EXPECT_EQ(InOutPort("io", "").second.direction, PortInfo::Direction::kInOut);
  EXPECT_EQ(TreeNode::BlackboardKey("{goal}", "p"), "goal");
  EXPECT_EQ(TreeNode::BlackboardKey("{=}", "p"), "p");
  EXPECT_EQ(TreeNode::BlackboardKey("goal", "p"), std::nullopt);
}

TEST(BehaviorTreeApiTest, RegistrationErrors) {
  TreeFactory factory;
  const auto tick = [](TreeNode&) { return NodeStatus::kSuccess; };
  EXPECT_TRUE(factory.IsRegistered("Sequence"));
  EXPECT_TRUE(factory.IsRegistered("SubTree"));
  EXPECT_FALSE(factory.IsRegistered("IsModeRequested"));
  factory.RegisterSimpleCondition("IsModeRequested", tick);
  EXPECT_TRUE(factory.IsRegistered("IsModeRequested"));
  EXPECT_THROW(factory.RegisterSimpleCondition("IsModeRequested", tick), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("Sequence", tick), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("SubTree", tick), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("Action", tick), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("", tick), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("Bad", tick, {InputPort("name", "")}), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("Bad", tick, {InputPort("_x", "")}), std::logic_error);
  EXPECT_THROW(factory.RegisterSimpleAction("Bad", nullptr), std::logic_error);
}

// ---- XML: happy paths ------------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, ParsesCompactAndExplicitFormsWithSeveralTrees) {
  const std::string xml = R"(<?xml version="1.0"?>
<root BTCPP_format="4" main_tree_to_execute="Main">
  <!-- a comment -->
  <BehaviorTree ID="Unused">
    <AlwaysFailure/>
  </BehaviorTree>
  <BehaviorTree ID="Main" _description="top">
    <Control ID="Sequence" name="top">
      <Condition ID="Flag" name="check" value="true" _description="always true here"/>
      <Action ID="AlwaysSuccess"/>
      <Decorator ID="Inverter"><AlwaysFailure/></Decorator>
      <AlwaysTrue/>
    </Control>
  </BehaviorTree>
  <TreeNodesModel>
    <Condition ID="Flag"><input_port name="value"/></Condition>
  </TreeNodesModel>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(tree.root().name(), "top");
  EXPECT_EQ(tree.root().registration_id(), "Sequence");
  EXPECT_EQ(tree.root().type(), NodeType::kControl);
  EXPECT_EQ(tree.root().config().xml_line, 8);
  ASSERT_EQ(tree.root().num_children(), 4u);
  EXPECT_EQ(tree.root().child(0).name(), "check");
  EXPECT_EQ(tree.root().child(1).name(), "AlwaysSuccess");  // no name attribute: the ID
  EXPECT_EQ(tree.root().child(3).type(), NodeType::kCondition);
  EXPECT_EQ(tree.blackboard(), blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(condition_ticks_["check"], 1);
}

TEST_F(BehaviorTreeTest, SingleTreeNeedsNoMainAndNullBlackboardGetsOne) {
  Tree tree = factory_.CreateTreeFromText(Wrap("<AlwaysSuccess/>"), nullptr);
  ASSERT_NE(tree.blackboard(), nullptr);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
}

TEST_F(BehaviorTreeTest, LoadsFromFile) {
  const std::string path = ::testing::TempDir() + "cairn_bt_test_tree.xml";
  {
    std::ofstream file(path);
    file << Wrap("<Sequence>\n<AlwaysSuccess/>\n<Bogus/>\n</Sequence>");
  }
  try {
    factory_.CreateTreeFromFile(path, blackboard_);
    ADD_FAILURE() << "expected TreeError";
  } catch (const TreeError& e) {
    EXPECT_PRED2(Contains, e.what(), path + ":5: unknown node ID 'Bogus'");
    EXPECT_EQ(e.line(), 5);
  }
  {
    std::ofstream file(path);
    file << Wrap("<AlwaysFailure/>");
  }
  Tree tree = factory_.CreateTreeFromFile(path, blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);
  std::remove(path.c_str());
}

TEST_F(BehaviorTreeTest, MissingFileNamesThePath) {
  try {
    factory_.CreateTreeFromFile("/nonexistent/cairn/mode_tree.xml", blackboard_);
    ADD_FAILURE() << "expected TreeError";
  } catch (const TreeError& e) {
    EXPECT_PRED2(Contains, e.what(), "/nonexistent/cairn/mode_tree.xml");
  }
}

// ---- XML: rejections -------------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, RejectsMalformedXml) {
  EXPECT_PRED2(Contains, ErrorOf(""), "malformed XML");
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"A\">\n"), "malformed XML");
}

TEST_F(BehaviorTreeTest, RejectsMissingRoot) {
  const std::string error = ErrorOf("<BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree>");
  EXPECT_PRED2(Contains, error, "line 1: missing <root>");
  EXPECT_PRED2(Contains, error, "<BehaviorTree>");
}

TEST_F(BehaviorTreeTest, RejectsWrongOrMissingFormat) {
  EXPECT_PRED2(
      Contains,
      ErrorOf("<root BTCPP_format=\"3\"><BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree></root>"),
      "line 1: unsupported BTCPP_format '3'");
  EXPECT_PRED2(Contains, ErrorOf("<root><BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree></root>"),
               "no BTCPP_format attribute");
}

TEST_F(BehaviorTreeTest, RejectsUnknownNodeId) {
  const std::string error = ErrorOf(Wrap("<Sequence>\n  <IsSlamReady/>\n</Sequence>"));
  EXPECT_PRED2(Contains, error, "line 4: unknown node ID 'IsSlamReady'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Action ID=\"Nope\"/>")), "unknown node ID 'Nope'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Action/>")), "<Action> has no ID attribute");
}

TEST_F(BehaviorTreeTest, RejectsExplicitCategoryMismatch) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Condition ID=\"AlwaysSuccess\"/>")),
               "'AlwaysSuccess' is registered with type Action, not Condition");
}

TEST_F(BehaviorTreeTest, RejectsUnknownPortAttribute) {
  const std::string error = ErrorOf(Wrap("<Sequence>\n<Async name=\"drive\" tiks=\"3\"/>\n</Sequence>"));
  EXPECT_PRED2(Contains, error, "line 4: node 'drive' (ID 'Async') has no port named 'tiks'");
  EXPECT_PRED2(Contains, error, "result, ticks");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Sequence foo=\"1\"><AlwaysSuccess/></Sequence>")),
               "has no port named 'foo' (its ports: none)");
}

TEST_F(BehaviorTreeTest, RejectsUnsupportedScriptingAttributes) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<AlwaysSuccess _skipIf=\"x\"/>")),
               "attribute '_skipIf' is not supported");
}

TEST_F(BehaviorTreeTest, RejectsMissingRequiredInputPort) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Sequence>\n<Flag name=\"slam_ready\"/>\n</Sequence>")),
               "line 4: node 'slam_ready' (ID 'Flag') is missing required input port 'value'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<SetBlackboard value=\"1\"/>")),
               "missing required input port 'output_key'");
}

TEST_F(BehaviorTreeTest, RejectsLiteralOnOutputPortAndEmptyKey) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Approach remaining_m=\"3\"/>")),
               "output port 'remaining_m' must be a blackboard key like {key}, got '3'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Flag value=\"{}\"/>")), "port 'value' has an empty blackboard key");
}

TEST_F(BehaviorTreeTest, RejectsDecoratorWithoutExactlyOneChild) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Inverter/>")),
               "line 3: node 'Inverter' (ID 'Inverter') is a Decorator and needs exactly one child, found 0");
  EXPECT_PRED2(
      Contains,
      ErrorOf(Wrap("<ForceSuccess name=\"f\">\n<AlwaysSuccess/>\n<AlwaysFailure/>\n</ForceSuccess>")),
      "node 'f' (ID 'ForceSuccess') is a Decorator and needs exactly one child, found 2");
}

TEST_F(BehaviorTreeTest, RejectsControlWithoutChildren) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Sequence name=\"empty\"/>")),
               "line 3: node 'empty' (ID 'Sequence') is a Control node and needs at least one child");
}

TEST_F(BehaviorTreeTest, RejectsLeafWithChildren) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<AlwaysSuccess>\n<AlwaysFailure/>\n</AlwaysSuccess>")),
               "line 3: node 'AlwaysSuccess' (ID 'AlwaysSuccess') is a leaf (Action) and cannot have "
               "children, found 1");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<SubTree ID=\"Main\"><AlwaysSuccess/></SubTree>")),
               "cannot have children");
}

TEST_F(BehaviorTreeTest, RejectsBadTreeStructure) {
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\"/>"), "contains no <BehaviorTree>");
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\"><BehaviorTree ID=\"A\"/></root>"),
               "<BehaviorTree ID=\"A\"> must contain exactly one root node, found 0");
  EXPECT_PRED2(Contains,
               ErrorOf("<root BTCPP_format=\"4\"><BehaviorTree><AlwaysSuccess/></BehaviorTree></root>"),
               "<BehaviorTree> has no ID attribute");
  EXPECT_PRED2(Contains,
               ErrorOf("<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree>\n"
                       "<BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree></root>"),
               "line 3: duplicate <BehaviorTree ID=\"A\">");
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\"><include path=\"x.xml\"/></root>"),
               "<include> is not supported");
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\"><Tree/></root>"), "unexpected element <Tree>");
}

TEST_F(BehaviorTreeTest, RejectsAmbiguousOrUnknownMainTree) {
  const std::string two_trees =
      "<BehaviorTree ID=\"A\"><AlwaysSuccess/></BehaviorTree><BehaviorTree "
      "ID=\"B\"><AlwaysSuccess/></BehaviorTree>";
  EXPECT_PRED2(Contains, ErrorOf("<root BTCPP_format=\"4\">" + two_trees + "</root>"),
               "has 2 BehaviorTrees but no main_tree_to_execute");
  EXPECT_PRED2(Contains,
               ErrorOf("<root BTCPP_format=\"4\" main_tree_to_execute=\"C\">" + two_trees + "</root>"),
               "main_tree_to_execute 'C' does not name a <BehaviorTree>");
}

TEST_F(BehaviorTreeTest, RejectsUndefinedSubTree) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Sequence>\n<SubTree ID=\"Docking\"/>\n</Sequence>")),
               "line 4: SubTree ID 'Docking' is not defined by any <BehaviorTree>");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<SubTree/>")), "<SubTree> has no ID attribute");
}

TEST_F(BehaviorTreeTest, RejectsRecursiveSubTrees) {
  const std::string mutual = R"(<root BTCPP_format="4" main_tree_to_execute="A">
<BehaviorTree ID="A"><SubTree ID="B"/></BehaviorTree>
<BehaviorTree ID="B"><Sequence><AlwaysSuccess/><SubTree ID="A"/></Sequence></BehaviorTree>
</root>)";
  const std::string error = ErrorOf(mutual);
  EXPECT_PRED2(Contains, error, "line 3: recursive SubTree 'A': A -> B -> A");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Fallback><AlwaysFailure/><SubTree ID=\"Main\"/></Fallback>")),
               "recursive SubTree 'Main': Main -> Main");
  // Recursion in a tree that is not the main tree is rejected too.
  const std::string unused = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><AlwaysSuccess/></BehaviorTree>
<BehaviorTree ID="Loop"><SubTree ID="Loop"/></BehaviorTree>
</root>)";
  EXPECT_PRED2(Contains, ErrorOf(unused), "recursive SubTree 'Loop'");
}

TEST_F(BehaviorTreeTest, ErrorsInUnusedTreesAreReported) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><AlwaysSuccess/></BehaviorTree>
<BehaviorTree ID="Other"><Frobnicate/></BehaviorTree>
</root>)";
  EXPECT_PRED2(Contains, ErrorOf(xml), "line 3: unknown node ID 'Frobnicate'");
}

TEST_F(BehaviorTreeTest, WrapsNodeConstructorErrors) {
  factory_.RegisterNodeType<Exploding>("Exploding");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Exploding name=\"motor\"/>")),
               "line 3: constructing node 'motor' (ID 'Exploding') failed: no motor driver");
}

// ---- Ports -----------------------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, PortsRemapDefaultsAndConvert) {
  struct Seen {
    std::optional<double> speed_mps;
    std::optional<int> speed_as_int;
    std::optional<int> count;
    std::optional<bool> enabled;
    std::optional<std::string> label;
    std::optional<int> missing_key;
    std::optional<double> optional_port;
    bool wrote_out = false;
    bool wrote_unset = false;
  } seen;
  factory_.RegisterSimpleAction(
      "Probe",
      [&seen](TreeNode& node) {
        seen.speed_mps = node.GetInput<double>("speed_mps");
        seen.speed_as_int = node.GetInput<int>("speed_mps");
        seen.count = node.GetInput<int>("count");
        seen.enabled = node.GetInput<bool>("enabled");
        seen.label = node.GetInput<std::string>("label");
        seen.missing_key = node.GetInput<int>("from_key");
        seen.optional_port = node.GetInput<double>("out");
        seen.wrote_out = node.SetOutput("out", 42);
        seen.wrote_unset = node.SetOutput("unset_out", 1);
        return NodeStatus::kSuccess;
      },
      {InputPort("speed_mps", 0.5, "speed, m/s"), InputPort("count", 3, "count"),
       InputPort("enabled", "enabled flag"), InputPort("label", "{label_key}", "label"),
       InputPort("from_key", "{nothing_here}", "absent key"), OutputPort("out", "result"),
       OutputPort("unset_out", "never remapped")});

  blackboard_->Set("enabled", "TRUE");
  blackboard_->Set("label_key", "hello");
  Tree tree = Load(R"(<Probe speed_mps="1.5" enabled="{=}" out="{result}"/>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(seen.speed_mps, 1.5);
  EXPECT_EQ(seen.speed_as_int, std::nullopt);  // "1.5" is not an int
  EXPECT_EQ(seen.count, 3);                    // default
  EXPECT_EQ(seen.enabled, true);               // {=}: key "enabled", text "TRUE"
  EXPECT_EQ(seen.label, "hello");              // default "{label_key}"
  EXPECT_EQ(seen.missing_key, std::nullopt);
  EXPECT_EQ(seen.optional_port, std::nullopt);  // "{result}" not yet written when read
  EXPECT_TRUE(seen.wrote_out);
  EXPECT_FALSE(seen.wrote_unset);
  EXPECT_EQ(blackboard_->Get<int>("result"), 42);
  EXPECT_EQ(blackboard_->Get<double>("result"), 42.0);

  // Defaults differ per instance: the literal wins, the default fills in.
  Tree defaults = Load(R"(<Probe enabled="false"/>)");
  EXPECT_EQ(defaults.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(seen.speed_mps, 0.5);
  EXPECT_EQ(seen.enabled, false);
  EXPECT_FALSE(seen.wrote_out);  // no "{key}" for out
}

TEST_F(BehaviorTreeTest, UndeclaredPortIsALogicError) {
  factory_.RegisterSimpleAction("Typo", [](TreeNode& node) {
    (void)node.GetInput<int>("not_declared");
    return NodeStatus::kSuccess;
  });
  Tree tree = Load("<Typo/>");
  try {
    tree.TickOnce();
    ADD_FAILURE() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_PRED2(Contains, e.what(), "no declared port 'not_declared'");
  }
}

TEST_F(BehaviorTreeTest, RegisterNodeTypeUsesProvidedPorts) {
  Tree tree = Load(R"(<Sequence>
  <Approach distance_m="3.0" remaining_m="{left_m}"/>
  <Approach name="defaulted" remaining_m="{left_default_m}"/>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<double>("left_m"), 1.5);
  EXPECT_EQ(blackboard_->Get<double>("left_default_m"), 1.0);
  blackboard_->Set("far", "abc");
  Tree bad = Load(R"(<Approach distance_m="{far}" remaining_m="{x}"/>)");
  EXPECT_EQ(bad.TickOnce(), NodeStatus::kFailure);  // "abc" is not a double
}

// ---- Sequence / Fallback ---------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, SequenceRemembersRunningChild) {
  blackboard_->Set("ok", true);
  Tree tree = Load(R"(<Sequence>
  <Flag name="check" value="{ok}"/>
  <Async name="drive" ticks="3"/>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  blackboard_->Set("ok", false);  // not re-checked: Sequence has memory
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(condition_ticks_["check"], 1);
  EXPECT_EQ(stats_["drive"].starts, 1);
  EXPECT_EQ(stats_["drive"].running_ticks, 2);
  EXPECT_EQ(stats_["drive"].halts, 0);
  // Completion resets the children; a new tick starts from the first child again.
  EXPECT_EQ(Statuses(tree), (std::vector<std::string>{"Sequence=SUCCESS", "check=IDLE", "drive=IDLE"}));
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);
  EXPECT_EQ(condition_ticks_["check"], 2);
  EXPECT_EQ(stats_["drive"].starts, 1);
}

TEST_F(BehaviorTreeTest, SequenceFailureStopsAndResets) {
  Tree tree = Load(R"(<Sequence>
  <Async name="a" ticks="2" result="FAILURE"/>
  <Async name="b" ticks="1"/>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);
  EXPECT_EQ(stats_["b"].starts, 0);
  EXPECT_EQ(Statuses(tree), (std::vector<std::string>{"Sequence=FAILURE", "a=IDLE", "b=IDLE"}));
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(stats_["a"].starts, 2);
}

TEST_F(BehaviorTreeTest, FallbackTriesChildrenInOrderWithMemory) {
  blackboard_->Set("ok", false);
  Tree tree = Load(R"(<Fallback>
  <Flag name="first" value="{ok}"/>
  <Async name="second" ticks="2" result="FAILURE"/>
  <Async name="third" ticks="2"/>
</Fallback>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);  // second running
  blackboard_->Set("ok", true);                      // not re-checked
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);  // second failed, third running
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(condition_ticks_["first"], 1);
  EXPECT_EQ(stats_["second"].starts, 1);
  EXPECT_EQ(stats_["third"].starts, 1);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);  // now the first child succeeds
  EXPECT_EQ(condition_ticks_["first"], 2);

  Tree all_fail = Load("<Fallback><AlwaysFailure/><AlwaysFailure/></Fallback>");
  EXPECT_EQ(all_fail.TickOnce(), NodeStatus::kFailure);
}

// ---- Reactive controls -----------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, ReactiveSequenceReEvaluatesAndHaltsRunningAction) {
  blackboard_->Set("ok", true);
  Tree tree = Load(R"(<ReactiveSequence>
  <Flag name="check" value="{ok}"/>
  <Async name="drive" ticks="10"/>
</ReactiveSequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(condition_ticks_["check"], 2);  // re-checked every tick
  EXPECT_EQ(stats_["drive"].starts, 1);
  EXPECT_EQ(stats_["drive"].running_ticks, 1);
  blackboard_->Set("ok", false);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(Statuses(tree),
            (std::vector<std::string>{"ReactiveSequence=FAILURE", "check=IDLE", "drive=IDLE"}));
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);
  tree.HaltTree();
  EXPECT_EQ(stats_["drive"].halts, 1);  // exactly once
  blackboard_->Set("ok", true);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(stats_["drive"].starts, 2);  // restarted, not resumed
}

TEST_F(BehaviorTreeTest, ReactiveFallbackHaltsRunningActionWhenEarlierChildSucceeds) {
  blackboard_->Set("arrived", false);
  Tree tree = Load(R"(<ReactiveFallback>
  <Flag name="arrived" value="{arrived}"/>
  <Async name="drive" ticks="10"/>
</ReactiveFallback>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(condition_ticks_["arrived"], 2);
  blackboard_->Set("arrived", true);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  tree.HaltTree();
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(stats_["drive"].starts, 1);
}

TEST_F(BehaviorTreeTest, ReactiveSequenceHaltsLaterChildWhenEarlierChildStartsRunning) {
  blackboard_->Set("door_open", true);
  Tree tree = Load(R"(<ReactiveSequence>
  <ReactiveFallback name="gate">
    <Flag name="door_open" value="{door_open}"/>
    <Async name="open_door" ticks="3"/>
  </ReactiveFallback>
  <Async name="drive" ticks="10"/>
</ReactiveSequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(stats_["drive"].starts, 1);
  blackboard_->Set("door_open", false);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);  // gate now running: drive is halted
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(stats_["open_door"].starts, 1);
  EXPECT_EQ(tree.root().child(1).status(), NodeStatus::kIdle);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(stats_["drive"].starts, 1);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);  // door opened, drive restarts
  EXPECT_EQ(stats_["drive"].starts, 2);
  EXPECT_EQ(stats_["open_door"].halts, 0);
}

// ---- Decorators and leaves -------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, DecoratorsMapResultsAndPassRunningThrough) {
  struct Case {
    std::string decorator;
    std::string child;
    std::vector<NodeStatus> expected;
  };
  const std::vector<Case> cases = {
      {"Inverter", "<AlwaysSuccess/>", {NodeStatus::kFailure}},
      {"Inverter", "<AlwaysFailure/>", {NodeStatus::kSuccess}},
      {"Inverter", "<Async ticks=\"2\"/>", {NodeStatus::kRunning, NodeStatus::kFailure}},
      {"ForceSuccess", "<AlwaysFailure/>", {NodeStatus::kSuccess}},
      {"ForceSuccess",
       "<Async ticks=\"2\" result=\"FAILURE\"/>",
       {NodeStatus::kRunning, NodeStatus::kSuccess}},
      {"ForceFailure", "<AlwaysSuccess/>", {NodeStatus::kFailure}},
      {"ForceFailure", "<Async ticks=\"2\"/>", {NodeStatus::kRunning, NodeStatus::kFailure}},
  };
  for (const Case& c : cases) {
    Tree tree = Load("<" + c.decorator + ">" + c.child + "</" + c.decorator + ">");
    for (NodeStatus expected : c.expected) {
      EXPECT_EQ(tree.TickOnce(), expected) << c.decorator << " " << c.child;
    }
    EXPECT_EQ(tree.root().child(0).status(), NodeStatus::kIdle) << "child reset after completion";
  }
}

TEST_F(BehaviorTreeTest, ConditionReturningRunningIsALogicError) {
  factory_.RegisterSimpleCondition("Confused", [](TreeNode&) { return NodeStatus::kRunning; });
  factory_.RegisterSimpleAction("Slow", [](TreeNode&) { return NodeStatus::kRunning; });
  factory_.RegisterSimpleAction("Lazy", [](TreeNode&) { return NodeStatus::kIdle; });
  Tree condition = Load("<Confused/>");
  try {
    condition.TickOnce();
    ADD_FAILURE() << "expected std::logic_error";
  } catch (const std::logic_error& e) {
    EXPECT_PRED2(Contains, e.what(), "node 'Confused' (ID 'Confused') is a Condition and returned RUNNING");
  }
  Tree action = Load("<Slow/>");
  EXPECT_THROW(action.TickOnce(), std::logic_error);
  Tree idle = Load("<Lazy/>");
  EXPECT_THROW(idle.TickOnce(), std::logic_error);
}

TEST_F(BehaviorTreeTest, SetBlackboardWritesLiteralsAndCopiesEntries) {
  blackboard_->Set("source", 12);
  Tree tree = Load(R"(<Sequence>
  <SetBlackboard value="1.5" output_key="speed_mps"/>
  <SetBlackboard value="{source}" output_key="{copy}"/>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<double>("speed_mps"), 1.5);
  EXPECT_EQ(blackboard_->Get<std::string>("speed_mps"), "1.5");
  EXPECT_EQ(blackboard_->Get<int>("copy"), 12);
  Tree missing = Load(R"(<SetBlackboard value="{no_such_key}" output_key="x"/>)");
  EXPECT_EQ(missing.TickOnce(), NodeStatus::kFailure);
  EXPECT_FALSE(blackboard_->Has("x"));
}

// ---- SubTree ---------------------------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, SubTreeRemapsPortsAndIsolatesItsBlackboard) {
  blackboard_->Set("goal", 7);
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main">
  <SubTree ID="Child" name="child" target="{goal}" result="{answer}" fixed="lit" alias="{=}"/>
</BehaviorTree>
<BehaviorTree ID="Child">
  <Sequence>
    <SetBlackboard value="{target}" output_key="result"/>
    <SetBlackboard value="{fixed}" output_key="copied"/>
    <SetBlackboard value="inner" output_key="alias"/>
    <SetBlackboard value="root" output_key="{@from_root}"/>
  </Sequence>
</BehaviorTree>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(tree.root().type(), NodeType::kSubTree);
  EXPECT_EQ(tree.root().registration_id(), "SubTree");
  EXPECT_EQ(tree.root().name(), "child");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<int>("answer"), 7);
  EXPECT_EQ(blackboard_->Get<std::string>("alias"), "inner");
  EXPECT_EQ(blackboard_->Get<std::string>("from_root"), "root");
  EXPECT_FALSE(blackboard_->Has("copied"));
  EXPECT_FALSE(blackboard_->Has("fixed"));
  EXPECT_FALSE(blackboard_->Has("result"));
  EXPECT_FALSE(blackboard_->Has("target"));
}

TEST_F(BehaviorTreeTest, SubTreeAutoRemapSharesTheParentBlackboard) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main">
  <Sequence>
    <SubTree ID="Child" _autoremap="true"/>
    <SubTree ID="Child" name="isolated"/>
  </Sequence>
</BehaviorTree>
<BehaviorTree ID="Child">
  <SetBlackboard value="written" output_key="shared"/>
</BehaviorTree>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<std::string>("shared"), "written");
  EXPECT_EQ(blackboard_->Keys(), std::vector<std::string>{"shared"});
  EXPECT_PRED2(Contains, ErrorOf(R"(<root BTCPP_format="4" main_tree_to_execute="M">
<BehaviorTree ID="M"><SubTree ID="C" _autoremap="maybe"/></BehaviorTree>
<BehaviorTree ID="C"><AlwaysSuccess/></BehaviorTree></root>)"),
               "_autoremap must be true or false, got 'maybe'");
}

TEST_F(BehaviorTreeTest, SubTreeRunsAndHaltsLikeAnyChild) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main">
  <Sequence>
    <SubTree ID="Drive"/>
    <AlwaysSuccess/>
  </Sequence>
</BehaviorTree>
<BehaviorTree ID="Drive">
  <Async name="drive" ticks="5"/>
</BehaviorTree>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  tree.HaltTree();
  EXPECT_EQ(stats_["drive"].halts, 1);
}

// ---- Traversal, halting, lifetime ------------------------------------------------------------------------

TEST_F(BehaviorTreeTest, ForEachNodeVisitsPreOrderWithDepth) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main">
  <Sequence name="top">
    <Fallback name="fb">
      <AlwaysFailure name="a"/>
      <Inverter name="inv"><AlwaysFailure name="b"/></Inverter>
    </Fallback>
    <SubTree ID="Child" name="sub"/>
    <AlwaysSuccess name="c"/>
  </Sequence>
</BehaviorTree>
<BehaviorTree ID="Child">
  <ReactiveSequence name="rs"><AlwaysSuccess name="d"/></ReactiveSequence>
</BehaviorTree>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  std::vector<std::string> visited;
  tree.ForEachNode([&](const TreeNode& node, int depth) {
    visited.push_back(std::to_string(depth) + ":" + node.name() + ":" + node.registration_id());
  });
  EXPECT_EQ(visited,
            (std::vector<std::string>{"0:top:Sequence", "1:fb:Fallback", "2:a:AlwaysFailure",
                                      "2:inv:Inverter", "3:b:AlwaysFailure", "1:sub:SubTree",
                                      "2:rs:ReactiveSequence", "3:d:AlwaysSuccess", "1:c:AlwaysSuccess"}));
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
}

TEST_F(BehaviorTreeTest, HaltTreeHaltsRunningActionsOnceAndResetsAll) {
  Tree tree = Load(R"(<Sequence>
  <AlwaysSuccess name="first"/>
  <ForceSuccess name="force"><Async name="drive" ticks="10"/></ForceSuccess>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  EXPECT_EQ(Statuses(tree), (std::vector<std::string>{"Sequence=RUNNING", "first=SUCCESS", "force=RUNNING",
                                                      "drive=RUNNING"}));
  tree.HaltTree();
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(Statuses(tree),
            (std::vector<std::string>{"Sequence=IDLE", "first=IDLE", "force=IDLE", "drive=IDLE"}));
  tree.HaltTree();
  EXPECT_EQ(stats_["drive"].halts, 1);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);  // starts over from the first child
  EXPECT_EQ(stats_["drive"].starts, 2);
}

TEST_F(BehaviorTreeTest, DestroyingOrReplacingATreeHaltsIt) {
  {
    Tree tree = Load(R"(<Async name="drive" ticks="10"/>)");
    EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  }
  EXPECT_EQ(stats_["drive"].halts, 1);
  Tree tree = Load(R"(<Async name="other" ticks="10"/>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  tree = Load("<AlwaysSuccess/>");
  EXPECT_EQ(stats_["other"].halts, 1);
}

TEST_F(BehaviorTreeTest, TreeIsMovable) {
  Tree tree = Load(R"(<Async name="drive" ticks="2"/>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kRunning);
  Tree moved = std::move(tree);
  EXPECT_TRUE(tree.empty());  // NOLINT(bugprone-use-after-move): testing the moved-from state
  EXPECT_THROW(tree.TickOnce(), std::logic_error);
  EXPECT_THROW((void)tree.root(), std::logic_error);
  tree.HaltTree();  // no-op
  EXPECT_EQ(moved.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(moved.blackboard(), blackboard_);
  EXPECT_EQ(stats_["drive"].halts, 0);
  Tree empty;
  EXPECT_TRUE(empty.empty());
  int count = 0;
  empty.ForEachNode([&](const TreeNode&, int) { ++count; });
  EXPECT_EQ(count, 0);
}

}  // namespace
}  // namespace cairn::bt
