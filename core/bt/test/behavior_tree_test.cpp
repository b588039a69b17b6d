#include "cairn/bt/behavior_tree.h"

#include <gtest/gtest.h>

#include <chrono>
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

TEST_F(BehaviorTreeTest, CreatesANamedTreeOfTheDocumentAsBtCppCreateTreeDoes) {
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Modes">
  <BehaviorTree ID="Modes"><Flag name="mode_check" value="false"/></BehaviorTree>
  <BehaviorTree ID="Recovery"><Sequence><Flag name="recovery_check" value="true"/><AlwaysSuccess/></Sequence></BehaviorTree>
</root>)";
  Tree main = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(main.TickOnce(), NodeStatus::kFailure);
  Tree recovery = factory_.CreateTreeFromText(xml, blackboard_, "Recovery");
  EXPECT_EQ(recovery.root().registration_id(), "Sequence");
  EXPECT_EQ(recovery.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(condition_ticks_["recovery_check"], 1);
  EXPECT_EQ(condition_ticks_["mode_check"], 1);
  // An unknown ID names the trees there are; the whole document is validated even for another tree.
  try {
    factory_.CreateTreeFromText(xml, blackboard_, "Explore");
    ADD_FAILURE() << "expected a TreeError";
  } catch (const TreeError& e) {
    EXPECT_EQ(std::string(e.what()),
              "no <BehaviorTree ID=\"Explore\"> in the document (its trees: Modes, Recovery)");
  }
  const std::string broken = R"(<root BTCPP_format="4" main_tree_to_execute="Modes">
  <BehaviorTree ID="Modes"><Flag value="true"/></BehaviorTree>
  <BehaviorTree ID="Recovery"><NoSuchNode/></BehaviorTree>
</root>)";
  EXPECT_THROW(factory_.CreateTreeFromText(broken, blackboard_, "Modes"), TreeError);
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

// A tree is ticked many times a second: one of thousands of nodes, or nested thousands deep, stalled its
// process instead of failing at load. The error names the limit and the document's value.
TEST_F(BehaviorTreeTest, TreesBeyondTheSizeAndDepthLimitsAreRefusedNamingLimitAndValue) {
  std::string wide;
  for (int i = 0; i < 3000; ++i) wide += "<AlwaysFailure/>";
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Fallback>" + wide + "</Fallback>")),
               "the document's trees have 3001 nodes, more than the limit of 1000 (max_nodes)");
  std::string deep = "<AlwaysSuccess/>";
  for (int i = 0; i < 40; ++i) deep = "<Inverter>" + deep + "</Inverter>";
  EXPECT_PRED2(Contains, ErrorOf(Wrap(deep)),
               "<Inverter> in tree 'Main' is at depth 33, deeper than the limit of 32 (max_depth)");
  // 10,000 deep: refused before any recursion (a stack overflow would crash instead).
  std::string very_deep = "<AlwaysSuccess/>";
  for (int i = 0; i < 10000; ++i) very_deep = "<Inverter>" + very_deep + "</Inverter>";
  EXPECT_THROW(factory_.CreateTreeFromText(Wrap(very_deep), blackboard_), TreeError);
  // Small trees that use one another ten times each multiply when expanded: 10^4 leaves from 40 elements.
  std::string nested = R"(<root BTCPP_format="4" main_tree_to_execute="T0">)";
  for (int level = 0; level < 4; ++level) {
    nested += "<BehaviorTree ID=\"T" + std::to_string(level) + "\"><Sequence>";
    for (int k = 0; k < 10; ++k) nested += "<SubTree ID=\"T" + std::to_string(level + 1) + "\"/>";
    nested += "</Sequence></BehaviorTree>";
  }
  nested += R"(<BehaviorTree ID="T4"><AlwaysSuccess/></BehaviorTree></root>)";
  EXPECT_PRED2(Contains, ErrorOf(nested), "tree 'T0' with its SubTrees expanded has more than 1000 nodes");
  // Within the limits it loads; the limits can be set, and invalid ones are refused naming the field.
  EXPECT_NO_THROW(factory_.CreateTreeFromText(
      Wrap("<Fallback>" + wide.substr(0, std::size_t{999} * 16) + "</Fallback>"), blackboard_));
  TreeLimits limits;
  limits.max_nodes = 5000;
  factory_.SetLimits(limits);
  EXPECT_NO_THROW(factory_.CreateTreeFromText(Wrap("<Fallback>" + wide + "</Fallback>"), blackboard_));
  limits.max_depth = 0;
  std::string why;
  EXPECT_FALSE(limits.IsValid(&why));
  EXPECT_EQ(why, "max_depth 0 is not in [1, 10000]");
  EXPECT_THROW(factory_.SetLimits(limits), std::invalid_argument);
  EXPECT_TRUE(TreeLimits{}.IsValid(&why));
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
  <SetBlackboard value="{source}" output_key="copy"/>
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
    <SetBlackboard value="root" output_key="@from_root"/>
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

// ---- Builtin nodes of BehaviorTree.CPP 4.10 --------------------------------------------------------------
// The expected tick traces below were checked against BehaviorTree.CPP 4.10.0 built from source, ticked with
// Tree::tickExactlyOnce (one root tick, like Tree::TickOnce here); each test names the source file it pins.

// A long action that logs "name.start", "name.run" and "name.halt"; runs `ticks` ticks, then returns
// `result`.
class TracedAction : public StatefulActionNode {
 public:
  TracedAction(const std::string& name, const NodeConfig& config, std::vector<std::string>* log)
      : StatefulActionNode(name, config), log_(log) {}
  static PortsList ProvidedPorts() {
    return {InputPort("ticks", 2, "ticks until done"), InputPort("result", "SUCCESS", "final status")};
  }

 protected:
  NodeStatus OnStart() override {
    log_->push_back(name() + ".start");
    remaining_ = GetInput<int>("ticks").value_or(1) - 1;
    return Step();
  }
  NodeStatus OnRunning() override {
    log_->push_back(name() + ".run");
    --remaining_;
    return Step();
  }
  void OnHalted() override { log_->push_back(name() + ".halt"); }

 private:
  NodeStatus Step() const {
    if (remaining_ > 0) return NodeStatus::kRunning;
    return GetInput<std::string>("result") == std::string("FAILURE") ? NodeStatus::kFailure
                                                                     : NodeStatus::kSuccess;
  }
  std::vector<std::string>* log_;
  int remaining_ = 0;
};

