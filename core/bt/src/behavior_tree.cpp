#include "cairn/bt/behavior_tree.h"

#include <tinyxml2.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <fstream>
#include <set>
#include <sstream>
#include <system_error>

namespace cairn::bt {

// ---------------------------------------------------------------------------------------------------------
// Enums, errors, conversions.

const char* ToString(NodeStatus status) {
  switch (status) {
    case NodeStatus::kIdle:
      return "IDLE";
    case NodeStatus::kRunning:
      return "RUNNING";
    case NodeStatus::kSuccess:
      return "SUCCESS";
    case NodeStatus::kFailure:
      return "FAILURE";
  }
  return "UNKNOWN";
}

const char* ToString(NodeType type) {
  switch (type) {
    case NodeType::kAction:
      return "Action";
    case NodeType::kCondition:
      return "Condition";
    case NodeType::kControl:
      return "Control";
    case NodeType::kDecorator:
      return "Decorator";
    case NodeType::kSubTree:
      return "SubTree";
  }
  return "Unknown";
}

TreeError::TreeError(const std::string& message, int line) : std::runtime_error(message), line_(line) {}

std::optional<bool> StringConverter<bool>::Convert(const std::string& text) {
  if (text == "true" || text == "True" || text == "TRUE" || text == "1") return true;
  if (text == "false" || text == "False" || text == "FALSE" || text == "0") return false;
  return std::nullopt;
}

std::optional<int> StringConverter<int>::Convert(const std::string& text) {
  int value = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

std::optional<double> StringConverter<double>::Convert(const std::string& text) {
  double value = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, value);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return value;
}

namespace detail {

std::string FormatDouble(double value) {
  std::array<char, 64> buffer{};
  const auto [ptr, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  if (ec != std::errc()) return std::to_string(value);
  return std::string(buffer.data(), ptr);
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// Blackboard.

std::shared_ptr<Blackboard> Blackboard::Create(std::shared_ptr<Blackboard> parent) {
  return std::shared_ptr<Blackboard>(new Blackboard(std::move(parent)));
}

template <class Self>
std::pair<Self*, std::string> Blackboard::Resolve(Self* self, std::string key) {
  if (!key.empty() && key.front() == '@') {
    key.erase(0, 1);
    while (self->parent_) self = self->parent_.get();
    return {self, key};
  }
  Self* next = nullptr;
  {
    std::lock_guard<std::mutex> lock(self->mutex_);
    const auto remap = self->remappings_.find(key);
    if (remap != self->remappings_.end()) {
      next = self->parent_.get();
      key = remap->second;
    } else if (self->entries_.count(key) > 0 || !self->auto_remapping_ || !self->parent_) {
      return {self, key};
    } else {
      next = self->parent_.get();
    }
  }
  return Resolve(next, std::move(key));
}

bool Blackboard::Has(const std::string& key) const { return GetAny(key).has_value(); }

std::optional<std::any> Blackboard::GetAny(const std::string& key) const {
  const auto [owner, owner_key] = Resolve(this, key);
  std::lock_guard<std::mutex> lock(owner->mutex_);
  const auto entry = owner->entries_.find(owner_key);
  if (entry == owner->entries_.end()) return std::nullopt;
  return entry->second;
}

void Blackboard::SetAny(const std::string& key, std::any value) {
  const auto [owner, owner_key] = Resolve(this, key);
  std::lock_guard<std::mutex> lock(owner->mutex_);
  owner->entries_[owner_key] = std::move(value);
}

void Blackboard::Erase(const std::string& key) {
  const auto [owner, owner_key] = Resolve(this, key);
  std::lock_guard<std::mutex> lock(owner->mutex_);
  owner->entries_.erase(owner_key);
}

std::vector<std::string> Blackboard::Keys() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> keys;
  keys.reserve(entries_.size());
  for (const auto& [key, value] : entries_) keys.push_back(key);
  return keys;
}

void Blackboard::AddRemapping(const std::string& key, const std::string& parent_key) {
  if (!parent_) throw std::logic_error("Blackboard::AddRemapping('" + key + "'): blackboard has no parent");
  if (key.empty() || parent_key.empty()) throw std::logic_error("Blackboard::AddRemapping: empty key");
  std::lock_guard<std::mutex> lock(mutex_);
  remappings_[key] = parent_key;
}

void Blackboard::EnableAutoRemapping(bool enable) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto_remapping_ = enable;
}

// ---------------------------------------------------------------------------------------------------------
// Ports.

namespace {

std::pair<std::string, PortInfo> MakePort(const std::string& name, PortInfo::Direction direction,
                                          const std::string* default_value, const std::string& description) {
  PortInfo info;
  info.direction = direction;
  info.has_default = default_value != nullptr;
  if (default_value != nullptr) info.default_value = *default_value;
  info.description = description;
  return {name, info};
}

}  // namespace

std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& description) {
  return MakePort(name, PortInfo::Direction::kInput, nullptr, description);
}

std::pair<std::string, PortInfo> InputPort(const std::string& name, const std::string& default_value,
                                           const std::string& description) {
  return MakePort(name, PortInfo::Direction::kInput, &default_value, description);
}

std::pair<std::string, PortInfo> OutputPort(const std::string& name, const std::string& description) {
  return MakePort(name, PortInfo::Direction::kOutput, nullptr, description);
}

std::pair<std::string, PortInfo> InOutPort(const std::string& name, const std::string& description) {
  return MakePort(name, PortInfo::Direction::kInOut, nullptr, description);
}

// ---------------------------------------------------------------------------------------------------------
// Nodes.

namespace {

std::string Describe(const TreeNode& node) {
  return "node '" + node.name() + "' (ID '" + node.registration_id() + "')";
}

std::string Describe(const std::string& name, const std::string& id) {
  return "node '" + name + "' (ID '" + id + "')";
}

}  // namespace

TreeNode::TreeNode(std::string name, NodeConfig config)
    : name_(std::move(name)), config_(std::move(config)) {}

NodeStatus TreeNode::ExecuteTick() {
  const NodeStatus result = Tick();
  if (result == NodeStatus::kIdle) {
    throw std::logic_error(Describe(*this) + " returned IDLE from Tick()");
  }
  if (result == NodeStatus::kRunning && !MayReturnRunning()) {
    throw std::logic_error(Describe(*this) + " is a " + ToString(type()) +
                           " and returned RUNNING; only stateful actions, controls and decorators may run");
  }
  status_ = result;
  return result;
}

void TreeNode::Halt() {
  HaltImpl();
  status_ = NodeStatus::kIdle;
}

void TreeNode::HaltChildren(std::size_t first) {
  for (std::size_t i = first; i < children_.size(); ++i) children_[i]->Halt();
}

std::optional<std::string> TreeNode::PortText(const std::string& port) const {
  const auto declared = config_.ports.find(port);
  if (declared == config_.ports.end()) {
    throw std::logic_error(Describe(*this) + " has no declared port '" + port + "'");
  }
  const auto value = config_.port_values.find(port);
  if (value != config_.port_values.end()) return value->second;
  if (declared->second.has_default) return declared->second.default_value;
  return std::nullopt;
}

std::optional<std::string> TreeNode::BlackboardKey(const std::string& text, const std::string& port) {
  if (text.size() < 3 || text.front() != '{' || text.back() != '}') return std::nullopt;
  std::string key = text.substr(1, text.size() - 2);
  if (key == "=") return port;
  return key;
}

NodeStatus StatefulActionNode::Tick() { return status() == NodeStatus::kRunning ? OnRunning() : OnStart(); }

void StatefulActionNode::HaltImpl() {
  if (status() == NodeStatus::kRunning) OnHalted();
}

namespace {

// Sequence (kContinue = kSuccess) and Fallback (kContinue = kFailure) with memory: a running child is resumed
// on the next tick without re-ticking the children before it.
template <NodeStatus kContinue>
class MemoryControlNode : public ControlNode {
 public:
  using ControlNode::ControlNode;

