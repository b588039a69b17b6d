#include "cairn/base/command_shell.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <deque>
#include <limits>
#include <sstream>
#include <thread>

#include "cairn/base/operator_text.h"
#include "cairn/core/shutdown.h"
#include "cairn/fleet/robot_status.h"
#include "command_table.h"
#include "shell_util.h"

namespace cairn::base {

namespace msgs = cairn_msgs;
using nlohmann::json;
using shell::Dump;
using shell::Fixed;
using shell::ParseNumber;
using shell::PrintTable;
using shell::StaircaseJson;
using shell::YawOf;

namespace {

// Every field of a view (`status --json`, `robots --json`): machines read these, people read the summary.
// `fleet`: every robot's view, for the task's place in a convoy.
json ViewJson(const RobotView& v, const std::vector<RobotView>& fleet, const std::string& base_id) {
  json j = {{"robot", v.robot_id},
            {"platform", v.platform},
            {"lost", v.lost},
            {"seen_s_ago", core::SecondsBetween(v.last_seen, core::SteadyClock::now())},
            {"valid_actions", ValidActions(v, base_id)}};
  if (v.lost) j["lost_reason"] = v.lost_reason;
  if (v.max_speed_mps > 0) j["max_speed_mps"] = v.max_speed_mps;
  if (v.state) {
    const auto& s = *v.state;
    j["mode"] = s.mode();
    j["holder"] = s.holder_id();
    j["holder_alive"] = s.holder_alive();
    j["holder_participant"] = s.holder_participant();
    j["holder_participants"] = s.holder_participants();
    j["task"] = TaskText(v, fleet);
    j["control_requester"] = s.control_requester_id();
    j["control_request_left_s"] = s.control_request_left_s();
    j["handover_outcome"] = s.handover_outcome();
    if (s.has_resumable_goal()) {
      const auto& g = s.resumable_goal_M();
      j["resumable_goal"] = {{"x_m", g.x_m()}, {"y_m", g.y_m()}};
      if (std::isfinite(g.z_m())) j["resumable_goal"]["z_m"] = g.z_m();
    }
    j["x_m"] = s.pose_MB().position().x_m();
    j["y_m"] = s.pose_MB().position().y_m();
    j["z_m"] = s.pose_MB().position().z_m();
    j["yaw_rad"] = YawOf(s.pose_MB().orientation());
    j["linear_x_mps"] = s.twist_B().linear_x_mps();
    j["angular_z_radps"] = s.twist_B().angular_z_radps();
    j["active_channel"] = s.active_channel();
    j["mux_reason"] = s.mux_reason();
    j["discarded_commands"] = s.discarded_commands();
    j["nav_status"] = fleet::NavStatusWord(s.nav_status());
    j["nav_reason"] = s.nav_reason();
    j["nav_goal_id"] = s.nav_goal_id();
    j["nav_distance_left_m"] = s.nav_distance_left_m();
    j["nav_eta_s"] = s.nav_eta_s();
    j["nav_replans"] = s.nav_replans();
    j["local_planner_status"] = s.local_planner_status();
    j["in_contact"] = s.in_contact();
    j["stops"] = s.stops();
    j["stopped_by"] = s.stopped_by();
    j["exploration"] = ExplorationJson(s);
    j["convoy"] = ConvoyJson(s);
    j["yield"] = {{"state", s.yield_state()}, {"peer", s.yield_peer_id()}, {"reason", s.yield_reason()}};
  }
  if (v.tree) {
    j["valid_modes"] = v.tree->valid_modes();
    j["goal_acceptable"] = v.tree->goal_acceptable();
    j["explore_acceptable"] = v.tree->explore_acceptable();
    const OperatorReason why = ExplainReason(v.robot_id, v.tree->last_refusal());
    j["last_refusal"] = why.text;
    j["last_refusal_condition"] = why.condition;
  }
  j["valid_actions"] = ValidActions(v, base_id);
  return j;
}

// Every robot's ViewJson, as `robots --json` and `watch --json` list them.
json FleetJson(const std::vector<RobotView>& fleet, const std::string& base_id) {
  json list = json::array();
  for (const auto& v : fleet) list.push_back(ViewJson(v, fleet, base_id));
  return list;
}

std::string ClockText(std::chrono::system_clock::time_point t) {
  const std::time_t seconds = std::chrono::system_clock::to_time_t(t);
  std::tm local{};
  localtime_r(&seconds, &local);
  char text[16];
  std::strftime(text, sizeof(text), "%H:%M:%S", &local);
  return text;
}

json EventJson(const OperatorEvent& e) {
  json j = e.staircase ? StaircaseJson(*e.staircase) : json::object();
  j["event"] = e.kind;
  j["robot"] = e.robot_id;
  j["message"] = e.message;
  j["time"] = ClockText(e.time);
  if (!e.other.empty()) j["other"] = e.other;
  if (!e.reason.empty()) j["reason"] = e.reason;
  if (!e.condition.empty()) j["condition"] = e.condition;
  if (e.kind == "proximity") j["distance_m"] = e.distance_m;
  if (e.kind == "staircase_merged") j["merged_id"] = e.merged_staircase_id;
  return j;
}

// `text` cut to `n` bytes with "..." (never inside a UTF-8 character).
std::string Truncate(const std::string& text, std::size_t n) {
  if (text.size() <= n) return text;
  std::size_t cut = n - 3;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;
  return text.substr(0, cut) + "...";
}

}  // namespace

CommandShell::CommandShell(Fleet& client, ShellOptions options, std::ostream& out)
    : client_(client),
      options_(std::move(options)),
      json_(options_.json),
      out_(out),
      places_(Places::Load(options_.places_file)) {}

CommandShell::CommandShell(Fleet& client, bool json, std::ostream& out)
    : CommandShell(client, ShellOptions{json, "", nullptr, nullptr}, out) {}

const std::vector<std::string>& CommandShell::CommandNames() {
  static const std::vector<std::string> kNames = [] {
    std::vector<std::string> names;
    for (const CommandSpec& spec : CommandTable()) names.push_back(spec.name);
    return names;
  }();
  return kNames;
}

std::string CommandShell::Help() { return CommandHelp(); }

bool CommandShell::Cancelled() {
  // SIGTERM (and SIGINT in scripts) requests shutdown: a long wait or teleop ends then too.
  return (options_.cancel != nullptr && options_.cancel->exchange(false)) || core::ShutdownRequested();
}

int CommandShell::UsageError(const std::string& command, const std::string& message) {
  if (json_) {
    out_ << Dump(
                json{{"command", command}, {"ok", false}, {"result", outcome::kInvalid}, {"reason", message}})
         << std::endl;
  } else {
    out_ << command << ": " << outcome::kInvalid << ": " << message << std::endl;
  }
  return kUsage;
}

bool CommandShell::RefuseUnknown(const std::string& command, const std::string& robot) {
  if (client_.Knows(robot)) return false;
  CommandOutcome o;
  o.result = outcome::kRefused;
  o.reason = client_.UnknownRobotReason(robot);
  Report(command, robot, o);
  return true;
}

std::optional<RobotView> CommandShell::FreshView(const std::string& robot) {
  const auto answered = last_answer_.find(robot);
  if (answered == last_answer_.end()) return client_.Robot(robot);
  const core::SteadyTime after = answered->second;
  auto view = client_.WaitUntil(robot, 0.5, [after](const RobotView& v) {
    return v.state.has_value() && v.whole_state_received > after;
  });
  return view ? view : client_.Robot(robot);
}

int CommandShell::Report(const std::string& command, const std::string& robot, const CommandOutcome& o,
                         const std::string& notice) {
  if (o.answered) last_answer_[robot] = core::SteadyClock::now();
  // A refusal says what is valid now (lesson L4), from the robot's latest behavior-tree state.
  std::string valid_text;
  std::vector<std::string> valid;
  if (!o.ok && o.result == outcome::kRefused) {
    if (auto view = client_.Robot(robot)) {
      if (o.answered) {
        // The robot's answer is newer than its last state: its holder and valid modes right after this
        // command.
        if (!view->state) view->state = cairn_msgs::RobotState{};
        view->state->holder_id(o.holder_id);
        view->state->mode(o.mode);
        if (!view->tree) view->tree = cairn_msgs::BehaviorTreeState{};
        view->tree->valid_modes(o.valid_modes);
        view->tree->goal_acceptable(o.goal_acceptable);
      }
      valid = ValidActions(*view, client_.base_id());
      valid_text = ValidActionsText(*view, client_.base_id());
    }
  }
  if (json_) {
    json j = {{"command", command},
              {"robot", robot},
              {"ok", o.ok},
              {"result", o.result},
              {"reason", o.reason},
              {"holder", o.holder_id},
              {"mode", o.mode},
              {"round_trip_ms", o.round_trip_ms},
              {"request_id", o.request_id},
              {"goal_id", o.goal_id}};
    if (!o.condition.empty()) j["condition"] = o.condition;
    if (!o.robot_reason.empty() && o.robot_reason != o.reason) j["robot_reason"] = o.robot_reason;
    if (!valid_text.empty()) j["valid_actions"] = valid;
    if (!notice.empty()) j["notice"] = notice;
    out_ << Dump(j) << std::endl;
  } else {
    if (!notice.empty()) out_ << command << " " << robot << ": note: " << notice << std::endl;
    out_ << command << " " << robot << ": " << o.result;
    if (!o.reason.empty()) out_ << ": " << o.reason;
    if (o.ok && !o.mode.empty()) {
      out_ << " (mode " << o.mode << ", holder " << (o.holder_id.empty() ? "none" : o.holder_id) << ")";
    }
    if (!valid_text.empty()) out_ << "; " << valid_text;
    out_ << std::endl;
  }
  return o.ok ? kOk : o.result == outcome::kInvalid ? kUsage : kRefused;
}

int CommandShell::Execute(const std::string& line) { return Execute(SplitCommandLine(line)); }

int CommandShell::Execute(const std::vector<std::string>& words) {
  PrintEvents();
  const int code = Run(words);
  PrintEvents();
  return code;
}

void CommandShell::PrintEvents() {
  if (!options_.print_events) return;
  for (const OperatorEvent& event : client_.TakeEvents()) {
    if (json_) {
      out_ << Dump(EventJson(event)) << std::endl;
    } else {
      out_ << "[" << ClockText(event.time) << "] " << event.message << std::endl;
    }
  }
}

std::vector<std::string> CommandShell::Complete(const std::vector<std::string>& before,
                                                const std::string& prefix) const {
  std::vector<std::string> pool;
  if (before.empty()) {
    pool = CommandNames();
  } else {
    const std::string& cmd = before[0];
    const std::size_t arg = before.size();  // index of the word being completed, 1-based after the command
    const CommandSpec* spec = FindCommand(cmd);
    const FirstArgument first = spec != nullptr ? spec->first : FirstArgument::kNone;
    if ((arg == 1 && first != FirstArgument::kNone) || first == FirstArgument::kRobots) {
      pool = client_.RobotIds();  // kRobots: every word (the robots of a convoy, in order)
      if (first == FirstArgument::kRobotOrAll) pool.emplace_back("all");
      if (first == FirstArgument::kRobotOrFleet) pool.emplace_back("fleet");
    } else if (cmd == "mode" && arg == 2) {
      pool = {"idle", "manual", "smart_joystick"};
      if (const auto view = client_.Robot(before[1]); view && view->tree) pool = view->tree->valid_modes();
    } else if ((spec != nullptr && spec->place_second && arg == 2) ||
               (cmd == "place" && arg == 2 && before[1] == "remove")) {
      pool = places_.Names();
    } else if (cmd == "wait" && arg == 2) {
      pool = {"arrived", "idle", "online", "lost", "mode="};
    } else if (cmd == "restart" && arg == 2) {
      if (const auto view = client_.Robot(before[1]); view && view->health) {
        for (const auto& c : view->health->components()) pool.push_back(c.name());
      }
    } else if (cmd == "place" && arg == 1) {
      pool = {"add", "remove"};
    }
  }
  std::vector<std::string> matches;
  for (const auto& word : pool) {
    if (word.rfind(prefix, 0) == 0) matches.push_back(word);
  }
  return matches;
}

int CommandShell::Run(const std::vector<std::string>& t) {
  if (t.empty()) return kOk;
  const std::string& cmd = t[0];
  const std::vector<std::string> args(t.begin() + 1, t.end());
  const CommandSpec* spec = FindCommand(cmd);
  if (spec == nullptr) {
    return UsageError(cmd,
                      "unknown command '" + cmd + "'" + DidYouMeanText(cmd, CommandNames()) + " (try help)");
  }
  // An option the command does not take is named as such (with the nearest one it takes), before any
  // argument is read as something else ("TOL '--wiat' is not a finite number").
  const std::vector<std::string> options = OptionsOf(*spec);
  for (const std::string& word : args) {
    if (word.size() < 3 || word.rfind("--", 0) != 0) continue;
    if (std::find(options.begin(), options.end(), word) != options.end()) continue;
    return UsageError(
        cmd, "unknown option " + word + " for " + cmd + DidYouMeanText(word, options) + "; " + UsageOf(cmd));
  }
  if (args.size() < spec->min_args || args.size() > spec->max_args) return UsageError(cmd, UsageOf(cmd));
  if (cmd == "help") {
    if (args.size() == 1) return HelpFor(args[0]);
    if (json_) {
      out_ << Dump(json{{"command", "help"}, {"ok", true}, {"result", outcome::kAccepted}, {"text", Help()}})
           << std::endl;
    } else {
      out_ << Help() << std::endl;
    }
    return kOk;
  }
  if (cmd == "robots") return Robots();
  if (cmd == "watch") return Watch(args);
  if (cmd == "links") return Links(args);
  if (cmd == "events") return Events(args);
  if (cmd == "status") return Status(args);
  if (cmd == "health") return Health(args);
  if (cmd == "restart") return Restart(args);
  if (cmd == "request-control") return Control(args, true);
  if (cmd == "release") return Control(args, false);
  if (cmd == "grant" || cmd == "deny" || cmd == "handover") return AnswerControl(cmd, args[0], args[1]);
  if (cmd == "convoy") return Convoy(args);
  if (cmd == "convoy-stop") return ConvoyStop(args);
  if (cmd == "peel") return Peel(args);
  if (cmd == "yield") return Yield(args);
  if (cmd == "mode") return Mode(args);
  if (cmd == "stop") return Stop(args);
  if (cmd == "goto" || cmd == "home") return Goto(cmd, args);
  if (cmd == "resume-goal") return ResumeGoal(args);
  if (cmd == "explore") return Explore(args);
  if (cmd == "frontiers") return Frontiers(args);
  if (cmd == "teleop") return Teleop(args);
  if (cmd == "path") return Path(args);
  if (cmd == "plan") return Plan(args);
  if (cmd == "wait") return Wait(args);
  if (cmd == "sleep") return Sleep(args);
  if (cmd == "place") return Place(args);
  if (cmd == "places") return ListPlaces();
  if (cmd == "map") return args[1] == "--save" ? Map(args) : UsageError(cmd, UsageOf(cmd));
  if (cmd == "snapshot") return Snapshot(args);
  if (cmd == "stairs") return Stairs();
  // Every command of the table has a branch above.
  throw std::logic_error("command '" + cmd + "' is in the table but has no handler");
}

void CommandShell::PrintRobotsTable() {
  const auto views = client_.Robots();
  std::vector<std::vector<std::string>> rows = {
      {"ROBOT", "PLATFORM", "MODE", "HOLDER", "POSITION", "TASK", "LEFT", "ETA", "HEARD", "LAST REFUSAL"}};
  for (const auto& v : views) {
    std::string mode = "?", holder = "-", position = "-", left = "-", eta = "-", refusal = "-";
    if (v.state) {
      const auto& s = *v.state;
      mode = s.mode();
      holder = s.holder_id().empty() ? "-" : s.holder_id() + (s.holder_alive() ? "" : " (lost)");
      const auto& p = s.pose_MB().position();
      position = "(" + Fixed(p.x_m(), 1) + ", " + Fixed(p.y_m(), 1) + ")";
      // The nearest named place within 5 m: operators say "at the junction", not coordinates.
      if (const auto place = places_.Nearest(p.x_m(), p.y_m(), p.z_m(), 5.0)) position += " " + place->name;
      if (s.nav_status() == msgs::NAV_STATUS_ACTIVE) {
        left = Fixed(s.nav_distance_left_m(), 1) + " m";
        eta = s.nav_eta_s() >= 0 ? Fixed(s.nav_eta_s(), 0) + " s" : "?";
      }
    }
    if (v.tree && !v.tree->last_refusal().empty()) {
      refusal = Truncate(ExplainReason(v.robot_id, v.tree->last_refusal()).text, 60);
    }
    const std::string heard =
        v.lost ? "LOST (" + v.lost_reason + ")"
               : Fixed(core::SecondsBetween(v.last_seen, core::SteadyClock::now()), 1) + " s ago";
    rows.push_back({v.robot_id, v.platform.empty() ? "?" : v.platform, mode, holder, position,
                    Truncate(TaskText(v, views), 48), left, eta, heard, refusal});
  }
  PrintTable(out_, rows);
  if (views.empty()) out_ << "(no robots discovered yet)" << std::endl;
}

int CommandShell::Robots() {
  // A fresh basestation needs a moment of discovery before its list means anything.
  std::this_thread::sleep_until(client_.started() + std::chrono::milliseconds(1500));
  if (json_) {
    const json list = FleetJson(client_.Robots(), client_.base_id());
    out_ << Dump(json{{"command", "robots"}, {"ok", true}, {"result", outcome::kAccepted}, {"robots", list}})
         << std::endl;
    return kOk;
  }
  PrintRobotsTable();
  return kOk;
}

int CommandShell::Watch(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("watch");
  double period_s = 1.0, count = options_.key_pressed ? 0 : 1;  // 0: until a key is pressed
  std::string error;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if (args[i] == "--count" && i + 1 < args.size()) {
      if (!ParseNumber(args[++i], "N", &count, &error) || count < 1 || count > 100000 ||
          count != std::floor(count)) {
        return UsageError(
            "watch", error.empty() ? "N '" + args[i] + "' must be a whole number in [1, 100000]" : error);
      }
    } else if (i == 0 && args[i].rfind("--", 0) != 0) {
      if (!ParseNumber(args[i], "PERIOD_S", &period_s, &error) || period_s < 0.1 || period_s > 60) {
        return UsageError("watch", error.empty() ? "PERIOD_S '" + args[i] + "' must be in [0.1, 60]" : error);
      }
    } else {
      return UsageError("watch", usage);
    }
  }
  std::this_thread::sleep_until(client_.started() + std::chrono::milliseconds(1500));
  const bool in_place = options_.key_pressed != nullptr && !json_;
  for (int n = 0; count == 0 || n < count; ++n) {
    if (in_place) out_ << "\033[H\033[2J";  // home and clear: the table is redrawn in place
    if (json_) {
      const json list = FleetJson(client_.Robots(), client_.base_id());
      out_ << Dump(json{{"command", "watch"}, {"progress", true}, {"robots", list}}) << std::endl;
    } else {
      PrintRobotsTable();
      const auto recent = client_.RecentEvents();
      for (std::size_t i = recent.size() > 5 ? recent.size() - 5 : 0; i < recent.size(); ++i) {
        out_ << "[" << ClockText(recent[i].time) << "] " << recent[i].message << "\n";
      }
      if (in_place)
        out_ << "(watching every " << Fixed(period_s, 1) << " s: press any key to stop)" << std::endl;
    }
    if (count != 0 && n + 1 >= count) break;
    // Wait for the next refresh, a key, or Ctrl-C.
    const auto next = core::SteadyClock::now() + std::chrono::duration_cast<core::SteadyClock::duration>(
                                                     std::chrono::duration<double>(period_s));
    bool stop = false;
    while (core::SteadyClock::now() < next && !stop) {
      stop = (options_.key_pressed && options_.key_pressed()) || Cancelled();
      if (!stop) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    if (stop) break;
  }
  if (json_) {
    out_ << Dump(json{{"command", "watch"}, {"ok", true}, {"result", outcome::kAccepted}}) << std::endl;
  }
  return kOk;
}

int CommandShell::Events(const std::vector<std::string>& args) {
  double n = 20;
  std::string error;

  if (args.size() == 1 &&
      (!ParseNumber(args[0], "N", &n, &error) || n < 1 || n > 100000 || n != std::floor(n))) {
    return UsageError("events",
                      error.empty() ? "N '" + args[0] + "' must be a whole number in [1, 100000]" : error);
  }
  const auto recent = client_.RecentEvents();
  const std::size_t from =
      recent.size() > static_cast<std::size_t>(n) ? recent.size() - static_cast<std::size_t>(n) : 0;
  if (json_) {
    json list = json::array();
    for (std::size_t i = from; i < recent.size(); ++i) list.push_back(EventJson(recent[i]));
    out_ << Dump(json{{"command", "events"}, {"ok", true}, {"result", outcome::kAccepted}, {"events", list}})
         << std::endl;
    return kOk;
  }
  if (recent.empty()) out_ << "events: none yet" << std::endl;
  for (std::size_t i = from; i < recent.size(); ++i) {
    out_ << "[" << ClockText(recent[i].time) << "] " << recent[i].message << std::endl;
  }
  return kOk;
}

int CommandShell::Status(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  if (RefuseUnknown("status", robot)) return kRefused;
  // A fresh basestation may know the robot before its first state arrives: give the state a moment.
  client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value() || v.lost; });
  const auto view = FreshView(robot);
  if (!view) return kRefused;  // known a moment ago; cannot vanish (views are never removed)
  if (json_) {
    json out = ViewJson(*view, client_.Robots(), client_.base_id());
    out["command"] = "status";
    out["ok"] = !view->lost;
    out["result"] = view->lost ? outcome::kFailed : outcome::kAccepted;
    out_ << Dump(out) << std::endl;
    return view->lost ? kRefused : kOk;
  }
  const RobotView& v = *view;
  out_ << v.robot_id << " (" << (v.platform.empty() ? "?" : v.platform) << ")";
  if (v.lost) out_ << ": LOST (" << v.lost_reason << ")";
  out_ << "\n";
  if (v.state) {
    const auto& s = *v.state;
    const auto& p = s.pose_MB().position();
    out_ << "  mode      " << s.mode() << " (" << s.mux_reason() << ")\n";
    out_ << "  pose      (" << Fixed(p.x_m(), 2) << ", " << Fixed(p.y_m(), 2) << ", " << Fixed(p.z_m(), 2)
         << ") m, heading " << Fixed(YawOf(s.pose_MB().orientation()) * 180.0 / M_PI, 0) << " deg, speed "
         << Fixed(s.twist_B().linear_x_mps(), 2) << " m/s" << (s.in_contact() ? ", IN CONTACT" : "") << "\n";
    out_ << "  control   ";
    if (s.holder_id().empty()) {
      out_ << "free";
    } else {
      out_ << "held by " << s.holder_id() << (s.holder_id() == client_.base_id() ? " (this basestation)" : "")
           << (s.holder_alive() ? ", connected" : ", NOT CONNECTED") << " (" << s.holder_participants()
           << " process" << (s.holder_participants() == 1 ? "" : "es") << ")";
    }
    if (s.discarded_commands() > 0)
      out_ << "; " << s.discarded_commands() << " commands from others discarded";
    if (!s.control_requester_id().empty()) {
      out_ << "; " << s.control_requester_id() << " asks for it ("
           << Fixed(std::ceil(s.control_request_left_s()), 0) << " s left)";
    }
    out_ << "\n";
    out_ << "  goal      ";
    if (s.nav_status() == msgs::NAV_STATUS_NONE) {
      out_ << "none";
    } else {
      out_ << ShortId(s.nav_goal_id()) << " to (" << Fixed(s.nav_goal_M().x_m(), 2) << ", "
           << Fixed(s.nav_goal_M().y_m(), 2) << "): " << fleet::NavStatusWord(s.nav_status());
      if (s.nav_status() == msgs::NAV_STATUS_ACTIVE) {
        out_ << ", " << Fixed(s.nav_distance_left_m(), 1) << " m left, ETA "
             << (s.nav_eta_s() >= 0 ? Fixed(s.nav_eta_s(), 0) + " s" : "unknown") << ", " << s.nav_replans()
             << " replans";
        if (!s.local_planner_status().empty()) out_ << "; local planner: " << s.local_planner_status();
        if (!s.nav_reason().empty()) out_ << "; " << s.nav_reason();  // a recovery under way
      } else if (s.nav_status() == msgs::NAV_STATUS_FAILED) {
        out_ << " (" << ExplainReason(v.robot_id, s.nav_reason()).text << ")";
      }
    }
    out_ << "\n";
    if (s.explore_task_id() != 0) out_ << "  explore   " << ExplorationText(s) << "\n";
    if (!s.convoy_ahead_ids().empty()) out_ << "  convoy    " << ConvoyText(s) << "\n";
    if (!s.yield_state().empty()) {
      out_ << "  yield     " << s.yield_state() << " (" << s.yield_peer_id() << "): " << s.yield_reason()
           << "\n";
    }
    if (s.stops() > 0) out_ << "  stops     " << s.stops() << ", last by " << s.stopped_by() << "\n";
  }
  if (v.tree && !v.tree->last_refusal().empty()) {
    out_ << "  refusal   " << ExplainReason(v.robot_id, v.tree->last_refusal()).text << "\n";
  }
  out_ << "  " << ValidActionsText(v, client_.base_id()) << "\n";
  out_ << "  heard     " << Fixed(core::SecondsBetween(v.last_seen, core::SteadyClock::now()), 1) << " s ago"
       << std::endl;
  return v.lost ? kRefused : kOk;
}

