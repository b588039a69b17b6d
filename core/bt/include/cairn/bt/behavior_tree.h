// A behavior-tree engine that reads BehaviorTree.CPP v4 XML (<root BTCPP_format="4">), so trees can be edited
// in Groot2 and loaded at start without recompiling. Builtin nodes follow BehaviorTree.CPP 4.10 (the tests
// cite the BehaviorTree.CPP source file whose behaviour each one pins).
//
// Supported XML (anything else is rejected with a TreeError naming the element/attribute and its line):
//   <root BTCPP_format="4" [main_tree_to_execute="ID"]>   main_tree_to_execute is required if > 1 tree
//     <BehaviorTree ID="ID"> exactly one child node </BehaviorTree>   (one or more)
//     <TreeNodesModel> ... </TreeNodesModel>                            (at most one; see below)
//   </root>
// Nodes are written compactly (<IsModeRequested mode="{requested}"/>) or explicitly
// (<Action ID="X"/>, <Condition ID="X"/>, <Control ID="X">, <Decorator ID="X">; the category must match the
// registered type). Attributes of a node: `name` (instance name), its declared ports, and `_description`
// (ignored). Other `_` attributes (scripting pre/post-conditions such as _skipIf) are not supported.
// A port value is either a literal ("1.5") or a blackboard key in braces ("{goal}"); "{=}" means the key
// with the port's own name; "{@key}" means `key` in the top-level blackboard.
//
// <TreeNodesModel> (as written by Groot2 and TreeFactory::WriteTreeNodesModel) holds one element per node
// type: <Action|Condition|Control|Decorator|SubTree ID="X"> with <input_port|output_port|inout_port
// name="p" [type="T"] [default="v"] [description="d"]>d</...> children. An entry for a registered ID must
// name its registered category; entries for unknown IDs are documentation and ignored. <SubTree ID="T">
// entries declare the ports of <BehaviorTree ID="T"> and are used as BehaviorTree.CPP 4.10 does: when a
// <SubTree ID="T"> element without _autoremap="true" does not set a declared port, the port's default is
// used as if written on the element ("{key}" remaps, anything else is a literal); a declared port without
// default must then be set on the element (else TreeError). With _autoremap="true" the model is not applied.
//
// The whole document is validated (every BehaviorTree, used or not) before any node is constructed.
//
// Builtin nodes registered by TreeFactory (BehaviorTree.CPP 4.10 names, ports and behaviour):
//   Controls:   Sequence, Fallback, ReactiveSequence, ReactiveFallback,
//               Parallel(success_count=-1, failure_count=1), Switch2 .. Switch6(variable, case_1 .. case_N)
//   Decorators: Inverter, ForceSuccess, ForceFailure, RetryUntilSuccessful(num_attempts),
//               Timeout(msec), Delay(delay_msec)
//   Actions:    AlwaysSuccess, AlwaysFailure, SetBlackboard(value, output_key)
//   SubTree:    <SubTree ID="Other" [_autoremap="true"] [child_key="{parent_key}"] [child_key="literal"]/>
// Semantics of the nodes that need more than their name (TreeError: at load, naming node and line;
// std::runtime_error at tick: a port read from the blackboard holds a bad value or is absent):
//   Parallel ticks, on each tick and in order, every child that has not completed since the Parallel
//     started; after each child it returns SUCCESS once success_count children succeeded, FAILURE once
//     failure_count children failed or too few are left to reach success_count. A negative count means
//     max(children + count + 1, 0), so -1 is "all". On completion running children are halted and all are
//     reset. A count above the number of children: TreeError (std::logic_error at tick if from the
//     blackboard); a count that is not an integer: TreeError.
//   SwitchN (N = 2..6 cases) needs N+1 children (else TreeError). It ticks the child of the first case_i
//     equal to `variable` as text, as integers, or as numbers within float epsilon ("2" matches "2.0"); else
//     the last child, also when `variable` is unset or its key absent (all ports are optional). A child left
//     running by another branch is halted when the branch changes.
//   RetryUntilSuccessful ticks its child until it succeeds, at most num_attempts times (-1: no limit; below
//     -1: TreeError), then fails. A child that fails in the same tick it started (it was idle) ends the
//     tick with RUNNING and the next attempt is made on the next tick; a child that fails after running is
//     retried in the same tick. (This is BehaviorTree.CPP ticked with tickExactlyOnce, which is what
//     Tree::TickOnce does; its tickOnce would re-tick the whole tree at once instead.)
//   Timeout ticks its child; on the first tick at or after `msec` ms since the Timeout started, if the child
//     is still running, it halts the child and fails without ticking it. msec="0": no limit. The Timeout
//     restarts after the child completes or when halted.
//   Delay returns RUNNING until `delay_msec` ms have passed since its first tick, then ticks its child and
//     returns its status; the child is never ticked on the Delay's first tick, even with delay_msec="0". It
//     restarts after the child completes or when halted.
//   Negative or non-integer msec/delay_msec: TreeError. Time is the tree's Clock (TreeFactory::SetClock), so
//   Timeout and Delay work on a simulated clock; expiry is seen when the tree is ticked.
//   SetBlackboard writes `value` (text, or a copy of the entry "{key}") to the entry NAMED by `output_key`:
//     output_key="goal" writes `goal` ("@goal": the top-level `goal`); output_key="{ptr}" writes the entry
//     whose name is the text stored in `ptr`, as BehaviorTree.CPP 4.10 does (std::runtime_error at tick if
//     `ptr` is absent). Returns FAILURE if `value` is a "{key}" that is absent.
//
// A Nav2-style RecoveryNode (retry an action N times, running a recovery between attempts) is expressed with
// these nodes, as BehaviorTree.CPP has no RecoveryNode:
//   <RetryUntilSuccessful num_attempts="N+1">
//     <Fallback>   (or ReactiveFallback to re-check a condition child every tick)
//       <Action/>
//       <Sequence> <Recovery/> <AlwaysFailure/> </Sequence>   (failure: try the action again)
//     </Fallback>
//   </RetryUntilSuccessful>
// Unlike Nav2's RecoveryNode, a failing recovery does not end the retries early: it counts as a failed
// attempt.
//
// SubTree blackboards follow BehaviorTree.CPP v4: each SubTree instance gets its OWN blackboard whose parent
// is the enclosing tree's blackboard. Every extra attribute `k="{p}"` makes the subtree's key `k` an alias of
// the parent's key `p` (`k="{=}"`: alias of the parent's `k`); `k="text"` stores the text under `k` in the
// subtree's blackboard. With _autoremap="true", every key the subtree does not define locally resolves in
// the parent under the same name (the easy way to share everything), except keys starting with '_', which
// stay private to the subtree (BehaviorTree.CPP 4.10).
#pragma once

