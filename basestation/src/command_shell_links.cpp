// The command shell's `links` command: each robot's link as this basestation sees it (see command_shell.h).
#include <thread>

#include "cairn/base/command_shell.h"
#include "cairn/base/operator_text.h"
#include "shell_util.h"

namespace cairn::base {

using nlohmann::json;
using shell::Dump;
using shell::Fixed;
using shell::PrintTable;

namespace {

json LinkJson(const RobotView& v) {
  json j = shell::LinkFieldsJson(v.link);
  j["robot"] = v.robot_id;
  j["link"] = v.link.link;
  j["lost"] = v.lost;
  j["heard_s_ago"] = core::SecondsBetween(v.last_seen, core::SteadyClock::now());
  if (v.lost) j["lost_reason"] = v.lost_reason;
  return j;
}

// "3.2 = command 0.1, state 2.1, tree 0.2, map 0.5, camera 0.3"
std::string UsageText(const LinkView& l) {
  if (l.usage.empty()) return "-";
  std::string text = Fixed(l.sent_kbps, 1) + " =";
  for (std::size_t i = 0; i < l.usage.size(); ++i) {
    text += (i == 0 ? " " : ", ") + l.usage[i].topic_class + " " + Fixed(l.usage[i].sent_kbps, 1);
  }
  return text;
}

}  // namespace

int CommandShell::Links(const std::vector<std::string>& args) {
  // A fresh basestation needs discovery and a probe's round trip before its table means anything.
  std::this_thread::sleep_until(client_.started() + std::chrono::milliseconds(2500));
  std::vector<RobotView> views;
  if (args.empty()) {
    views = client_.Robots();
  } else {
    if (RefuseUnknown("links", args[0])) return kRefused;
    views.push_back(*client_.Robot(args[0]));
  }
  if (json_) {
    json list = json::array();
    for (const RobotView& v : views) list.push_back(LinkJson(v));
    out_ << Dump(json{{"command", "links"}, {"ok", true}, {"result", outcome::kAccepted}, {"robots", list}})
         << std::endl;
    return kOk;
  }
  std::vector<std::vector<std::string>> rows = {
      {"ROBOT", "LINK", "HEARD", "RTT ms (max 10)", "STATE LOST (10 s, total)", "SENDS kbit/s"}};
  std::vector<std::string> warnings;
  for (const RobotView& v : views) {
    const LinkView& l = v.link;
    const std::string link =
        l.link.empty() ? "?" : l.link + (l.budget_kbps > 0 ? " " + Fixed(l.budget_kbps, 0) + " kbit/s" : "");
    const std::string heard =
        v.lost ? "LOST (" + v.lost_reason + ")"
               : Fixed(core::SecondsBetween(v.last_seen, core::SteadyClock::now()), 1) + " s ago";
    const std::string rtt = l.rtt_ms < 0 ? "-" : Fixed(l.rtt_ms, 1) + " (" + Fixed(l.rtt_max_ms, 1) + ")";
    const std::string loss = Fixed(l.loss_pct, 1) + " % (" + std::to_string(l.state_lost) + " of " +
                             std::to_string(l.state_received + l.state_lost) + ")";
    rows.push_back({v.robot_id, link, heard, rtt, loss, UsageText(l)});
    if (l.over_budget) {
      warnings.push_back("warning: " + v.robot_id + " sends " + Fixed(l.sent_kbps, 1) +
                         " kbit/s, over its link budget of " + Fixed(l.budget_kbps, 0) + " kbit/s");
    }
    if (l.probe_wait_s > 0) {
      warnings.push_back("warning: " + v.robot_id + " has not answered the link probe for " +
                         Fixed(l.probe_wait_s, 1) + " s");
    }
  }
  PrintTable(out_, rows);
  if (views.empty()) out_ << "(no robots discovered yet)" << std::endl;
  for (const std::string& w : warnings) out_ << w << std::endl;
  return kOk;
}

}  // namespace cairn::base
