#include "cairn/bt/behavior_tree.h"

#include <tinyxml2.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <climits>
#include <cmath>
#include <fstream>
#include <limits>
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

std::chrono::nanoseconds SteadyClockNow() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
      std::chrono::steady_clock::now().time_since_epoch());
}

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
    } else if (self->entries_.count(key) > 0 || !self->auto_remapping_ || !self->parent_ ||
               (!key.empty() && key.front() == '_')) {  // private keys are never auto-remapped
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

std::pair<std::string, PortInfo> OptionalInputPort(const std::string& name, const std::string& description) {
  std::pair<std::string, PortInfo> port = MakePort(name, PortInfo::Direction::kInput, nullptr, description);
  port.second.optional = true;
  return port;
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

std::chrono::nanoseconds TreeNode::Now() const { return config_.clock ? config_.clock() : SteadyClockNow(); }

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

// ---- Helpers of the builtin nodes with numeric ports.

// The literal integer of port `port` in `port_values`: nullopt if the port is absent or a "{key}" (only known
// at tick). Throws std::invalid_argument (for XmlValidator) if the literal is not an integer >= `min`.
std::optional<int> IntLiteral(const std::map<std::string, std::string>& port_values, const std::string& port,
                              int min) {
  const auto it = port_values.find(port);
  if (it == port_values.end() || TreeNode::BlackboardKey(it->second, port)) return std::nullopt;
  const std::optional<int> value = StringConverter<int>::Convert(it->second);
  if (!value || *value < min) {
    throw std::invalid_argument("port '" + port + "' must be an integer >= " + std::to_string(min) +
                                ", got '" + it->second + "'");
  }
  return value;
}

// Reads integer input `port` of `node` at tick (the value may come from the blackboard). Throws
// std::runtime_error naming the node, the port and its text when it is unset, its key is absent, or the value
// is not an integer >= `min`.
int RequireInt(const TreeNode& node, const std::string& port, int min) {
  const std::optional<int> value = node.GetInput<int>(port);
  if (value && *value >= min) return *value;
  const auto it = node.config().port_values.find(port);
  std::string text = it != node.config().port_values.end() ? it->second : std::string("(unset)");
  if (const std::optional<std::string> key = TreeNode::BlackboardKey(text, port)) {
    const std::optional<std::string> stored =
        node.config().blackboard ? node.config().blackboard->Get<std::string>(*key) : std::nullopt;
    text += stored ? " = '" + *stored + "'" : " (absent)";
  }
  throw std::runtime_error(Describe(node) + ": port '" + port +
                           "' must be an integer >= " + std::to_string(min) + ", got " + text);
}

// A port description with its TreeNodesModel type (the type BehaviorTree.CPP declares for it).
std::pair<std::string, PortInfo> Typed(std::pair<std::string, PortInfo> port, const char* type_name) {
  port.second.type_name = type_name;
  return port;
}

// ---- Parallel (BehaviorTree.CPP src/controls/parallel_node.cpp).

// The number of children a count stands for: a negative count means (children + count + 1), at least 0.
std::size_t ParallelThreshold(int count, std::size_t num_children) {
  if (count >= 0) return static_cast<std::size_t>(count);
  return static_cast<std::size_t>(std::max(static_cast<int>(num_children) + count + 1, 0));
}

// Why `success_count`/`failure_count` cannot work with `num_children` children, or "" if they can.
std::string ParallelThresholdError(int success_count, int failure_count, std::size_t num_children) {
  const std::string children = std::to_string(num_children) + " children";
  if (ParallelThreshold(success_count, num_children) > num_children) {
    return "success_count " + std::to_string(success_count) + " needs more successes than its " + children +
           " (it could never succeed)";
  }
  if (ParallelThreshold(failure_count, num_children) > num_children) {
    return "failure_count " + std::to_string(failure_count) + " needs more failures than its " + children +
           " (it could never fail)";
  }
  return "";
}

// Ticks every child that has not completed yet, in order. After each child it returns SUCCESS if
// success_count children succeeded, FAILURE if failure_count children failed or too few are left to reach
// success_count; completed children are not ticked again until the Parallel completes or is halted. On
// completion the running children are halted and all are reset.
class ParallelNode : public ControlNode {
 public:
  using ControlNode::ControlNode;

  static constexpr int kDefaultSuccessCount = -1;  // all children
  static constexpr int kDefaultFailureCount = 1;

  static PortsList ProvidedPorts() {
    return {Typed(InputPort("success_count", kDefaultSuccessCount,
                            "children that must succeed for SUCCESS; negative: children + value + 1"),
                  "int"),
            Typed(InputPort("failure_count", kDefaultFailureCount,
                            "children that must fail for FAILURE; negative: children + value + 1"),
                  "int")};
  }

  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t num_children) {
    const std::optional<int> success = IntLiteral(port_values, "success_count", INT_MIN);
    const std::optional<int> failure = IntLiteral(port_values, "failure_count", INT_MIN);
    const bool success_known = success || port_values.count("success_count") == 0;
    const bool failure_known = failure || port_values.count("failure_count") == 0;
    const std::string error =
        ParallelThresholdError(success_known ? success.value_or(kDefaultSuccessCount) : 0,
                               failure_known ? failure.value_or(kDefaultFailureCount) : 0, num_children);
    if (!error.empty()) throw std::invalid_argument(error);
  }

 protected:
  NodeStatus Tick() override {
    const int success_count = RequireInt(*this, "success_count", INT_MIN);
    const int failure_count = RequireInt(*this, "failure_count", INT_MIN);
    const std::size_t n = num_children();
    const std::string error = ParallelThresholdError(success_count, failure_count, n);
    if (!error.empty()) throw std::logic_error(Describe(*this) + ": " + error);
    const std::size_t needed_successes = ParallelThreshold(success_count, n);
    const std::size_t enough_failures = ParallelThreshold(failure_count, n);
    completed_.resize(n, false);
    for (std::size_t i = 0; i < n; ++i) {
      if (!completed_[i]) {
        const NodeStatus result = MutableChild(i).ExecuteTick();
        if (result != NodeStatus::kRunning) {
          completed_[i] = true;
          ++(result == NodeStatus::kSuccess ? successes_ : failures_);
        }
      }
      if (successes_ >= needed_successes) return Complete(NodeStatus::kSuccess);
      if (n - failures_ < needed_successes || failures_ == enough_failures) {
        return Complete(NodeStatus::kFailure);
      }
    }
    return NodeStatus::kRunning;
  }

  void HaltImpl() override {
    Clear();
    ControlNode::HaltImpl();
  }

 private:
  NodeStatus Complete(NodeStatus result) {
    Clear();
    HaltChildren();
    return result;
  }
  void Clear() {
    completed_.assign(completed_.size(), false);
    successes_ = 0;
    failures_ = 0;
  }

  std::vector<bool> completed_;  // by child index
  std::size_t successes_ = 0;
  std::size_t failures_ = 0;
};

// ---- SwitchN (BehaviorTree.CPP include/behaviortree_cpp/controls/switch_node.h,
// src/controls/switch_node.cpp).

// BehaviorTree.CPP's case comparison: equal text, or both integers and equal, or both numbers within float
// epsilon (so "2" matches "2.0" and "1e0" matches "1").
bool SwitchCaseMatches(const std::string& value, const std::string& case_value) {
  if (value == case_value) return true;
  const std::optional<int> value_int = StringConverter<int>::Convert(value);
  const std::optional<int> case_int = StringConverter<int>::Convert(case_value);
  if (value_int && case_int && *value_int == *case_int) return true;
  const std::optional<double> value_real = StringConverter<double>::Convert(value);
  const std::optional<double> case_real = StringConverter<double>::Convert(case_value);
  return value_real && case_real &&
         std::abs(*value_real - *case_real) <= static_cast<double>(std::numeric_limits<float>::epsilon());
}

std::string SwitchCasePort(std::size_t i) { return "case_" + std::to_string(i + 1); }

// N cases and N+1 children: ticks the child of the first case equal to `variable` (unset ports are skipped),
// else the last child. When the selected child changes while another one runs, that one is halted first.
template <std::size_t kCases>
class SwitchNode : public ControlNode {
 public:
  using ControlNode::ControlNode;

  static PortsList ProvidedPorts() {
    PortsList ports{
        Typed(OptionalInputPort("variable", "value compared with the cases (unset or absent key: default)"),
              "std::string")};
    for (std::size_t i = 0; i < kCases; ++i) {
      ports.insert(
          Typed(OptionalInputPort(SwitchCasePort(i), "value selecting child " + std::to_string(i + 1)),
                "std::string"));
    }
    return ports;
  }

  static void ValidateXml(const std::map<std::string, std::string>&, std::size_t num_children) {
    if (num_children != kCases + 1) throw std::invalid_argument(ChildrenError(num_children));
  }

 protected:
  NodeStatus Tick() override {
    if (num_children() != kCases + 1)
      throw std::logic_error(Describe(*this) + ": " + ChildrenError(num_children()));
    std::size_t selected = kCases;  // the default child
    if (const std::optional<std::string> variable = GetInput<std::string>("variable")) {
      for (std::size_t i = 0; i < kCases; ++i) {
        const std::optional<std::string> case_value = GetInput<std::string>(SwitchCasePort(i));
        if (case_value && SwitchCaseMatches(*variable, *case_value)) {
          selected = i;
          break;
        }
      }
    }
    if (running_ && *running_ != selected) HaltChild(*running_);
    const NodeStatus result = MutableChild(selected).ExecuteTick();
    if (result == NodeStatus::kRunning) {
      running_ = selected;
    } else {
      running_.reset();
      HaltChildren();
    }
    return result;
  }

  void HaltImpl() override {
    running_.reset();
    ControlNode::HaltImpl();
  }

 private:
  static std::string ChildrenError(std::size_t num_children) {
    return "a Switch" + std::to_string(kCases) + " needs " + std::to_string(kCases + 1) + " children (" +
           std::to_string(kCases) + " cases, then the default), found " + std::to_string(num_children);
  }

  std::optional<std::size_t> running_;  // the child left running by the last tick
};

// ---- RetryUntilSuccessful (BehaviorTree.CPP src/decorators/retry_node.cpp).

// Ticks the child until it succeeds, at most num_attempts times (-1: no limit); then fails. A child that
// fails in the same tick it started (it was idle) yields: RUNNING is returned and the next attempt is made on
// the next tick. A child that fails after running is retried at once, in the same tick.
class RetryUntilSuccessfulNode : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;

  static PortsList ProvidedPorts() {
    return {Typed(InputPort("num_attempts", "attempts before failing; -1: retry forever"), "int")};
  }

  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t) {
    IntLiteral(port_values, "num_attempts", -1);
  }

 protected:
  NodeStatus Tick() override {
    int attempts = RequireInt(*this, "num_attempts", -1);
    bool again = failures_ < attempts || attempts == -1;
    while (again) {
      const NodeStatus before = Child().status();
      const NodeStatus result = Child().ExecuteTick();
      if (result == NodeStatus::kRunning) return result;
      HaltChildren();
      if (result == NodeStatus::kSuccess) {
        failures_ = 0;
        return result;
      }
      ++failures_;
      attempts = RequireInt(*this, "num_attempts", -1);  // the child may have changed it
      again = failures_ < attempts || attempts == -1;
      if (before == NodeStatus::kIdle && again) return NodeStatus::kRunning;
    }
    failures_ = 0;
    return NodeStatus::kFailure;
  }

  void HaltImpl() override {
    failures_ = 0;
    DecoratorNode::HaltImpl();
  }

 private:
  int failures_ = 0;
};

