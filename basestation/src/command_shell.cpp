#include "cairn/base/command_shell.h"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>

#include <nlohmann/json.hpp>

namespace cairn::base {

namespace msgs = cairn_msgs;
using nlohmann::json;

namespace {

std::vector<std::string> Tokenize(const std::string& line) {
  std::vector<std::string> tokens;
  std::istringstream in(line);
  std::string token;
  while (in >> token) {
    if (token[0] == '#') break;
    tokens.push_back(token);
  }
  return tokens;
}

// Parses a finite number; on failure sets `error` naming the argument and the value.
bool ParseNumber(const std::string& text, const char* name, double* value, std::string* error) {
  std::size_t used = 0;
  try {
    *value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(*value)) {
    *error = std::string(name) + " '" + text + "' is not a finite number";
    return false;
  }
  return true;
}

const char* NavStatusName(msgs::NavStatus s) {
  switch (s) {
    case msgs::NAV_STATUS_NONE:
      return "none";
    case msgs::NAV_STATUS_ACTIVE:
      return "active";
    case msgs::NAV_STATUS_ARRIVED:
      return "arrived";
    case msgs::NAV_STATUS_FAILED:
      return "failed";
  }
  return "?";
}

double YawOf(const msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}

json ViewJson(const RobotView& v) {
  json j = {{"robot", v.robot_id},
            {"platform", v.platform},
            {"lost", v.lost},
            {"seen_s_ago", core::SecondsBetween(v.last_seen, core::SteadyClock::now())}};
  if (v.lost) j["lost_reason"] = v.lost_reason;
  if (v.state) {
    const auto& s = *v.state;
    j["mode"] = s.mode();
    j["holder"] = s.holder_id();
    j["holder_alive"] = s.holder_alive();
    j["holder_participant"] = s.holder_participant();
    j["holder_participants"] = s.holder_participants();
    j["x_m"] = s.pose_MB().position().x_m();
    j["y_m"] = s.pose_MB().position().y_m();
    j["z_m"] = s.pose_MB().position().z_m();
    j["yaw_rad"] = YawOf(s.pose_MB().orientation());
    j["linear_x_mps"] = s.twist_B().linear_x_mps();
    j["angular_z_radps"] = s.twist_B().angular_z_radps();
    j["active_channel"] = s.active_channel();
    j["mux_reason"] = s.mux_reason();
    j["discarded_commands"] = s.discarded_commands();
    j["nav_status"] = NavStatusName(s.nav_status());
    j["nav_reason"] = s.nav_reason();
    j["nav_goal_id"] = s.nav_goal_id();
    j["nav_distance_left_m"] = s.nav_distance_left_m();
    j["nav_eta_s"] = s.nav_eta_s();
    j["nav_replans"] = s.nav_replans();
    j["local_planner_status"] = s.local_planner_status();
    j["in_contact"] = s.in_contact();
  }
  if (v.tree) {
    j["valid_modes"] = v.tree->valid_modes();
    j["last_refusal"] = v.tree->last_refusal();
  }
  return j;
}

std::string Fixed(double value, int digits) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(digits) << value;
  return out.str();
}

// One fleet staircase as JSON (the `stairs` list and the staircase event share it).
json StaircaseJson(const perception::StaircaseRegistry::Entry& e) {
  const perception::Staircase& s = e.staircase;
  return {{"id", e.id},           {"x_m", s.p_W_first_step.x()}, {"y_m", s.p_W_first_step.y()},
          {"z_m", s.p_W_first_step.z()}, {"yaw_rad", s.yaw_rad},      {"num_steps", s.num_steps},
          {"rise_m", s.rise_m},   {"run_m", s.run_m},             {"width_m", s.width_m},
          {"confidence", s.confidence}, {"sources", e.sources}};
}

}  // namespace

CommandShell::CommandShell(FleetClient& client, bool json_output, std::ostream& out)
    : client_(client), json_(json_output), out_(out), created_(core::SteadyClock::now()) {}