int CommandShell::HelpFor(const std::string& robot) {
  const auto& names = CommandNames();
  if (std::find(names.begin(), names.end(), robot) != names.end()) {  // `help goto`: that command's usage
    std::istringstream help(Help());
    std::string text;
    bool in = false;
    for (std::string line; std::getline(help, line);) {
      const bool starts = line.rfind("  " + robot + " ", 0) == 0 || line == "  " + robot;
      const bool other = line.size() > 2 && line[2] != ' ' && !starts;
      in = starts || (in && !other && line.rfind("  ", 0) == 0);
      if (in) text += line + "\n";
    }
    if (json_) {
      out_ << Dump(json{{"command", "help"}, {"ok", true}, {"result", outcome::kAccepted}, {"text", text}})
           << std::endl;
    } else {
      out_ << text << std::flush;
    }
    return kOk;
  }
  if (RefuseUnknown("help", robot)) return kRefused;
  client_.WaitUntil(robot, 3.0,
                    [](const RobotView& v) { return (v.state.has_value() && v.tree.has_value()) || v.lost; });
  const auto view = FreshView(robot);
  const std::vector<std::string> actions = ValidActions(*view, client_.base_id());
  if (json_) {
    out_ << Dump(json{{"command", "help"},
                      {"robot", robot},
                      {"ok", true},
                      {"result", outcome::kAccepted},
                      {"valid_actions", actions}})
         << std::endl;
    return kOk;
  }
  out_ << robot << ": " << ValidActionsText(*view, client_.base_id()) << "\n";
  for (const auto& action : actions) {
    const std::string verb = action.substr(0, action.find(' '));
    if (const CommandSpec* spec = FindCommand(verb); spec != nullptr) out_ << "  " << spec->usage << "\n";
  }
  out_.flush();
  return kOk;
}

