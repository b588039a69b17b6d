#include "cairn/agent/modes/waypoint_recovery.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <future>
#include <stdexcept>

#include "cairn/agent/modes/tree_file.h"
#include "cairn/core/range_check.h"

namespace cairn::agent {

using bt::NodeStatus;

namespace {

constexpr double kPi = 3.14159265358979323846;

using core::Fixed;

// Parses a port's text as a number in (lo, hi] for ValidateXml; throws std::invalid_argument naming both.
void CheckNumber(const std::map<std::string, std::string>& ports, const std::string& port, double lo,
                 double hi) {
  const auto it = ports.find(port);
  if (it == ports.end() || it->second.empty() || it->second.front() == '{') return;  // default or blackboard
  std::size_t used = 0;
  double value = std::nan("");
  try {
    value = std::stod(it->second, &used);
  } catch (const std::exception&) {
  }
  std::string why;
  if (used != it->second.size() || !core::InRange(("port " + port).c_str(), value, lo, hi, true, &why)) {
    throw std::invalid_argument(why.empty() ? "port " + port + " = '" + it->second + "' is not a number"
                                            : why);
  }
}

}  // namespace

// State shared by the tree's nodes and the component.
struct WaypointRecovery::Context {
  nav::Navigation* navigation = nullptr;
  Hooks hooks;
  // Input of the current tick.
  core::BaseState state;
  double now_s = 0.0;
  // Output of the current tick.
  double linear_x_mps = 0.0;
  double angular_z_radps = 0.0;
  bool arrived = false;
  std::future<nav::GlobalPlan> plan;  // the attempt's plan, while it runs on the planner's worker
  // The goal being recovered.
  double goal_x_m = 0.0;
  double goal_y_m = 0.0;
  double goal_z_m = std::numeric_limits<double>::quiet_NaN();  // the goal's level, NaN = none named
  double goal_tolerance_m = 0.0;
  bool active = false;
  std::string first_failure;     // navigation's reason that started the recovery
  int attempt = 0;               // number of the attempt under way (1-based), 0 before the first
  std::string attempt_label;     // e.g. "back up 0.30 m"
  std::vector<std::string> log;  // one line per finished attempt or failed action
  bool abandoned = false;  // an attempt's goal was abandoned (NavigationStep::abandoned): no further attempt

  void Stop() {
    linear_x_mps = 0.0;
    angular_z_radps = 0.0;
  }
  // An action before the retry failed: counts as the attempt, with its reason.
  NodeStatus ActionFailed(const std::string& action, const std::string& why) {
    ++attempt;
    log.push_back("attempt " + std::to_string(attempt) + " (" + action + "): " + why);
    Stop();
    return NodeStatus::kFailure;
  }
};

namespace {

using Context = WaypointRecovery::Context;

std::shared_ptr<Context> Need(const std::shared_ptr<Context>& context, const std::string& id) {
  if (!context) {
    throw std::logic_error(id + " is a waypoint recovery action: it can only run in the " +
                           std::string(WaypointRecovery::kTreeId) + " tree");
  }
  return context;
}

// Drives straight backwards distance_m at speed_mps, checking the way back against the live obstacles.
class BackUp : public bt::StatefulActionNode {
 public:
  BackUp(const std::string& name, const bt::NodeConfig& config, std::shared_ptr<Context> context)
      : StatefulActionNode(name, config), ctx_(std::move(context)) {}
  static bt::PortsList ProvidedPorts() {
    return {bt::InputPort("distance_m", 0.3, "distance to back up, metres (0, 2]"),
            bt::InputPort("speed_mps", 0.15, "backing speed, m/s (0, 0.5]")};
  }
  static void ValidateXml(const std::map<std::string, std::string>& ports, std::size_t) {
    CheckNumber(ports, "distance_m", 0.0, 2.0);
    CheckNumber(ports, "speed_mps", 0.0, 0.5);
  }

