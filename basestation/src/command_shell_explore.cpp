// The command shell's exploration commands: `explore R [--region X0,Y0,X1,Y1] [--z-range Z0,Z1]
// [--wait [TIMEOUT_S]]` and `frontiers R` (see command_shell.h), and the exploration fields of `status`.
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

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

// "A,B[,C,D]" -> `n` numbers named `names` (for messages); false with `*error` naming the flag and the value.
bool ParseList(const std::string& flag, const std::string& text, std::size_t n, double* values,
               std::string* error) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    parts.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (parts.size() != n) {
    *error = flag + " '" + text + "' must be " + std::to_string(n) +
             " comma-separated numbers (metres, map frame)";
    return false;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!shell::ParseNumber(parts[i], flag.c_str(), &values[i], error)) return false;
    if (!std::isfinite(values[i]) || std::abs(values[i]) > 1e5) {
      *error = flag + " '" + text + "': '" + parts[i] + "' must be a finite coordinate within 100 km";
      return false;
    }
  }
  return true;
}

}  // namespace

json ExplorationJson(const cairn_msgs::RobotState& s) {
  json j = {{"state", s.explore_state()},
            {"reason", s.explore_reason()},
            {"task_id", s.explore_task_id()},
            {"explored_m2", s.explored_m2()},
            {"frontiers", s.frontier_clusters()},
            {"reachable_frontiers", s.reachable_frontiers()},
            {"targets_reached", s.explore_targets_reached()},
            {"targets_failed", s.explore_targets_failed()},
            {"peers", s.explore_peers()},
            {"peer_seen_m2", s.explore_peer_seen_m2()}};
  if (s.explore_has_target()) {
    j["target"] = {{"x_m", s.explore_target_M().x_m()},
                   {"y_m", s.explore_target_M().y_m()},
                   {"z_m", s.explore_target_M().z_m()}};
  }
  return j;
}

std::string ExplorationText(const cairn_msgs::RobotState& s) {
  if (s.explore_state().empty() || s.explore_state() == fleet::explore_state::kNone) return "none";
  std::string text = ShortId(s.explore_task_id()) + ": " + s.explore_state() + ", " +
                     Fixed(s.explored_m2(), 0) + " m² explored, " + std::to_string(s.frontier_clusters()) +
                     " frontiers (" + std::to_string(s.reachable_frontiers()) + " reachable), " +
                     std::to_string(s.explore_targets_reached()) + " reached, " +
                     std::to_string(s.explore_targets_failed()) + " given up";
  if (s.explore_has_target()) {
    text += "; target (" + Fixed(s.explore_target_M().x_m(), 2) + ", " +
            Fixed(s.explore_target_M().y_m(), 2) + ")";
  }
  if (s.explore_peers() > 0 || s.explore_peer_seen_m2() > 0) {
    text += "; " + std::to_string(s.explore_peers()) + (s.explore_peers() == 1 ? " peer" : " peers") +
            " exploring, " + Fixed(s.explore_peer_seen_m2(), 0) + " m² seen by peers";
  }
  if (!s.explore_reason().empty()) text += "; " + s.explore_reason();
  return text;
}