 protected:
  NodeStatus Tick() override {
    while (current_ < num_children()) {
      const NodeStatus result = MutableChild(current_).ExecuteTick();
      if (result == NodeStatus::kRunning) return result;
      if (result != kContinue) {
        Reset();
        return result;
      }
      ++current_;
    }
    Reset();
    return kContinue;
  }
  void HaltImpl() override {
    current_ = 0;
    ControlNode::HaltImpl();
  }

 private:
  void Reset() {
    current_ = 0;
    HaltChildren();
  }
  std::size_t current_ = 0;
};

// ReactiveSequence (kContinue = kSuccess) and ReactiveFallback (kContinue = kFailure): every tick starts at
// the first child; when child i runs, the children after it are halted (an earlier child changed the
// outcome).
template <NodeStatus kContinue>
class ReactiveControlNode : public ControlNode {
 public:
  using ControlNode::ControlNode;

 protected:
  NodeStatus Tick() override {
    for (std::size_t i = 0; i < num_children(); ++i) {
      const NodeStatus result = MutableChild(i).ExecuteTick();
      if (result == NodeStatus::kRunning) {
        HaltChildren(i + 1);
        return result;
      }
      if (result != kContinue) {
        HaltChildren();
        return result;
      }
    }
    HaltChildren();
    return kContinue;
  }
};

class InverterNode : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;

