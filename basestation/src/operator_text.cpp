#include "cairn/base/operator_text.h"

#include <algorithm>
#include <cstdio>
#include <utility>

#include "cairn/core/health_monitor.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::base {

namespace {

// The text after "Condition: " in a reason, or "" when `reason` does not contain `condition`.
std::string Detail(const std::string& reason, const std::string& condition) {
  const auto at = reason.find(condition + ": ");
  return at == std::string::npos ? "" : reason.substr(at + condition.size() + 2);
}

std::size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

}  // namespace

OperatorReason ExplainReason(const std::string& robot_id, const std::string& reason) {
  struct Rule {
    const char* condition;
    std::string (*explain)(const std::string& robot, const std::string& detail);
  };
  static const Rule kRules[] = {
      {"IsControlHeld",
       [](const std::string& r, const std::string&) {
         return "nobody holds " + r + "'s control lock: request-control " + r + " first";
       }},
      {"IsHolderAlive",
       [](const std::string& r, const std::string& d) {
         return "the basestation holding " + r + " is not connected (" + d + ")";
       }},
      {"IsLocalized",
       [](const std::string& r, const std::string& d) {
         return r + " does not know where it is (not localized" + (d.empty() ? "" : ": " + d) + ")";
       }},
      {"HasWaypointGoal",
       [](const std::string& r, const std::string&) {
         return "waypoint mode needs a goal: use goto " + r + " X Y";
       }},
      {"IsJoystickAlive",
       [](const std::string&, const std::string&) {
         return std::string(
             "smart joystick needs a joystick at the holding basestation (it runs with --no-joystick "
             "or is not connected): use manual");
       }},
      {"IsLocalPlannerHealthy",
       [](const std::string& r, const std::string& d) {
         return r + "'s obstacle sensing is not ready: " + d;
       }},
      {"IsMappingHealthy",
       [](const std::string& r, const std::string& d) { return r + " is not mapping: " + d; }},
      {"IsComponentUp",
       [](const std::string& r, const std::string& d) {
         if (d.find(core::HealthMonitor::kStartingSuffix) != std::string::npos) {
           return r + " is still starting its software: " + d + "; try again in a moment";
         }
         return "a part of " + r + "'s software is down and restarting by itself: " + d + " (health " + r +
                ")";
       }},
      {"HasExploreTask", [](const std::string& r,
                            const std::string&) { return "explore mode needs a task: use explore " + r; }},
      {"HasYieldTask",
       [](const std::string& r, const std::string&) {
         return r + " gets out of the way only when asked: use yield " + r;
       }},
      {"HasConvoyTask",
       [](const std::string& r, const std::string&) {
         return "convoy mode needs the robots ahead: use convoy LEADER ... " + r + " (in order)";
       }},
  };
  for (const Rule& rule : kRules) {
    const std::string detail = Detail(reason, rule.condition);
    if (detail.empty() && reason.find(std::string(rule.condition) + ":") == std::string::npos) continue;
    std::string text = rule.explain(robot_id, detail);
    // A re-check keeps its lead-in ("manual no longer allowed: ..."): say what changed, then why.
    const auto at = reason.find(rule.condition);
    if (at > 0 && at != std::string::npos) text = reason.substr(0, at) + text;
    return {text, rule.condition};
  }
  return {reason, ""};
}