const std::vector<std::string>& CommandShell::CommandNames() {
  static const std::vector<std::string> kNames = {"robots", "status", "request-control", "release", "mode",
                                                  "goto",   "path",   "plan",            "teleop",  "stop",
                                                  "wait",   "sleep",  "map",             "snapshot", "stairs",
                                                  "help"};
  return kNames;
}

std::string CommandShell::Help() {
  return "commands:\n"
         "  robots                              every robot: id, platform, mode, holder, pose, last seen\n"
         "  status R                            full state of robot R (mux channel, valid modes, navigation)\n"
         "  request-control R                   ask for R's control lock (denied if another basestation holds it)\n"
         "  release R                           give R's control lock back (the robot stops)\n"
         "  mode R MODE                         switch R to idle | manual | smart_joystick | waypoint\n"
         "  goto R X Y [TOL] [--wait [TIMEOUT_S]]  drive R to (X, Y) metres in the map frame; --wait prints\n"
         "                                      progress (distance left, ETA) until it arrives or fails\n"
         "                                      (default 600 s)\n"
         "  path R                              the global path R is following (waypoints, length)\n"
         "  plan R X Y [--from X,Y] [--platform P]  ask R's global planner for a path (from R's pose, for\n"
         "                                      R's platform by default); prints the path or the reason\n"
         "  teleop R VX_MPS WZ_RADPS DURATION_S [VY_MPS]  drive R for DURATION_S, then stop sending: manual\n"
         "                                      mode unless R is in smart_joystick, where the twist is the\n"
         "                                      direction the local planner follows\n"
         "  stop R                              stop R now: zero twist, mode idle, goal cancelled; from any\n"
         "                                      basestation, without the control lock (the lock stays)\n"
         "  wait R arrived|idle|mode=M|online|lost [TIMEOUT_S]  block until R reaches that state (default 60 s)\n"
         "  map R|fleet --save FILE.bt          save R's coarse map (or the fleet map merged from every robot) as\n"
         "                                      an OctoMap .bt; asks for a snapshot first if it is incomplete\n"
         "  snapshot R FILE.jpg [TIMEOUT_S]     save R's next camera frame (JPEG) to FILE.jpg (default 5 s)\n"
         "  stairs                              staircases found by the fleet (merged across robots)\n"
         "  sleep S                             pause a script for S seconds\n"
         "  help                                this text\n"
         "Refusals print the robot's reason; a refused or failed command exits non-zero.\n"
         "Events (a new staircase) print as they arrive between commands, once each.";
}

int CommandShell::UsageError(const std::string& command, const std::string& message) {
  if (json_) {
    out_ << json{{"command", command}, {"ok", false}, {"result", "usage"}, {"reason", message}}.dump() << std::endl;
  } else {
    out_ << command << ": " << message << std::endl;
  }
  return kUsage;
}

int CommandShell::Report(const std::string& command, const std::string& robot, const CommandOutcome& o) {
  if (json_) {
    out_ << json{{"command", command},       {"robot", robot},   {"ok", o.ok},
                 {"result", o.result},       {"reason", o.reason}, {"holder", o.holder_id},
                 {"mode", o.mode},           {"round_trip_ms", o.round_trip_ms},
                 {"request_id", o.request_id}, {"goal_id", o.goal_id}}
                .dump()
         << std::endl;
  } else {
    out_ << command << " " << robot << ": " << o.result;
    if (!o.reason.empty()) out_ << ": " << o.reason;
    if (o.ok) out_ << " (mode " << o.mode << ", holder " << (o.holder_id.empty() ? "none" : o.holder_id) << ")";
    out_ << std::endl;
  }
  return o.ok ? kOk : kRefused;
}

int CommandShell::Execute(const std::string& line) {
  PrintEvents();
  const int code = Run(line);
  PrintEvents();
  return code;
}