 protected:
  NodeStatus Tick() override {
    const NodeStatus result = Child().ExecuteTick();
    if (result == NodeStatus::kRunning) return result;
    HaltChildren();
    return result == NodeStatus::kSuccess ? NodeStatus::kFailure : NodeStatus::kSuccess;
  }
};

// ForceSuccess / ForceFailure: RUNNING passes through, completion becomes kResult.
template <NodeStatus kResult>
class ForceNode : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;

 protected:
  NodeStatus Tick() override {
    const NodeStatus result = Child().ExecuteTick();
    if (result == NodeStatus::kRunning) return result;
    HaltChildren();
    return kResult;
  }
};

template <NodeStatus kResult>
class ConstantActionNode : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;

 protected:
  NodeStatus Tick() override { return kResult; }
};

// Writes `value` (text, or a copy of the entry "{key}") to the key named by `output_key` ("key" or "{key}").
// Fails if `value` is a key that is not on the blackboard.
class SetBlackboardNode : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;

  static PortsList ProvidedPorts() {
    return {InputPort("value", "text to store, or {key} of an entry to copy"),
            InputPort("output_key", "blackboard key to write (plain name or {key})")};
  }

 protected:
  NodeStatus Tick() override {
    const std::string value_text = config().port_values.at("value");
    const std::string key_text = config().port_values.at("output_key");
    const std::string key = BlackboardKey(key_text, "output_key").value_or(key_text);
    const std::shared_ptr<Blackboard>& blackboard = config().blackboard;
    if (const std::optional<std::string> source = BlackboardKey(value_text, "value")) {
      std::optional<std::any> value = blackboard->GetAny(*source);
      if (!value) return NodeStatus::kFailure;
      blackboard->SetAny(key, std::move(*value));
    } else {
      blackboard->Set(key, value_text);
    }
    return NodeStatus::kSuccess;
  }
};

// An instance of another <BehaviorTree>; its single child is that tree's root.
class SubTreeNode : public TreeNode {
 public:
  using TreeNode::TreeNode;
  NodeType type() const override { return NodeType::kSubTree; }

 protected:
  NodeStatus Tick() override {
    const NodeStatus result = MutableChild(0).ExecuteTick();
    if (result != NodeStatus::kRunning) HaltChildren();
    return result;
  }
  void HaltImpl() override { HaltChildren(); }
};

class SimpleConditionNode : public ConditionNode {
 public:
  SimpleConditionNode(const std::string& name, const NodeConfig& config,
                      std::function<NodeStatus(TreeNode&)> tick)
      : ConditionNode(name, config), tick_(std::move(tick)) {}

 protected:
  NodeStatus Tick() override { return tick_(*this); }

 private:
  std::function<NodeStatus(TreeNode&)> tick_;
};