#include <chrono>
#include <cstddef>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "cairn/bt/blackboard.h"

namespace cairn::bt {

/// Result of ticking a node. kIdle means "not ticked since the last reset/halt"; Tick() must never return it.
enum class NodeStatus { kIdle, kRunning, kSuccess, kFailure };

/// "IDLE", "RUNNING", "SUCCESS" or "FAILURE".
const char* ToString(NodeStatus status);

/// The category of a node, which fixes how many children it takes in XML.
enum class NodeType {
  kAction,     ///< leaf that does something; no children
  kCondition,  ///< leaf that checks something; no children; never returns kRunning
  kControl,    ///< one or more children
  kDecorator,  ///< exactly one child
  kSubTree,    ///< instance of another <BehaviorTree>; its root is the single child
};

/// "Action", "Condition", "Control", "Decorator" or "SubTree".
const char* ToString(NodeType type);

/// Time source of a tree, read by the time-based builtin nodes (Timeout, Delay) and by TreeNode::Now(): the
/// current time as a duration since an arbitrary fixed epoch. It must never go backwards. A tree ticked on a
/// simulated clock gets a Clock returning simulated time (TreeFactory::SetClock).
using Clock = std::function<std::chrono::nanoseconds()>;

/// std::chrono::steady_clock's time since its epoch: the default Clock of a TreeFactory.
std::chrono::nanoseconds SteadyClockNow();

/// A configuration error: malformed or unsupported XML, unknown node ID or port, wrong number of children,
/// undefined or recursive SubTree, missing file. what() names the offending node/attribute/value and starts
/// with "line N: " (or "<path>:N: " when loaded from a file) when the error has a line.
class TreeError : public std::runtime_error {
 public:
  /// `line` is the 1-based XML line of the error, 0 if none.
  explicit TreeError(const std::string& message, int line = 0);
  /// The 1-based XML line the error refers to, 0 if none.
  int line() const { return line_; }