// ---- Timeout (BehaviorTree.CPP src/decorators/timeout_node.cpp) and Delay (src/decorators/delay_node.cpp).
// BehaviorTree.CPP runs a timer thread; here the tree's Clock is read on each tick, so the expiry is seen on
// the first tick at or after it (which is when BehaviorTree.CPP's tick sees its timer's result, too).

// A decorator timed from its first tick: Start() reads `port` (ms) and notes the time, Elapsed() is the time
// since, TickChild() ticks the child and restarts the timing once it completes. Shared by Timeout and Delay.
class TimedDecorator : public DecoratorNode {
 public:
  using DecoratorNode::DecoratorNode;

 protected:
  bool started() const { return started_; }
  void Start(const char* port) {
    duration_ = std::chrono::milliseconds(RequireInt(*this, port, 0));
    start_ = Now();
    started_ = true;
  }
  std::chrono::nanoseconds Elapsed() const { return Now() - start_; }
  std::chrono::milliseconds duration() const { return duration_; }
  void Reset() {
    started_ = false;
    HaltChildren();
  }
  NodeStatus TickChild() {
    const NodeStatus result = Child().ExecuteTick();
    if (result != NodeStatus::kRunning) Reset();
    return result;
  }
  void HaltImpl() override {
    started_ = false;
    DecoratorNode::HaltImpl();
  }

