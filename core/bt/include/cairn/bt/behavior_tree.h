// A behavior-tree engine that reads BehaviorTree.CPP v4 XML (<root BTCPP_format="4">), so trees can be edited
// in Groot2 and loaded at start without recompiling.
//
// Supported XML (anything else is rejected with a TreeError naming the element/attribute and its line):
//   <root BTCPP_format="4" [main_tree_to_execute="ID"]>   main_tree_to_execute is required if > 1 tree
//     <BehaviorTree ID="ID"> exactly one child node </BehaviorTree>   (one or more)
//     <TreeNodesModel> ... </TreeNodesModel>                            (ignored)
//   </root>
// Nodes are written compactly (<IsModeRequested mode="{requested}"/>) or explicitly
// (<Action ID="X"/>, <Condition ID="X"/>, <Control ID="X">, <Decorator ID="X">; the category must match the
// registered type). Attributes of a node: `name` (instance name), its declared ports, and `_description`
// (ignored). Other `_` attributes (scripting pre/post-conditions such as _skipIf) are not supported.
// A port value is either a literal ("1.5") or a blackboard key in braces ("{goal}"); "{=}" means the key
// with the port's own name; "{@key}" means `key` in the top-level blackboard.
//
// The whole document is validated (every BehaviorTree, used or not) before any node is constructed.
//
// Builtin nodes registered by TreeFactory:
//   Controls:   Sequence, Fallback, ReactiveSequence, ReactiveFallback
//   Decorators: Inverter, ForceSuccess, ForceFailure
//   Actions:    AlwaysSuccess, AlwaysFailure, SetBlackboard(value, output_key)
//   SubTree:    <SubTree ID="Other" [_autoremap="true"] [child_key="{parent_key}"] [child_key="literal"]/>
//
// SubTree blackboards follow BehaviorTree.CPP v4: each SubTree instance gets its OWN blackboard whose parent
// is the enclosing tree's blackboard. Every extra attribute `k="{p}"` makes the subtree's key `k` an alias of
// the parent's key `p` (`k="{=}"`: alias of the parent's `k`); `k="text"` stores the text under `k` in the
// subtree's blackboard. With _autoremap="true", every key the subtree does not define locally resolves in
// the parent under the same name (the easy way to share everything).
#pragma once

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
  std::string description;
};

/// Ports of a node type, by port name.
using PortsList = std::map<std::string, PortInfo>;

/// A required input port (XML must set it).
std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& description);
/// An optional input port with a default (literal text or "{key}") used when the XML omits it.
std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& default_value,
                                           const std::string& description);
/// An optional input port with a bool/int/double default (stored as text, e.g. 1.5 -> "1.5").
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
  return InputPort(name, text, description);
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
};

namespace detail {
class TreeBuilder;
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

 protected:
  /// One tick of the node's logic. Must not return kIdle.
  virtual NodeStatus Tick() = 0;
  /// Called by Halt() before the status is reset to kIdle: stop work, halt children. Default: nothing.
  virtual void HaltImpl() {}
  /// Mutable access to child `i` (for control and decorator nodes). Throws std::out_of_range.
  TreeNode& MutableChild(std::size_t i) { return *children_.at(i); }
  /// Halts children [first, num_children()).
  void HaltChildren(std::size_t first = 0);

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

namespace detail {
/// True if T has `static PortsList ProvidedPorts()`.
template <class T, class = void>
struct HasProvidedPorts : std::false_type {};
template <class T>
struct HasProvidedPorts<T, std::void_t<decltype(T::ProvidedPorts())>> : std::true_type {};
}  // namespace detail

/// Registry of node types and XML loader. Copyable; holds no global state.
class TreeFactory {
 public:
  /// A factory with the builtin nodes registered (see file comment).
  TreeFactory();

  /// Registers node type T under `id`. T must derive from ConditionNode, SyncActionNode, StatefulActionNode
  /// (or ActionNodeBase), ControlNode or DecoratorNode, have a constructor T(const std::string& name,
  /// const NodeConfig& config), and may have `static PortsList ProvidedPorts()`.
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
    RegisterBuilder(id, type, std::move(ports), [](const std::string& name, const NodeConfig& config) {
      return std::unique_ptr<TreeNode>(std::make_unique<T>(name, config));
    });
  }

  /// Registers a condition whose tick is `tick` (returning kSuccess/kFailure; kRunning throws
  /// std::logic_error when ticked). Same registration errors as RegisterNodeType.
  void RegisterSimpleCondition(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                               PortsList ports = {});
  /// Registers a synchronous action whose tick is `tick` (kSuccess/kFailure; kRunning throws
  /// std::logic_error when ticked — write a StatefulActionNode for long actions). Same errors as above.
  void RegisterSimpleAction(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                            PortsList ports = {});
  /// Low-level registration used by the above. Same errors; also std::logic_error if `type` is kSubTree or
  /// `builder` is empty.
  void RegisterBuilder(const std::string& id, NodeType type, PortsList ports, NodeBuilder builder);

  /// True if `id` is a registered node type (builtin or user) or "SubTree".
  bool IsRegistered(const std::string& id) const;

  /// Parses and validates BehaviorTree.CPP v4 XML and instantiates the main tree on `blackboard` (a new empty
  /// blackboard if null). Throws TreeError (see class TreeError; message starts with "line N: "), or
  /// TreeError wrapping the message of an exception thrown by a node constructor.
  Tree CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard) const;
  /// As CreateTreeFromText, reading `path`. Throws TreeError naming the path if it cannot be read; error
  /// messages start with "<path>:N: ".
  Tree CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard) const;

 private:
  friend class detail::TreeBuilder;
  struct Entry {
    NodeType type;
    PortsList ports;
    NodeBuilder builder;
  };

  Tree CreateTree(const std::string& xml, std::shared_ptr<Blackboard> blackboard,
                  const std::string& source) const;

  std::map<std::string, Entry> entries_;
};

}  // namespace cairn::bt