std::vector<std::string> ValidActions(const RobotView& view, const std::string& base_id) {
  if (view.lost || !view.state) return {"stop"};  // a stop is always allowed (and sent even to a lost robot)
  const std::string& holder = view.state->holder_id();
  // Get out of the way: any basestation may ask (the robot's yield policy decides, not the lock), but never
  // a robot an operator drives, nor one already yielding.
  const std::string& now = view.state->mode();
  const bool can_yield = now != "manual" && now != "smart_joystick" && now != "yield";
  if (holder.empty()) {
    return can_yield ? std::vector<std::string>{"request-control", "yield", "stop"}
                     : std::vector<std::string>{"request-control", "stop"};
  }
  // Another basestation holds it: a request asks its operator to hand it over.
  if (holder != base_id)
    return can_yield ? std::vector<std::string>{"request-control", "yield", "stop"}
                     : std::vector<std::string>{"request-control", "stop"};
  std::vector<std::string> actions;
  // A request for the lock waits for this basestation's answer.
  if (const std::string& asking = view.state->control_requester_id(); !asking.empty()) {
    actions.push_back("grant " + asking);
    actions.push_back("deny " + asking);
  }
  std::string modes;
  bool can_teleop = false, can_goto = false, can_explore = false;
  if (view.tree) {
    for (const auto& mode : view.tree->valid_modes()) {
      if (mode == "manual" || mode == "smart_joystick") can_teleop = true;
      // Entered by goto / explore / convoy, which set the task.
      if (mode == "waypoint" || mode == "explore" || mode == "convoy") continue;
      modes += (modes.empty() ? "" : "|") + mode;
    }
    can_goto = view.tree->goal_acceptable();
    can_explore = view.tree->explore_acceptable();
  }
  const std::string& mode = view.state->mode();
  can_teleop = can_teleop || mode == "manual" || mode == "smart_joystick";
  if (!modes.empty()) actions.push_back("mode " + modes);
  if (can_goto) actions.emplace_back("goto");
  if (can_goto) actions.emplace_back("home");
  if (can_goto && view.state->has_resumable_goal()) actions.emplace_back("resume-goal");
  if (can_explore) actions.emplace_back("explore");
  // A convoy: any robot the tree would drive to a goal may lead or follow; a follower may peel off or stop
  // it.
  if (can_goto) actions.emplace_back("convoy");
  if (!view.state->convoy_ahead_ids().empty()) {
    actions.emplace_back("peel");
    actions.emplace_back("convoy-stop");
  }
  if (can_teleop) actions.emplace_back("teleop");
  if (can_yield) actions.emplace_back("yield");
  actions.emplace_back("handover");
  actions.emplace_back("release");
  actions.emplace_back("stop");
  return actions;
}

namespace {

// The robots of `fleet` that follow `leader` in a convoy (its robot last in their convoy_ahead_ids).
std::size_t FollowersOf(const std::string& leader, const std::vector<RobotView>& fleet) {
  std::size_t n = 0;
  for (const RobotView& other : fleet) {
    if (other.state && !other.state->convoy_ahead_ids().empty() &&
        other.state->convoy_ahead_ids().back() == leader) {
      ++n;
    }
  }
  return n;
}

std::string PointText(double x_m, double y_m) {
  char text[64];
  std::snprintf(text, sizeof(text), "(%.1f, %.1f)", x_m, y_m);
  return text;
}

}  // namespace

std::string TaskText(const RobotView& view, const std::vector<RobotView>& fleet) {
  if (!view.state) return "?";
  const cairn_msgs::RobotState& s = *view.state;
  namespace yield = fleet::yield_state;
  const std::string& peer = s.yield_peer_id();
  if (s.mission_state() == fleet::mission_state::kPaused) {
    return s.mission_kind() + " paused" + (s.mission_reason().empty() ? "" : ": " + s.mission_reason());
  }
  if (s.yield_state() == yield::kReturning) return "back after yielding to " + peer;
  if (fleet::GivesWay(s.yield_state())) return "yielding to " + peer;
  if (s.yield_state() == yield::kAsking) return "waiting for " + peer + " to yield";
  if (s.yield_state() == yield::kBlocked) return "blocked by " + peer;
  const auto& ahead = s.convoy_ahead_ids();
  if (!ahead.empty()) {
    const std::string place = "convoy " + std::to_string(ahead.size() + 1) + " of " +
                              std::to_string(FollowersOf(ahead.back(), fleet) + 1) + " behind " +
                              ahead.front();
    const std::string& state = s.convoy_state();
    return state == fleet::convoy_state::kFollowing || state.empty() ? place : place + ", " + state;
  }
  const std::size_t followers = FollowersOf(view.robot_id, fleet);
  const std::string leads = followers > 0 ? "leads a convoy of " + std::to_string(followers + 1) : "";
  std::string task;
  if (s.explore_state() == fleet::explore_state::kExploring) {
    task = "exploring: " + std::to_string(static_cast<long>(s.explored_m2())) + " m² mapped, " +
           std::to_string(s.reachable_frontiers()) + " frontiers";
  } else if (s.nav_status() == cairn_msgs::NAV_STATUS_ACTIVE) {
    task = "to " + PointText(s.nav_goal_M().x_m(), s.nav_goal_M().y_m());
  } else if (s.mode() == "manual" || s.mode() == "smart_joystick") {
    task = "driven (" + s.mode() + ")";
  } else if (s.mode() == "idle" && s.nav_status() == cairn_msgs::NAV_STATUS_ARRIVED) {
    task = "arrived at " + PointText(s.nav_goal_M().x_m(), s.nav_goal_M().y_m());
  } else {
    task = s.mode().empty() ? "?" : s.mode();
  }
  return leads.empty() ? task : leads + "; " + task;
}