 private:
  bool started_ = false;
  std::chrono::nanoseconds start_{0};
  std::chrono::milliseconds duration_{0};
};

// Ticks the child; on the first tick at or after `msec` ms since the Timeout started, while the child is
// still running, halts the child and fails without ticking it. msec="0": no time limit.
class TimeoutNode : public TimedDecorator {
 public:
  using TimedDecorator::TimedDecorator;

  static PortsList ProvidedPorts() {
    return {Typed(InputPort("msec", "halt the child and fail after this many ms of running; 0: never"),
                  "unsigned int")};
  }

  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t) {
    IntLiteral(port_values, "msec", 0);
  }

 protected:
  NodeStatus Tick() override {
    if (!started()) Start("msec");
    if (duration().count() > 0 && Child().status() == NodeStatus::kRunning && Elapsed() >= duration()) {
      Reset();
      return NodeStatus::kFailure;
    }
    return TickChild();
  }
};

// Returns RUNNING until `delay_msec` ms have passed since its first tick, then ticks the child (RUNNING,
// SUCCESS or FAILURE passes through). The first tick never ticks the child, even with delay_msec="0".
// When the child completes, the next tick starts a new delay.
class DelayNode : public TimedDecorator {
 public:
  using TimedDecorator::TimedDecorator;

