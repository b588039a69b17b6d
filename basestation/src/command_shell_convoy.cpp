// The command shell's convoy commands: `convoy LEADER R1 R2 ...`, `convoy-stop [LEADER]` and
// `peel R X Y|X,Y|PLACE [TOL]` (see command_shell.h), and the convoy fields of `status`.
//
// A convoy is the followers' state, not the shell's: each follower says whom it follows (RobotState's
// convoy_ahead_ids, nearest first, the leader last), so that convoy-stop and peel work from any shell of the
// basestation that holds the robots, and after a restart of it.
#include <algorithm>
#include <cmath>
#include <limits>
#include <set>
#include <thread>

#include "cairn/base/command_shell.h"
#include "cairn/base/operator_text.h"
#include "cairn/fleet/robot_status.h"
#include "command_table.h"
#include "shell_util.h"

namespace cairn::base {

using nlohmann::json;
using shell::Dump;
using shell::Fixed;

namespace {

// The IDL's bound on ConvoyRequest.ahead_ids.
constexpr std::size_t kMaxAhead = 16;

std::string Joined(const std::vector<std::string>& ids, const char* separator) {
  std::string text;
  for (const std::string& id : ids) text += (text.empty() ? "" : separator) + id;
  return text;
}

// A passing robot's route from where it is: its position, then its global path from the point nearest it on,
// at most 32 points in all (the IDL's bound on YieldRequest.keep_clear).
std::vector<Eigen::Vector2d> RouteAhead(const RobotView& passing) {
  const auto& pose = passing.state->pose_MB().position();
  const auto& path = passing.global_path->path_M();
  std::size_t nearest = 0;
  double nearest_d = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < path.size(); ++i) {
    const double d = std::hypot(path[i].x_m() - pose.x_m(), path[i].y_m() - pose.y_m());
    if (d < nearest_d) {
      nearest_d = d;
      nearest = i;
    }
  }
  std::vector<Eigen::Vector2d> route = {{pose.x_m(), pose.y_m()}};
  const std::size_t left = path.size() - nearest;
  const std::size_t stride = (left + 30) / 31;
  for (std::size_t i = nearest; i < path.size(); i += std::max<std::size_t>(stride, 1))
    route.emplace_back(path[i].x_m(), path[i].y_m());
  if (route.back() != Eigen::Vector2d(path.back().x_m(), path.back().y_m()) && route.size() < 32)
    route.emplace_back(path.back().x_m(), path.back().y_m());
  return route;
}

// Whether robot `v` answered a request to yield to `passing` sent when its state was `before`: it gives way
// or refused, or (a robot already clear of the route ends its yield within a cycle, before a state of it is
// sampled here) a yield to `passing` ended since the request went (its reason changed).
bool AnswersYield(const RobotView& v, const std::string& passing, const cairn_msgs::RobotState& before) {
  if (!v.state || v.state->yield_peer_id() != passing) return false;
  const std::string& state = v.state->yield_state();
  if (!state.empty()) return state != fleet::yield_state::kReturning;
  return !v.state->yield_reason().empty() &&
         (v.state->yield_reason() != before.yield_reason() || before.yield_peer_id() != passing ||
          !before.yield_state().empty());
}

}  // namespace

json ConvoyJson(const cairn_msgs::RobotState& s) {
  json j = {{"state", s.convoy_state()}, {"ahead", s.convoy_ahead_ids()}, {"reason", s.convoy_reason()}};
  if (std::isfinite(s.convoy_gap_m())) j["gap_m"] = s.convoy_gap_m();
  return j;
}

std::string ConvoyText(const cairn_msgs::RobotState& s) {
  if (s.convoy_ahead_ids().empty()) return "none";
  std::string text = s.convoy_state() + " behind " + s.convoy_ahead_ids().front();
  if (std::isfinite(s.convoy_gap_m())) text += " (" + Fixed(s.convoy_gap_m(), 1) + " m along its path)";
  text += ", leader " + s.convoy_ahead_ids().back();
  if (!s.convoy_reason().empty()) text += "; " + s.convoy_reason();
  return text;
}