std::string RobotWhoseRoutePasses(const std::vector<RobotView>& fleet, const RobotView& robot,
                                  double within_m) {
  if (!robot.state) return "";
  const Eigen::Vector2d p(robot.state->pose_MB().position().x_m(), robot.state->pose_MB().position().y_m());
  std::string best;
  double best_d = within_m;
  for (const RobotView& other : fleet) {
    if (other.robot_id == robot.robot_id || other.lost || !other.global_path || !other.state) continue;
    const auto& path = other.global_path->path_M();
    for (std::size_t i = 0; i + 1 < path.size(); ++i) {
      const Eigen::Vector2d a(path[i].x_m(), path[i].y_m()), b(path[i + 1].x_m(), path[i + 1].y_m());
      const Eigen::Vector2d ab = b - a;
      const double t = ab.squaredNorm() > 0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      const double d = (a + t * ab - p).norm();
      if (d <= best_d) {
        best_d = d;
        best = other.robot_id;
      }
    }
  }
  return best;
}

std::string DescribeAgent(const RobotView& view) {
  auto joined = [](const std::vector<std::string>& words) {
    std::string text;
    for (const std::string& w : words) text += (text.empty() ? "" : " ") + w;
    return text;
  };
  auto fixed = [](double v, int digits) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.*f", digits, v);
    return std::string(text);
  };
  std::vector<std::string> parts;
  if (!view.platform.empty()) parts.push_back(view.platform);
  if (!view.version.empty()) parts.push_back("cairn " + view.version);
  if (!view.capabilities.empty()) parts.push_back("modes " + joined(view.capabilities));
  parts.push_back(view.sensors.empty() ? "no sensors" : "sensors " + joined(view.sensors));
  parts.push_back(view.map_resolution_m > 0 ? "map " + fixed(view.map_resolution_m, 2) + " m" : "no map");
  if (!view.link.link.empty()) {
    parts.push_back("link " + view.link.link +
                    (view.link.budget_kbps > 0 ? " " + fixed(view.link.budget_kbps, 0) + " kbit/s" : ""));
  }
  std::string text;
  for (const std::string& p : parts) text += (text.empty() ? "" : ", ") + p;
  return text;
}

std::string ValidActionsText(const RobotView& view, const std::string& base_id) {
  const std::vector<std::string> actions = ValidActions(view, base_id);
  std::string text = "valid now: ";
  if (view.lost) text = "robot " + view.robot_id + " is lost; valid now: ";
  if (!view.lost && !view.state) text = "no state from " + view.robot_id + " yet; valid now: ";
  for (std::size_t i = 0; i < actions.size(); ++i) text += (i ? ", " : "") + actions[i];
  return text;
}

std::vector<std::string> DidYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  std::vector<std::pair<std::size_t, std::string>> scored;
  for (const auto& c : candidates) {
    if (c == word) continue;
    const std::size_t d = EditDistance(word, c);
    const bool prefix = word.size() >= 3 && c.rfind(word, 0) == 0;
    if (d <= 2 || prefix) scored.emplace_back(prefix ? 0 : d, c);
  }
  std::stable_sort(scored.begin(), scored.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<std::string> best;
  for (const auto& [d, c] : scored) {
    if (best.size() == 3) break;
    best.push_back(c);
  }
  return best;
}

std::string DidYouMeanText(const std::string& word, const std::vector<std::string>& candidates) {
  const std::vector<std::string> best = DidYouMean(word, candidates);
  if (best.empty()) return "";
  std::string text = " (did you mean ";
  for (std::size_t i = 0; i < best.size(); ++i) {
    text += (i == 0 ? "" : i + 1 == best.size() ? " or " : ", ") + best[i];
  }
  return text + "?)";
}

std::string ShortId(std::uint32_t id) {
  if (id < 1000) return "#" + std::to_string(id);
  char text[8];
  std::snprintf(text, sizeof(text), "#%03u", static_cast<unsigned>(id % 1000));
  return text;
}

}  // namespace cairn::base
