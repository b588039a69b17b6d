#include "cairn/agent/modes/mode_manager.h"

#include <algorithm>
#include <map>

#include "cairn/agent/modes/tree_file.h"

namespace cairn::agent {

using bt::NodeStatus;

// State shared between the manager and the node callbacks registered with the factory.
struct ModeManager::Context {
  ModeConditions conditions;
  std::string failure;  // first failed condition of the matching branch
  std::string selected_mode;
  std::string selected_channel;
  std::map<const bt::TreeNode*, NodeStatus> trace;  // leaf results of the current tick
};

namespace {

NodeStatus Fail(std::string* failure, std::string text) {
  if (failure->empty()) *failure = std::move(text);
  return NodeStatus::kFailure;
}

// Wraps a leaf callback so that its result is recorded in the tick's trace (control nodes reset their
// children when they finish, so the tree itself no longer shows what each leaf returned).
template <class Context>
std::function<NodeStatus(bt::TreeNode&)> Traced(std::shared_ptr<Context> ctx,
                                                std::function<NodeStatus(bt::TreeNode&)> tick) {
  return [ctx, tick = std::move(tick)](bt::TreeNode& node) {
    const NodeStatus status = tick(node);
    ctx->trace[&node] = status;
    return status;
  };
}

// A fact of ModeConditions the tree checks: a condition node that succeeds when it holds and otherwise fails
// saying why (the refusal an operator reads).
struct Fact {
  const char* node;
  bool (*holds)(const ModeConditions&);
  std::string (*why)(const ModeConditions&);
};

const Fact kFacts[] = {
    {"IsControlHeld", [](const ModeConditions& c) { return !c.holder_id.empty(); },
     [](const ModeConditions&) { return std::string("no basestation holds the control lock"); }},
    {"IsHolderAlive", [](const ModeConditions& c) { return !c.holder_id.empty() && c.holder_alive; },
     [](const ModeConditions& c) {
       return c.holder_id.empty() ? std::string("no basestation holds the control lock")
                                  : "liveliness of control holder " + c.holder_id +
                                        " is lost (no live process speaks for it)";
     }},
    {"IsLocalized", [](const ModeConditions& c) { return c.localized; },
     [](const ModeConditions& c) {
       return "no valid pose estimate" +
              (c.localization_problem.empty() ? std::string() : ": " + c.localization_problem);
     }},
    {"HasWaypointGoal", [](const ModeConditions& c) { return c.has_waypoint_goal; },
     [](const ModeConditions&) { return std::string("no accepted waypoint goal (send goto first)"); }},
    {"HasExploreTask", [](const ModeConditions& c) { return c.has_explore_task; },
     [](const ModeConditions&) { return std::string("no exploration task (send explore first)"); }},
    {"HasConvoyTask", [](const ModeConditions& c) { return c.has_convoy_task; },
     [](const ModeConditions&) { return std::string("not in a convoy (send convoy first)"); }},
    {"HasYieldTask", [](const ModeConditions& c) { return c.has_yield_task; },
     [](const ModeConditions&) { return std::string("no yield request accepted (a peer or yield R asks)"); }},
    {"IsMappingHealthy", [](const ModeConditions& c) { return c.mapping_healthy; },
     [](const ModeConditions& c) { return c.mapping_problem; }},
    {"IsJoystickAlive", [](const ModeConditions& c) { return c.joystick_alive; },
     [](const ModeConditions&) { return std::string("the control holder has no live joystick"); }},
    {"IsLocalPlannerHealthy", [](const ModeConditions& c) { return c.local_planner_healthy; },
     [](const ModeConditions& c) { return c.local_planner_problem; }},
};

}  // namespace

void ModeManager::RegisterFactNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx) {
  for (const Fact& fact : kFacts) {
    factory.RegisterSimpleCondition(fact.node, Traced(ctx, [ctx, fact](bt::TreeNode&) {
                                      if (fact.holds(ctx->conditions)) return NodeStatus::kSuccess;
                                      return Fail(&ctx->failure,
                                                  std::string(fact.node) + ": " + fact.why(ctx->conditions));
                                    }));
  }
}

void ModeManager::RegisterNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx) {
  RegisterModeNodes(factory, ctx);
  // The other trees of the same file (the waypoint recovery) use these; they run only there.
  RegisterOtherTreeNodeTypes(factory, TreeInFile::kModeTree);
}

void ModeManager::RegisterModeNodes(bt::TreeFactory& factory) {
  RegisterModeNodes(factory, std::make_shared<Context>());
}