class BuiltinNodesTest : public BehaviorTreeTest {
 protected:
  BuiltinNodesTest() {
    factory_.RegisterBuilder("Traced", NodeType::kAction, TracedAction::ProvidedPorts(),
                             [this](const std::string& name, const NodeConfig& config) {
                               return std::make_unique<TracedAction>(name, config, &log_);
                             });
    // Fails the first `fails` times it is ticked, then succeeds; logs "name.fail" / "name.ok".
    factory_.RegisterSimpleAction("Flaky",
                                  [this](TreeNode& node) {
                                    const bool fail = ++flaky_ticks_[node.name()] <=
                                                      node.GetInput<int>("fails").value_or(0);
                                    log_.push_back(node.name() + (fail ? ".fail" : ".ok"));
                                    return fail ? NodeStatus::kFailure : NodeStatus::kSuccess;
                                  },
                                  {InputPort("fails", 0, "ticks that fail before the first success")});
    factory_.SetClock([this] { return now_; });
  }

  // Ticks `tree` `n` times, advancing the fake clock by `step` after each tick; one "STATUS [events]" per
  // tick.
  std::vector<std::string> Ticks(Tree& tree, int n, std::chrono::milliseconds step = {}) {
    std::vector<std::string> out;
    for (int i = 0; i < n; ++i) {
      std::string line = ToString(tree.TickOnce());
      line += " [" + TakeLog() + "]";
      out.push_back(line);
      now_ += step;
    }
    return out;
  }

  // The events logged since the last call, space-separated.
  std::string TakeLog() {
    std::string out;
    for (const std::string& event : log_) out += (out.empty() ? "" : " ") + event;
    log_.clear();
    return out;
  }

  std::vector<std::string> log_;
  std::map<std::string, int> flaky_ticks_;
  std::chrono::nanoseconds now_{std::chrono::seconds(1000)};
};

using Trace = std::vector<std::string>;

// -- RetryUntilSuccessful: BehaviorTree.CPP src/decorators/retry_node.cpp

TEST_F(BuiltinNodesTest, RetryYieldsRunningBetweenSynchronousFailures) {
  Tree tree =
      Load(R"(<RetryUntilSuccessful num_attempts="3"><Flaky name="f" fails="5"/></RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 4),
            (Trace{"RUNNING [f.fail]", "RUNNING [f.fail]", "FAILURE [f.fail]", "RUNNING [f.fail]"}));
  Tree succeeds =
      Load(R"(<RetryUntilSuccessful num_attempts="3"><Flaky name="g" fails="1"/></RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(succeeds, 3), (Trace{"RUNNING [g.fail]", "SUCCESS [g.ok]", "SUCCESS [g.ok]"}));
}

TEST_F(BuiltinNodesTest, RetryRestartsARunningChildThatFailedInTheSameTick) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="3">
  <Traced name="a" ticks="2" result="FAILURE"/>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 5), (Trace{"RUNNING [a.start]", "RUNNING [a.run a.start]", "RUNNING [a.run a.start]",
                                   "FAILURE [a.run]", "RUNNING [a.start]"}));
  Tree one_tick = Load(R"(<RetryUntilSuccessful num_attempts="2">
  <Traced name="b" ticks="1" result="FAILURE"/>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(one_tick, 2), (Trace{"RUNNING [b.start]", "FAILURE [b.start]"}));
}

TEST_F(BuiltinNodesTest, RetryZeroAttemptsFailsAndMinusOneRetriesForever) {
  Tree zero = Load(R"(<RetryUntilSuccessful num_attempts="0"><Traced name="a"/></RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(zero, 1), (Trace{"FAILURE []"}));
  Tree forever =
      Load(R"(<RetryUntilSuccessful num_attempts="-1"><Flaky name="f" fails="4"/></RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(forever, 5), (Trace{"RUNNING [f.fail]", "RUNNING [f.fail]", "RUNNING [f.fail]",
                                      "RUNNING [f.fail]", "SUCCESS [f.ok]"}));
}

TEST_F(BuiltinNodesTest, RetryHaltResetsTheAttemptCount) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="2">
  <Traced name="a" ticks="2" result="FAILURE"/>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 2), (Trace{"RUNNING [a.start]", "RUNNING [a.run a.start]"}));
  tree.HaltTree();
  EXPECT_EQ(TakeLog(), "a.halt");
  EXPECT_EQ(Ticks(tree, 3), (Trace{"RUNNING [a.start]", "RUNNING [a.run a.start]", "FAILURE [a.run]"}));
}

TEST_F(BuiltinNodesTest, RetryAttemptsFromBlackboardAndBadValues) {
  blackboard_->Set("attempts", 2);
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="{attempts}">
  <Flaky name="f" fails="9"/>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 2), (Trace{"RUNNING [f.fail]", "FAILURE [f.fail]"}));
  blackboard_->Erase("attempts");
  try {
    tree.TickOnce();
    ADD_FAILURE() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_PRED2(Contains, e.what(), "port 'num_attempts' must be an integer >= -1, got {attempts} (absent)");
  }
  EXPECT_PRED2(
      Contains,
      ErrorOf(Wrap("<RetryUntilSuccessful num_attempts=\"-2\"><AlwaysSuccess/></RetryUntilSuccessful>")),
      "line 3: node 'RetryUntilSuccessful' (ID 'RetryUntilSuccessful'): port 'num_attempts' must be an "
      "integer >= -1, got '-2'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<RetryUntilSuccessful><AlwaysSuccess/></RetryUntilSuccessful>")),
               "missing required input port 'num_attempts'");
}

// -- A Nav2-style recovery with BehaviorTree.CPP's own nodes (retry_node.cpp, fallback_node.cpp,
//    reactive_fallback.cpp): RetryUntilSuccessful { Fallback { action, Sequence { recovery, AlwaysFailure } }
//    }

TEST_F(BuiltinNodesTest, RecoveryRunsBetweenAttemptsUntilTheActionSucceeds) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="3">
  <Fallback>
    <Flaky name="act" fails="2"/>
    <Sequence><Flaky name="rec"/><AlwaysFailure/></Sequence>
  </Fallback>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 3),
            (Trace{"RUNNING [act.fail rec.ok]", "RUNNING [act.fail rec.ok]", "SUCCESS [act.ok]"}));
}

