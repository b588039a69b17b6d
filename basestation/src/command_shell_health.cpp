// The command shell's `health R` and `restart R COMPONENT` (see command_shell.h): the components of a robot's
// agent as its health monitor judges them, and an operator's restart of one.
#include <cstdio>

#include "cairn/base/command_shell.h"
#include "cairn/base/operator_text.h"
#include "shell_util.h"

namespace cairn::base {

using nlohmann::json;
using shell::Dump;
using shell::Fixed;
using shell::PrintTable;

namespace {

std::string Megabytes(std::uint64_t bytes) {
  return bytes == 0 ? "-" : Fixed(static_cast<double>(bytes) / 1e6, 1);
}

json HealthJson(const cairn_msgs::AgentHealth& h) {
  json components = json::array();
  for (const auto& c : h.components()) {
    json j{{"name", c.name()},
           {"state", c.state()},
           {"loop_rate_hz", c.loop_rate_hz()},
           {"target_rate_hz", c.target_rate_hz()},
           {"cpu_percent", c.cpu_percent()},
           {"memory_bytes", c.memory_bytes()},
           {"restarts", c.restarts()},
           {"degraded", c.degraded()},
           {"last_error", c.last_error()}};
    if (c.state() == "down") {
      j["restart_in_s"] = c.restart_in_s();
      j["down_for_s"] = c.down_for_s();
    }
    components.push_back(std::move(j));
  }
  return json{{"components", components},
              {"rss_bytes", h.rss_bytes()},
              {"process_cpu_percent", h.process_cpu_percent()},
              {"late_control_cycles", h.late_control_cycles()},
              {"events", h.events()},
              {"last_event", h.last_event()},
              {"forged_senders", h.forged_senders()},
              {"last_forged_sender", h.last_forged_sender()}};
}

}  // namespace

int CommandShell::Health(const std::vector<std::string>& args) {
  const std::string& robot = args[0];
  if (RefuseUnknown("health", robot)) return kRefused;
  // A fresh basestation may know the robot before its health arrives (every 2 s; latched): a moment.
  const auto view = client_.WaitUntil(robot, 3.0, [](const RobotView& v) { return v.health.has_value(); });
  if (!view || !view->health) {
    const std::string why =
        robot + " has sent no health (an agent older than this basestation, or its link drops it)";
    if (json_) {
      out_ << Dump(json{{"command", "health"},
                        {"robot", robot},
                        {"ok", false},
                        {"result", outcome::kFailed},
                        {"reason", why}})
           << std::endl;
    } else {
      out_ << "health " << robot << ": " << why << std::endl;
    }
    return kRefused;
  }
  const cairn_msgs::AgentHealth& h = *view->health;
  bool all_up = true;
  for (const auto& c : h.components()) all_up = all_up && c.state() == "active";
  if (json_) {
    json out = HealthJson(h);
    out["command"] = "health";
    out["robot"] = robot;
    out["ok"] = true;
    out["result"] = outcome::kAccepted;
    out["all_up"] = all_up;
    out["lost"] = view->lost;
    out_ << Dump(out) << std::endl;
    return kOk;
  }
  out_ << robot << ": " << (all_up ? "all components up" : "COMPONENTS DOWN") << ", process "
       << Megabytes(h.rss_bytes()) << " MB resident, " << Fixed(h.process_cpu_percent(), 0) << " % CPU, "
       << h.late_control_cycles() << " late control cycles"
       << (view->lost ? " (LOST: the last health heard)" : "") << "\n";
  std::vector<std::vector<std::string>> rows = {
      {"COMPONENT", "STATE", "RATE HZ", "TARGET", "CPU %", "MEM MB", "RESTARTS", "LAST ERROR"}};
  for (const auto& c : h.components()) {
    std::string state = c.state();
    if (state == "down") {
      state = "DOWN " + Fixed(c.down_for_s(), 1) + " s, restart in " + Fixed(c.restart_in_s(), 1) + " s";
    } else if (c.degraded()) {
      state =
          "DEGRADED (slow: " + Fixed(c.loop_rate_hz(), 1) + " of " + Fixed(c.target_rate_hz(), 0) + " Hz)";
    }
    std::string error = c.last_error().empty() ? "-" : c.last_error();
    if (error.size() > 60) error = error.substr(0, 57) + "...";
    rows.push_back({c.name(), state, Fixed(c.loop_rate_hz(), 1), Fixed(c.target_rate_hz(), 0),
                    Fixed(c.cpu_percent(), 1), Megabytes(c.memory_bytes()), std::to_string(c.restarts()),
                    error});
  }
  PrintTable(out_, rows);
  if (!h.last_event().empty()) out_ << "  last event: " << h.last_event() << "\n";
  if (h.forged_senders() > 0) {
    out_ << "  FORGED SENDERS: " << h.forged_senders()
         << " message(s) dropped, the sender id not the certificate's; last: " << h.last_forged_sender()
         << "\n";
  }
  out_ << std::flush;
  return kOk;
}

int CommandShell::Restart(const std::vector<std::string>& args) {
  return Report("restart", args[0], client_.Restart(args[0], args[1]));
}

}  // namespace cairn::base