std::string CommandShell::RefuseUnlessHeld(const std::string& command,
                                           const std::vector<std::string>& robots) {
  for (const std::string& robot : robots) {
    if (!client_.Knows(robot)) return client_.UnknownRobotReason(robot);
    // A lock just granted (request-control right before) shows in the robot's next whole state: wait for it
    // a little before refusing.
    const std::string base = client_.base_id();
    const auto view = client_
                          .WaitUntil(robot, 1.5,
                                     [&base](const RobotView& v) {
                                       return (v.state.has_value() && v.state->holder_id() == base) || v.lost;
                                     })
                          .value_or(client_.Robot(robot).value_or(RobotView{}));
    if (!view.state) return "no state from " + robot + " yet";
    const std::string& holder = view.state->holder_id();
    if (holder != client_.base_id()) {
      return "robot " + robot + " is " +
             (holder.empty() ? "not locked by anyone" : "locked by basestation " + holder) + ": " + command +
             " needs this basestation (" + client_.base_id() + ") to hold every robot named (" +
             "request-control " + robot + ")";
    }
  }
  return "";
}

std::vector<CommandOutcome> CommandShell::SendConvoys(const std::vector<std::string>& followers,
                                                      const std::vector<std::vector<std::string>>& ahead) {
  // Every follower at once: one robot's round trip does not hold up the others.
  return shell::SendToEach<CommandOutcome>(followers, [&](const std::string& robot, std::size_t i) {
    return client_.SendConvoy(robot, ahead[i]);
  });
}

int CommandShell::Convoy(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("convoy") + " (followers in order behind the leader)";
  if (args.size() < 2) return UsageError("convoy", usage);
  if (args.size() > kMaxAhead + 1) {
    return UsageError("convoy", std::to_string(args.size()) + " robots named: a convoy has at most " +
                                    std::to_string(kMaxAhead + 1) + " (a leader and " +
                                    std::to_string(kMaxAhead) + " followers)");
  }
  std::set<std::string> seen;
  for (const std::string& robot : args) {
    if (!seen.insert(robot).second) return UsageError("convoy", "robot " + robot + " is named twice");
  }
  for (const std::string& robot : args) {
    if (RefuseUnknown("convoy", robot)) return kRefused;
  }
  if (const std::string why = RefuseUnlessHeld("convoy", args); !why.empty()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = why;
    return Report("convoy", args[0], o);
  }
  // Follower k follows robots k-1 ... 0 (the leader last).
  std::vector<std::string> followers(args.begin() + 1, args.end());
  std::vector<std::vector<std::string>> ahead;
  for (std::size_t k = 1; k < args.size(); ++k)
    ahead.emplace_back(args.rend() - static_cast<std::ptrdiff_t>(k), args.rend());
  std::vector<CommandOutcome> outcomes = SendConvoys(followers, ahead);
  if (std::any_of(outcomes.begin(), outcomes.end(), [](const CommandOutcome& o) { return !o.ok; })) {
    // Not all follow: none does (a convoy with a hole in it would follow the wrong robot).
    std::vector<std::string> taken;
    for (std::size_t i = 0; i < followers.size(); ++i) {
      if (outcomes[i].ok) {
        taken.push_back(followers[i]);
        outcomes[i].ok = false;
        outcomes[i].result = outcome::kRefused;
        outcomes[i].reason = "left the convoy again: another follower refused";
      }
    }
    SendConvoys(taken, std::vector<std::vector<std::string>>(taken.size()));
    return ReportEach("convoy", args[0], followers, outcomes, /*always_list=*/true);
  }
  if (!json_) {
    // What happens next, before it happens: the followers close up first, the leader waits for its operator.
    out_ << "convoy " << args[0] << ": " << Joined(args, " <- ") << "\n"
         << "  each follower first drives to the trail of the robot ahead of it (where that robot is now), "
            "then "
            "follows it at its spacing; "
         << args[0] << " stays where it is until you drive it (goto, teleop, smart_joystick)" << std::endl;
  }
  return ReportEach("convoy", args[0], followers, outcomes, /*always_list=*/true);
}