class SimpleActionNode : public SyncActionNode {
 public:
  SimpleActionNode(const std::string& name, const NodeConfig& config,
                   std::function<NodeStatus(TreeNode&)> tick)
      : SyncActionNode(name, config), tick_(std::move(tick)) {}

 protected:
  NodeStatus Tick() override { return tick_(*this); }

 private:
  std::function<NodeStatus(TreeNode&)> tick_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Tree.

Tree::Tree(Tree&& other) noexcept
    : nodes_(std::move(other.nodes_)),
      root_(std::exchange(other.root_, nullptr)),
      blackboard_(std::move(other.blackboard_)) {}

Tree& Tree::operator=(Tree&& other) noexcept {
  if (this != &other) {
    HaltTree();
    nodes_ = std::move(other.nodes_);
    root_ = std::exchange(other.root_, nullptr);
    blackboard_ = std::move(other.blackboard_);
  }
  return *this;
}

Tree::~Tree() { HaltTree(); }

NodeStatus Tree::TickOnce() {
  if (root_ == nullptr) throw std::logic_error("Tree::TickOnce on an empty tree");
  return root_->ExecuteTick();
}

void Tree::HaltTree() {
  if (root_ != nullptr) root_->Halt();
}

const TreeNode& Tree::root() const {
  if (root_ == nullptr) throw std::logic_error("Tree::root on an empty tree");
  return *root_;
}

namespace {

void VisitPreOrder(const TreeNode& node, int depth, const std::function<void(const TreeNode&, int)>& visit) {
  visit(node, depth);
  for (std::size_t i = 0; i < node.num_children(); ++i) VisitPreOrder(node.child(i), depth + 1, visit);
}

}  // namespace

void Tree::ForEachNode(const std::function<void(const TreeNode& node, int depth)>& visit) const {
  if (root_ != nullptr) VisitPreOrder(*root_, 0, visit);
}

// ---------------------------------------------------------------------------------------------------------
// XML parsing, validation and instantiation.

namespace detail {

namespace {

constexpr char kSubTreeId[] = "SubTree";

// One node element of the XML, validated.
struct NodeSpec {
  std::string id;    // registration ID, or "SubTree"
  std::string name;  // instance name
  int line = 0;
  std::map<std::string, std::string> attributes;  // ports (or, for SubTree, remappings)
  std::string subtree_id;                         // SubTree only
  bool autoremap = false;                         // SubTree only
  std::vector<NodeSpec> children;
};

bool StartsWith(const std::string& text, const char* prefix) { return text.rfind(prefix, 0) == 0; }

std::string Join(const std::vector<std::string>& items, const char* separator) {
  std::string out;
  for (const std::string& item : items) {
    if (!out.empty()) out += separator;
    out += item;
  }
  return out;
}

std::optional<NodeType> ExplicitCategory(const std::string& tag) {
  if (tag == "Action") return NodeType::kAction;
  if (tag == "Condition") return NodeType::kCondition;
  if (tag == "Control") return NodeType::kControl;
  if (tag == "Decorator") return NodeType::kDecorator;
  return std::nullopt;
}

}  // namespace

class TreeBuilder {
 public:
  TreeBuilder(const TreeFactory& factory, std::string source)
      : factory_(factory), source_(std::move(source)) {}

  Tree Build(const std::string& xml, std::shared_ptr<Blackboard> blackboard) {
    const std::string main_id = Parse(xml);
    CheckRecursion();
    Tree tree;
    tree.blackboard_ = blackboard ? std::move(blackboard) : Blackboard::Create();
    TreeNode* root = Instantiate(trees_.at(main_id), tree.blackboard_, tree);
    tree.root_ = root;
    return tree;
  }

 private:
  [[noreturn]] void Fail(int line, const std::string& message) const {
    std::string where;
    if (line > 0) {
      where = source_.empty() ? "line " + std::to_string(line) + ": "
                              : source_ + ":" + std::to_string(line) + ": ";
    } else if (!source_.empty()) {
      where = source_ + ": ";
    }
    throw TreeError(where + message, line);
  }