 private:
  int line_;
};

/// Declaration of one port of a node type.
struct PortInfo {
  enum class Direction { kInput, kOutput, kInOut };
  Direction direction = Direction::kInput;
  std::string default_value;  ///< used when the XML omits the port (only if has_default); may be "{key}"
  bool has_default = false;
  /// An input without default that the XML may omit (GetInput then returns nullopt). Inputs and in/out ports
  /// that are neither optional nor defaulted are required: omitting them is a TreeError.
  bool optional = false;
  std::string description;
  /// Type shown as the `type` attribute in a TreeNodesModel (e.g. "double"); empty: untyped, omitted.
  std::string type_name;
};

/// Ports of a node type, by port name.
using PortsList = std::map<std::string, PortInfo>;

/// A required input port (XML must set it).
std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& description);
/// An optional input port with a default (literal text or "{key}") used when the XML omits it.
std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& default_value,
                                           const std::string& description);
/// An input port without default that the XML may omit; GetInput then returns nullopt.
std::pair<std::string, PortInfo> OptionalInputPort(const std::string& name, const std::string& description);

namespace detail {
/// The TreeNodesModel type name of an arithmetic port type ("bool", "int", "double", ...), "" if unnamed.
template <class T>
const char* ArithmeticTypeName() {
  if constexpr (std::is_same_v<T, bool>) return "bool";
  if constexpr (std::is_same_v<T, int>) return "int";
  if constexpr (std::is_same_v<T, unsigned>) return "unsigned int";
  if constexpr (std::is_same_v<T, long>) return "long";
  if constexpr (std::is_same_v<T, unsigned long>) return "unsigned long";
  if constexpr (std::is_same_v<T, float>) return "float";
  if constexpr (std::is_same_v<T, double>) return "double";
  return "";
}
}  // namespace detail

/// An optional input port with a bool/int/double default (stored as text, e.g. 1.5 -> "1.5"); its
/// TreeNodesModel type is the C++ type ("bool", "int", "double", ...).
template <class T, class = std::enable_if_t<std::is_arithmetic_v<T>>>
std::pair<std::string, PortInfo> InputPort(const std::string& name, T default_value,
                                           const std::string& description) {
  std::string text;
  if constexpr (std::is_same_v<T, bool>) {
    text = default_value ? "true" : "false";
  } else if constexpr (std::is_integral_v<T>) {
    text = std::to_string(default_value);
  } else {
    text = detail::FormatDouble(static_cast<double>(default_value));
  }
  std::pair<std::string, PortInfo> port = InputPort(name, text, description);
  port.second.type_name = detail::ArithmeticTypeName<T>();
  return port;
}
/// An optional output port; XML must give it as "{key}" if set.
std::pair<std::string, PortInfo> OutputPort(const std::string& name, const std::string& description);
/// A required port that is both read and written; XML must give it as "{key}".
std::pair<std::string, PortInfo> InOutPort(const std::string& name, const std::string& description);

/// Everything a node gets from the XML. Built by TreeFactory; tests may build one by hand.
struct NodeConfig {
  std::shared_ptr<Blackboard> blackboard;          ///< the blackboard of the (sub)tree the node belongs to
  std::map<std::string, std::string> port_values;  ///< port name -> XML attribute text (literal or "{key}")
  PortsList ports;                                 ///< the node type's declared ports
  std::string registration_id;                     ///< e.g. "Sequence", "IsModeRequested"
  int xml_line = 0;                                ///< line of the node's element, 0 if not from XML
  Clock clock;                                     ///< the tree's time source; empty means SteadyClockNow
};

namespace detail {
class TreeBuilder;
class ModelWriter;
}  // namespace detail

/// Base of all nodes. A node is ticked by its parent through ExecuteTick() and stopped through Halt().
/// Not thread-safe: a tree is ticked and halted from one thread.
class TreeNode {
 public:
  /// `name`: instance name (XML `name`, or the ID if absent).
  TreeNode(std::string name, NodeConfig config);
  virtual ~TreeNode() = default;
  TreeNode(const TreeNode&) = delete;
  TreeNode& operator=(const TreeNode&) = delete;