int CommandShell::Control(const std::vector<std::string>& args, bool request) {
  // Several robots at once (a convoy's): every request in parallel, one answer line each.
  const auto outcomes = shell::SendToEach<CommandOutcome>(args, [&](const std::string& robot, std::size_t) {
    return request ? client_.RequestControl(robot) : client_.ReleaseControl(robot);
  });
  return ReportEach(request ? "request-control" : "release", args.front(), args, outcomes);
}

int CommandShell::AnswerControl(const std::string& command, const std::string& robot,
                                const std::string& to_base_id) {
  if (RefuseUnknown(command, robot)) return kRefused;
  if (command == "grant" || command == "deny") {
    // Only a request that waits can be granted or denied: say so here rather than hand the lock over unasked.
    const auto view = client_.Robot(robot);
    const std::string waiting = view && view->state ? view->state->control_requester_id() : "";
    if (waiting != to_base_id) {
      CommandOutcome o;
      o.result = outcome::kRefused;
      o.reason = (waiting.empty() ? "no request for " + robot + "'s lock waits"
                                  : "the request waiting for " + robot + "'s lock is " + waiting + "'s") +
                 (command == "grant" ? " (handover " + robot + " " + to_base_id + " gives it unasked)" : "");
      return Report(command, robot, o);
    }
  }
  return Report(command, robot,
                command == "deny" ? client_.DenyControl(robot, to_base_id)
                                  : client_.HandOverControl(robot, to_base_id));
}