  // Parses the document into trees_ and returns the main tree's ID.
  std::string Parse(const std::string& xml) {
    tinyxml2::XMLDocument doc;
    if (doc.Parse(xml.data(), xml.size()) != tinyxml2::XML_SUCCESS) {
      Fail(doc.ErrorLineNum(), std::string("malformed XML: ") + doc.ErrorStr());
    }
    const tinyxml2::XMLElement* root = doc.RootElement();
    if (root == nullptr) Fail(0, "missing <root> element: the document has no element");
    if (std::string(root->Name()) != "root") {
      Fail(root->GetLineNum(),
           std::string("missing <root> element: the top element is <") + root->Name() + ">");
    }
    const char* format = root->Attribute("BTCPP_format");
    if (format == nullptr) {
      Fail(root->GetLineNum(), "<root> has no BTCPP_format attribute; only BTCPP_format=\"4\" is supported");
    }
    if (std::string(format) != "4") {
      Fail(root->GetLineNum(),
           std::string("unsupported BTCPP_format '") + format + "'; only BTCPP_format=\"4\" is supported");
    }

    // Pass 1: collect the trees, so SubTree references can be checked in pass 2.
    std::vector<std::pair<std::string, const tinyxml2::XMLElement*>> tree_elements;
    for (const tinyxml2::XMLElement* child = root->FirstChildElement(); child != nullptr;
         child = child->NextSiblingElement()) {
      const std::string tag = child->Name();
      if (tag == "TreeNodesModel") continue;
      if (tag == "include")
        Fail(child->GetLineNum(), "<include> is not supported; put all trees in one file");
      if (tag != "BehaviorTree") {
        Fail(child->GetLineNum(), "unexpected element <" + tag + "> under <root> (expected <BehaviorTree>)");
      }
      const char* id = child->Attribute("ID");
      if (id == nullptr || *id == '\0') Fail(child->GetLineNum(), "<BehaviorTree> has no ID attribute");
      if (!tree_ids_.insert(id).second) {
        Fail(child->GetLineNum(), std::string("duplicate <BehaviorTree ID=\"") + id + "\">");
      }
      tree_elements.emplace_back(id, child);
    }
    if (tree_elements.empty()) Fail(root->GetLineNum(), "<root> contains no <BehaviorTree>");

    // Pass 2: parse and validate every tree.
    for (const auto& [id, element] : tree_elements) {
      int count = 0;
      for (const tinyxml2::XMLElement* c = element->FirstChildElement(); c != nullptr;
           c = c->NextSiblingElement()) {
        ++count;
      }
      if (count != 1) {
        Fail(element->GetLineNum(), "<BehaviorTree ID=\"" + id +
                                        "\"> must contain exactly one root node, found " +
                                        std::to_string(count));
      }
      trees_.emplace(id, ParseNode(*element->FirstChildElement()));
    }

    const char* main = root->Attribute("main_tree_to_execute");
    if (main != nullptr) {
      if (tree_ids_.count(main) == 0) {
        Fail(root->GetLineNum(), std::string("main_tree_to_execute '") + main +
                                     "' does not name a <BehaviorTree> in the document");
      }
      return main;
    }
    if (tree_elements.size() > 1) {
      Fail(root->GetLineNum(), "<root> has " + std::to_string(tree_elements.size()) +
                                   " BehaviorTrees but no main_tree_to_execute attribute");
    }
    return tree_elements.front().first;
  }