 protected:
  NodeStatus OnStart() override {
    distance_m_ = GetInput<double>("distance_m").value_or(0.3);
    speed_mps_ = GetInput<double>("speed_mps").value_or(0.15);
    label_ = "back up " + Fixed(distance_m_, 2) + " m";
    start_ = ctx_->state;
    std::string why;
    if (!ctx_->navigation->ClearBehind(ctx_->state, distance_m_, kMarginM, &why)) {
      return ctx_->ActionFailed(label_, why);
    }
    return OnRunning();
  }
  NodeStatus OnRunning() override {
    const double travelled = std::hypot(ctx_->state.x_m - start_.x_m, ctx_->state.y_m - start_.y_m);
    if (travelled >= distance_m_ - 0.02) {
      ctx_->Stop();
      ctx_->attempt_label = label_;
      return NodeStatus::kSuccess;
    }
    std::string why;
    if (!ctx_->navigation->ClearBehind(ctx_->state, distance_m_ - travelled, kMarginM, &why)) {
      return ctx_->ActionFailed(label_, "stopped after " + Fixed(travelled, 2) + " m: " + why);
    }
    ctx_->linear_x_mps = -speed_mps_;
    ctx_->angular_z_radps = 0.0;
    return NodeStatus::kRunning;
  }
  void OnHalted() override {
    ctx_->Stop();
    if (ctx_->active) ctx_->ActionFailed(label_, "interrupted (e.g. by a Timeout)");
  }

 private:
  static constexpr double kMarginM = 0.02;
  std::shared_ptr<Context> ctx_;
  core::BaseState start_;
  double distance_m_ = 0.3;
  double speed_mps_ = 0.15;
  std::string label_;
};

// Turns in place by angle_deg toward the goal's side (a disk footprint cannot collide by turning).
class Spin : public bt::StatefulActionNode {
 public:
  Spin(const std::string& name, const bt::NodeConfig& config, std::shared_ptr<Context> context)
      : StatefulActionNode(name, config), ctx_(std::move(context)) {}
  static bt::PortsList ProvidedPorts() {
    return {bt::InputPort("angle_deg", 90.0, "angle to turn, degrees (0, 360]"),
            bt::InputPort("yaw_rate_radps", 0.8, "turn rate, rad/s (0, 3]")};
  }
  static void ValidateXml(const std::map<std::string, std::string>& ports, std::size_t) {
    CheckNumber(ports, "angle_deg", 0.0, 360.0);
    CheckNumber(ports, "yaw_rate_radps", 0.0, 3.0);
  }

 protected:
  NodeStatus OnStart() override {
    angle_rad_ = GetInput<double>("angle_deg").value_or(90.0) * kPi / 180.0;
    rate_radps_ = GetInput<double>("yaw_rate_radps").value_or(0.8);
    const double bearing = std::atan2(ctx_->goal_y_m - ctx_->state.y_m, ctx_->goal_x_m - ctx_->state.x_m);
    direction_ = std::remainder(bearing - ctx_->state.yaw_rad, 2 * kPi) >= 0.0 ? 1.0 : -1.0;
    turned_rad_ = 0.0;
    last_yaw_rad_ = ctx_->state.yaw_rad;
    label_ = "rotate " + Fixed(angle_rad_ * 180.0 / kPi, 0) + " deg";
    return OnRunning();
  }
  NodeStatus OnRunning() override {
    turned_rad_ += std::abs(std::remainder(ctx_->state.yaw_rad - last_yaw_rad_, 2 * kPi));
    last_yaw_rad_ = ctx_->state.yaw_rad;
    if (turned_rad_ >= angle_rad_ - 0.05) {
      ctx_->Stop();
      ctx_->attempt_label = label_;
      return NodeStatus::kSuccess;
    }
    ctx_->linear_x_mps = 0.0;
    ctx_->angular_z_radps = direction_ * rate_radps_;
    return NodeStatus::kRunning;
  }
  void OnHalted() override {
    ctx_->Stop();
    if (ctx_->active)
      ctx_->ActionFailed(label_, "interrupted after " + Fixed(turned_rad_ * 180 / kPi, 0) + " deg");
  }