  /// XML name attribute, or the ID if none.
  const std::string& name() const { return name_; }
  /// The ID the node type is registered under, e.g. "Sequence", "IsModeRequested", "SubTree".
  const std::string& registration_id() const { return config_.registration_id; }
  /// Status returned by the last tick; kIdle after construction, halt or reset by the parent.
  NodeStatus status() const { return status_; }
  /// Category of the node.
  virtual NodeType type() const = 0;
  /// The configuration the node was built with.
  const NodeConfig& config() const { return config_; }
  /// Children in XML order (empty for leaves).
  std::size_t num_children() const { return children_.size(); }
  /// Child `i`. Throws std::out_of_range if i >= num_children().
  const TreeNode& child(std::size_t i) const { return *children_.at(i); }

  /// Reads input port `port`: its XML value, else the port's default; a literal is converted from text with
  /// StringConverter<T>, a "{key}" is read from the blackboard with Blackboard::Get<T>. nullopt if the port
  /// is unset without default, the key is absent, or the value does not convert to T. Throws std::logic_error
  /// if the node type does not declare `port` (a programming error).
  template <class T>
  std::optional<T> GetInput(const std::string& port) const {
    const std::optional<std::string> text = PortText(port);
    if (!text) return std::nullopt;
    if (const std::optional<std::string> key = BlackboardKey(*text, port)) {
      return config_.blackboard ? config_.blackboard->Get<T>(*key) : std::nullopt;
    }
    if constexpr (StringConverter<T>::kAvailable) {
      return StringConverter<T>::Convert(*text);
    } else {
      return std::nullopt;
    }
  }

  /// Writes `value` to the blackboard key that port `port` is remapped to ("{key}" in XML or default).
  /// Returns false (and writes nothing) if the port is not set to a "{key}".
  /// Throws std::logic_error if the node type does not declare `port` (a programming error).
  template <class T>
  bool SetOutput(const std::string& port, T value) {
    const std::optional<std::string> text = PortText(port);
    if (!text || !config_.blackboard) return false;
    const std::optional<std::string> key = BlackboardKey(*text, port);
    if (!key) return false;
    config_.blackboard->Set(*key, std::move(value));
    return true;
  }

  /// Ticks the node once (calls Tick()) and records the returned status.
  /// Throws std::logic_error if Tick() returns kIdle, or kRunning from a node that may not run (conditions,
  /// synchronous actions); exceptions thrown by user code propagate.
  NodeStatus ExecuteTick();

  /// Stops the node: a running node (and its running descendants) is halted (StatefulActionNode::OnHalted
  /// is called exactly once per running action) and every status in the subtree is reset to kIdle.
  /// Halting a node that is not running only resets statuses.
  void Halt();

  /// If `text` is a blackboard pointer "{key}", returns key ("{=}" -> `port`; "{@k}" stays "@k").
  static std::optional<std::string> BlackboardKey(const std::string& text, const std::string& port);

  /// The tree's current time: config().clock(), or SteadyClockNow() if the config has no clock.
  std::chrono::nanoseconds Now() const;

 protected:
  /// One tick of the node's logic. Must not return kIdle.
  virtual NodeStatus Tick() = 0;
  /// Called by Halt() before the status is reset to kIdle: stop work, halt children. Default: nothing.
  virtual void HaltImpl() {}
  /// Mutable access to child `i` (for control and decorator nodes). Throws std::out_of_range.
  TreeNode& MutableChild(std::size_t i) { return *children_.at(i); }
  /// Halts children [first, num_children()).
  void HaltChildren(std::size_t first = 0);
  /// Halts child `i` only. Throws std::out_of_range.
  void HaltChild(std::size_t i) { MutableChild(i).Halt(); }

 private:
  friend class detail::TreeBuilder;
  // Whether Tick() may return kRunning (false for conditions and synchronous actions).
  virtual bool MayReturnRunning() const { return true; }
  // The XML value of `port`, else its default, else nullopt. Throws std::logic_error if undeclared.
  std::optional<std::string> PortText(const std::string& port) const;

  std::string name_;
  NodeConfig config_;
  NodeStatus status_ = NodeStatus::kIdle;
  std::vector<TreeNode*> children_;  // owned by the Tree
};

/// A leaf that checks something and returns kSuccess or kFailure (kRunning throws std::logic_error).
/// Override Tick().
class ConditionNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeType type() const final { return NodeType::kCondition; }

 private:
  bool MayReturnRunning() const final { return false; }
};

/// Base of action leaves.
class ActionNodeBase : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeType type() const final { return NodeType::kAction; }
};