  static PortsList ProvidedPorts() {
    return {Typed(InputPort("delay_msec", "ms to wait before ticking the child"), "unsigned int")};
  }

  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t) {
    IntLiteral(port_values, "delay_msec", 0);
  }

 protected:
  NodeStatus Tick() override {
    if (!started()) {
      Start("delay_msec");
      return NodeStatus::kRunning;
    }
    if (Elapsed() < duration()) return NodeStatus::kRunning;
    return TickChild();
  }
};

// ---- SetBlackboard (BehaviorTree.CPP include/behaviortree_cpp/actions/set_blackboard_node.h).

// Writes `value` (text, or a copy of the entry "{key}") to the entry named by `output_key`. As in
// BehaviorTree.CPP 4.10, output_key is read like any input port: a literal is the key's name ("goal",
// "@goal"); "{ptr}" reads the entry `ptr`, whose text is the name of the key to write. Fails if `value` is a
// "{key}" that is absent (BehaviorTree.CPP fails for a declared but empty entry and throws for an undeclared
// one; this blackboard has no empty entries). Throws std::runtime_error if output_key is "{ptr}" and `ptr`
// is absent.
class SetBlackboardNode : public SyncActionNode {
 public:
  using SyncActionNode::SyncActionNode;

  static PortsList ProvidedPorts() {
    return {
        InputPort("value", "text to store, or {key} of an entry to copy"),
        InputPort("output_key", "name of the blackboard entry to write (\"{ptr}\": the name stored in ptr)")};
  }

  static void ValidateXml(const std::map<std::string, std::string>& port_values, std::size_t) {
    const auto key = port_values.find("output_key");
    if (key != port_values.end() && key->second.empty()) {
      throw std::invalid_argument("output_key must name a blackboard entry, got ''");
    }
  }