 private:
  std::shared_ptr<Context> ctx_;
  double angle_rad_ = 0.0;
  double rate_radps_ = 0.8;
  double direction_ = 1.0;
  double turned_rad_ = 0.0;
  double last_yaw_rad_ = 0.0;
  std::string label_;
};

// Plans the goal again from where the robot is and drives it with Navigation: success on arrival, failure
// (with navigation's reason, logged as one attempt) when navigation gives up again.
class FollowGoal : public bt::StatefulActionNode {
 public:
  FollowGoal(const std::string& name, const bt::NodeConfig& config, std::shared_ptr<Context> context)
      : StatefulActionNode(name, config), ctx_(std::move(context)) {}
  static bt::PortsList ProvidedPorts() {
    return {
        bt::InputPort("clearance", "normal",
                      "normal, or reduced: plan with no clearance preference and squeeze through tight spots "
                      "with no margin beyond the footprint"),
        bt::InputPort("attempt", "",
                      "what this attempt tried, for the report (default: what the actions "
                      "before it did, else \"replan\")")};
  }
  static void ValidateXml(const std::map<std::string, std::string>& ports, std::size_t) {
    const auto it = ports.find("clearance");
    if (it != ports.end() && it->second != "normal" && it->second != "reduced") {
      throw std::invalid_argument("port clearance = '" + it->second + "' must be normal or reduced");
    }
  }

 protected:
  NodeStatus OnStart() override {
    const bool reduced = GetInput<std::string>("clearance").value_or("normal") == "reduced";
    std::string label = GetInput<std::string>("attempt").value_or("");
    if (label.empty()) label = ctx_->attempt_label.empty() ? "replan" : ctx_->attempt_label;
    if (reduced) label += ", reduced clearance";
    ctx_->attempt_label.clear();
    ++ctx_->attempt;
    label_ = label;
    ctx_->navigation->SetReducedClearance(reduced);
    // Planned on a worker: the robot holds still meanwhile, and the control loop goes on (its watchdogs too).
    ctx_->plan = ctx_->navigation->PlanGoalAsync(ctx_->state, ctx_->goal_x_m, ctx_->goal_y_m, ctx_->goal_z_m);
    return OnRunning();
  }
  NodeStatus OnRunning() override {
    if (ctx_->plan.valid()) {
      ctx_->Stop();
      if (nav::PlanRunning(ctx_->plan)) return NodeStatus::kRunning;
      const nav::GlobalPlan plan = ctx_->plan.get();
      if (!plan.IsUsable()) return Failed("no path: " + plan.reason);
      ctx_->navigation->AcceptGoal(plan, ctx_->goal_x_m, ctx_->goal_y_m, ctx_->goal_tolerance_m, ctx_->now_s,
                                   ctx_->goal_z_m);
    }
    const nav::NavigationStep step = ctx_->navigation->StepWaypoint(ctx_->state, ctx_->now_s);
    if (step.arrived) {
      ctx_->Stop();
      ctx_->arrived = true;
      ctx_->navigation->SetReducedClearance(false);
      return NodeStatus::kSuccess;
    }
    if (step.failed) {
      ctx_->abandoned = ctx_->abandoned || step.abandoned;
      return Failed(step.reason);
    }
    ctx_->linear_x_mps = step.linear_x_mps;
    ctx_->angular_z_radps = step.angular_z_radps;
    return NodeStatus::kRunning;
  }
  void OnHalted() override {
    ctx_->Stop();
    ctx_->navigation->Abandon(std::move(ctx_->plan));
    ctx_->navigation->ClearGoal();
    ctx_->navigation->SetReducedClearance(false);
    if (ctx_->active)
      ctx_->log.push_back("attempt " + std::to_string(ctx_->attempt) + " (" + label_ + "): interrupted");
  }

 private:
  NodeStatus Failed(const std::string& why) {
    ctx_->log.push_back("attempt " + std::to_string(ctx_->attempt) + " (" + label_ + "): " + why);
    ctx_->navigation->SetReducedClearance(false);
    ctx_->Stop();
    return NodeStatus::kFailure;
  }