  NodeSpec ParseNode(const tinyxml2::XMLElement& element) {
    const std::string tag = element.Name();
    if (tag == kSubTreeId) return ParseSubTree(element);
    NodeSpec spec;
    spec.line = element.GetLineNum();
    const std::optional<NodeType> category = ExplicitCategory(tag);
    if (category) {
      const char* id = element.Attribute("ID");
      if (id == nullptr || *id == '\0') Fail(spec.line, "<" + tag + "> has no ID attribute");
      spec.id = id;
    } else {
      spec.id = tag;
    }
    const auto entry = factory_.entries_.find(spec.id);
    if (entry == factory_.entries_.end()) Fail(spec.line, "unknown node ID '" + spec.id + "'");
    const TreeFactory::Entry& type = entry->second;
    if (category && *category != type.type) {
      Fail(spec.line, "<" + tag + " ID=\"" + spec.id + "\">: '" + spec.id + "' is registered with type " +
                          ToString(type.type) + ", not " + tag);
    }
    const char* name = element.Attribute("name");
    spec.name = name != nullptr ? name : spec.id;
    const std::string who = Describe(spec.name, spec.id);

    for (const tinyxml2::XMLAttribute* a = element.FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string attribute = a->Name();
      const std::string value = a->Value();
      if (attribute == "name" || attribute == "_description" || (category && attribute == "ID")) continue;
      if (StartsWith(attribute, "_")) {
        Fail(a->GetLineNum(), who + ": attribute '" + attribute +
                                  "' is not supported (scripting pre/post-conditions are not implemented)");
      }
      const auto port = type.ports.find(attribute);
      if (port == type.ports.end()) {
        std::vector<std::string> names;
        for (const auto& [port_name, info] : type.ports) names.push_back(port_name);
        Fail(a->GetLineNum(), who + " has no port named '" + attribute + "' (its ports: " +
                                  (names.empty() ? std::string("none") : Join(names, ", ")) + ")");
      }
      CheckKeySyntax(a->GetLineNum(), who, attribute, value);
      if (port->second.direction != PortInfo::Direction::kInput &&
          !TreeNode::BlackboardKey(value, attribute)) {
        Fail(a->GetLineNum(), who + ": output port '" + attribute +
                                  "' must be a blackboard key like {key}, got '" + value + "'");
      }
      spec.attributes[attribute] = value;
    }
    for (const auto& [port_name, info] : type.ports) {
      if (info.direction != PortInfo::Direction::kOutput && !info.has_default &&
          spec.attributes.count(port_name) == 0) {
        Fail(spec.line, who + " is missing required input port '" + port_name + "'");
      }
    }

    for (const tinyxml2::XMLElement* c = element.FirstChildElement(); c != nullptr;
         c = c->NextSiblingElement()) {
      spec.children.push_back(ParseNode(*c));
    }
    const std::size_t n = spec.children.size();
    if (type.type == NodeType::kControl && n == 0) {
      Fail(spec.line, who + " is a Control node and needs at least one child");
    }
    if (type.type == NodeType::kDecorator && n != 1) {
      Fail(spec.line, who + " is a Decorator and needs exactly one child, found " + std::to_string(n));
    }
    if ((type.type == NodeType::kAction || type.type == NodeType::kCondition) && n != 0) {
      Fail(spec.line, who + " is a leaf (" + ToString(type.type) + ") and cannot have children, found " +
                          std::to_string(n));
    }
    return spec;
  }

  NodeSpec ParseSubTree(const tinyxml2::XMLElement& element) {
    NodeSpec spec;
    spec.id = kSubTreeId;
    spec.line = element.GetLineNum();
    const char* id = element.Attribute("ID");
    if (id == nullptr || *id == '\0') Fail(spec.line, "<SubTree> has no ID attribute");
    spec.subtree_id = id;
    if (tree_ids_.count(spec.subtree_id) == 0) {
      Fail(spec.line, "SubTree ID '" + spec.subtree_id + "' is not defined by any <BehaviorTree>");
    }
    const char* name = element.Attribute("name");
    spec.name = name != nullptr ? name : spec.subtree_id;
    const std::string who = "SubTree '" + spec.name + "' (ID '" + spec.subtree_id + "')";
    for (const tinyxml2::XMLAttribute* a = element.FirstAttribute(); a != nullptr; a = a->Next()) {
      const std::string attribute = a->Name();
      const std::string value = a->Value();
      if (attribute == "name" || attribute == "ID" || attribute == "_description") continue;
      if (attribute == "_autoremap") {
        const std::optional<bool> enabled = StringConverter<bool>::Convert(value);
        if (!enabled) Fail(a->GetLineNum(), who + ": _autoremap must be true or false, got '" + value + "'");
        spec.autoremap = *enabled;
        continue;
      }
      if (StartsWith(attribute, "_"))
        Fail(a->GetLineNum(), who + ": attribute '" + attribute + "' is not supported");
      CheckKeySyntax(a->GetLineNum(), who, attribute, value);
      spec.attributes[attribute] = value;
    }
    if (element.FirstChildElement() != nullptr) Fail(spec.line, who + " cannot have children");
    return spec;
  }