 protected:
  NodeStatus Tick() override {
    const std::string& value_text = config().port_values.at("value");
    const std::string& key_text = config().port_values.at("output_key");
    const std::optional<std::string> pointer = BlackboardKey(key_text, "output_key");
    const std::optional<std::string> key =
        pointer ? config().blackboard->Get<std::string>(*pointer) : std::optional<std::string>(key_text);
    if (!key || key->empty()) {
      throw std::runtime_error(
          Describe(*this) + ": output_key '" + key_text + "' means: write the entry named " +
          "by the text of entry '" + pointer.value_or("") + "', which is " +
          (key ? "empty" : "absent or not text") + " (to write entry '" + pointer.value_or("") +
          "' itself, write output_key=\"" + pointer.value_or("") + "\", as in BehaviorTree.CPP)");
    }
    const std::shared_ptr<Blackboard>& blackboard = config().blackboard;
    if (const std::optional<std::string> source = BlackboardKey(value_text, "value")) {
      std::optional<std::any> value = blackboard->GetAny(*source);
      if (!value) return NodeStatus::kFailure;
      blackboard->SetAny(*key, std::move(*value));
    } else {
      blackboard->Set(*key, value_text);
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

  Tree Build(const std::string& xml, std::shared_ptr<Blackboard> blackboard, const std::string& tree_id) {
    std::string main_id = Parse(xml);
    CheckRecursion();
    if (!tree_id.empty()) {
      if (trees_.count(tree_id) == 0) {
        std::string ids;
        for (const auto& [id, unused] : trees_) ids += (ids.empty() ? "" : ", ") + id;
        Fail(0, "no <BehaviorTree ID=\"" + tree_id + "\"> in the document (its trees: " + ids + ")");
      }
      main_id = tree_id;
    }
    CheckExpandedSize(main_id);
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
      if (tag == "TreeNodesModel") {
        if (models_line_ != 0) {
          Fail(child->GetLineNum(), "a second <TreeNodesModel> (the first is on line " +
                                        std::to_string(models_line_) + "); only one is allowed");
        }
        models_line_ = child->GetLineNum();
        ParseModels(*child);
        continue;
      }
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

    CheckDocumentSize(tree_elements);

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

  // Counts the node elements of every tree and finds the deepest one, without recursion (a document nested
  // thousands deep must not exhaust the stack), before anything is parsed further: TreeError when the count
  // passes max_nodes or a node lies deeper than max_depth.
  void CheckDocumentSize(
      const std::vector<std::pair<std::string, const tinyxml2::XMLElement*>>& tree_elements) const {
    const TreeLimits& limits = factory_.limits_;
    long count = 0;
    int first_line_over = 0;
    std::vector<std::pair<const tinyxml2::XMLElement*, int>> stack;
    for (const auto& [id, element] : tree_elements) {
      for (const tinyxml2::XMLElement* c = element->FirstChildElement(); c != nullptr;
           c = c->NextSiblingElement()) {
        stack.emplace_back(c, 0);
      }
      while (!stack.empty()) {
        const auto [node, depth] = stack.back();
        stack.pop_back();
        if (++count == limits.max_nodes + 1L) first_line_over = node->GetLineNum();
        if (depth > limits.max_depth) {
          Fail(node->GetLineNum(), "<" + std::string(node->Name()) + "> in tree '" + id + "' is at depth " +
                                       std::to_string(depth) + ", deeper than the limit of " +
                                       std::to_string(limits.max_depth) + " (max_depth)");
        }
        for (const tinyxml2::XMLElement* c = node->FirstChildElement(); c != nullptr;
             c = c->NextSiblingElement()) {
          stack.emplace_back(c, depth + 1);
        }
      }
    }
    if (count > limits.max_nodes) {
      Fail(first_line_over, "the document's trees have " + std::to_string(count) +
                                " nodes, more than the limit of " + std::to_string(limits.max_nodes) +
                                " (max_nodes)");
    }
  }

  // The instantiated main tree (each SubTree expanded where it is used: a few small trees used by one another
  // many times would multiply) within max_nodes and max_depth. Sizes saturate just past the limit.
  void CheckExpandedSize(const std::string& main_id) const {
    const TreeLimits& limits = factory_.limits_;
    std::map<std::string, std::pair<long, int>> memo;  // tree ID -> (nodes, depth of its deepest node)
    const std::function<std::pair<long, int>(const NodeSpec&)> measure = [&](const NodeSpec& spec) {
      long nodes = 1;
      int depth = 0;
      if (spec.id == kSubTreeId) {
        auto found = memo.find(spec.subtree_id);
        if (found == memo.end())
          found = memo.emplace(spec.subtree_id, measure(trees_.at(spec.subtree_id))).first;
        nodes += found->second.first;
        depth = found->second.second + 1;
      }
      for (const NodeSpec& child : spec.children) {
        const auto [child_nodes, child_depth] = measure(child);
        nodes = std::min<long>(nodes + child_nodes, limits.max_nodes + 1L);
        depth = std::max(depth, child_depth + 1);
      }
      return std::make_pair(std::min<long>(nodes, limits.max_nodes + 1L), depth);
    };
    const auto [nodes, depth] = measure(trees_.at(main_id));
    if (nodes > limits.max_nodes) {
      Fail(0, "tree '" + main_id + "' with its SubTrees expanded has more than " +
                  std::to_string(limits.max_nodes) + " nodes, the limit (max_nodes)");
    }
    if (depth > limits.max_depth) {
      Fail(0, "tree '" + main_id + "' with its SubTrees expanded is " + std::to_string(depth) +
                  " deep, deeper than the limit of " + std::to_string(limits.max_depth) + " (max_depth)");
    }
  }

  // Reads <TreeNodesModel>: keeps the SubTree port declarations, checks the categories of registered IDs.
  void ParseModels(const tinyxml2::XMLElement& models) {
    for (const tinyxml2::XMLElement* entry = models.FirstChildElement(); entry != nullptr;
         entry = entry->NextSiblingElement()) {
      const std::string tag = entry->Name();
      const int line = entry->GetLineNum();
      const std::optional<NodeType> category = tag == kSubTreeId ? NodeType::kSubTree : ExplicitCategory(tag);
      if (!category) {
        Fail(line, "unexpected element <" + tag +
                       "> in <TreeNodesModel> (expected Action, Condition, Control, Decorator or SubTree)");
      }
      const char* id = entry->Attribute("ID");
      if (id == nullptr || *id == '\0') Fail(line, "<" + tag + "> in <TreeNodesModel> has no ID attribute");
      const std::string who = "<TreeNodesModel> entry <" + tag + " ID=\"" + id + "\">";
      PortsList ports = ParseModelPorts(*entry, who);
      if (*category == NodeType::kSubTree) {
        if (!subtree_models_.emplace(id, SubTreeModel{line, std::move(ports)}).second) {
          Fail(line, "duplicate " + who);
        }
        continue;
      }
      const auto registered = factory_.entries_.find(id);
      if (registered != factory_.entries_.end() && registered->second.type != *category) {
        Fail(line, who + ": '" + id + "' is registered with type " + ToString(registered->second.type) +
                       ", not " + tag);
      }
    }
  }

  // The <input_port|output_port|inout_port name=.. [default=..] [type=..] [description=..]> of a model
  // entry; other children (Groot2 metadata) are ignored.
  PortsList ParseModelPorts(const tinyxml2::XMLElement& entry, const std::string& who) {
    PortsList ports;
    for (const tinyxml2::XMLElement* port = entry.FirstChildElement(); port != nullptr;
         port = port->NextSiblingElement()) {
      const std::string tag = port->Name();
      PortInfo info;
      if (tag == "input_port") {
        info.direction = PortInfo::Direction::kInput;
      } else if (tag == "output_port") {
        info.direction = PortInfo::Direction::kOutput;
      } else if (tag == "inout_port") {
        info.direction = PortInfo::Direction::kInOut;
      } else {
        continue;
      }
      const char* name = port->Attribute("name");
      if (name == nullptr || *name == '\0') Fail(port->GetLineNum(), who + ": <" + tag + "> has no name");
      if (const char* default_value = port->Attribute("default")) {
        info.has_default = true;
        info.default_value = default_value;
      }
      if (const char* type_name = port->Attribute("type")) info.type_name = type_name;
      if (const char* description = port->Attribute("description")) {
        info.description = description;
      } else if (const char* text = port->GetText()) {
        info.description = text;
      }
      if (!ports.emplace(name, std::move(info)).second) {
        Fail(port->GetLineNum(), who + " declares port '" + std::string(name) + "' twice");
      }
    }
    return ports;
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
      if (info.direction != PortInfo::Direction::kOutput && !info.has_default && !info.optional &&
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
    if (type.validator) {
      try {
        type.validator(spec.attributes, n);
      } catch (const std::exception& e) {
        Fail(spec.line, who + ": " + e.what());
      }
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
    ApplySubTreeModel(spec, who);
    return spec;
  }

  // BehaviorTree.CPP 4.10 (xml_parsing.cpp, recursivelyCreateSubtree): without _autoremap, a port declared
  // in the <TreeNodesModel> and not set on the element takes the declared default; one without default (or
  // with an empty one) must be set.
  void ApplySubTreeModel(NodeSpec& spec, const std::string& who) const {
    const auto model = subtree_models_.find(spec.subtree_id);
    if (model == subtree_models_.end() || spec.autoremap) return;
    for (const auto& [port, info] : model->second.ports) {
      if (spec.attributes.count(port) > 0) continue;
      if (!info.has_default || info.default_value.empty()) {
        Fail(spec.line, who + " does not set port '" + port + "', which the <TreeNodesModel> (line " +
                            std::to_string(model->second.line) + ") declares without a default");
      }
      if (info.default_value == "{}") {
        Fail(model->second.line, "<TreeNodesModel> entry <SubTree ID=\"" + spec.subtree_id + "\">: port '" +
                                     port + "' has an empty blackboard key '{}' as default");
      }
      spec.attributes[port] = info.default_value;
    }
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
    config.clock = factory_.clock_;
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

  // A <SubTree> entry of the <TreeNodesModel>.
  struct SubTreeModel {
    int line = 0;
    PortsList ports;
  };

  const TreeFactory& factory_;
  const std::string source_;
  std::set<std::string> tree_ids_;
  std::map<std::string, NodeSpec> trees_;
  std::map<std::string, SubTreeModel> subtree_models_;  // by SubTree ID
  int models_line_ = 0;                                 // line of <TreeNodesModel>, 0 if none
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
  RegisterNodeType<ParallelNode>("Parallel");
  RegisterNodeType<SwitchNode<2>>("Switch2");
  RegisterNodeType<SwitchNode<3>>("Switch3");
  RegisterNodeType<SwitchNode<4>>("Switch4");
  RegisterNodeType<SwitchNode<5>>("Switch5");
  RegisterNodeType<SwitchNode<6>>("Switch6");
  RegisterNodeType<RetryUntilSuccessfulNode>("RetryUntilSuccessful");
  RegisterNodeType<TimeoutNode>("Timeout");
  RegisterNodeType<DelayNode>("Delay");
  for (auto& [id, entry] : entries_) entry.builtin = true;
}

void TreeFactory::RegisterBuilder(const std::string& id, NodeType type, PortsList ports, NodeBuilder builder,
                                  XmlValidator validator) {
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
  entries_.emplace(id, Entry{type, std::move(ports), std::move(builder), std::move(validator)});
}

void TreeFactory::RegisterSimpleCondition(const std::string& id, std::function<NodeStatus(TreeNode&)> tick,
                                          PortsList ports, XmlValidator validator) {
  if (!tick) throw std::logic_error("TreeFactory: registering '" + id + "': empty tick function");
  RegisterBuilder(
      id, NodeType::kCondition, std::move(ports),
      [tick = std::move(tick)](const std::string& name, const NodeConfig& config) {
        return std::unique_ptr<TreeNode>(std::make_unique<SimpleConditionNode>(name, config, tick));
      },
      std::move(validator));
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

bool TreeFactory::IsBuiltin(const std::string& id) const {
  const auto entry = entries_.find(id);
  return id == detail::kSubTreeId || (entry != entries_.end() && entry->second.builtin);
}

void TreeFactory::SetClock(Clock clock) {
  if (!clock) throw std::logic_error("TreeFactory::SetClock: empty clock");
  clock_ = std::move(clock);
}

// ---------------------------------------------------------------------------------------------------------
// TreeNodesModel (the format of BehaviorTree.CPP's writeTreeNodesModelXML, src/xml_parsing.cpp).

namespace {

const char* ModelPortTag(PortInfo::Direction direction) {
  switch (direction) {
    case PortInfo::Direction::kInput:
      return "input_port";
    case PortInfo::Direction::kOutput:
      return "output_port";
    case PortInfo::Direction::kInOut:
      return "inout_port";
  }
  return "input_port";
}

std::string Print(const tinyxml2::XMLNode& node) {
  tinyxml2::XMLPrinter printer;
  node.Accept(&printer);
  return printer.CStr();
}

}  // namespace

namespace detail {

class ModelWriter {
 public:
  // Appends to `models` one element per registered type written by WriteTreeNodesModel; returns their IDs.
  static std::set<std::string> Append(const TreeFactory& factory, tinyxml2::XMLDocument& doc,
                                      tinyxml2::XMLElement& models, bool include_builtin);
};

std::set<std::string> ModelWriter::Append(const TreeFactory& factory, tinyxml2::XMLDocument& doc,
                                          tinyxml2::XMLElement& models, bool include_builtin) {
  std::set<std::string> ids;
  for (const auto& [id, entry] : factory.entries_) {  // std::map: sorted by ID
    if (entry.builtin && !include_builtin) continue;
    tinyxml2::XMLElement* element = doc.NewElement(ToString(entry.type));
    element->SetAttribute("ID", id.c_str());
    for (const auto& [name, info] : entry.ports) {
      tinyxml2::XMLElement* port = doc.NewElement(ModelPortTag(info.direction));
      port->SetAttribute("name", name.c_str());
      if (!info.type_name.empty()) port->SetAttribute("type", info.type_name.c_str());
      if (info.has_default) port->SetAttribute("default", info.default_value.c_str());
      if (!info.description.empty()) port->SetText(info.description.c_str());
      element->InsertEndChild(port);
    }
    models.InsertEndChild(element);
    ids.insert(id);
  }
  return ids;
}

}  // namespace detail

std::string TreeFactory::WriteTreeNodesModel(bool include_builtin) const {
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* models = doc.NewElement("TreeNodesModel");
  doc.InsertEndChild(models);
  detail::ModelWriter::Append(*this, doc, *models, include_builtin);
  return Print(*models);
}

std::string TreeFactory::WriteTreeNodesModelDocument(bool include_builtin) const {
  tinyxml2::XMLDocument doc;
  tinyxml2::XMLElement* root = doc.NewElement("root");
  root->SetAttribute("BTCPP_format", "4");
  doc.InsertEndChild(root);
  tinyxml2::XMLElement* models = doc.NewElement("TreeNodesModel");
  root->InsertEndChild(models);
  detail::ModelWriter::Append(*this, doc, *models, include_builtin);
  return Print(doc);
}

std::string TreeFactory::AddTreeNodesModel(const std::string& tree_xml, bool include_builtin) const {
  tinyxml2::XMLDocument doc;
  if (doc.Parse(tree_xml.data(), tree_xml.size()) != tinyxml2::XML_SUCCESS) {
    throw TreeError("line " + std::to_string(doc.ErrorLineNum()) + ": malformed XML: " + doc.ErrorStr(),
                    doc.ErrorLineNum());
  }
  tinyxml2::XMLElement* root = doc.RootElement();
  if (root == nullptr || std::string(root->Name()) != "root") {
    throw TreeError("missing <root> element: cannot add a <TreeNodesModel>", root ? root->GetLineNum() : 0);
  }
  tinyxml2::XMLElement* models = root->FirstChildElement("TreeNodesModel");
  if (models != nullptr) {
    if (const tinyxml2::XMLElement* second = models->NextSiblingElement("TreeNodesModel")) {
      throw TreeError(
          "line " + std::to_string(second->GetLineNum()) + ": a second <TreeNodesModel>; only one is allowed",
          second->GetLineNum());
    }
  } else {
    models = doc.NewElement("TreeNodesModel");
    root->InsertEndChild(models);
  }
  tinyxml2::XMLDocument generated;
  tinyxml2::XMLElement* fresh = generated.NewElement("TreeNodesModel");
  generated.InsertEndChild(fresh);
  const std::set<std::string> ids = detail::ModelWriter::Append(*this, generated, *fresh, include_builtin);
  // Drop the old entries of the generated node types (not SubTree declarations), then append the new ones.
  for (tinyxml2::XMLElement* entry = models->FirstChildElement(); entry != nullptr;) {
    tinyxml2::XMLElement* next = entry->NextSiblingElement();
    const char* id = entry->Attribute("ID");
    if (id != nullptr && ids.count(id) > 0 && std::string(entry->Name()) != detail::kSubTreeId) {
      models->DeleteChild(entry);
    }
    entry = next;
  }
  for (const tinyxml2::XMLElement* entry = fresh->FirstChildElement(); entry != nullptr;
       entry = entry->NextSiblingElement()) {
    models->InsertEndChild(entry->DeepClone(&doc));
  }
  return Print(doc);
}

bool TreeLimits::IsValid(std::string* why) const {
  if (max_nodes < 1 || max_nodes > 1000000) {
    *why = "max_nodes " + std::to_string(max_nodes) + " is not in [1, 1000000]";
    return false;
  }
  if (max_depth < 1 || max_depth > 10000) {
    *why = "max_depth " + std::to_string(max_depth) + " is not in [1, 10000]";
    return false;
  }
  return true;
}

void TreeFactory::SetLimits(const TreeLimits& limits) {
  std::string why;
  if (!limits.IsValid(&why)) throw std::invalid_argument("TreeLimits: " + why);
  limits_ = limits;
}

Tree TreeFactory::CreateTree(const std::string& xml, std::shared_ptr<Blackboard> blackboard,
                             const std::string& source, const std::string& tree_id) const {
  return detail::TreeBuilder(*this, source).Build(xml, std::move(blackboard), tree_id);
}

std::string TreeFactory::ReadTreeFile(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw TreeError("cannot open behavior tree file '" + path + "'");
  std::ostringstream content;
  content << file.rdbuf();
  if (file.bad()) throw TreeError("cannot read behavior tree file '" + path + "'");
  return content.str();
}

Tree TreeFactory::CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard) const {
  return CreateTree(xml, std::move(blackboard), "", "");
}

Tree TreeFactory::CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard) const {
  return CreateTree(ReadTreeFile(path), std::move(blackboard), path, "");
}

Tree TreeFactory::CreateTreeFromText(const std::string& xml, std::shared_ptr<Blackboard> blackboard,
                                     const std::string& tree_id) const {
  return CreateTree(xml, std::move(blackboard), "", tree_id);
}

Tree TreeFactory::CreateTreeFromFile(const std::string& path, std::shared_ptr<Blackboard> blackboard,
                                     const std::string& tree_id) const {
  return CreateTree(ReadTreeFile(path), std::move(blackboard), path, tree_id);
}

}  // namespace cairn::bt
