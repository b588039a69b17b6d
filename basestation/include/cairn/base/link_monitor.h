// A basestation's view of each robot's link (bandwidth monitoring; Sriganesh et al. 2024 § Host
// discovery and communication): when it was last heard, the round trip of the base's link probe, how many of
// its 10 Hz state samples (RobotPose) were lost on the way (gaps in their writer's sequence numbers), and
// what the robot says it sends per topic class against its stated budget. Pure logic, no DDS: FleetClient
// feeds it from its readers and probe writer. Not thread-safe (FleetClient holds its lock).
#pragma once

#include <cstdint>
#include <deque>
#include <map>
#include <string>
#include <vector>

#include "cairn/core/time.h"
#include "cairn/fleet/robot_view.h"

namespace cairn::base {

using fleet::ClassUsage;
using fleet::LinkView;

/// Tracks every robot's link. Times are steady-clock (core::SteadyTime).
class LinkMonitor {
 public:
  /// A link probe `probe_id` went out to every robot at `now` (ids increase).
  void OnProbeSent(std::uint32_t probe_id, core::SteadyTime now);
  /// `robot_id` answered probe `probe_id` at `now`. Unknown or very old probe ids are ignored.
  void OnProbeReply(const std::string& robot_id, std::uint32_t probe_id, core::SteadyTime now);
  /// A 10 Hz state sample (RobotPose) of `robot_id` arrived: its writer (`writer_id`, core::WriterIdOf) and
  /// that writer's sequence number. A new writer (the robot restarted) starts counting afresh; a sequence
  /// number that is not newer (a duplicate) is ignored.
  void OnState(const std::string& robot_id, const std::string& writer_id, std::uint64_t sequence_number,
               core::SteadyTime now);
  /// The robot's agent info: its link class and stated budget (kbit/s, 0 = none).
  void OnInfo(const std::string& robot_id, const std::string& link, double budget_kbps);
  /// The usage its latest state reports (non-finite or negative rates are taken as 0).
  void OnUsage(const std::string& robot_id, std::vector<ClassUsage> usage);

  /// The link of `robot_id` at `now` (a default LinkView for a robot never heard).
  LinkView View(const std::string& robot_id, core::SteadyTime now) const;

 private:
  struct StateSample {
    core::SteadyTime time;
    std::uint64_t lost_before = 0;  // gap this sample revealed
  };
  struct Robot {
    LinkView view;
    std::string writer_id;
    std::uint64_t last_sequence = 0;
    std::uint32_t last_answered_probe = 0;
    std::deque<double> rtts_ms;      // last 10 answered
    std::deque<StateSample> recent;  // last 10 s of state samples
  };
  std::map<std::string, Robot> robots_;
  std::deque<std::pair<std::uint32_t, core::SteadyTime>> probes_;  // last 120 sent, oldest first
};

}  // namespace cairn::base