void ModeManager::RegisterModeNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& ctx) {
  factory.RegisterSimpleCondition(
      "IsModeRequested",
      Traced(ctx,
             [](bt::TreeNode& node) {
               const auto wanted = node.GetInput<std::string>("mode");
               const auto requested = node.GetInput<std::string>("requested_mode");
               return (wanted && requested && *wanted == *requested) ? NodeStatus::kSuccess
                                                                     : NodeStatus::kFailure;
             }),
      {bt::InputPort("mode", "mode this branch implements"),
       bt::InputPort("requested_mode", "{requested_mode}", "mode being asked for")});
  RegisterFactNodes(factory, ctx);
  factory.RegisterSimpleCondition(
      "IsComponentUp",
      Traced(ctx,
             [ctx](bt::TreeNode& node) {
               const auto name = node.GetInput<std::string>("component");
               if (!name) return Fail(&ctx->failure, "IsComponentUp: missing component port");
               const std::vector<std::string>& known = AgentComponentNames();
               if (std::find(known.begin(), known.end(), *name) == known.end()) {
                 std::string names;
                 for (const auto& k : known) names += (names.empty() ? "" : ", ") + k;
                 return Fail(&ctx->failure, "IsComponentUp: no component \"" + *name +
                                                "\" (the components are " + names + ")");
               }
               const auto down = ctx->conditions.components_down.find(*name);
               return down == ctx->conditions.components_down.end()
                          ? NodeStatus::kSuccess
                          : Fail(&ctx->failure, "IsComponentUp: " + down->second);
             }),
      {bt::InputPort("component", "an agent component (AgentComponentNames())")},
      // A literal name that is no component would fail every tick: the branch could never be taken.
      [](const std::map<std::string, std::string>& ports, std::size_t) {
        const auto component = ports.find("component");
        if (component == ports.end() || bt::TreeNode::BlackboardKey(component->second, "component")) return;
        const std::vector<std::string>& known = AgentComponentNames();
        if (std::find(known.begin(), known.end(), component->second) != known.end()) return;
        std::string names;
        for (const auto& k : known) names += (names.empty() ? "" : ", ") + k;
        throw std::invalid_argument("component \"" + component->second +
                                    "\" is not a component of cairn_agent (its components: " + names + ")");
      });
  factory.RegisterSimpleAction(
      "SelectMode",
      Traced(ctx,
             [ctx](bt::TreeNode& node) {
               const auto mode = node.GetInput<std::string>("mode");
               const auto channel = node.GetInput<std::string>("channel");
               if (!mode || !channel) return Fail(&ctx->failure, "SelectMode: missing mode or channel port");
               ctx->selected_mode = *mode;
               ctx->selected_channel = *channel;
               return NodeStatus::kSuccess;
             }),
      {bt::InputPort("mode", "mode to commit"), bt::InputPort("channel", "mux channel of that mode")});
}

std::string ModeManager::TreeNodesModel() {
  bt::TreeFactory factory;
  RegisterNodes(factory, std::make_shared<Context>());
  return factory.WriteTreeNodesModel();
}

std::string ModeManager::WithTreeNodesModel(const std::string& tree_xml) {
  bt::TreeFactory factory;
  RegisterNodes(factory, std::make_shared<Context>());
  return factory.AddTreeNodesModel(tree_xml);
}

ModeManager::ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels,
                         const std::map<std::string, std::string>& module_channels)
    : ModeManager(tree_file, mux_channels, &module_channels) {}

ModeManager::ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels)
    : ModeManager(tree_file, mux_channels, nullptr) {}

ModeManager::ModeManager(const std::string& tree_file, const std::vector<std::string>& mux_channels,
                         const std::map<std::string, std::string>* module_channels)
    : context_(std::make_shared<Context>()) {
  bt::TreeFactory factory;
  RegisterNodes(factory, context_);
  tree_ = factory.CreateTreeFromFile(tree_file, bt::Blackboard::Create());
  tree_.ForEachNode([this](const bt::TreeNode& node, int) {
    if (node.registration_id() != "IsModeRequested") return;
    if (auto mode = node.GetInput<std::string>("mode")) {
      if (std::find(known_modes_.begin(), known_modes_.end(), *mode) == known_modes_.end()) {
        known_modes_.push_back(*mode);
      }
    }
  });
  if (std::find(known_modes_.begin(), known_modes_.end(), kIdleMode) == known_modes_.end()) {
    throw bt::TreeError(tree_file + ": the mode tree has no branch for the fail-safe mode 'idle'");
  }
  CheckChannels(tree_file, mux_channels, module_channels);
}