/// An action that completes within one tick: returns kSuccess or kFailure (kRunning throws
/// std::logic_error). Override Tick().
class SyncActionNode : public ActionNodeBase {
 public:
  using ActionNodeBase::ActionNodeBase;

 private:
  bool MayReturnRunning() const final { return false; }
};

/// A long action that never blocks a tick: OnStart() on the first tick (or the first after completion or
/// halt), OnRunning() on the following ticks while it returns kRunning, OnHalted() when halted while running.
class StatefulActionNode : public ActionNodeBase {
 public:
  using ActionNodeBase::ActionNodeBase;

 protected:
  /// Starts the action; kRunning to be ticked again via OnRunning(), or kSuccess/kFailure if already done.
  virtual NodeStatus OnStart() = 0;
  /// Progresses the action; kRunning, kSuccess or kFailure.
  virtual NodeStatus OnRunning() = 0;
  /// The action was running and is stopped by its parent (or Tree::HaltTree()); called exactly once.
  virtual void OnHalted() = 0;

  NodeStatus Tick() final;
  void HaltImpl() final;
};

/// Base of control nodes (one or more children). Halt() halts all children.
class ControlNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeType type() const final { return NodeType::kControl; }

 protected:
  void HaltImpl() override { HaltChildren(); }
};

/// Base of decorator nodes (exactly one child). Halt() halts the child.
class DecoratorNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeType type() const final { return NodeType::kDecorator; }

 protected:
  /// The single child.
  TreeNode& Child() { return MutableChild(0); }
  void HaltImpl() override { HaltChildren(); }
};

/// An instantiated tree: owns its nodes. Movable, not copyable. Not thread-safe (tick from one thread).
/// Destroying a tree, or move-assigning over it, halts it first (so running actions get OnHalted; OnHalted
/// must not throw there, or std::terminate is called).
class Tree {
 public:
  /// An empty tree (TickOnce/root throw std::logic_error). Real trees come from TreeFactory.
  Tree() = default;
  Tree(Tree&& other) noexcept;
  Tree& operator=(Tree&& other) noexcept;
  Tree(const Tree&) = delete;
  Tree& operator=(const Tree&) = delete;
  ~Tree();

  /// Ticks the root once and returns its status. Throws std::logic_error on an empty tree and what the
  /// nodes throw (see TreeNode::ExecuteTick).
  NodeStatus TickOnce();
  /// Halts the whole tree (running actions get OnHalted) and resets every node to kIdle. No-op if empty.
  void HaltTree();
  /// The blackboard given to the factory (subtrees have their own, parented to it).
  const std::shared_ptr<Blackboard>& blackboard() const { return blackboard_; }
  /// The root node. Throws std::logic_error on an empty tree.
  const TreeNode& root() const;
  /// True if this tree has no nodes (default-constructed or moved from).
  bool empty() const { return root_ == nullptr; }
  /// Visits every node in pre-order (parent before children, children in XML order); the root has depth 0
  /// and a SubTree's root is one deeper than the SubTree node.
  void ForEachNode(const std::function<void(const TreeNode& node, int depth)>& visit) const;

 private:
  friend class detail::TreeBuilder;
  std::vector<std::unique_ptr<TreeNode>> nodes_;  // pre-order
  TreeNode* root_ = nullptr;
  std::shared_ptr<Blackboard> blackboard_;
};

/// Makes the node of a registered type: receives the instance name and configuration.
using NodeBuilder =
    std::function<std::unique_ptr<TreeNode>(const std::string& name, const NodeConfig& config)>;

/// A node type's check of its XML element, run by TreeFactory for every element of the type in a document
/// (used trees or not) before any node is constructed. `port_values`: the element's port attributes as
/// written (defaults not filled in); `num_children`: its number of child elements. Throws
/// std::invalid_argument with a reason to reject the document; the factory reports it as a TreeError naming
/// the node and line.
using XmlValidator =
    std::function<void(const std::map<std::string, std::string>& port_values, std::size_t num_children)>;

namespace detail {
/// True if T has `static PortsList ProvidedPorts()`.
template <class T, class = void>
struct HasProvidedPorts : std::false_type {};
template <class T>
struct HasProvidedPorts<T, std::void_t<decltype(T::ProvidedPorts())>> : std::true_type {};
/// True if T has `static void ValidateXml(const std::map<std::string, std::string>&, std::size_t)`.
template <class T, class = void>
struct HasValidateXml : std::false_type {};
template <class T>
struct HasValidateXml<T, std::void_t<decltype(T::ValidateXml(
                             std::declval<const std::map<std::string, std::string>&>(), std::size_t{}))>>
    : std::true_type {};
}  // namespace detail