void CommandShell::PrintEvents() {
  for (const FleetEvent& event : client_.perception().TakeEvents()) {
    if (json_) {
      json j = StaircaseJson(event.staircase);
      j["event"] = event.kind;
      j["message"] = event.message;
      out_ << j.dump() << std::endl;
    } else {
      out_ << "event: " << event.message << std::endl;
    }
  }
}

int CommandShell::Run(const std::string& line) {
  const std::vector<std::string> t = Tokenize(line);
  if (t.empty()) return kOk;
  const std::string& cmd = t[0];
  const std::vector<std::string> args(t.begin() + 1, t.end());
  auto need = [&](std::size_t n, const char* usage) -> bool {
    if (args.size() == n) return true;
    UsageError(cmd, std::string("usage: ") + usage);
    return false;
  };
  if (cmd == "help") {
    if (json_) {
      out_ << json{{"command", "help"}, {"ok", true}, {"text", Help()}}.dump() << std::endl;
    } else {
      out_ << Help() << std::endl;
    }
    return kOk;
  }
  if (cmd == "robots") return args.empty() ? Robots() : UsageError(cmd, "usage: robots");
  if (cmd == "status") return need(1, "status R") ? Status(args) : kUsage;
  if (cmd == "request-control") return need(1, "request-control R") ? Control(args, true) : kUsage;
  if (cmd == "release") return need(1, "release R") ? Control(args, false) : kUsage;
  if (cmd == "mode") return need(2, "mode R MODE") ? Mode(args) : kUsage;
  if (cmd == "stop") return need(1, "stop R") ? Report("stop", args[0], client_.Stop(args[0])) : kUsage;
  if (cmd == "goto") return Goto(args);
  if (cmd == "teleop") {
    return (args.size() == 4 || args.size() == 5) ? Teleop(args)
                                                  : UsageError(cmd, "usage: teleop R VX_MPS WZ_RADPS DURATION_S [VY_MPS]");
  }
  if (cmd == "path") return need(1, "path R") ? Path(args) : kUsage;
  if (cmd == "plan") return Plan(args);
  if (cmd == "wait") return Wait(args);
  if (cmd == "sleep") return need(1, "sleep S") ? Sleep(args) : kUsage;
  if (cmd == "map") {
    return (args.size() == 3 && args[1] == "--save") ? Map(args) : UsageError(cmd, "usage: map R|fleet --save FILE.bt");
  }
  if (cmd == "snapshot") {
    return (args.size() == 2 || args.size() == 3) ? Snapshot(args)
                                                  : UsageError(cmd, "usage: snapshot R FILE.jpg [TIMEOUT_S]");
  }
  if (cmd == "stairs") return args.empty() ? Stairs() : UsageError(cmd, "usage: stairs");
  return UsageError(cmd, "unknown command '" + cmd + "' (try help)");
}

int CommandShell::Robots() {
  // A fresh basestation needs a moment of discovery before its list means anything.
  std::this_thread::sleep_until(created_ + std::chrono::milliseconds(1500));
  const auto views = client_.Robots();
  if (json_) {
    json list = json::array();
    for (const auto& v : views) list.push_back(ViewJson(v));
    out_ << json{{"command", "robots"}, {"ok", true}, {"robots", list}}.dump() << std::endl;
    return kOk;
  }
  out_ << std::left << std::setw(10) << "ROBOT" << std::setw(9) << "PLATFORM" << std::setw(10) << "MODE"
       << std::setw(10) << "HOLDER" << std::setw(26) << "POSE (x, y, yaw)" << "LAST SEEN" << std::endl;
  for (const auto& v : views) {
    std::string mode = "?", holder = "-", pose = "?";
    if (v.state) {
      mode = v.state->mode();
      holder = v.state->holder_id().empty() ? "-" : v.state->holder_id();
      if (!v.state->holder_alive()) holder += "(lost)";
      pose = "(" + Fixed(v.state->pose_MB().position().x_m(), 2) + ", " +
             Fixed(v.state->pose_MB().position().y_m(), 2) + ", " + Fixed(YawOf(v.state->pose_MB().orientation()), 2) +
             ")";
    }
    const std::string seen = v.lost ? "LOST (" + v.lost_reason + ")"
                                    : Fixed(core::SecondsBetween(v.last_seen, core::SteadyClock::now()), 1) + " s ago";
    out_ << std::left << std::setw(10) << v.robot_id << std::setw(9) << v.platform << std::setw(10) << mode
         << std::setw(10) << holder << std::setw(26) << pose << seen << std::endl;
  }
  if (views.empty()) out_ << "(no robots discovered yet)" << std::endl;
  return kOk;
}