TEST_F(BuiltinNodesTest, RecoveryWithLongActionsAndRetriesExhausted) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="2">
  <Fallback>
    <Traced name="act" ticks="2" result="FAILURE"/>
    <Sequence><Traced name="rec" ticks="2"/><AlwaysFailure/></Sequence>
  </Fallback>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 6),
            (Trace{"RUNNING [act.start]", "RUNNING [act.run rec.start]", "RUNNING [rec.run act.start]",
                   "RUNNING [act.run rec.start]", "FAILURE [rec.run]", "RUNNING [act.start]"}));
}

TEST_F(BuiltinNodesTest, RecoveryFailureCountsAsAFailedAttempt) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="2">
  <Fallback>
    <Flaky name="act" fails="99"/>
    <Sequence><Flaky name="rec" fails="99"/><AlwaysFailure/></Sequence>
  </Fallback>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 2), (Trace{"RUNNING [act.fail rec.fail]", "FAILURE [act.fail rec.fail]"}));
}

TEST_F(BuiltinNodesTest, ReactiveRecoveryHaltsTheActionWhenTheGoalIsReached) {
  Tree tree = Load(R"(<RetryUntilSuccessful num_attempts="2">
  <ReactiveFallback>
    <Flaky name="reached" fails="3"/>
    <Sequence><Traced name="act" ticks="2" result="FAILURE"/><Traced name="rec" ticks="1"/></Sequence>
  </ReactiveFallback>
</RetryUntilSuccessful>)");
  EXPECT_EQ(Ticks(tree, 3), (Trace{"RUNNING [reached.fail act.start]",
                                   "RUNNING [reached.fail act.run reached.fail act.start]",
                                   "SUCCESS [reached.ok act.halt]"}));
}

// -- Parallel: BehaviorTree.CPP src/controls/parallel_node.cpp

const char kParallelChildren[] = R"(<Traced name="a" ticks="1"/>
<Traced name="b" ticks="3" result="FAILURE"/>
<Traced name="c" ticks="2"/>)";

TEST_F(BuiltinNodesTest, ParallelDefaultsNeedAllSuccessesAndFailOnTheFirstFailure) {
  Tree tree = Load(std::string("<Parallel>") + kParallelChildren + "</Parallel>");
  EXPECT_EQ(Ticks(tree, 4), (Trace{"RUNNING [a.start b.start c.start]", "RUNNING [b.run c.run]",
                                   "FAILURE [b.run]", "RUNNING [a.start b.start c.start]"}));
  Tree all_succeed = Load(R"(<Parallel><Traced name="x" ticks="1"/><Traced name="y" ticks="2"/></Parallel>)");
  EXPECT_EQ(Ticks(all_succeed, 2), (Trace{"RUNNING [x.start y.start]", "SUCCESS [y.run]"}));
}

TEST_F(BuiltinNodesTest, ParallelCountsAndNegativeCountsFromTheNumberOfChildren) {
  for (const std::string ports : {R"(success_count="2")", R"(success_count="-2" failure_count="2")"}) {
    Tree tree = Load("<Parallel " + ports + ">" + kParallelChildren + "</Parallel>");
    EXPECT_EQ(Ticks(tree, 2), (Trace{"RUNNING [a.start b.start c.start]", "SUCCESS [b.run c.run b.halt]"}))
        << ports;
  }
  Tree minus_one = Load(std::string(R"(<Parallel success_count="-1" failure_count="-1">)") +
                        kParallelChildren + "</Parallel>");
  EXPECT_EQ(Ticks(minus_one, 3),
            (Trace{"RUNNING [a.start b.start c.start]", "RUNNING [b.run c.run]", "FAILURE [b.run]"}));
  // Zero counts complete after the first child: success_count="-5" means max(3 - 5 + 1, 0) = 0.
  for (const std::string ports : {R"(success_count="0")", R"(success_count="-5")"}) {
    Tree tree = Load("<Parallel " + ports + ">" + kParallelChildren + "</Parallel>");
    EXPECT_EQ(Ticks(tree, 1), (Trace{"SUCCESS [a.start]"})) << ports;
  }
  Tree zero_failures =
      Load(std::string(R"(<Parallel failure_count="0">)") + kParallelChildren + "</Parallel>");
  EXPECT_EQ(Ticks(zero_failures, 1), (Trace{"FAILURE [a.start]"}));
}

TEST_F(BuiltinNodesTest, ParallelFailsAsSoonAsSuccessIsImpossible) {
  Tree tree = Load(R"(<Parallel success_count="3" failure_count="2">
  <AlwaysSuccess/><AlwaysFailure/><Traced name="c" ticks="2"/>
</Parallel>)");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"FAILURE []"}));  // c is never started
}

TEST_F(BuiltinNodesTest, ParallelKeepsCompletedChildrenUntilItCompletesOrIsHalted) {
  Tree tree =
      Load(R"(<Parallel name="p"><Traced name="a" ticks="1"/><Traced name="b" ticks="3"/></Parallel>)");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [a.start b.start]"}));
  EXPECT_EQ(Statuses(tree), (std::vector<std::string>{"p=RUNNING", "a=SUCCESS", "b=RUNNING"}));
  tree.HaltTree();
  EXPECT_EQ(TakeLog(), "b.halt");
  EXPECT_EQ(Ticks(tree, 3), (Trace{"RUNNING [a.start b.start]", "RUNNING [b.run]", "SUCCESS [b.run]"}));
  EXPECT_EQ(Statuses(tree), (std::vector<std::string>{"p=SUCCESS", "a=IDLE", "b=IDLE"}));
}

TEST_F(BuiltinNodesTest, ParallelCountsAboveTheNumberOfChildrenAreRejected) {
  EXPECT_PRED2(
      Contains,
      ErrorOf(Wrap(std::string("<Parallel success_count=\"4\">") + kParallelChildren + "</Parallel>")),
      "line 3: node 'Parallel' (ID 'Parallel'): success_count 4 needs more successes than its 3 "
      "children (it could never succeed)");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Parallel failure_count=\"2\"><AlwaysSuccess/></Parallel>")),
               "failure_count 2 needs more failures than its 1 children (it could never fail)");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Parallel success_count=\"many\"><AlwaysSuccess/></Parallel>")),
               "port 'success_count' must be an integer");
  blackboard_->Set("needed", 5);
  Tree tree = Load(std::string("<Parallel success_count=\"{needed}\">") + kParallelChildren + "</Parallel>");
  EXPECT_THROW(tree.TickOnce(), std::logic_error);
}