/// Bounds on the trees a TreeFactory loads, checked before any node is constructed: a tree is ticked many
/// times a second (and dry-run once per mode to find the valid ones), so a huge or deep document would stall
/// its process rather than fail. Defaults allow ten times the shipped mode tree (103 elements, depth 5).
struct TreeLimits {
  /// Most nodes: the node elements of every <BehaviorTree> of the document together, and the nodes of the
  /// instantiated tree (each SubTree expanded where it is used); range [1, 1000000].
  int max_nodes = 1000;
  /// Deepest node: a <BehaviorTree>'s root node is at depth 0, its children at 1; in the instantiated tree a
  /// SubTree's root is one deeper than the SubTree node; range [1, 10000].
  int max_depth = 32;

  /// True when both fields are in range; else false and `*why` names the field, its value and the range.
  bool IsValid(std::string* why) const;
};

/// Registry of node types and XML loader. Copyable; holds no global state.
class TreeFactory {
 public:
  /// A factory with the builtin nodes registered (see file comment).
  TreeFactory();

  /// Registers node type T under `id`. T must derive from ConditionNode, SyncActionNode, StatefulActionNode
  /// (or ActionNodeBase), ControlNode or DecoratorNode, have a constructor T(const std::string& name,
  /// const NodeConfig& config), and may have `static PortsList ProvidedPorts()` and a load-time check
  /// `static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t
  /// num_children)` (see XmlValidator).
  /// Throws std::logic_error if `id` is empty, reserved (root, BehaviorTree, TreeNodesModel, SubTree, Action,
  /// Condition, Control, Decorator) or already registered, or a port is named "name", "ID" or starts with
  /// '_'.
  template <class T>
  void RegisterNodeType(const std::string& id) {
    static_assert(std::is_base_of_v<TreeNode, T>, "T must derive from cairn::bt::TreeNode");
    static_assert(std::is_constructible_v<T, const std::string&, const NodeConfig&>,
                  "T needs a constructor T(const std::string& name, const NodeConfig& config)");
    NodeType type;
    if constexpr (std::is_base_of_v<ConditionNode, T>) {
      type = NodeType::kCondition;
    } else if constexpr (std::is_base_of_v<ActionNodeBase, T>) {
      type = NodeType::kAction;
    } else if constexpr (std::is_base_of_v<ControlNode, T>) {
      type = NodeType::kControl;
    } else {
      static_assert(std::is_base_of_v<DecoratorNode, T>,
                    "T must derive from ConditionNode, an action base, ControlNode or DecoratorNode");
      type = NodeType::kDecorator;
    }
    PortsList ports;
    if constexpr (detail::HasProvidedPorts<T>::value) ports = T::ProvidedPorts();
    XmlValidator validator;
    if constexpr (detail::HasValidateXml<T>::value) validator = &T::ValidateXml;
    RegisterBuilder(
        id, type, std::move(ports),
        [](const std::string& name, const NodeConfig& config) {
          return std::unique_ptr<TreeNode>(std::make_unique<T>(name, config));
        },
        std::move(validator));
  }

  /// Registers a condition whose tick is `tick` (returning kSuccess/kFailure; kRunning throws
  /// std::logic_error when ticked), with `validator` (may be empty) checking each of its XML elements at
  /// load. Same registration errors as RegisterNodeType.
  void RegisterSimpleCondition(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                               PortsList ports = {}, XmlValidator validator = nullptr);
  /// Registers a synchronous action whose tick is `tick` (kSuccess/kFailure; kRunning throws
  /// std::logic_error when ticked — write a StatefulActionNode for long actions). Same errors as above.
  void RegisterSimpleAction(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                            PortsList ports = {});
  /// Low-level registration used by the above; `validator` (may be empty) checks each XML element of the
  /// type at load. Same errors; also std::logic_error if `type` is kSubTree or `builder` is empty.
  void RegisterBuilder(const std::string& id, NodeType type, PortsList ports, NodeBuilder builder,
                       XmlValidator validator = nullptr);