int CommandShell::ReportEach(const std::string& command, const std::string& label,
                             const std::vector<std::string>& robots,
                             const std::vector<CommandOutcome>& outcomes, bool always_list) {
  if (robots.size() == 1 && !always_list) return Report(command, robots[0], outcomes[0]);
  bool all_ok = !robots.empty();
  json results = json::array();
  for (std::size_t i = 0; i < robots.size(); ++i) {
    all_ok = all_ok && outcomes[i].ok;
    if (outcomes[i].answered) last_answer_[robots[i]] = core::SteadyClock::now();
    if (json_) {
      results.push_back({{"robot", robots[i]},
                         {"ok", outcomes[i].ok},
                         {"result", outcomes[i].result},
                         {"reason", outcomes[i].reason}});
    } else {
      out_ << command << " " << robots[i] << ": " << outcomes[i].result << ": " << outcomes[i].reason << "\n";
    }
  }
  if (json_) {
    out_ << Dump(json{{"command", command},
                      {"robot", label},
                      {"ok", all_ok},
                      {"result", all_ok ? outcome::kAccepted : outcome::kFailed},
                      {"robots", results}})
         << std::endl;
  } else if (robots.empty()) {
    out_ << command << " " << label << ": " << outcome::kFailed << ": no robot known" << std::endl;
  }
  out_.flush();
  return all_ok ? kOk : kRefused;
}

