// Helpers shared by the command shell's translation units (internal to cairn_base_lib).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "cairn/base/fleet.h"
#include "cairn/base/link_monitor.h"
#include "cairn/core/range_check.h"
#include "cairn/core/time.h"
#include "cairn/perception/staircase.h"
#include "cairn_msgs.h"

namespace cairn::base::shell {

/// A wait on a robot (goto --wait, explore --wait) gives up on a lost robot only once it has stayed lost for
/// `grace_s`, or at once if its process exited: on a lossy link a state gap of a second is not the end of a
/// mission (the robot drives on), and the wait goes on through it.
class LostRobotGrace {
 public:
  explicit LostRobotGrace(double grace_s = 5.0) : grace_s_(grace_s) {}
  /// The failure ("robot lost for 5.0 s (REASON)") once `view` has been lost long enough at `now`, else "".
  std::string Check(const RobotView& view, core::SteadyTime now) {
    if (!view.lost) {
      lost_since_.reset();
      return "";
    }
    if (!lost_since_) lost_since_ = now;
    const double lost_s = core::SecondsBetween(*lost_since_, now);
    if (!view.left && lost_s < grace_s_) return "";
    std::ostringstream out;
    out << "robot lost";
    if (!view.left) out << " for " << std::fixed << std::setprecision(1) << lost_s << " s";
    out << " (" << view.lost_reason << ")";
    return out.str();
  }

 private:
  double grace_s_;
  std::optional<core::SteadyTime> lost_since_;
};

/// One JSON object as one output line's text; invalid UTF-8 from operator input is replaced, never thrown.
inline std::string Dump(const nlohmann::json& j) {
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

using core::Fixed;  // `value` with `digits` decimals

/// `send(robots[i])` for every robot at once, one thread each (one robot's round trip never holds up the
/// others); the outcomes in the order of `robots`.
template <class Outcome, class Send>
std::vector<Outcome> SendToEach(const std::vector<std::string>& robots, const Send& send) {
  std::vector<Outcome> outcomes(robots.size());
  std::vector<std::thread> senders;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    senders.emplace_back([&, i] { outcomes[i] = send(robots[i], i); });
  }
  for (auto& t : senders) t.join();
  return outcomes;
}

/// Columns `text` takes on a terminal: its UTF-8 code points (each is one column here: "m²" is two).
inline std::size_t ColumnsOf(const std::string& text) {
  std::size_t n = 0;
  for (const char c : text) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80 ? 1 : 0;
  return n;
}

/// Prints rows as columns separated by two spaces, each as wide as its widest cell.
inline void PrintTable(std::ostream& out, const std::vector<std::vector<std::string>>& rows) {
  std::vector<std::size_t> widths;
  for (const auto& row : rows) {
    widths.resize(std::max(widths.size(), row.size()));
    for (std::size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], ColumnsOf(row[c]));
  }
  for (const auto& row : rows) {
    std::string line;
    for (std::size_t c = 0; c < row.size(); ++c) {
      line += row[c];
      if (c + 1 < row.size()) line += std::string(widths[c] - ColumnsOf(row[c]) + 2, ' ');
    }
    out << line << "\n";
  }
  out.flush();
}

/// Parses a finite number; on failure sets `error` naming the argument and the value.
inline bool ParseNumber(const std::string& text, const char* name, double* value, std::string* error) {
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

/// Yaw about +z of a unit quaternion, radians.
inline double YawOf(const cairn_msgs::Quaternion& q) {
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}

inline nlohmann::json PointsJson(const std::vector<cairn_msgs::Point>& points) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : points) list.push_back({p.x_m(), p.y_m(), p.z_m()});
  return list;
}

inline std::string PointsText(const std::vector<cairn_msgs::Point>& points) {
  std::string text;
  for (std::size_t i = 0; i < points.size(); ++i) {
    text += "  " + std::to_string(i) + ": (" + Fixed(points[i].x_m(), 2) + ", " + Fixed(points[i].y_m(), 2) +
            ", " + Fixed(points[i].z_m(), 2) + ")\n";
  }
  return text;
}

/// One fleet staircase as JSON (the `stairs` list and the staircase event share it).
inline nlohmann::json StaircaseJson(const perception::StaircaseRegistry::Entry& e) {
  const perception::Staircase& s = e.staircase;
  return {{"id", e.id},
          {"x_m", s.p_W_first_step.x()},
          {"y_m", s.p_W_first_step.y()},
          {"z_m", s.p_W_first_step.z()},
          {"yaw_rad", s.yaw_rad},
          {"num_steps", s.num_steps},
          {"rise_m", s.rise_m},
          {"run_m", s.run_m},
          {"width_m", s.width_m},
          {"confidence", s.confidence},
          {"sources", e.sources}};
}

/// A robot's link as this basestation sees it (LinkMonitor), for `links --json` and the GUI's fleet message:
/// budget_kbps, rtt_ms (-1 none yet), rtt_max_ms, probe_wait_s, state_received, state_lost, loss_pct (over
/// 10 s), sent_kbps, over_budget and usage (topic_class, sent_kbps, sent_bytes in the robot's priority
/// order). The link class itself is the caller's ("link" in the shell, "class" in the GUI).
inline nlohmann::json LinkFieldsJson(const LinkView& l) {
  nlohmann::json usage = nlohmann::json::array();
  for (const ClassUsage& u : l.usage) {
    usage.push_back(
        {{"topic_class", u.topic_class}, {"sent_kbps", u.sent_kbps}, {"sent_bytes", u.sent_bytes}});
  }
  return {{"budget_kbps", l.budget_kbps},
          {"rtt_ms", l.rtt_ms},
          {"rtt_max_ms", l.rtt_max_ms},
          {"probe_wait_s", l.probe_wait_s},
          {"state_received", l.state_received},
          {"state_lost", l.state_lost},
          {"loss_pct", l.loss_pct},
          {"sent_kbps", l.sent_kbps},
          {"over_budget", l.over_budget},
          {"usage", usage}};
}

}  // namespace cairn::base::shell

namespace cairn::base {

/// A robot's exploration fields (RobotState.explore_*) as JSON: state, reason, task id, explored m²,
/// frontiers, reachable frontiers, targets reached and given up, the target when it has one.
nlohmann::json ExplorationJson(const cairn_msgs::RobotState& s);
/// The same as one line: "7: exploring, 120 m² explored, 14 frontiers (12 reachable), 3 reached, 0 given up;
/// target (12.30, 4.10); best of 12 reachable frontiers"; "none" before any exploration.
std::string ExplorationText(const cairn_msgs::RobotState& s);
/// A convoy follower's fields (RobotState.convoy_*) as JSON: state, the robots ahead (nearest first), reason,
/// gap along the trail in metres when known.
nlohmann::json ConvoyJson(const cairn_msgs::RobotState& s);
/// The same as one line: "following behind r1 (3.1 m along its path), leader r0"; "none" when not following.
std::string ConvoyText(const cairn_msgs::RobotState& s);

}  // namespace cairn::base