  void CheckKeySyntax(int line, const std::string& who, const std::string& attribute,
                      const std::string& value) {
    if (value == "{}") Fail(line, who + ": port '" + attribute + "' has an empty blackboard key '{}'");
  }

  // Rejects SubTree cycles (A -> B -> A, or A -> A).
  void CheckRecursion() const {
    std::map<std::string, int> state;  // 0 unvisited, 1 on the current path, 2 done
    std::vector<std::string> path;
    for (const auto& [id, spec] : trees_) {
      if (state[id] == 0) VisitTree(id, state, path);
    }
  }

  void VisitTree(const std::string& id, std::map<std::string, int>& state,
                 std::vector<std::string>& path) const {
    state[id] = 1;
    path.push_back(id);
    VisitSpec(trees_.at(id), state, path);
    path.pop_back();
    state[id] = 2;
  }

  void VisitSpec(const NodeSpec& spec, std::map<std::string, int>& state,
                 std::vector<std::string>& path) const {
    if (spec.id == kSubTreeId) {
      const int s = state[spec.subtree_id];
      if (s == 1) {
        const auto start = std::find(path.begin(), path.end(), spec.subtree_id);
        std::vector<std::string> cycle(start, path.end());
        cycle.push_back(spec.subtree_id);
        Fail(spec.line, "recursive SubTree '" + spec.subtree_id + "': " + Join(cycle, " -> "));
      }
      if (s == 0) VisitTree(spec.subtree_id, state, path);
      return;
    }
    for (const NodeSpec& child : spec.children) VisitSpec(child, state, path);
  }

  TreeNode* Instantiate(const NodeSpec& spec, const std::shared_ptr<Blackboard>& blackboard,
                        Tree& tree) const {
    NodeConfig config;
    config.blackboard = blackboard;
    config.port_values = spec.attributes;
    config.registration_id = spec.id;
    config.xml_line = spec.line;
    std::unique_ptr<TreeNode> node;
    if (spec.id == kSubTreeId) {
      node = std::make_unique<SubTreeNode>(spec.name, config);
    } else {
      const TreeFactory::Entry& entry = factory_.entries_.at(spec.id);
      config.ports = entry.ports;
      try {
        node = entry.builder(spec.name, config);
      } catch (const TreeError&) {
        throw;
      } catch (const std::exception& e) {
        Fail(spec.line, "constructing " + Describe(spec.name, spec.id) + " failed: " + e.what());
      }
      if (!node) Fail(spec.line, "the builder of " + Describe(spec.name, spec.id) + " returned null");
      if (node->type() != entry.type) {
        Fail(spec.line, "the builder of " + Describe(spec.name, spec.id) + " made a " +
                            ToString(node->type()) + " but the type is registered as a " +
                            ToString(entry.type));
      }
    }
    TreeNode* raw = node.get();
    tree.nodes_.push_back(std::move(node));

    if (spec.id == kSubTreeId) {
      std::shared_ptr<Blackboard> scoped = Blackboard::Create(blackboard);
      for (const auto& [key, value] : spec.attributes) {
        if (const std::optional<std::string> parent_key = TreeNode::BlackboardKey(value, key)) {
          scoped->AddRemapping(key, *parent_key);
        } else {
          scoped->Set(key, value);
        }
      }
      scoped->EnableAutoRemapping(spec.autoremap);
      raw->children_.push_back(Instantiate(trees_.at(spec.subtree_id), scoped, tree));
    } else {
      for (const NodeSpec& child : spec.children)
        raw->children_.push_back(Instantiate(child, blackboard, tree));
    }
    return raw;
  }