int CommandShell::Mode(const std::vector<std::string>& args) {
  return Report("mode", args[0], client_.RequestMode(args[0], args[1]));
}

int CommandShell::Stop(const std::vector<std::string>& args) {
  if (args.size() == 1 && args[0] != "all") return Report("stop", args[0], client_.Stop(args[0]));
  if (args[0] != "all") {
    // Several robots: every stop in parallel (none waits for another's round trip), one answer line each.
    if (std::find(args.begin(), args.end(), "all") != args.end()) {
      return UsageError("stop", "stop all takes no robot besides; " + UsageOf("stop"));
    }
    const auto outcomes = shell::SendToEach<CommandOutcome>(
        args, [&](const std::string& robot, std::size_t) { return client_.Stop(robot); });
    return ReportEach("stop", args.front(), args, outcomes);
  }
  // Each robot's stop goes out as soon as the robot is heard, all in parallel: a fleet stop must neither wait
  // for one robot's round trip before the next nor for discovery to end before the first (a one-shot
  // `cairn_base -- stop all` reached the robots only after it). Robots heard until discovery ends are stopped
  // too, lost ones included: a robot that looks lost may still hear a stop.
  const auto discovery_end = client_.discovery_end();
  std::vector<std::string> robots;
  std::deque<CommandOutcome> outcomes;  // a deque: each sender keeps the address of its own
  std::vector<std::thread> senders;
  while (true) {
    for (const std::string& id : client_.RobotIds()) {
      if (std::find(robots.begin(), robots.end(), id) != robots.end()) continue;
      robots.push_back(id);
      CommandOutcome* outcome = &outcomes.emplace_back();
      senders.emplace_back([this, id, outcome] { *outcome = client_.Stop(id); });
    }
    if (core::SteadyClock::now() >= discovery_end) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  for (auto& t : senders) t.join();
  std::vector<std::size_t> order(robots.size());  // listed by robot id, whatever order they were heard in
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return robots[a] < robots[b]; });
  std::vector<std::string> sorted_robots;
  std::vector<CommandOutcome> sorted_outcomes;
  for (const std::size_t i : order) {
    sorted_robots.push_back(robots[i]);
    sorted_outcomes.push_back(outcomes[i]);
  }
  return ReportEach("stop", "all", sorted_robots, sorted_outcomes, /*always_list=*/true);
}