void ModeManager::CheckChannels(const std::string& tree_file, const std::vector<std::string>& mux_channels,
                                const std::map<std::string, std::string>* module_channels) const {
  std::string list = "none";
  for (const auto& c : mux_channels) list += ", " + c;
  std::vector<std::string> ancestors;  // names of the nodes above the one visited (pre-order)
  tree_.ForEachNode([&](const bt::TreeNode& node, int depth) {
    ancestors.resize(static_cast<std::size_t>(depth));
    const std::string branch = ancestors.empty() ? node.name() : ancestors.back();
    ancestors.push_back(node.name());
    if (node.registration_id() != "SelectMode") return;
    const auto& ports = node.config().port_values;
    const auto channel = ports.find("channel");
    const auto mode = ports.find("mode");
    const std::string where = tree_file + ":" + std::to_string(node.config().xml_line) + ": branch '" +
                              branch + "' (SelectMode mode=\"" + (mode == ports.end() ? "" : mode->second) +
                              "\")";
    if (channel == ports.end())
      throw bt::TreeError(where + " has no channel port (mux channels: " + list + ")");
    if (mode == ports.end() || mode->second.empty() || mode->second.find('{') != std::string::npos) {
      throw bt::TreeError(where +
                          ": a SelectMode's mode must be a literal mode name (checked against its channel "
                          "at load), not empty or a blackboard entry");
    }
    const std::string& name = channel->second;
    if (name.find('{') != std::string::npos) {
      throw bt::TreeError(where + " takes its channel '" + name +
                          "' from the blackboard: a channel must be a literal mux channel (" + list + ")");
    }
    if (mode->second == kIdleMode && name != "none") {
      throw bt::TreeError(
          where + ": the fail-safe mode 'idle' must select channel 'none' (zero twist), not '" + name + "'");
    }
    if (module_channels != nullptr && module_channels->count(mode->second) == 0) {
      std::string modules;
      for (const auto& [m, c] : *module_channels) modules += (modules.empty() ? "" : ", ") + m;
      throw bt::TreeError(where + ": no mode module implements mode '" + mode->second + "' (modules: " +
                          modules + "): a new mode needs its module registered in the agent");
    }
    if (name != "none" && std::find(mux_channels.begin(), mux_channels.end(), name) == mux_channels.end()) {
      throw bt::TreeError(where + " names mux channel '" + name +
                          "', which the mux does not have (channels: " + list + ")");
    }
    if (module_channels != nullptr && module_channels->at(mode->second) != name) {
      throw bt::TreeError(where + " selects mux channel '" + name + "', but mode module '" + mode->second +
                          "' feeds channel '" + module_channels->at(mode->second) + "'");
    }
  });
}

bool ModeManager::Evaluate(const std::string& mode, const ModeConditions& conditions, std::string* channel,
                           std::string* failure) {
  context_->conditions = conditions;
  context_->failure.clear();
  context_->selected_mode.clear();
  context_->selected_channel.clear();
  context_->trace.clear();
  tree_.blackboard()->Set<std::string>("requested_mode", mode);
  const NodeStatus status = tree_.TickOnce();
  ++tick_count_;
  last_root_status_ = status;
  tree_.HaltTree();  // every evaluation starts fresh; no node keeps running between mode decisions
  if (status == NodeStatus::kSuccess && context_->selected_mode == mode) {
    *channel = context_->selected_channel;
    return true;
  }
  if (!context_->failure.empty()) {
    *failure = context_->failure;
  } else {
    std::string list;
    for (const auto& m : known_modes_) list += (list.empty() ? "" : ", ") + m;
    *failure = "unknown mode '" + mode + "' (valid: " + list + ")";
  }
  return false;
}

ModeDecision ModeManager::Request(const std::string& mode, const ModeConditions& conditions) {
  std::string channel, failure;
  const bool accepted = Evaluate(mode, conditions, &channel, &failure);
  KeepTrace();
  if (accepted) {
    mode_ = mode;
    channel_ = channel;
    last_refusal_.clear();
    return {true, mode_, channel_, ""};
  }
  last_refusal_ = failure;
  return {false, mode_, channel_, failure};
}

ModeDecision ModeManager::Recheck(const ModeConditions& conditions) {
  std::string channel, failure;
  const bool still_allowed = Evaluate(mode_, conditions, &channel, &failure);
  KeepTrace();
  if (still_allowed) {
    channel_ = channel;
    return {true, mode_, channel_, ""};
  }
  const std::string previous = mode_;
  std::string idle_channel, idle_failure;
  Evaluate(kIdleMode, conditions, &idle_channel, &idle_failure);
  KeepTrace();
  mode_ = kIdleMode;
  channel_ = idle_channel.empty() ? "none" : idle_channel;
  return {false, mode_, channel_, previous + " no longer allowed: " + failure};
}

ModeDecision ModeManager::ForceIdle(const std::string& refusal) {
  mode_ = kIdleMode;
  channel_ = "none";
  if (!refusal.empty()) last_refusal_ = refusal;
  return {true, mode_, channel_, refusal};
}

void ModeManager::KeepTrace() {
  last_trace_ = context_->trace;
  last_trace_[&tree_.root()] = last_root_status_;
}

NodeStatus ModeManager::LastTickStatus(const bt::TreeNode& node) const {
  auto it = last_trace_.find(&node);
  return it == last_trace_.end() ? NodeStatus::kIdle : it->second;
}

std::vector<std::string> ModeManager::ValidModes(const ModeConditions& conditions) {
  std::vector<std::string> valid;
  for (const auto& mode : known_modes_) {
    std::string channel, failure;
    if (Evaluate(mode, conditions, &channel, &failure)) valid.push_back(mode);
  }
  return valid;
}

}  // namespace cairn::agent