int CommandShell::Status(const std::vector<std::string>& args) {
  // A fresh basestation may know the robot before its first state arrives: give the state a moment.
  client_.WaitUntil(args[0], 3.0, [](const RobotView& v) { return v.state.has_value(); });
  const auto view = client_.Robot(args[0]);
  if (!view) {
    CommandOutcome o;
    o.result = "error";
    o.reason = "unknown robot '" + args[0] + "'";
    return Report("status", args[0], o);
  }
  const json j = ViewJson(*view);
  if (json_) {
    json out = j;
    out["command"] = "status";
    out["ok"] = !view->lost;
    out_ << out.dump() << std::endl;
  } else {
    for (const auto& [key, value] : j.items()) out_ << "  " << std::left << std::setw(20) << key << value << std::endl;
  }
  return view->lost ? kRefused : kOk;
}

int CommandShell::Control(const std::vector<std::string>& args, bool request) {
  return Report(request ? "request-control" : "release", args[0],
                request ? client_.RequestControl(args[0]) : client_.ReleaseControl(args[0]));
}

int CommandShell::Mode(const std::vector<std::string>& args) {
  return Report("mode", args[0], client_.RequestMode(args[0], args[1]));
}

int CommandShell::Goto(const std::vector<std::string>& all_args) {
  static const char* kUsageText = "usage: goto R X Y [TOL] [--wait [TIMEOUT_S]]";
  std::vector<std::string> args;
  bool wait = false;
  double timeout = 600;
  std::string error;
  for (std::size_t i = 0; i < all_args.size(); ++i) {
    if (all_args[i] != "--wait") {
      args.push_back(all_args[i]);
      continue;
    }
    wait = true;
    if (i + 1 < all_args.size()) {
      if (!ParseNumber(all_args[i + 1], "TIMEOUT_S", &timeout, &error) || timeout <= 0 || timeout > 86400) {
        return UsageError("goto", error.empty() ? "TIMEOUT_S '" + all_args[i + 1] + "' must be in (0, 86400]" : error);
      }
      if (i + 2 != all_args.size()) return UsageError("goto", kUsageText);
      break;
    }
  }
  if (args.size() != 3 && args.size() != 4) return UsageError("goto", kUsageText);
  double x = 0, y = 0, tolerance = 0;
  if (!ParseNumber(args[1], "X", &x, &error) || !ParseNumber(args[2], "Y", &y, &error) ||
      (args.size() == 4 && !ParseNumber(args[3], "TOL", &tolerance, &error))) {
    return UsageError("goto", error);
  }
  const CommandOutcome o = client_.SendWaypoint(args[0], x, y, tolerance);
  if (o.ok) last_goal_id_[args[0]] = o.goal_id;
  if (!o.ok || !wait) return Report("goto", args[0], o);
  // With --wait, one result line ends the command (JSON: the acceptance is a progress line before it).
  if (json_) {
    out_ << json{{"command", "goto"}, {"robot", args[0]}, {"progress", true}, {"accepted", true},
                 {"reason", o.reason}, {"request_id", o.request_id}, {"goal_id", o.goal_id}}
                .dump()
         << std::endl;
  } else {
    Report("goto", args[0], o);
  }
  return WaitArrived("goto", args[0], timeout);
}