  std::shared_ptr<Context> ctx_;
  std::string label_;
};

template <class Node>
void Register(bt::TreeFactory& factory, const std::string& id, const std::shared_ptr<Context>& context) {
  factory.RegisterBuilder(
      id, bt::NodeType::kAction, Node::ProvidedPorts(),
      [context, id](const std::string& name, const bt::NodeConfig& config) {
        return std::unique_ptr<bt::TreeNode>(std::make_unique<Node>(name, config, Need(context, id)));
      },
      &Node::ValidateXml);
}

}  // namespace

void WaypointRecovery::RegisterNodes(bt::TreeFactory& factory, const std::shared_ptr<Context>& context) {
  factory.RegisterSimpleAction("ClearObstacleMemory", [context](bt::TreeNode&) {
    const auto ctx = Need(context, "ClearObstacleMemory");
    if (ctx->hooks.clear_obstacle_memory) ctx->hooks.clear_obstacle_memory();
    ctx->navigation->ClearObstacles();
    ctx->Stop();
    ctx->attempt_label = "clear the local obstacle memory";
    return NodeStatus::kSuccess;
  });
  Register<BackUp>(factory, "BackUp", context);
  Register<Spin>(factory, "Spin", context);
  Register<FollowGoal>(factory, "FollowGoal", context);
}

WaypointRecovery::WaypointRecovery(const std::string& tree_file, nav::Navigation* navigation, Hooks hooks)
    : context_(std::make_shared<Context>()) {
  if (navigation == nullptr) throw std::invalid_argument("WaypointRecovery: navigation is null");
  context_->navigation = navigation;
  context_->hooks = std::move(hooks);
  // The mode tree file holds the mode conditions too: the factory knows every node type the agent
  // registers, so that the whole document validates (mode nodes cannot run here: their context is absent).
  bt::TreeFactory factory;
  RegisterOtherTreeNodeTypes(factory, TreeInFile::kWaypointRecovery);
  RegisterNodes(factory, context_);
  // Timeout and Delay count on the navigation clock (Step's now_s), so that a simulated clock runs them too.
  factory.SetClock([context = context_] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
        std::chrono::duration<double>(context->now_s));
  });
  try {
    tree_ = factory.CreateTreeFromFile(tree_file, bt::Blackboard::Create(), kTreeId);
  } catch (const bt::TreeError& e) {
    if (std::string(e.what()).find(std::string("no <BehaviorTree ID=\"") + kTreeId + "\">") ==
        std::string::npos) {
      throw;
    }
  }
}

WaypointRecovery::~WaypointRecovery() { Halt(); }

bool WaypointRecovery::active() const { return context_->active; }

bool WaypointRecovery::planning() const { return context_->active && nav::PlanRunning(context_->plan); }

void WaypointRecovery::Start(double x_m, double y_m, double tolerance_m, const std::string& failure,
                             double z_m) {
  if (!enabled()) throw std::logic_error("WaypointRecovery::Start: the tree file has no recovery tree");
  Halt();
  Context& c = *context_;
  c.goal_x_m = x_m;
  c.goal_y_m = y_m;
  c.goal_z_m = z_m;
  c.goal_tolerance_m = tolerance_m;
  c.first_failure = failure;
  c.attempt = 0;
  c.attempt_label.clear();
  c.log.clear();
  c.arrived = false;
  c.abandoned = false;
  c.Stop();
  c.active = true;
}

nav::NavigationStep WaypointRecovery::Step(const core::BaseState& state, double now_s) {
  nav::NavigationStep out;
  Context& c = *context_;
  if (!c.active) return out;
  c.state = state;
  c.now_s = now_s;
  c.Stop();
  const NodeStatus status = tree_.TickOnce();
  if (status == NodeStatus::kRunning && !c.abandoned) {
    out.linear_x_mps = c.linear_x_mps;
    out.angular_z_radps = c.angular_z_radps;
    return out;
  }
  c.active = false;
  tree_.HaltTree();
  if (status == NodeStatus::kSuccess && c.arrived) {
    out.arrived = true;
    return out;
  }
  out.failed = true;  // a tree that ends without arriving has not recovered the goal
  out.abandoned = c.abandoned;
  std::string attempts;
  for (const std::string& line : c.log) attempts += (attempts.empty() ? "" : "; ") + line;
  out.reason = c.first_failure + "; recovery failed: " + (attempts.empty() ? "no attempt made" : attempts);
  return out;
}

void WaypointRecovery::Halt() {
  if (!context_->active) return;
  context_->active = false;  // halted actions do not log an interruption when the whole recovery stops
  tree_.HaltTree();
  context_->Stop();
}

std::string WaypointRecovery::Report() const {
  const Context& c = *context_;
  if (!c.active) return "";
  std::string text = "recovering after: " + c.first_failure;
  for (const std::string& line : c.log) text += "; " + line;
  return text;
}

}  // namespace cairn::agent