// -- Switch2 .. Switch6: BehaviorTree.CPP include/behaviortree_cpp/controls/switch_node.h,
// src/controls/switch_node.cpp

TEST_F(BuiltinNodesTest, SwitchTicksTheMatchingCaseComparedAsTextIntegerOrNumber) {
  blackboard_->Set("v", "2");
  Tree tree = Load(R"(<Switch3 variable="{v}" case_1="1" case_2="2.0" case_3="x">
  <Traced name="c1"/><Traced name="c2"/><Traced name="c3"/><Traced name="d"/>
</Switch3>)");
  EXPECT_EQ(Ticks(tree, 2), (Trace{"RUNNING [c2.start]", "SUCCESS [c2.run]"}));
  blackboard_->Set("v", "x");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [c3.start]"}));
  tree.HaltTree();
  TakeLog();
  blackboard_->Set("v", 1);  // an int on the blackboard matches "1"
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [c1.start]"}));
  tree.HaltTree();
  TakeLog();
  Tree exponent = Load(R"(<Switch2 variable="1e0" case_1="1" case_2="b">
  <Traced name="e1" ticks="1"/><Traced name="e2"/><Traced name="ed"/>
</Switch2>)");
  EXPECT_EQ(Ticks(exponent, 1), (Trace{"SUCCESS [e1.start]"}));
}

TEST_F(BuiltinNodesTest, SwitchFallsBackToTheLastChild) {
  Tree absent = Load(R"(<Switch2 variable="{nope}" case_1="1" case_2="2">
  <Traced name="c1"/><Traced name="c2"/><Traced name="d"/>
</Switch2>)");
  EXPECT_EQ(Ticks(absent, 1), (Trace{"RUNNING [d.start]"}));
  absent.HaltTree();
  TakeLog();
  // Ports are optional, as in BehaviorTree.CPP: an unset case never matches, an unset variable selects the
  // default.
  Tree unset_case = Load(R"(<Switch2 variable="b" case_1="a">
  <Traced name="u1"/><Traced name="u2"/><Traced name="ud" ticks="1"/>
</Switch2>)");
  EXPECT_EQ(Ticks(unset_case, 1), (Trace{"SUCCESS [ud.start]"}));
  Tree no_variable = Load(R"(<Switch2 case_1="" case_2="b">
  <Traced name="n1"/><Traced name="n2"/><Traced name="nd" ticks="1"/>
</Switch2>)");
  EXPECT_EQ(Ticks(no_variable, 1), (Trace{"SUCCESS [nd.start]"}));
}

TEST_F(BuiltinNodesTest, SwitchHaltsTheRunningBranchWhenTheCaseChanges) {
  blackboard_->Set("v", "1");
  Tree tree = Load(R"(<Switch2 variable="{v}" case_1="1" case_2="2">
  <Traced name="c1" ticks="5"/><Traced name="c2" ticks="5"/><Traced name="d" ticks="5"/>
</Switch2>)");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [c1.start]"}));
  blackboard_->Set("v", "2");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [c1.halt c2.start]"}));
  blackboard_->Set("v", "zzz");
  EXPECT_EQ(Ticks(tree, 1), (Trace{"RUNNING [c2.halt d.start]"}));
  tree.HaltTree();
  EXPECT_EQ(TakeLog(), "d.halt");
}

TEST_F(BuiltinNodesTest, SwitchNeedsOneChildPerCasePlusTheDefault) {
  for (int cases = 2; cases <= 6; ++cases) {
    std::string xml = "<Switch" + std::to_string(cases) + " variable=\"x\">";
    for (int i = 0; i <= cases; ++i) xml += "<AlwaysFailure/>";
    xml += "</Switch" + std::to_string(cases) + ">";
    Tree tree = Load(xml);
    EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure) << xml;
    EXPECT_EQ(tree.root().config().ports.size(), static_cast<std::size_t>(cases + 1)) << xml;
  }
  // Also in a tree that is not the main one.
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><AlwaysSuccess/></BehaviorTree>
<BehaviorTree ID="Other">
  <Switch2 name="sw" variable="a" case_1="a" case_2="b"><AlwaysSuccess/><AlwaysSuccess/></Switch2>
</BehaviorTree>
</root>)";
  EXPECT_PRED2(
      Contains, ErrorOf(xml),
      "line 4: node 'sw' (ID 'Switch2'): a Switch2 needs 3 children (2 cases, then the default), found 2");
}

// -- Timeout: BehaviorTree.CPP src/decorators/timeout_node.cpp (time from the factory's Clock)

TEST_F(BuiltinNodesTest, TimeoutHaltsTheChildAndFailsOnTheFirstTickAfterTheDeadline) {
  Tree tree = Load(R"(<Timeout msec="50"><Traced name="a" ticks="10"/></Timeout>)");
  const std::chrono::milliseconds step(20);
  EXPECT_EQ(Ticks(tree, 5, step), (Trace{"RUNNING [a.start]", "RUNNING [a.run]", "RUNNING [a.run]",
                                         "FAILURE [a.halt]", "RUNNING [a.start]"}));
  Tree exact = Load(R"(<Timeout msec="50"><Traced name="b" ticks="10"/></Timeout>)");
  EXPECT_EQ(Ticks(exact, 3, std::chrono::milliseconds(25)),
            (Trace{"RUNNING [b.start]", "RUNNING [b.run]", "FAILURE [b.halt]"}));  // at exactly 50 ms
}

TEST_F(BuiltinNodesTest, TimeoutRestartsAfterTheChildCompletesAndZeroNeverExpires) {
  Tree tree = Load(R"(<Timeout msec="50"><Traced name="a" ticks="2"/></Timeout>)");
  EXPECT_EQ(Ticks(tree, 4, std::chrono::milliseconds(20)),
            (Trace{"RUNNING [a.start]", "SUCCESS [a.run]", "RUNNING [a.start]", "SUCCESS [a.run]"}));
  Tree never = Load(R"(<Timeout msec="0"><Traced name="b" ticks="4"/></Timeout>)");
  EXPECT_EQ(Ticks(never, 4, std::chrono::hours(1)),
            (Trace{"RUNNING [b.start]", "RUNNING [b.run]", "RUNNING [b.run]", "SUCCESS [b.run]"}));
}