namespace {

// explore's words: the robots and the options every one of them gets.
struct ExploreArgs {
  std::vector<std::string> robots;
  std::optional<Eigen::AlignedBox2d> region_M;
  double min_z_m = std::numeric_limits<double>::quiet_NaN();
  double max_z_m = std::numeric_limits<double>::quiet_NaN();
  bool wait = false;
  double timeout_s = 3600;
  double home_after_silence_s = 0.0;
};

// Reads `all_args` into `*out`; false with `*error` naming the option and the value at fault.
bool ParseExploreArgs(const std::vector<std::string>& all_args, ExploreArgs* out, std::string* error) {
  for (std::size_t i = 0; i < all_args.size(); ++i) {
    const std::string& a = all_args[i];
    if (a == "--region" || a == "--z-range") {
      if (i + 1 >= all_args.size()) {
        *error = a == "--region" ? "--region needs X0,Y0,X1,Y1 (metres, map frame)"
                                 : "--z-range needs Z0,Z1 (metres, map frame)";
        return false;
      }
      if (a == "--region") {
        double v[4];
        if (!ParseList(a, all_args[i + 1], 4, v, error)) return false;
        if (!(v[0] < v[2]) || !(v[1] < v[3])) {
          *error = "--region '" + all_args[i + 1] + "': X0 must be below X1 and Y0 below Y1";
          return false;
        }
        out->region_M = Eigen::AlignedBox2d(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
      } else {
        double v[2];
        if (!ParseList(a, all_args[i + 1], 2, v, error)) return false;
        if (!(v[0] < v[1])) {
          *error = "--z-range '" + all_args[i + 1] + "': Z0 must be below Z1";
          return false;
        }
        out->min_z_m = v[0];
        out->max_z_m = v[1];
      }
      ++i;
    } else if (a == "--home-after-silence") {
      if (i + 1 >= all_args.size() ||
          !shell::ParseNumber(all_args[i + 1], "S", &out->home_after_silence_s, error) ||
          !(out->home_after_silence_s > 0 && out->home_after_silence_s <= 86400)) {
        if (error->empty()) {
          *error = "--home-after-silence needs S in (0, 86400] seconds" +
                   (i + 1 < all_args.size() ? ", not '" + all_args[i + 1] + "'" : std::string());
        }
        return false;
      }
      ++i;
    } else if (a == "--wait") {
      out->wait = true;
      if (i + 1 < all_args.size() && all_args[i + 1].rfind("--", 0) != 0) {
        if (!shell::ParseNumber(all_args[i + 1], "TIMEOUT_S", &out->timeout_s, error) ||
            out->timeout_s <= 0 || out->timeout_s > 86400) {
          if (error->empty()) *error = "TIMEOUT_S '" + all_args[i + 1] + "' must be in (0, 86400]";
          return false;
        }
        ++i;
      }
    } else if (a.rfind("--", 0) == 0) {
      *error = "unknown option '" + a + "'; " + UsageOf("explore");
      return false;
    } else {
      out->robots.push_back(a);
    }
  }
  return true;
}

}  // namespace

int CommandShell::Explore(const std::vector<std::string>& all_args) {
  ExploreArgs e;
  std::string error;
  if (!ParseExploreArgs(all_args, &e, &error)) return UsageError("explore", error);
  const std::vector<std::string>& args = e.robots;
  if (args.empty()) return UsageError("explore", UsageOf("explore"));
  if (args.size() > 1) {
    // Several robots, each its own task with the same options (the team shares its frontiers by itself).
    if (e.wait) return UsageError("explore", "--wait takes one robot (explore the others first, without it)");
    const auto outcomes = shell::SendToEach<CommandOutcome>(args, [&](const std::string& robot, std::size_t) {
      return client_.SendExplore(robot, e.region_M, e.min_z_m, e.max_z_m, e.home_after_silence_s);
    });
    return ReportEach("explore", args.front(), args, outcomes);
  }
  const std::string& robot = args[0];
  const CommandOutcome o =
      client_.SendExplore(robot, e.region_M, e.min_z_m, e.max_z_m, e.home_after_silence_s);
  if (!o.ok || !e.wait) return Report("explore", robot, o);
  if (json_) {
    out_ << Dump(json{{"command", "explore"},
                      {"robot", robot},
                      {"progress", true},
                      {"accepted", true},
                      {"reason", o.reason},
                      {"request_id", o.request_id},
                      {"task_id", o.goal_id}})
         << std::endl;
  } else {
    Report("explore", robot, o);
  }
  return WaitExplored(robot, o.goal_id, e.timeout_s);
}

int CommandShell::WaitExplored(const std::string& robot, uint32_t task_id, double timeout_s) {
  std::string failure;
  // Evaluated under the fleet client's lock: decide only, print nothing here.
  shell::LostRobotGrace lost_grace;
  auto done = [&](const RobotView& v) {
    failure = lost_grace.Check(v, core::SteadyClock::now());
    if (!v.state) return !failure.empty();
    const auto& s = *v.state;
    if (s.explore_task_id() != task_id) return !failure.empty();  // its state from before the command
    if (s.explore_state() == fleet::explore_state::kFailed ||
        s.explore_state() == fleet::explore_state::kStopped) {
      failure = "exploration " + s.explore_state() + ": " + ExplainReason(robot, s.explore_reason()).text;
    }
    return s.explore_state() == fleet::explore_state::kComplete || !failure.empty();
  };
  const auto start = core::SteadyClock::now();
  auto last_progress = start;
  std::optional<RobotView> view;
  bool cancelled = false;
  while (true) {
    const double left = timeout_s - core::SecondsBetween(start, core::SteadyClock::now());
    if (left <= 0) break;
    view = client_.WaitUntil(robot, std::min(0.1, left), done);
    if (view) break;
    if (Cancelled()) {
      cancelled = true;
      break;
    }
    PrintEvents();
    if (core::SecondsBetween(last_progress, core::SteadyClock::now()) < 5.0) continue;
    last_progress = core::SteadyClock::now();
    const auto now_view = client_.Robot(robot);  // progress, printed outside the client's lock
    if (!now_view || !now_view->state || now_view->state->explore_task_id() != task_id) continue;
    if (json_) {
      json j = ExplorationJson(*now_view->state);
      j["command"] = "explore";
      j["robot"] = robot;
      j["progress"] = true;
      out_ << Dump(j) << std::endl;
    } else {
      out_ << "explore " << robot << ": " << ExplorationText(*now_view->state) << std::endl;
    }
  }
  CommandOutcome o;
  o.ok = view.has_value() && failure.empty();
  o.result = o.ok        ? outcome::kAccepted
             : cancelled ? "cancelled"
             : view      ? outcome::kFailed
                         : outcome::kTimedOut;
  const std::string elapsed = Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 1);
  if (cancelled) {
    o.reason = "stopped waiting after " + elapsed + " s (Ctrl-C); " + robot + " explores on: stop " + robot +
               " to stop it";
  } else if (!failure.empty()) {
    o.reason = failure;
  } else if (view) {
    o.reason = view->state->explore_reason() + " after " + elapsed + " s, " +
               Fixed(view->state->explored_m2(), 0) + " m² explored";
  } else {
    o.reason = "robot " + robot + " still exploring after " + Fixed(timeout_s, 0) + " s";
  }
  if (view && view->state) {
    o.mode = view->state->mode();
    o.holder_id = view->state->holder_id();
  }
  o.goal_id = task_id;
  o.round_trip_ms = core::SecondsBetween(start, core::SteadyClock::now()) * 1000.0;
  return Report("explore", robot, o);
}

int CommandShell::Frontiers(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  if (RefuseUnknown("frontiers", robot)) return kRefused;
  client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value() || v.lost; });
  const auto view = FreshView(robot);
  if (!view || !view->state) {
    CommandOutcome o;
    o.result = outcome::kFailed;
    o.reason = "no state from " + robot + " yet";
    return Report("frontiers", robot, o);
  }
  const auto& s = *view->state;
  if (json_) {
    json j = ExplorationJson(s);
    j["command"] = "frontiers";
    j["robot"] = robot;
    j["ok"] = true;
    j["result"] = outcome::kAccepted;
    out_ << Dump(j) << std::endl;
    return kOk;
  }
  out_ << "frontiers " << robot << ": exploration " << ExplorationText(s) << std::endl;
  return kOk;
}

}  // namespace cairn::base
