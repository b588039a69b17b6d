#include "cairn/base/link_monitor.h"

#include <algorithm>
#include <cmath>

namespace cairn::base {

namespace {
constexpr std::size_t kProbesKept = 120;
constexpr std::size_t kRttsKept = 10;
constexpr double kLossWindowS = 10.0;
constexpr double kProbePeriodS = 1.0;
}  // namespace

void LinkMonitor::OnProbeSent(std::uint32_t probe_id, core::SteadyTime now) {
  probes_.emplace_back(probe_id, now);
  if (probes_.size() > kProbesKept) probes_.pop_front();
}

void LinkMonitor::OnProbeReply(const std::string& robot_id, std::uint32_t probe_id, core::SteadyTime now) {
  auto sent =
      std::find_if(probes_.begin(), probes_.end(), [&](const auto& p) { return p.first == probe_id; });
  if (sent == probes_.end()) return;
  Robot& robot = robots_[robot_id];
  const double rtt_ms = 1000.0 * core::SecondsBetween(sent->second, now);
  robot.rtts_ms.push_back(rtt_ms);
  if (robot.rtts_ms.size() > kRttsKept) robot.rtts_ms.pop_front();
  robot.view.rtt_ms = rtt_ms;
  robot.view.rtt_max_ms = *std::max_element(robot.rtts_ms.begin(), robot.rtts_ms.end());
  robot.last_answered_probe = std::max(robot.last_answered_probe, probe_id);
}

void LinkMonitor::OnState(const std::string& robot_id, const std::string& writer_id,
                          std::uint64_t sequence_number, core::SteadyTime now) {
  Robot& robot = robots_[robot_id];
  std::uint64_t gap = 0;
  if (robot.writer_id != writer_id) {
    robot.writer_id = writer_id;  // first sample, or a restarted robot: nothing to compare with
  } else if (sequence_number <= robot.last_sequence) {
    return;
  } else {
    gap = sequence_number - robot.last_sequence - 1;
  }
  robot.last_sequence = sequence_number;
  robot.view.state_received += 1;
  robot.view.state_lost += gap;
  robot.recent.push_back({now, gap});
  while (!robot.recent.empty() && core::SecondsBetween(robot.recent.front().time, now) > kLossWindowS) {
    robot.recent.pop_front();
  }
}

void LinkMonitor::OnInfo(const std::string& robot_id, const std::string& link, double budget_kbps) {
  LinkView& view = robots_[robot_id].view;
  view.link = link;
  view.budget_kbps = std::isfinite(budget_kbps) && budget_kbps > 0 ? budget_kbps : 0.0;
}

void LinkMonitor::OnUsage(const std::string& robot_id, std::vector<ClassUsage> usage) {
  LinkView& view = robots_[robot_id].view;
  view.sent_kbps = 0.0;
  for (ClassUsage& u : usage) {
    if (!std::isfinite(u.sent_kbps) || u.sent_kbps < 0) u.sent_kbps = 0.0;
    view.sent_kbps += u.sent_kbps;
  }
  view.usage = std::move(usage);
}

LinkView LinkMonitor::View(const std::string& robot_id, core::SteadyTime now) const {
  auto it = robots_.find(robot_id);
  if (it == robots_.end()) return {};
  const Robot& robot = it->second;
  LinkView view = robot.view;
  view.over_budget = view.budget_kbps > 0 && view.sent_kbps > view.budget_kbps;
  std::uint64_t received = 0, lost = 0;
  for (const StateSample& s : robot.recent) {
    if (core::SecondsBetween(s.time, now) > kLossWindowS) continue;
    received += 1;
    lost += s.lost_before;
  }
  view.loss_pct =
      received + lost > 0 ? 100.0 * static_cast<double>(lost) / static_cast<double>(received + lost) : 0.0;
  // The oldest probe sent after the last answered one, once it is older than a probe period.
  if (view.rtt_ms >= 0) {
    for (const auto& [id, sent] : probes_) {
      if (id <= robot.last_answered_probe) continue;
      const double wait_s = core::SecondsBetween(sent, now);
      if (wait_s > kProbePeriodS) view.probe_wait_s = wait_s;
      break;
    }
  }
  return view;
}

}  // namespace cairn::base