TEST_F(BuiltinNodesTest, TimeoutHaltResetsTheTimer) {
  Tree tree = Load(R"(<Timeout msec="50"><Traced name="a" ticks="10"/></Timeout>)");
  EXPECT_EQ(Ticks(tree, 2, std::chrono::milliseconds(40)), (Trace{"RUNNING [a.start]", "RUNNING [a.run]"}));
  tree.HaltTree();
  EXPECT_EQ(TakeLog(), "a.halt");
  EXPECT_EQ(Ticks(tree, 3, std::chrono::milliseconds(20)),
            (Trace{"RUNNING [a.start]", "RUNNING [a.run]", "RUNNING [a.run]"}));
}

TEST_F(BuiltinNodesTest, TimeoutAndDelayRejectBadMilliseconds) {
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Timeout msec=\"-5\"><AlwaysSuccess/></Timeout>")),
               "port 'msec' must be an integer >= 0, got '-5'");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Delay delay_msec=\"1.5\"><AlwaysSuccess/></Delay>")),
               "port 'delay_msec' must be an integer >= 0, got '1.5'");
  blackboard_->Set("t", "soon");
  Tree tree = Load(R"(<Timeout msec="{t}"><AlwaysSuccess/></Timeout>)");
  try {
    tree.TickOnce();
    ADD_FAILURE() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_PRED2(Contains, e.what(),
                 "node 'Timeout' (ID 'Timeout'): port 'msec' must be an integer >= 0, "
                 "got {t} = 'soon'");
  }
}

// -- Delay: BehaviorTree.CPP src/decorators/delay_node.cpp

TEST_F(BuiltinNodesTest, DelayWaitsThenTicksTheChildAndStartsOverAfterIt) {
  Tree tree = Load(R"(<Delay delay_msec="50"><Traced name="a" ticks="2"/></Delay>)");
  EXPECT_EQ(Ticks(tree, 6, std::chrono::milliseconds(20)),
            (Trace{"RUNNING []", "RUNNING []", "RUNNING []", "RUNNING [a.start]", "SUCCESS [a.run]",
                   "RUNNING []"}));
}

TEST_F(BuiltinNodesTest, DelayNeverTicksTheChildOnItsFirstTick) {
  Tree tree = Load(R"(<Delay delay_msec="0"><Traced name="a" ticks="1"/></Delay>)");
  EXPECT_EQ(Ticks(tree, 3), (Trace{"RUNNING []", "SUCCESS [a.start]", "RUNNING []"}));
}

TEST_F(BuiltinNodesTest, DelayHaltRestartsTheDelay) {
  Tree tree = Load(R"(<Delay delay_msec="30"><Traced name="a" ticks="1"/></Delay>)");
  EXPECT_EQ(Ticks(tree, 1, std::chrono::milliseconds(20)), (Trace{"RUNNING []"}));
  tree.HaltTree();
  EXPECT_EQ(Ticks(tree, 3, std::chrono::milliseconds(20)),
            (Trace{"RUNNING []", "RUNNING []", "SUCCESS [a.start]"}));
}

// -- Clock

TEST_F(BuiltinNodesTest, TreesKeepTheClockTheyWereCreatedWith) {
  Tree tree = Load(R"(<Timeout msec="100"><Traced name="a" ticks="10"/></Timeout>)");
  EXPECT_EQ(tree.root().Now(), now_);
  std::chrono::nanoseconds other_now{0};
  factory_.SetClock([&other_now] { return other_now; });
  Tree later = Load("<AlwaysSuccess/>");
  EXPECT_EQ(later.root().Now(), other_now);
  EXPECT_EQ(tree.root().Now(), now_);
  EXPECT_THROW(factory_.SetClock(nullptr), std::logic_error);
}

TEST(ClockTest, DefaultClockIsSteady) {
  TreeFactory factory;
  const std::chrono::nanoseconds before = SteadyClockNow();
  const std::chrono::nanoseconds now = factory.clock()();
  EXPECT_LE(before, now);
  EXPECT_LE(now, SteadyClockNow());
  Tree tree = factory.CreateTreeFromText(Wrap("<AlwaysSuccess/>"), nullptr);
  EXPECT_LE(now, tree.root().Now());
  struct Leaf : SyncActionNode {
    using SyncActionNode::SyncActionNode;
    NodeStatus Tick() override { return NodeStatus::kSuccess; }
  };
  const Leaf hand_made("leaf", NodeConfig{});  // no clock in the config: the steady clock
  EXPECT_LE(now, hand_made.Now());
}

// -- SubTree blackboards and models: BehaviorTree.CPP src/blackboard.cpp (IsPrivateKey) and
// src/xml_parsing.cpp
//    (recursivelyCreateSubtree, loadSubtreeModel)

TEST(BlackboardTest, AutoRemappingKeepsPrivateKeysLocal) {
  auto parent = Blackboard::Create();
  parent->Set("_secret", 1);
  parent->Set("shared", 2);
  auto child = Blackboard::Create(parent);
  child->EnableAutoRemapping(true);
  EXPECT_EQ(child->Get<int>("shared"), 2);
  EXPECT_FALSE(child->Has("_secret"));
  EXPECT_EQ(child->Get<int>("@_secret"), 1);  // the root key, named explicitly
  child->Set("_mine", 3);
  EXPECT_FALSE(parent->Has("_mine"));
  EXPECT_EQ(child->Keys(), std::vector<std::string>{"_mine"});
  child->AddRemapping("_alias", "shared");  // explicit remapping still works for private keys
  EXPECT_EQ(child->Get<int>("_alias"), 2);
}

TEST_F(BuiltinNodesTest, SubTreeAutoRemapDoesNotShareUnderscoreKeys) {
  blackboard_->Set("_private", "parent");
  blackboard_->Set("_secret", "s");
  const std::string xml = R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main"><SubTree ID="Sub" _autoremap="true"/></BehaviorTree>
<BehaviorTree ID="Sub">
  <Sequence>
    <SetBlackboard value="in" output_key="_private"/>
    <SetBlackboard value="in" output_key="shared"/>
    <SetBlackboard value="{_secret}" output_key="copied_secret"/>
  </Sequence>
</BehaviorTree>
</root>)";
  Tree tree = factory_.CreateTreeFromText(xml, blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);  // {_secret} is not visible in the subtree
  EXPECT_EQ(blackboard_->Get<std::string>("_private"), "parent");
  EXPECT_EQ(blackboard_->Get<std::string>("shared"), "in");
  EXPECT_FALSE(blackboard_->Has("copied_secret"));
}