std::vector<std::pair<std::string, std::vector<std::string>>> CommandShell::ConvoyFollowers(
    const std::string& leader) {
  std::vector<std::pair<std::string, std::vector<std::string>>> followers;
  for (const RobotView& v : client_.Robots()) {
    if (!v.state || v.state->convoy_ahead_ids().empty()) continue;
    if (!leader.empty() && v.state->convoy_ahead_ids().back() != leader) continue;
    followers.emplace_back(v.robot_id, v.state->convoy_ahead_ids());
  }
  return followers;
}

int CommandShell::ConvoyStop(const std::vector<std::string>& all_args) {
  // --stop-leader: the leaders stop too (an operator stop); without it they drive on.
  std::vector<std::string> args;
  bool stop_leader = false;
  for (const std::string& a : all_args) {
    if (a == "--stop-leader") {
      stop_leader = true;
    } else {
      args.push_back(a);
    }
  }
  if (args.size() > 1) return UsageError("convoy-stop", UsageOf("convoy-stop"));
  const std::string leader = args.empty() ? "" : args[0];
  if (!leader.empty() && RefuseUnknown("convoy-stop", leader)) return kRefused;
  std::this_thread::sleep_until(client_.started() + std::chrono::milliseconds(1500));  // discovery
  std::vector<std::string> followers;
  std::vector<std::string> leaders;
  for (const auto& [robot, ahead] : ConvoyFollowers(leader)) {
    followers.push_back(robot);
    if (!ahead.empty() && std::find(leaders.begin(), leaders.end(), ahead.back()) == leaders.end()) {
      leaders.push_back(ahead.back());
    }
  }
  const std::string label = leader.empty() ? "all" : leader;
  if (followers.empty()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = leader.empty() ? "no robot is in a convoy" : "no robot follows " + leader;
    return Report("convoy-stop", label, o);
  }
  if (const std::string why = RefuseUnlessHeld("convoy-stop", followers); !why.empty()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = why;
    return Report("convoy-stop", label, o);
  }
  std::vector<std::string> robots = followers;
  std::vector<CommandOutcome> outcomes =
      SendConvoys(followers, std::vector<std::vector<std::string>>(followers.size()));
  for (const std::string& l : leaders) {
    if (stop_leader) {
      robots.push_back(l);
      outcomes.push_back(client_.Stop(l));
    } else if (!json_) {
      out_ << "convoy-stop " << label << ": " << l
           << " keeps driving (its goal or its operator's stick): convoy-stop " << label
           << " --stop-leader stops it too, or stop " << l << "\n";
    }
  }
  return ReportEach("convoy-stop", label, robots, outcomes, /*always_list=*/true);
}

int CommandShell::Peel(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("peel");
  if (args.size() < 2) return UsageError("peel", usage);
  const std::string& robot = args[0];
  double x = 0, y = 0, tolerance = 0;
  std::size_t used = 0;
  std::string error;
  if (!ParsePoint(args, 1, &x, &y, &used, &error)) return UsageError("peel", error);
  if (args.size() > 2 + used) return UsageError("peel", usage);
  if (args.size() == 2 + used && !shell::ParseNumber(args[1 + used], "TOL", &tolerance, &error)) {
    return UsageError("peel", error);
  }
  if (RefuseUnknown("peel", robot)) return kRefused;
  client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value() || v.lost; });
  const auto view = FreshView(robot);
  if (!view || !view->state || view->state->convoy_ahead_ids().empty()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = "robot " + robot + " is not a convoy follower (convoy LEADER R1 R2 ... first)";
    return Report("peel", robot, o);
  }
  // The followers behind it follow the robots ahead of it instead.
  const std::string leader = view->state->convoy_ahead_ids().back();
  std::vector<std::string> behind;
  std::vector<std::vector<std::string>> relinked;
  for (const auto& [follower, ahead] : ConvoyFollowers(leader)) {
    if (std::find(ahead.begin(), ahead.end(), robot) == ahead.end()) continue;
    behind.push_back(follower);
    relinked.emplace_back();
    for (const std::string& id : ahead) {
      if (id != robot) relinked.back().push_back(id);
    }
  }
  std::vector<std::string> held = behind;
  held.push_back(robot);
  if (const std::string why = RefuseUnlessHeld("peel", held); !why.empty()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = why;
    return Report("peel", robot, o);
  }
  // The goal first: a robot that cannot go there stays in the convoy and nobody re-links.
  const CommandOutcome goal = client_.SendWaypoint(robot, x, y, tolerance);
  if (goal.ok) last_goal_id_[robot] = goal.goal_id;
  if (!goal.ok || behind.empty()) return Report("peel", robot, goal);
  std::vector<std::string> robots = {robot};
  robots.insert(robots.end(), behind.begin(), behind.end());
  std::vector<CommandOutcome> outcomes = {goal};
  for (CommandOutcome& o : SendConvoys(behind, relinked)) outcomes.push_back(std::move(o));
  return ReportEach("peel", robot, robots, outcomes, /*always_list=*/true);
}