bool CommandShell::ParsePoint(const std::vector<std::string>& args, std::size_t first, double* x_m,
                              double* y_m, std::size_t* used, std::string* error) {
  if (first >= args.size()) {
    *error = "missing point (X Y, X,Y or a place name)";
    return false;
  }
  const std::string& word = args[first];
  if (const auto comma = word.find(','); comma != std::string::npos) {
    *used = 1;
    return ParseNumber(word.substr(0, comma), "X", x_m, error) &&
           ParseNumber(word.substr(comma + 1), "Y", y_m, error);
  }
  // A word that reads as a number (nan and inf included, refused below as not finite) is X; else a place.
  std::size_t numeric = 0;
  try {
    std::stod(word, &numeric);
  } catch (const std::exception&) {
    numeric = 0;
  }
  if (numeric != word.size()) {
    const char first_char = word.empty() ? '\0' : word[0];
    if (!std::isalpha(static_cast<unsigned char>(first_char))) return ParseNumber(word, "X", x_m, error);
    auto place = places_.Find(word);
    if (!place && !options_.places_file.empty()) {  // another console may have added it
      try {
        places_ = Places::Load(options_.places_file);
      } catch (const std::exception&) {
      }
      place = places_.Find(word);
    }
    if (!place) {
      *error = "unknown place '" + word + "'" + DidYouMeanText(word, places_.Names()) +
               " (places: add one with place add NAME X Y)";
      return false;
    }
    *x_m = place->x_m;
    *y_m = place->y_m;
    *used = 1;
    return true;
  }
  *used = 2;
  if (first + 1 >= args.size()) {
    *error = "missing Y after X '" + word + "' (give X Y, X,Y or a place name)";
    return false;
  }
  return ParseNumber(word, "X", x_m, error) && ParseNumber(args[first + 1], "Y", y_m, error);
}

int CommandShell::ResumeGoal(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("resume-goal");
  if (args.empty() || args[0].rfind("--", 0) == 0) return UsageError("resume-goal", usage);
  const std::string& robot = args[0];
  if (RefuseUnknown("resume-goal", robot)) return kRefused;
  const auto view = client_.Robot(robot);
  if (!view || !view->state || !view->state->has_resumable_goal()) {
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = robot +
               " offers no goal to resume (a robot restarted with --resume in the middle of a goal offers "
               "it until it leaves idle)";
    return Report("resume-goal", robot, o);
  }
  // A new goal to the old point: the same as goto, on the level the old goal asked for.
  const cairn_msgs::Point& goal = view->state->resumable_goal_M();
  std::vector<std::string> goto_args = {robot, fmt::format("{:.3f},{:.3f}", goal.x_m(), goal.y_m())};
  if (std::isfinite(goal.z_m())) {
    goto_args.emplace_back("--z");
    goto_args.push_back(fmt::format("{:.3f}", goal.z_m()));
  }
  goto_args.insert(goto_args.end(), args.begin() + 1, args.end());
  return Goto("goto", goto_args);
}

int CommandShell::Goto(const std::string& command, const std::vector<std::string>& all_args) {
  const bool home = command == "home";
  const std::string usage = UsageOf(command);
  std::vector<std::string> args;
  bool wait = false;
  double timeout = 600;
  double z_m = std::numeric_limits<double>::quiet_NaN();
  std::string error;
  for (std::size_t i = 0; i < all_args.size(); ++i) {
    if (all_args[i] == "--z") {
      if (i + 1 >= all_args.size()) return UsageError(command, "--z needs a height Z_M (metres, map frame)");
      if (!ParseNumber(all_args[i + 1], "Z_M", &z_m, &error)) return UsageError(command, error);
      if (!std::isfinite(z_m) || std::abs(z_m) > 10000) {
        return UsageError(command,
                          "Z_M '" + all_args[i + 1] + "' must be a finite height in [-10000, 10000] m");
      }
      ++i;
      continue;
    }
    if (all_args[i] != "--wait") {
      args.push_back(all_args[i]);
      continue;
    }
    wait = true;
    if (i + 1 < all_args.size()) {
      if (!ParseNumber(all_args[i + 1], "TIMEOUT_S", &timeout, &error) || timeout <= 0 || timeout > 86400) {
        return UsageError(
            command, error.empty() ? "TIMEOUT_S '" + all_args[i + 1] + "' must be in (0, 86400]" : error);
      }
      if (i + 2 != all_args.size()) return UsageError(command, usage);
      break;
    }
  }
  if (args.size() < (home ? 1u : 2u)) return UsageError(command, usage);
  double x = 0, y = 0, tolerance = 0;
  std::size_t used = 0;
  if (args.size() > 1 && !ParsePoint(args, 1, &x, &y, &used, &error)) return UsageError(command, error);
  const std::size_t rest = 1 + used;
  if (args.size() > rest + (home ? 0 : 1)) return UsageError(command, usage);
  if (args.size() == rest + 1 && !ParseNumber(args[rest], "TOL", &tolerance, &error))
    return UsageError(command, error);
  if (home && used == 0 && std::isfinite(z_m))
    return UsageError(command, "--z names the level of a POINT: give one");
  const CommandOutcome o =
      !home
          ? client_.SendWaypoint(args[0], x, y, tolerance, z_m)
          : client_.SendHome(args[0], used == 0 ? std::nullopt : std::optional<Eigen::Vector3d>({x, y, z_m}));
  if (o.ok) last_goal_id_[args[0]] = o.goal_id;
  if (!o.ok || !wait) return Report(command, args[0], o);
  // With --wait, one result line ends the command (JSON: the acceptance is a progress line before it).
  if (json_) {
    out_ << Dump(json{{"command", command},
                      {"robot", args[0]},
                      {"progress", true},
                      {"accepted", true},
                      {"reason", o.reason},
                      {"request_id", o.request_id},
                      {"goal_id", o.goal_id}})
         << std::endl;
  } else {
    Report(command, args[0], o);
  }
  return WaitArrived(command, args[0], timeout);
}

void CommandShell::PrintGoalProgress(const std::string& command, const std::string& robot, uint32_t goal_id) {
  const auto now_view = client_.Robot(robot);  // progress, printed outside the client's lock
  if (!now_view || !now_view->state || now_view->state->nav_status() != msgs::NAV_STATUS_ACTIVE ||
      (goal_id != 0 && now_view->state->nav_goal_id() != goal_id)) {
    return;
  }
  const auto& s = *now_view->state;
  const std::string eta = s.nav_eta_s() >= 0 ? Fixed(s.nav_eta_s(), 0) + " s" : "unknown";
  if (json_) {
    out_ << Dump(json{{"command", command},
                      {"robot", robot},
                      {"progress", true},
                      {"distance_left_m", s.nav_distance_left_m()},
                      {"eta_s", s.nav_eta_s()},
                      {"local_planner", s.local_planner_status()},
                      {"replans", s.nav_replans()}})
         << std::endl;
  } else {
    out_ << command << " " << robot << ": " << Fixed(s.nav_distance_left_m(), 1) << " m left, ETA " << eta;
    if (!s.local_planner_status().empty() && s.local_planner_status() != "path") {
      out_ << " (" << s.local_planner_status() << ")";
    }
    if (s.nav_replans() > 0) out_ << ", " << s.nav_replans() << " replans";
    out_ << std::endl;
  }
}