  const TreeFactory& factory_;
  const std::string source_;
  std::set<std::string> tree_ids_;
  std::map<std::string, NodeSpec> trees_;
};

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// TreeFactory.

TreeFactory::TreeFactory() {
  RegisterNodeType<MemoryControlNode<NodeStatus::kSuccess>>("Sequence");
  RegisterNodeType<MemoryControlNode<NodeStatus::kFailure>>("Fallback");
  RegisterNodeType<ReactiveControlNode<NodeStatus::kSuccess>>("ReactiveSequence");
  RegisterNodeType<ReactiveControlNode<NodeStatus::kFailure>>("ReactiveFallback");
  RegisterNodeType<InverterNode>("Inverter");
  RegisterNodeType<ForceNode<NodeStatus::kSuccess>>("ForceSuccess");
  RegisterNodeType<ForceNode<NodeStatus::kFailure>>("ForceFailure");
  RegisterNodeType<ConstantActionNode<NodeStatus::kSuccess>>("AlwaysSuccess");
  RegisterNodeType<ConstantActionNode<NodeStatus::kFailure>>("AlwaysFailure");
  RegisterNodeType<SetBlackboardNode>("SetBlackboard");
}

void TreeFactory::RegisterBuilder(const std::string& id, NodeType type, PortsList ports,
                                  NodeBuilder builder) {
  const std::string where = "TreeFactory: registering '" + id + "': ";
  if (id.empty()) throw std::logic_error("TreeFactory: empty node ID");
  for (const char* reserved : {"root", "BehaviorTree", "TreeNodesModel", "include", "SubTree", "Action",
                               "Condition", "Control", "Decorator"}) {
    if (id == reserved) throw std::logic_error(where + "the ID is reserved by the XML format");
  }
  if (entries_.count(id) > 0) throw std::logic_error(where + "the ID is already registered");
  if (type == NodeType::kSubTree) throw std::logic_error(where + "SubTree nodes cannot be registered");
  if (!builder) throw std::logic_error(where + "empty builder");
  for (const auto& [port, info] : ports) {
    if (port.empty() || port == "name" || port == "ID" || port.front() == '_') {
      throw std::logic_error(where + "invalid port name '" + port +
                             "' (empty, 'name', 'ID' or starting with '_')");
    }
  }
  entries_.emplace(id, Entry{type, std::move(ports), std::move(builder)});
}

void TreeFactory::RegisterSimpleCondition(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                                          PortsList ports) {
  if (!tick) throw std::logic_error("TreeFactory: registering '" + id + "': empty tick function");
  RegisterBuilder(
      id, NodeType::kCondition, std::move(ports),
      [tick = std::move(tick)](const std::string& name, const NodeConfig& config) {
        return std::unique_ptr<TreeNode>(std::make_unique<SimpleConditionNode>(name, config, tick));
      });
}

void TreeFactory::RegisterSimpleAction(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                                       PortsList ports) {
  if (!tick) throw std::logic_error("TreeFactory: registering '" + id + "': empty tick function");
  RegisterBuilder(id, NodeType::kAction, std::move(ports),
                  [tick = std::move(tick)](const std::string& name, const NodeConfig& config) {
                    return std::unique_ptr<TreeNode>(std::make_unique<SimpleActionNode>(name, config, tick));
                  });
}

bool TreeFactory::IsRegistered(const std::string& id) const {
  return id == detail::kSubTreeId || entries_.count(id) > 0;
}

Tree TreeFactory::CreateTree(const std::string& xml, std::shared_ptr<Blackboard> blackboard,
                             const std::string& source) const {
  return detail::TreeBuilder(*this, source).Build(xml, std::move(blackboard));
}

Tree TreeFactory::CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard) const {
  return CreateTree(xml, std::move(blackboard), "");
}

Tree TreeFactory::CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard) const {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw TreeError("cannot open behavior tree file '" + path + "'");
  std::ostringstream content;
  content << file.rdbuf();
  if (file.bad()) throw TreeError("cannot read behavior tree file '" + path + "'");
  return CreateTree(content.str(), std::move(blackboard), path);
}

}  // namespace cairn::bt