int CommandShell::Yield(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("yield") + " (R gets out of A's way)";
  if (args.empty() || args.size() == 2 || args.size() > 3 || (args.size() == 3 && args[1] != "for")) {
    return UsageError("yield", usage);
  }
  const std::string& robot = args[0];
  if (RefuseUnknown("yield", robot)) return kRefused;
  if (args.size() == 3 && RefuseUnknown("yield", args[2])) return kRefused;
  if (args.size() == 3 && args[2] == robot)
    return UsageError("yield", robot + " cannot get out of its own way");
  client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value() || v.lost; });
  const auto view = FreshView(robot);
  CommandOutcome o;
  o.result = outcome::kRefused;
  if (!view || !view->state) {
    o.reason = "no state from " + robot + " yet";
    return Report("yield", robot, o);
  }
  const std::string passing =
      args.size() == 3 ? args[2] : RobotWhoseRoutePasses(client_.Robots(), *view, 1.5);
  if (passing.empty()) {
    o.reason =
        "no robot's route passes " + robot + ": name the robot to let pass (yield " + robot + " for A)";
    return Report("yield", robot, o);
  }
  const auto other = client_.Robot(passing);
  if (!other || !other->state || !other->global_path || other->global_path->path_M().empty()) {
    o.reason = passing + " has no route to keep clear (send it a goal first)";
    return Report("yield", robot, o);
  }
  const std::vector<Eigen::Vector2d> keep_clear = RouteAhead(*other);
  const double radius_m = other->footprint_radius_m > 0 ? other->footprint_radius_m : 0.35;
  // The answer is the robot's yield state; the request goes again once if none came.
  const cairn_msgs::RobotState before = *view->state;
  auto answered = [&](const RobotView& v) { return v.lost || AnswersYield(v, passing, before); };
  std::optional<RobotView> answer;
  for (int attempt = 0; attempt < 2 && !answer; ++attempt) {
    if (std::string why = client_.SendYield(robot, passing, radius_m, keep_clear); !why.empty()) {
      o.result = why.find("DDS Security") != std::string::npos ? outcome::kRefused : outcome::kFailed;
      o.reason = why;
      return Report("yield", robot, o);
    }
    answer = client_.WaitUntil(robot, 2.5, answered);
  }
  if (!answer || !answer->state || answer->lost) {
    o.result = outcome::kTimedOut;
    o.reason = robot + " did not answer within 5 s";
    return Report("yield", robot, o);
  }
  const std::string& state = answer->state->yield_state();
  o.ok = state != fleet::yield_state::kRefused;
  o.answered = true;
  o.result = o.ok ? outcome::kAccepted : outcome::kRefused;
  o.reason = (o.ok ? "gets out of " + passing + "'s way: " : "refused to yield to " + passing + ": ") +
             answer->state->yield_reason();
  o.robot_reason = answer->state->yield_reason();
  o.mode = answer->state->mode();
  o.holder_id = answer->state->holder_id();
  return Report("yield", robot, o);
}

}  // namespace cairn::base