int CommandShell::WaitArrived(const std::string& command, const std::string& robot, double timeout_s) {
  const uint32_t goal_id = last_goal_id_.count(robot) ? last_goal_id_[robot] : 0;
  std::string failure;
  bool seen_goal = false;
  // Evaluated under the fleet client's lock: decide only, print nothing here.
  shell::LostRobotGrace lost_grace;
  auto done = [&](const RobotView& v) {
    failure = lost_grace.Check(v, core::SteadyClock::now());
    if (!v.state) return !failure.empty();
    const auto& s = *v.state;
    if (goal_id != 0 && s.nav_goal_id() != goal_id) {
      // Once our goal was seen, another id means another goto replaced it.
      if (seen_goal && s.nav_status() != msgs::NAV_STATUS_NONE) {
        failure = "goal " + ShortId(goal_id) + " superseded by goal " + ShortId(s.nav_goal_id());
      }
      return !failure.empty();
    }
    seen_goal = true;
    if (s.nav_status() == msgs::NAV_STATUS_FAILED) {
      failure = "navigation failed: " + ExplainReason(robot, s.nav_reason()).text;
    }
    return s.nav_status() == msgs::NAV_STATUS_ARRIVED || !failure.empty();
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
    PrintEvents();  // news about the rest of the fleet while this robot drives
    if (core::SecondsBetween(last_progress, core::SteadyClock::now()) < 2.0) continue;
    last_progress = core::SteadyClock::now();
    PrintGoalProgress(command, robot, goal_id);
  }
  CommandOutcome o;
  o.ok = view.has_value() && failure.empty();
  o.result = o.ok        ? outcome::kAccepted
             : cancelled ? "cancelled"
             : view      ? outcome::kFailed
                         : outcome::kTimedOut;
  const std::string elapsed = Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 2);
  o.reason = cancelled ? "stopped waiting after " + elapsed + " s (Ctrl-C); " + robot + " drives on: stop " +
                             robot + " to stop it"
             : !failure.empty() ? failure
             : view             ? "arrived after " + elapsed + " s"
                                : "robot " + robot + " not arrived within " + Fixed(timeout_s, 1) + " s";
  if (view && view->state) {
    o.mode = view->state->mode();
    o.holder_id = view->state->holder_id();
  }
  o.goal_id = goal_id;
  o.round_trip_ms = core::SecondsBetween(start, core::SteadyClock::now()) * 1000.0;
  return Report(command == "wait" ? "wait" : command, robot, o);
}

int CommandShell::Teleop(const std::vector<std::string>& args) {
  double vx = 0, wz = 0, duration = 0, vy = 0;
  std::string error;
  if (!ParseNumber(args[1], "VX_MPS", &vx, &error) || !ParseNumber(args[2], "WZ_RADPS", &wz, &error) ||
      !ParseNumber(args[3], "DURATION_S", &duration, &error) ||
      (args.size() == 5 && !ParseNumber(args[4], "VY_MPS", &vy, &error))) {
    return UsageError("teleop", error);
  }
  if (duration <= 0 || duration > 600) {
    return UsageError("teleop", "DURATION_S '" + args[3] + "' must be in (0, 600]");
  }
  const std::string& robot = args[0];
  if (RefuseUnknown("teleop", robot)) return kRefused;
  if (!client_.WaitForRobot(robot, 3.0)) {  // lost: no twist is sent to a robot that cannot be heard
    CommandOutcome o;
    o.result = outcome::kRefused;
    o.reason = client_.UnknownRobotReason(robot);
    return Report("teleop", robot, o);
  }
  // The state after this shell's last command (a mode switch just before), then, if it shows no driving mode
  // yet, half a second more for one (a switch from another process).
  const auto driving = [](const RobotView& v) {
    return v.state && (v.state->mode() == "manual" || v.state->mode() == "smart_joystick");
  };
  auto view = FreshView(robot);
  if (!view || !driving(*view)) view = client_.WaitUntil(robot, 0.5, driving);
  if (!view) view = client_.Robot(robot);
  // Limits applied with a notice: a value typed in the wrong unit (80 for 0.8) is not silently clamped.
  std::string notice;
  auto clamp = [&](double* value, double low, double high, const char* what, const char* unit) {
    if (high <= 0 || (*value >= low && *value <= high)) return;
    const double asked = *value;
    *value = std::clamp(*value, low, high);
    notice += (notice.empty() ? "" : "; ") + Fixed(std::abs(*value), 2) + " " + unit + " is " + robot +
              "'s " + what + ": sent " + Fixed(*value, 2) + " (asked " + Fixed(asked, 2) + ")";
  };
  if (view) {
    clamp(&vx, -view->max_reverse_speed_mps, view->max_speed_mps,
          vx < 0 ? "largest reverse speed" : "largest speed", "m/s");
    clamp(&vy, -view->max_speed_mps, view->max_speed_mps, "largest speed", "m/s");
    clamp(&wz, -view->max_yaw_rate_radps, view->max_yaw_rate_radps, "largest yaw rate", "rad/s");
  }
  std::string mode = "manual";
  if (view && view->state && view->state->mode() == "smart_joystick") {
    mode = "smart_joystick";
  } else if (!view || !view->state || view->state->mode() != "manual") {
    const CommandOutcome o = client_.RequestMode(robot, "manual");
    if (!o.ok) return Report("teleop", robot, o, notice);
  }
  // Stream at 10 Hz for the duration, then fall silent: the robot's mux stops it after teleop_timeout_s.
  const auto start = core::SteadyClock::now();
  int sent = 0;
  bool cancelled = false;
  for (int tick = 0; core::SecondsBetween(start, core::SteadyClock::now()) < duration; ++tick) {
    if (Cancelled()) {
      cancelled = true;
      client_.PublishTeleop(robot, 0.0, 0.0, 0.0);  // a zero stick: the robot brakes now
      break;
    }
    if (client_.PublishTeleop(robot, vx, wz, vy)) ++sent;
    std::this_thread::sleep_until(start + std::chrono::milliseconds(100 * (tick + 1)));
  }
  CommandOutcome o;
  o.ok = !cancelled;
  o.result = cancelled ? "cancelled" : outcome::kAccepted;
  o.reason = "sent " + std::to_string(sent) + " twists over " +
             Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 1) + " s" +
             (cancelled ? " (Ctrl-C: a zero twist followed)" : "");
  o.mode = mode;
  if (const auto v = client_.Robot(robot); v && v->state) o.holder_id = v->state->holder_id();
  return Report("teleop", robot, o, notice);
}