  /// True if `id` is a registered node type (builtin or user) or "SubTree".
  bool IsRegistered(const std::string& id) const;
  /// True if `id` is "SubTree" or a node type registered by the constructor (see file comment).
  bool IsBuiltin(const std::string& id) const;

  /// Sets the time source of the trees created from now on (trees already created keep the clock they were
  /// created with). Default: SteadyClockNow. Throws std::logic_error if `clock` is empty.
  void SetClock(Clock clock);
  /// The time source given to new trees.
  const Clock& clock() const { return clock_; }

  /// Sets the bounds of the documents loaded from now on. Throws std::invalid_argument naming the field and
  /// value when `limits` is not valid (TreeLimits::IsValid).
  void SetLimits(const TreeLimits& limits);
  /// The bounds checked at load (TreeLimits defaults unless SetLimits was called).
  const TreeLimits& limits() const { return limits_; }

  /// The Groot2 node palette: a <TreeNodesModel> element (text, ending in a newline) with one entry per
  /// registered node type, sorted by ID, in the format of BehaviorTree.CPP's writeTreeNodesModelXML:
  ///   <TreeNodesModel>
  ///       <Action ID="Approach">                       (Action, Condition, Control or Decorator)
  ///           <input_port name="distance_m" type="double" default="2">distance to go, metres</input_port>
  ///           <output_port name="remaining_m">half of it</output_port>
  ///       </Action>
  ///   </TreeNodesModel>
  /// Ports are input_port, output_port or inout_port; `type` is written if PortInfo::type_name is set,
  /// `default` if the port has one, the description as the element's text if not empty. Builtin node types
  /// (IsBuiltin) are left out unless `include_builtin`, as BehaviorTree.CPP does by default.
  std::string WriteTreeNodesModel(bool include_builtin = false) const;
  /// The model as a complete document, <root BTCPP_format="4"> <TreeNodesModel>...</TreeNodesModel> </root>
  /// (what BehaviorTree.CPP's writeTreeNodesModelXML returns; Groot2 imports it as a palette).
  std::string WriteTreeNodesModelDocument(bool include_builtin = false) const;
  /// `tree_xml` (a tree file's text) with the model merged into its <TreeNodesModel>, which is created as the
  /// last child of <root> if absent: entries whose ID is written by WriteTreeNodesModel are replaced; other
  /// entries (SubTree port declarations, node types of other programs) are kept. The document is re-printed
  /// by tinyxml2: comments and content are kept, indentation is normalised. The result loads with
  /// CreateTreeFromText if `tree_xml` did. Throws TreeError if `tree_xml` is malformed, its top element is
  /// not <root>, or it has more than one <TreeNodesModel>.
  std::string AddTreeNodesModel(const std::string& tree_xml, bool include_builtin = false) const;

  /// Parses and validates BehaviorTree.CPP v4 XML and instantiates the main tree on `blackboard` (a new empty
  /// blackboard if null). Throws TreeError (see class TreeError; message starts with "line N: "), or
  /// TreeError wrapping the message of an exception thrown by a node constructor; also TreeError naming the
  /// limit and the document's value when it exceeds limits() (too many nodes, a node too deep).
  Tree CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard) const;
  /// As CreateTreeFromText, reading `path`. Throws TreeError naming the path if it cannot be read; error
  /// messages start with "<path>:N: ".
  Tree CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard) const;
  /// As above, instantiating the <BehaviorTree> whose ID is `tree_id` instead of the main tree
  /// (BehaviorTree.CPP: registerBehaviorTreeFromFile + createTree(tree_id)); the whole document is still
  /// validated. Throws TreeError naming `tree_id` and the IDs present if no tree has it.
  Tree CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard,
                          const std::string& tree_id) const;
  Tree CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard,
                          const std::string& tree_id) const;

 private:
  friend class detail::TreeBuilder;
  friend class detail::ModelWriter;
  struct Entry {
    NodeType type;
    PortsList ports;
    NodeBuilder builder;
    XmlValidator validator;  // may be empty
    bool builtin = false;
  };

  Tree CreateTree(const std::string& xml, std::shared_ptr<Blackboard> blackboard, const std::string& source,
                  const std::string& tree_id) const;
  static std::string ReadTreeFile(const std::string& path);

  std::map<std::string, Entry> entries_;
  Clock clock_ = SteadyClockNow;
  TreeLimits limits_;
};

}  // namespace cairn::bt