// A subtree that copies its `speed` to `result` and its `goal` to the local `goal_copy`.
const char kModelledSubTree[] = R"(
<BehaviorTree ID="Drive">
  <Sequence>
    <SetBlackboard value="{speed}" output_key="result"/>
    <SetBlackboard value="{goal}" output_key="goal_copy"/>
  </Sequence>
</BehaviorTree>)";

std::string ModelledDocument(const std::string& subtree_element, const std::string& model) {
  return R"(<root BTCPP_format="4" main_tree_to_execute="Main">
<BehaviorTree ID="Main">)" +
         subtree_element + "</BehaviorTree>" + kModelledSubTree + "\n" + model + "\n</root>";
}

const char kDriveModel[] = R"(<TreeNodesModel>
  <SubTree ID="Drive">
    <input_port name="speed" default="0.5">speed, m/s</input_port>
    <input_port name="goal" default="{the_goal}"/>
    <output_port name="result" default="{res}"/>
  </SubTree>
</TreeNodesModel>)";

TEST_F(BuiltinNodesTest, SubTreeModelDefaultsApplyToPortsTheElementDoesNotSet) {
  blackboard_->Set("the_goal", "G");
  Tree tree =
      factory_.CreateTreeFromText(ModelledDocument(R"(<SubTree ID="Drive"/>)", kDriveModel), blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<double>("res"), 0.5);  // literal default; {res} remaps the output
  EXPECT_EQ(blackboard_->Keys(), (std::vector<std::string>{"res", "the_goal"}));

  auto other = Blackboard::Create();
  other->Set("the_goal", "G");
  Tree overridden = factory_.CreateTreeFromText(
      ModelledDocument(R"(<SubTree ID="Drive" speed="2" result="{out}"/>)", kDriveModel), other);
  EXPECT_EQ(overridden.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(other->Get<std::string>("out"), "2");
  EXPECT_FALSE(other->Has("res"));
}

TEST_F(BuiltinNodesTest, SubTreeModelIsNotAppliedWithAutoRemap) {
  blackboard_->Set("the_goal", "G");
  Tree tree = factory_.CreateTreeFromText(
      ModelledDocument(R"(<SubTree ID="Drive" _autoremap="true"/>)", kDriveModel), blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kFailure);  // `speed` is looked up in the parent, where it is absent
  blackboard_->Set("speed", 3);
  blackboard_->Set("goal", "H");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<int>("result"), 3);
  EXPECT_EQ(blackboard_->Get<std::string>("goal_copy"), "H");
}

TEST_F(BuiltinNodesTest, SubTreeModelPortWithoutDefaultMustBeSet) {
  const std::string model = R"(<TreeNodesModel>
  <SubTree ID="Drive"><input_port name="speed"/><input_port name="goal" default=""/></SubTree>
</TreeNodesModel>)";
  EXPECT_PRED2(Contains, ErrorOf(ModelledDocument(R"(<SubTree ID="Drive" goal="g"/>)", model)),
               "line 2: SubTree 'Drive' (ID 'Drive') does not set port 'speed', which the <TreeNodesModel> "
               "(line 10) declares without a default");
  EXPECT_PRED2(Contains, ErrorOf(ModelledDocument(R"(<SubTree ID="Drive" speed="1"/>)", model)),
               "does not set port 'goal'");
  Tree tree = factory_.CreateTreeFromText(
      ModelledDocument(R"(<SubTree ID="Drive" speed="1" goal="g"/>)", model), blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
}

TEST_F(BuiltinNodesTest, TreeNodesModelIsValidated) {
  const auto doc = [](const std::string& model) {
    return "<root BTCPP_format=\"4\">\n<BehaviorTree ID=\"Main\"><AlwaysSuccess/></BehaviorTree>\n" + model +
           "\n</root>";
  };
  EXPECT_PRED2(Contains, ErrorOf(doc("<TreeNodesModel/>\n<TreeNodesModel/>")),
               "line 4: a second <TreeNodesModel> (the first is on line 3); only one is allowed");
  EXPECT_PRED2(Contains, ErrorOf(doc("<TreeNodesModel><Widget ID=\"x\"/></TreeNodesModel>")),
               "line 3: unexpected element <Widget> in <TreeNodesModel>");
  EXPECT_PRED2(Contains, ErrorOf(doc("<TreeNodesModel><Action/></TreeNodesModel>")),
               "<Action> in <TreeNodesModel> has no ID attribute");
  EXPECT_PRED2(
      Contains, ErrorOf(doc("<TreeNodesModel><Condition ID=\"Approach\"/></TreeNodesModel>")),
      "<TreeNodesModel> entry <Condition ID=\"Approach\">: 'Approach' is registered with type Action, "
      "not Condition");
  EXPECT_PRED2(Contains,
               ErrorOf(doc("<TreeNodesModel><Action ID=\"X\"><input_port/></Action></TreeNodesModel>")),
               "<input_port> has no name");
  EXPECT_PRED2(Contains,
               ErrorOf(doc("<TreeNodesModel><SubTree ID=\"S\"/>\n<SubTree ID=\"S\"/></TreeNodesModel>")),
               "line 4: duplicate <TreeNodesModel> entry <SubTree ID=\"S\">");
  // Entries of unknown node types (another program's palette) and Groot2 metadata are accepted.
  Tree tree = factory_.CreateTreeFromText(doc(R"(<TreeNodesModel>
  <Action ID="Elsewhere"><input_port name="p"/><MetadataFields><Metadata a="b"/></MetadataFields></Action>
</TreeNodesModel>)"),
                                          blackboard_);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
}

// -- SetBlackboard: BehaviorTree.CPP include/behaviortree_cpp/actions/set_blackboard_node.h (output_key is
// read
//    with getInput: a plain name is the key; "{ptr}" names the entry holding the key's name)