int CommandShell::Wait(const std::vector<std::string>& args) {
  if (args.size() != 2 && args.size() != 3) {
    return UsageError("wait", UsageOf("wait"));
  }
  const std::string& robot = args[0];
  const std::string& what = args[1];
  double timeout = 60;
  std::string error;
  if (args.size() == 3 &&
      (!ParseNumber(args[2], "TIMEOUT_S", &timeout, &error) || timeout < 0 || timeout > 86400)) {
    return UsageError("wait", error.empty() ? "TIMEOUT_S '" + args[2] + "' must be in [0, 86400]" : error);
  }
  std::function<bool(const RobotView&)> done;
  if (what == "arrived") {
    return WaitArrived("wait", robot, timeout);
  } else if (what == "idle" || what.rfind("mode=", 0) == 0) {
    const std::string mode = what == "idle" ? "idle" : what.substr(5);
    done = [mode](const RobotView& v) { return v.state && !v.lost && v.state->mode() == mode; };
  } else if (what == "online") {
    // Heard from: its state comes from the control loop, which runs once its components do.
    done = [](const RobotView& v) { return v.state && !v.lost; };
  } else if (what == "lost") {
    done = [](const RobotView& v) { return v.lost; };
  } else {
    return UsageError("wait", "condition '" + what + "' is not one of arrived, idle, mode=M, online, lost" +
                                  DidYouMeanText(what, {"arrived", "idle", "online", "lost"}));
  }
  const auto start = core::SteadyClock::now();
  std::optional<RobotView> view;
  bool cancelled = false;
  while (!view) {
    const double left = timeout - core::SecondsBetween(start, core::SteadyClock::now());
    view = client_.WaitUntil(robot, std::max(0.0, std::min(0.1, left)), done);
    if (view || left <= 0.1) break;
    if (Cancelled()) {
      cancelled = true;
      break;
    }
    PrintEvents();
  }
  CommandOutcome o;
  o.ok = view.has_value();
  o.result = o.ok ? outcome::kAccepted : cancelled ? "cancelled" : outcome::kTimedOut;
  const std::string elapsed = Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 2);
  o.reason = view        ? what + " after " + elapsed + " s"
             : cancelled ? "stopped waiting after " + elapsed + " s (Ctrl-C)"
                         : "robot " + robot + " not " + what + " within " + Fixed(timeout, 1) + " s";
  if (view && view->state) {
    o.mode = view->state->mode();
    o.holder_id = view->state->holder_id();
  }
  o.round_trip_ms = core::SecondsBetween(start, core::SteadyClock::now()) * 1000.0;
  return Report("wait", robot, o);
}

int CommandShell::Sleep(const std::vector<std::string>& args) {
  double seconds = 0;
  std::string error;
  if (!ParseNumber(args[0], "S", &seconds, &error) || seconds < 0 || seconds > 3600) {
    return UsageError("sleep", error.empty() ? "S '" + args[0] + "' must be in [0, 3600]" : error);
  }
  const auto until = core::SteadyClock::now() + std::chrono::duration_cast<core::SteadyClock::duration>(
                                                    std::chrono::duration<double>(seconds));
  bool cancelled = false;
  while (core::SteadyClock::now() < until && !cancelled) {
    std::this_thread::sleep_for(std::min<core::SteadyClock::duration>(std::chrono::milliseconds(50),
                                                                      until - core::SteadyClock::now()));
    cancelled = Cancelled();
    PrintEvents();  // as they happen, not after the sleep
  }
  if (json_) {  // one JSON object per command, so that a program driving --json never waits for nothing
    out_ << Dump(json{{"command", "sleep"},
                      {"ok", !cancelled},
                      {"result", cancelled ? "cancelled" : outcome::kAccepted}})
         << std::endl;
  }
  return cancelled ? kRefused : kOk;
}

int CommandShell::Place(const std::vector<std::string>& args) {
  const std::string usage = UsageOf("place");
  if (args.empty()) return UsageError("place", usage);
  // Other consoles share the file: start from what it holds now, so that their places are kept.
  try {
    places_ = Places::Load(options_.places_file);
  } catch (const std::exception& e) {
    CommandOutcome o;
    o.result = outcome::kFailed;
    o.reason = e.what();
    return Report("place", args.size() > 1 ? args[1] : "", o);
  }
  std::string message;
  if (args[0] == "add" && args.size() >= 3) {
    base::Place place;
    place.name = args[1];
    std::string error;
    if (!Places::IsValidName(place.name, &error)) return UsageError("place", error);
    std::size_t used = 0;
    double probe = 0;
    if (!ParseNumber(args[2], "X", &probe, &error) && args[2].find(',') == std::string::npos) {
      return UsageError("place", error);
    }
    if (!ParsePoint(args, 2, &place.x_m, &place.y_m, &used, &error)) return UsageError("place", error);
    if (args.size() > 2 + used + 1) return UsageError("place", usage);
    if (args.size() == 2 + used + 1 && !ParseNumber(args[2 + used], "Z", &place.z_m, &error)) {
      return UsageError("place", error);
    }
    places_.Add(place);
    message = "place " + place.name + " = (" + Fixed(place.x_m, 2) + ", " + Fixed(place.y_m, 2) + ", " +
              Fixed(place.z_m, 2) + ")";
  } else if (args[0] == "remove" && args.size() == 2) {
    if (!places_.Remove(args[1])) {
      return UsageError("place",
                        "unknown place '" + args[1] + "'" + DidYouMeanText(args[1], places_.Names()));
    }
    message = "place " + args[1] + " removed";
  } else {
    return UsageError("place", usage);
  }
  std::string where = options_.places_file.empty()
                          ? " (this session only: start cairn_base with --places FILE "
                            "to keep places)"
                          : " (saved to " + options_.places_file + ")";
  try {
    places_.Save();
  } catch (const std::exception& e) {
    CommandOutcome o;
    o.result = outcome::kFailed;
    o.reason = message + " but not saved: " + e.what();
    return Report("place", args[1], o);
  }
  if (json_) {
    out_ << Dump(json{{"command", "place"},
                      {"ok", true},
                      {"result", outcome::kAccepted},
                      {"reason", message + where}})
         << std::endl;
  } else {
    out_ << "place: " << outcome::kAccepted << ": " << message << where << std::endl;
  }
  return kOk;
}

int CommandShell::ListPlaces() {
  const auto all = places_.All();
  if (json_) {
    json list = json::array();
    for (const auto& p : all)
      list.push_back({{"name", p.name}, {"x_m", p.x_m}, {"y_m", p.y_m}, {"z_m", p.z_m}});
    out_ << Dump(json{{"command", "places"}, {"ok", true}, {"result", outcome::kAccepted}, {"places", list}})
         << std::endl;
    return kOk;
  }
  if (all.empty()) {
    out_ << "places: none (add one with place add NAME X Y)" << std::endl;
    return kOk;
  }
  std::vector<std::vector<std::string>> rows = {{"PLACE", "X_M", "Y_M", "Z_M"}};
  for (const auto& p : all) rows.push_back({p.name, Fixed(p.x_m, 2), Fixed(p.y_m, 2), Fixed(p.z_m, 2)});
  PrintTable(out_, rows);
  return kOk;
}

}  // namespace cairn::base