int CommandShell::WaitArrived(const std::string& command, const std::string& robot, double timeout_s) {
  const uint32_t goal_id = last_goal_id_.count(robot) ? last_goal_id_[robot] : 0;
  std::string failure;
  bool seen_goal = false;
  // Evaluated under the fleet client's lock: decide only, print nothing here.
  auto done = [&](const RobotView& v) {
    if (v.lost) failure = "robot lost (" + v.lost_reason + ")";
    if (!v.state) return !failure.empty();
    const auto& s = *v.state;
    if (goal_id != 0 && s.nav_goal_id() != goal_id) {
      // Once our goal was seen, another id means another goto replaced it.
      if (seen_goal && s.nav_status() != msgs::NAV_STATUS_NONE) {
        failure = "goal " + std::to_string(goal_id) + " superseded by goal " + std::to_string(s.nav_goal_id());
      }
      return !failure.empty();
    }
    seen_goal = true;
    if (s.nav_status() == msgs::NAV_STATUS_FAILED) failure = "navigation failed: " + s.nav_reason();
    return s.nav_status() == msgs::NAV_STATUS_ARRIVED || !failure.empty();
  };
  const auto start = core::SteadyClock::now();
  std::optional<RobotView> view;
  while (true) {
    const double left = timeout_s - core::SecondsBetween(start, core::SteadyClock::now());
    if (left <= 0) break;
    view = client_.WaitUntil(robot, std::min(2.0, left), done);
    if (view) break;
    const auto now_view = client_.Robot(robot);  // progress, printed outside the client's lock
    if (!now_view || !now_view->state || now_view->state->nav_status() != msgs::NAV_STATUS_ACTIVE ||
        (goal_id != 0 && now_view->state->nav_goal_id() != goal_id)) {
      continue;
    }
    const auto& s = *now_view->state;
    const std::string eta = s.nav_eta_s() >= 0 ? Fixed(s.nav_eta_s(), 0) + " s" : "unknown";
    if (json_) {
      out_ << json{{"command", command}, {"robot", robot}, {"progress", true},
                   {"distance_left_m", s.nav_distance_left_m()}, {"eta_s", s.nav_eta_s()},
                   {"local_planner", s.local_planner_status()}, {"replans", s.nav_replans()}}
                  .dump()
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
  CommandOutcome o;
  o.ok = view.has_value() && failure.empty();
  o.result = o.ok ? "accepted" : (view ? "failed" : "timeout");
  o.reason = !failure.empty() ? failure
             : view ? "arrived after " + Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 2) + " s"
                    : "robot " + robot + " not arrived within " + Fixed(timeout_s, 1) + " s";
  if (view && view->state) {
    o.mode = view->state->mode();
    o.holder_id = view->state->holder_id();
  }
  o.goal_id = goal_id;
  o.round_trip_ms = core::SecondsBetween(start, core::SteadyClock::now()) * 1000.0;
  return Report(command == "goto" ? "goto" : "wait", robot, o);
}

namespace {

json PointsJson(const std::vector<msgs::Point>& points) {
  json list = json::array();
  for (const auto& p : points) list.push_back({p.x_m(), p.y_m(), p.z_m()});
  return list;
}

std::string PointsText(const std::vector<msgs::Point>& points) {
  std::string text;
  for (std::size_t i = 0; i < points.size(); ++i) {
    text += "  " + std::to_string(i) + ": (" + Fixed(points[i].x_m(), 2) + ", " + Fixed(points[i].y_m(), 2) + ", " +
            Fixed(points[i].z_m(), 2) + ")\n";
  }
  return text;
}

}  // namespace

int CommandShell::Map(const std::vector<std::string>& args) {
  const std::string& target = args[0];
  const std::string& path = args[2];
  if (path.size() < 4 || path.substr(path.size() - 3) != ".bt") {
    return UsageError("map", "FILE '" + path + "' must end in .bt (OctoMap binary)");
  }
  const MapSaveResult r = client_.perception().SaveMap(target, path, /*sync_timeout_s=*/10.0);
  if (json_) {
    json j = {{"command", "map"}, {"target", target}, {"ok", r.ok}, {"file", path}};
    if (r.ok) {
      j["voxels"] = r.voxels;
      j["occupied"] = r.occupied;
      j["resolution_m"] = r.resolution_m;
    } else {
      j["reason"] = r.error;
    }
    out_ << j.dump() << std::endl;
  } else if (r.ok) {
    out_ << "map " << target << ": " << r.voxels << " voxels (" << r.occupied << " occupied) at "
         << Fixed(r.resolution_m, 2) << " m saved to " << path << std::endl;
  } else {
    out_ << "map " << target << ": failed: " << r.error << std::endl;
  }
  return r.ok ? kOk : kRefused;
}

int CommandShell::Snapshot(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  const std::string& path = args[1];
  double timeout_s = 5.0;
  std::string error;
  if (args.size() == 3 && (!ParseNumber(args[2], "TIMEOUT_S", &timeout_s, &error) || timeout_s <= 0 ||
                           timeout_s > 600)) {
    return UsageError("snapshot", error.empty() ? "TIMEOUT_S '" + args[2] + "' must be in (0, 600]" : error);
  }
  // The next frame, so that the picture is from now, not from whenever the last one arrived.
  const auto latest = client_.perception().LatestFrame(robot);
  const auto view = client_.perception().WaitForFrame(robot, latest ? latest->frames_received : 0, timeout_s);
  auto fail = [&](const std::string& reason) {
    CommandOutcome o;
    o.result = "error";
    o.reason = reason;
    return Report("snapshot", robot, o);
  };
  if (!view) {
    return fail("no camera frame from robot " + robot + " within " + Fixed(timeout_s, 1) +
                " s (unknown robot, camera off, or frames dropped on a saturated link)");
  }
  std::ofstream file(path, std::ios::binary);
  const auto& data = view->frame.data();
  file.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  file.close();
  if (!file) return fail("cannot write '" + path + "'");
  const auto& p = view->frame.pose_MC().position();
  if (json_) {
    out_ << json{{"command", "snapshot"}, {"robot", robot}, {"ok", true}, {"file", path},
                 {"bytes", data.size()}, {"width_px", view->frame.width_px()}, {"height_px", view->frame.height_px()},
                 {"seq", view->frame.seq()}, {"frames_missed", view->frames_missed},
                 {"x_m", p.x_m()}, {"y_m", p.y_m()}, {"z_m", p.z_m()}}
                .dump()
         << std::endl;
  } else {
    out_ << "snapshot " << robot << ": frame " << view->frame.seq() << ", " << view->frame.width_px() << "x"
         << view->frame.height_px() << " JPEG, " << data.size() << " bytes, camera at (" << Fixed(p.x_m(), 2) << ", "
         << Fixed(p.y_m(), 2) << ", " << Fixed(p.z_m(), 2) << ") saved to " << path << std::endl;
  }
  return kOk;
}

int CommandShell::Stairs() {
  const auto entries = client_.perception().Staircases();
  if (json_) {
    json list = json::array();
    for (const auto& e : entries) list.push_back(StaircaseJson(e));
    out_ << json{{"command", "stairs"}, {"ok", true}, {"staircases", list}}.dump() << std::endl;
    return kOk;
  }
  if (entries.empty()) {
    out_ << "stairs: none found" << std::endl;
    return kOk;
  }
  for (const auto& e : entries) {
    out_ << "staircase " << e.id << ": " << DescribeStaircase(e) << ", confidence " << Fixed(e.staircase.confidence, 2)
         << std::endl;
  }
  return kOk;
}

int CommandShell::Path(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  // The path is latched: a fresh basestation receives it shortly after discovery. After this shell's own
  // goto, wait for that goal's path.
  const uint32_t goal_id = last_goal_id_.count(robot) ? last_goal_id_[robot] : 0;
  auto view = client_.WaitUntil(robot, 3.0, [goal_id](const RobotView& v) {
    return v.global_path.has_value() && (goal_id == 0 || v.global_path->goal_id() == goal_id ||
                                         (v.state && v.state->nav_goal_id() == goal_id &&
                                          v.state->nav_status() != msgs::NAV_STATUS_ACTIVE));
  });
  if (!view) view = client_.Robot(robot);
  if (view && !view->global_path) view.reset();
  if (!view) {
    CommandOutcome o;
    o.result = "error";
    o.reason = client_.Robot(robot) ? "robot " + robot + " has published no global path" : "unknown robot '" + robot + "'";
    return Report("path", robot, o);
  }
  const auto& p = *view->global_path;
  if (json_) {
    out_ << json{{"command", "path"},        {"robot", robot},       {"ok", true},
                 {"goal_id", p.goal_id()},   {"platform", p.platform()}, {"frame_id", p.frame_id()},
                 {"length_m", p.length_m()}, {"map_version", p.map_version()}, {"replans", p.replans()},
                 {"path", PointsJson(p.path_M())}}
                .dump()
         << std::endl;
    return kOk;
  }
  if (p.path_M().empty()) {
    out_ << "path " << robot << ": none (no active goal)" << std::endl;
    return kOk;
  }
  out_ << "path " << robot << ": goal " << p.goal_id() << ", " << Fixed(p.length_m(), 1) << " m, "
       << p.path_M().size() << " waypoints (frame " << p.frame_id() << ", platform " << p.platform()
       << ", map version " << p.map_version() << ", " << p.replans() << " replans)" << std::endl
       << PointsText(p.path_M());
  return kOk;
}

int CommandShell::Plan(const std::vector<std::string>& args) {
  static const char* kUsageText = "usage: plan R X Y [--from X,Y] [--platform P]";
  std::vector<std::string> positional;
  std::string platform, from;
  for (std::size_t i = 0; i < args.size(); ++i) {
    if ((args[i] == "--from" || args[i] == "--platform") && i + 1 < args.size()) {
      (args[i] == "--from" ? from : platform) = args[i + 1];
      ++i;
    } else if (args[i].rfind("--", 0) == 0) {
      return UsageError("plan", "unknown or incomplete option '" + args[i] + "'; " + kUsageText);
    } else {
      positional.push_back(args[i]);
    }
  }
  if (positional.size() != 3) return UsageError("plan", kUsageText);
  const std::string& robot = positional[0];
  double gx = 0, gy = 0, sx = 0, sy = 0;
  std::string error;
  if (!ParseNumber(positional[1], "X", &gx, &error) || !ParseNumber(positional[2], "Y", &gy, &error)) {
    return UsageError("plan", error);
  }
  if (!from.empty()) {
    const auto comma = from.find(',');
    if (comma == std::string::npos || !ParseNumber(from.substr(0, comma), "--from X", &sx, &error) ||
        !ParseNumber(from.substr(comma + 1), "--from Y", &sy, &error)) {
      return UsageError("plan", error.empty() ? "--from '" + from + "' must be X,Y" : error);
    }
  } else {
    const auto view = client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.state.has_value(); });
    if (!view) {
      CommandOutcome o;
      o.result = "error";
      o.reason = "no state from robot '" + robot + "' to plan from (give --from X,Y)";
      return Report("plan", robot, o);
    }
    sx = view->state->pose_MB().position().x_m();
    sy = view->state->pose_MB().position().y_m();
  }
  const PathAnswer a = client_.RequestPath(robot, platform, sx, sy, gx, gy);
  if (json_) {
    json j = {{"command", "plan"}, {"robot", robot}, {"ok", a.ok}, {"result", a.result}, {"reason", a.reason},
              {"round_trip_ms", a.round_trip_ms}};
    if (a.result == "path" || a.result == "refused") {
      j["status"] = a.response.status();
      j["length_m"] = a.response.length_m();
      j["planning_time_s"] = a.response.planning_time_s();
      j["map_version"] = a.response.map_version();
      j["path"] = PointsJson(a.response.path_M());
    }
    out_ << j.dump() << std::endl;
  } else if (a.ok) {
    out_ << "plan " << robot << ": path " << Fixed(a.response.length_m(), 1) << " m, "
         << a.response.path_M().size() << " waypoints, planned in "
         << Fixed(a.response.planning_time_s() * 1000.0, 1) << " ms (map version " << a.response.map_version() << ")"
         << std::endl
         << PointsText(a.response.path_M());
  } else {
    out_ << "plan " << robot << ": " << a.result << ": " << a.reason << std::endl;
  }
  return a.ok ? kOk : kRefused;
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
  // A mode switch made just before may not show in the state yet (10 Hz): give it half a second.
  const auto driving = [](const RobotView& v) {
    return v.state && (v.state->mode() == "manual" || v.state->mode() == "smart_joystick");
  };
  auto view = client_.WaitForRobot(robot, 3.0) ? client_.WaitUntil(robot, 0.5, driving) : std::nullopt;
  if (!view) view = client_.Robot(robot);
  std::string mode = "manual";
  if (view && view->state && view->state->mode() == "smart_joystick") {
    mode = "smart_joystick";
  } else if (!view || !view->state || view->state->mode() != "manual") {
    const CommandOutcome o = client_.RequestMode(robot, "manual");
    if (!o.ok) return Report("teleop", robot, o);
  }
  // Stream at 10 Hz for the duration, then fall silent: the robot's mux stops it after teleop_timeout_s.
  const auto start = core::SteadyClock::now();
  int sent = 0;
  for (int tick = 0; core::SecondsBetween(start, core::SteadyClock::now()) < duration; ++tick) {
    if (client_.PublishTeleop(robot, vx, wz, vy)) ++sent;
    std::this_thread::sleep_until(start + std::chrono::milliseconds(100 * (tick + 1)));
  }
  CommandOutcome o;
  o.ok = true;
  o.result = "accepted";
  o.reason = "sent " + std::to_string(sent) + " twists over " + Fixed(duration, 1) + " s";
  o.mode = mode;
  if (const auto v = client_.Robot(robot); v && v->state) o.holder_id = v->state->holder_id();
  return Report("teleop", robot, o);
}