TEST_F(BuiltinNodesTest, SetBlackboardOutputKeyIsAPlainKeyName) {
  blackboard_->Set("ptr", "target");
  Tree tree = Load(R"(<Sequence>
  <SetBlackboard value="v1" output_key="{ptr}"/>
  <SetBlackboard value="v2" output_key="plain"/>
  <SetBlackboard value="r" output_key="@root_key"/>
</Sequence>)");
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard_->Get<std::string>("target"), "v1");
  EXPECT_EQ(blackboard_->Get<std::string>("ptr"), "target");
  EXPECT_EQ(blackboard_->Get<std::string>("plain"), "v2");
  EXPECT_EQ(blackboard_->Get<std::string>("root_key"), "r");

  Tree absent = Load(R"(<SetBlackboard name="set" value="v" output_key="{copy}"/>)");
  try {
    absent.TickOnce();
    ADD_FAILURE() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_PRED2(Contains, e.what(), "node 'set' (ID 'SetBlackboard'): output_key '{copy}'");
    EXPECT_PRED2(Contains, e.what(), "write output_key=\"copy\"");
  }
  EXPECT_FALSE(blackboard_->Has("copy"));
  EXPECT_PRED2(Contains, ErrorOf(Wrap(R"(<SetBlackboard value="v" output_key=""/>)")),
               "output_key must name a blackboard entry");
}

// ---- Port and registration extensions --------------------------------------------------------------------

TEST(BehaviorTreeApiTest, OptionalAndTypedPorts) {
  const auto optional = OptionalInputPort("hint", "may be omitted");
  EXPECT_TRUE(optional.second.optional);
  EXPECT_FALSE(optional.second.has_default);
  EXPECT_FALSE(InputPort("p", "").second.optional);
  EXPECT_EQ(InputPort("speed_mps", 0.5, "").second.type_name, "double");
  EXPECT_EQ(InputPort("n", 3, "").second.type_name, "int");
  EXPECT_EQ(InputPort("on", true, "").second.type_name, "bool");
  EXPECT_EQ(InputPort("s", "x", "").second.type_name, "");

  TreeFactory factory;
  std::optional<int> seen = 7;
  factory.RegisterSimpleAction("Hinted",
                               [&seen](TreeNode& node) {
                                 seen = node.GetInput<int>("hint");
                                 return NodeStatus::kSuccess;
                               },
                               {OptionalInputPort("hint", "a hint")});
  Tree tree = factory.CreateTreeFromText(Wrap("<Hinted/>"), nullptr);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(seen, std::nullopt);
}

// A control whose XML must have an even number of children and a literal `size_m` > 0.
class Pairs : public ControlNode {
 public:
  using ControlNode::ControlNode;
  static PortsList ProvidedPorts() { return {InputPort("size_m", 1.0, "pair size, metres")}; }
  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t num_children) {
    if (num_children % 2 != 0) throw std::invalid_argument("needs pairs of children");
    const auto size = port_values.find("size_m");
    if (size != port_values.end() && StringConverter<double>::Convert(size->second).value_or(0.0) <= 0.0) {
      throw std::invalid_argument("size_m must be > 0");
    }
  }

 protected:
  NodeStatus Tick() override { return NodeStatus::kSuccess; }
};

TEST_F(BehaviorTreeTest, RegisteredXmlValidatorsRunAtLoad) {
  factory_.RegisterNodeType<Pairs>("Pairs");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Sequence>\n<Pairs name=\"p\"><AlwaysSuccess/></Pairs>\n</Sequence>")),
               "line 4: node 'p' (ID 'Pairs'): needs pairs of children");
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<Pairs size_m=\"-1\"><AlwaysSuccess/><AlwaysSuccess/></Pairs>")),
               "size_m must be > 0");
  EXPECT_EQ(Load("<Pairs><AlwaysSuccess/><AlwaysSuccess/></Pairs>").TickOnce(), NodeStatus::kSuccess);
  factory_.RegisterBuilder(
      "NoChildrenPlease", NodeType::kDecorator, {},
      [](const std::string& name, const NodeConfig& config) {
        return std::unique_ptr<TreeNode>(std::make_unique<Pairs>(name, config));
      },
      [](const std::map<std::string, std::string>&, std::size_t) {
        throw std::invalid_argument("never valid");
      });
  EXPECT_PRED2(Contains, ErrorOf(Wrap("<NoChildrenPlease><AlwaysSuccess/></NoChildrenPlease>")),
               "never valid");
}

TEST(BehaviorTreeApiTest, BuiltinsAreTheConstructorsRegistrations) {
  TreeFactory factory;
  for (const char* id : {"Sequence",         "Fallback",
                         "ReactiveSequence", "ReactiveFallback",
                         "Parallel",         "Switch2",
                         "Switch3",          "Switch4",
                         "Switch5",          "Switch6",
                         "Inverter",         "ForceSuccess",
                         "ForceFailure",     "RetryUntilSuccessful",
                         "Timeout",          "Delay",
                         "AlwaysSuccess",    "AlwaysFailure",
                         "SetBlackboard",    "SubTree"}) {
    EXPECT_TRUE(factory.IsBuiltin(id)) << id;
    EXPECT_TRUE(factory.IsRegistered(id)) << id;
  }
  factory.RegisterNodeType<AlwaysTrue>("AlwaysTrue");
  EXPECT_FALSE(factory.IsBuiltin("AlwaysTrue"));
  EXPECT_FALSE(factory.IsBuiltin("Nothing"));
}

// ---- TreeNodesModel writer: BehaviorTree.CPP src/xml_parsing.cpp (writeTreeNodesModelXML) ---------------

// A decorator with an in/out port, for the model.
class Stamp : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;
  static PortsList ProvidedPorts() { return {InOutPort("counter", "incremented <each> tick & \"quoted\"")}; }

 protected:
  NodeStatus Tick() override { return Child().ExecuteTick(); }
};

class TreeNodesModelTest : public ::testing::Test {
 protected:
  TreeNodesModelTest() {
    factory_.RegisterNodeType<Approach>("Approach");
    factory_.RegisterNodeType<AlwaysTrue>("AlwaysTrue");
    factory_.RegisterNodeType<Stamp>("Stamp");
    factory_.RegisterNodeType<Pairs>("Pairs");
  }
  TreeFactory factory_;
};

const char kExpectedModel[] = R"(<TreeNodesModel>
    <Condition ID="AlwaysTrue"/>
    <Action ID="Approach">
        <input_port name="distance_m" type="double" default="2">distance to go, metres</input_port>
        <output_port name="remaining_m">half of it</output_port>
    </Action>
    <Control ID="Pairs">
        <input_port name="size_m" type="double" default="1">pair size, metres</input_port>
    </Control>
    <Decorator ID="Stamp">
        <inout_port name="counter">incremented &lt;each&gt; tick &amp; "quoted"</inout_port>
    </Decorator>
</TreeNodesModel>
)";

TEST_F(TreeNodesModelTest, WritesRegisteredTypesWithoutBuiltins) {
  EXPECT_EQ(factory_.WriteTreeNodesModel(), kExpectedModel);
  EXPECT_EQ(
      factory_.WriteTreeNodesModelDocument(), "<root BTCPP_format=\"4\">\n    " + [] {
        std::string indented;
        for (const char* c = kExpectedModel; *c != '\0'; ++c) {
          indented += *c;
          if (*c == '\n' && c[1] != '\0') indented += "    ";
        }
        return indented;
      }() + "</root>\n");
  EXPECT_EQ(TreeFactory().WriteTreeNodesModel(), "<TreeNodesModel/>\n");
}

TEST_F(TreeNodesModelTest, IncludesBuiltinsOnRequest) {
  const std::string model = factory_.WriteTreeNodesModel(true);
  EXPECT_PRED2(
      Contains, model,
      "<Control ID=\"Parallel\">\n        <input_port name=\"failure_count\" type=\"int\" default=\"1\">");
  EXPECT_PRED2(Contains, model, "<input_port name=\"success_count\" type=\"int\" default=\"-1\">");
  EXPECT_PRED2(Contains, model,
               "<Decorator ID=\"RetryUntilSuccessful\">\n        <input_port name=\"num_attempts\" "
               "type=\"int\">");
  EXPECT_PRED2(Contains, model, "<input_port name=\"msec\" type=\"unsigned int\">");
  EXPECT_PRED2(Contains, model, "<input_port name=\"case_6\" type=\"std::string\">");
  EXPECT_PRED2(Contains, model, "<Action ID=\"AlwaysSuccess\"/>");
  EXPECT_PRED2(Contains, model, "<Action ID=\"Approach\">");
}

const char kTreeFile[] = R"(<?xml version="1.0" encoding="UTF-8"?>
<!-- the mode tree -->
<root BTCPP_format="4" main_tree_to_execute="Main">
  <BehaviorTree ID="Main">
    <Sequence>
      <Approach distance_m="4" remaining_m="{left_m}"/>
      <SubTree ID="Drive" target="{left_m}"/>
    </Sequence>
  </BehaviorTree>
  <BehaviorTree ID="Drive">
    <Stamp counter="{=}"><SetBlackboard value="{target}" output_key="result"/></Stamp>
  </BehaviorTree>
  <TreeNodesModel>
    <SubTree ID="Drive">
      <input_port name="target"/>
      <output_port name="result" default="{driven_m}"/>
    </SubTree>
    <Action ID="Approach"><input_port name="stale_port"/></Action>
    <Action ID="SomebodyElses"/>
  </TreeNodesModel>
</root>
)";

TEST_F(TreeNodesModelTest, AddsTheModelToATreeFileThatThenLoads) {
  const std::string merged = factory_.AddTreeNodesModel(kTreeFile);
  EXPECT_PRED2(Contains, merged, "<!-- the mode tree -->");
  EXPECT_PRED2(Contains, merged, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>");
  EXPECT_EQ(merged.find("stale_port"), std::string::npos);  // the registered type's entry is replaced
  EXPECT_PRED2(Contains, merged, "<Action ID=\"SomebodyElses\"/>");  // other entries are kept
  EXPECT_PRED2(Contains, merged, "<output_port name=\"result\" default=\"{driven_m}\"/>");
  EXPECT_PRED2(Contains, merged, "<Decorator ID=\"Stamp\">");
  EXPECT_EQ(factory_.AddTreeNodesModel(merged), merged);  // idempotent

  // The merged file loads, and its SubTree model default remaps the subtree's output.
  const std::string path = ::testing::TempDir() + "cairn_bt_model_test_tree.xml";
  {
    std::ofstream file(path);
    file << merged;
  }
  auto blackboard = Blackboard::Create();
  Tree tree = factory_.CreateTreeFromFile(path, blackboard);
  std::remove(path.c_str());
  blackboard->Set("counter", 0);
  EXPECT_EQ(tree.TickOnce(), NodeStatus::kSuccess);
  EXPECT_EQ(blackboard->Get<double>("left_m"), 2.0);
  EXPECT_EQ(blackboard->Get<double>("driven_m"), 2.0);
}

TEST_F(TreeNodesModelTest, AddsAModelWhereThereIsNoneAndAFullDocumentLoadsToo) {
  const std::string bare =
      "<root BTCPP_format=\"4\"><BehaviorTree ID=\"M\"><AlwaysTrue/></BehaviorTree></root>";
  const std::string merged = factory_.AddTreeNodesModel(bare);
  EXPECT_PRED2(Contains, merged, "    <TreeNodesModel>\n        <Condition ID=\"AlwaysTrue\"/>");
  EXPECT_EQ(factory_.CreateTreeFromText(merged, nullptr).TickOnce(), NodeStatus::kSuccess);
  // The builtin models load as well (a full palette in the file).
  const std::string with_builtins = factory_.AddTreeNodesModel(bare, true);
  EXPECT_EQ(factory_.CreateTreeFromText(with_builtins, nullptr).TickOnce(), NodeStatus::kSuccess);
}

TEST_F(TreeNodesModelTest, AddTreeNodesModelErrors) {
  EXPECT_THROW(factory_.AddTreeNodesModel("<root"), TreeError);
  EXPECT_THROW(factory_.AddTreeNodesModel("<tree/>"), TreeError);
  try {
    factory_.AddTreeNodesModel("<root BTCPP_format=\"4\">\n<TreeNodesModel/>\n<TreeNodesModel/>\n</root>");
    ADD_FAILURE() << "expected TreeError";
  } catch (const TreeError& e) {
    EXPECT_PRED2(Contains, e.what(), "line 3: a second <TreeNodesModel>");
    EXPECT_EQ(e.line(), 3);
  }
}

}  // namespace
}  // namespace cairn::bt