int CommandShell::Wait(const std::vector<std::string>& args) {
  if (args.size() != 2 && args.size() != 3) {
    return UsageError("wait", "usage: wait R arrived|idle|mode=M|online|lost [TIMEOUT_S]");
  }
  const std::string& robot = args[0];
  const std::string& what = args[1];
  double timeout = 60;
  std::string error;
  if (args.size() == 3 && (!ParseNumber(args[2], "TIMEOUT_S", &timeout, &error) || timeout < 0 || timeout > 86400)) {
    return UsageError("wait", error.empty() ? "TIMEOUT_S '" + args[2] + "' must be in [0, 86400]" : error);
  }
  std::function<bool(const RobotView&)> done;
  if (what == "arrived") {
    return WaitArrived("wait", robot, timeout);
  } else if (what == "idle" || what.rfind("mode=", 0) == 0) {
    const std::string mode = what == "idle" ? "idle" : what.substr(5);
    done = [mode](const RobotView& v) { return v.state && !v.lost && v.state->mode() == mode; };
  } else if (what == "online") {
    done = [](const RobotView& v) { return !v.lost; };
  } else if (what == "lost") {
    done = [](const RobotView& v) { return v.lost; };
  } else {
    return UsageError("wait", "condition '" + what + "' is not one of arrived, idle, mode=M, online, lost");
  }
  const auto start = core::SteadyClock::now();
  const auto view = client_.WaitUntil(robot, timeout, done);
  CommandOutcome o;
  o.ok = view.has_value();
  o.result = o.ok ? "accepted" : "timeout";
  o.reason = view ? what + " after " + Fixed(core::SecondsBetween(start, core::SteadyClock::now()), 2) + " s"
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
  std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
  return kOk;
}

}  // namespace cairn::base
