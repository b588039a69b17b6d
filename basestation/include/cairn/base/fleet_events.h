// News without asking (Sriganesh et al. 2024, § Operator interface: notifications): what changed in the
// fleet, told once to every operator as it happens. Pure logic over successive robot views, no DDS;
// FleetClient feeds it and queues what it says.
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cairn/perception/staircase.h"
#include "cairn_msgs.h"

namespace cairn::fleet {
struct RobotView;
}  // namespace cairn::fleet

namespace cairn::base {

using fleet::RobotView;

/// One thing an operator should hear about.
struct OperatorEvent {
  /// "joined" (its agent info reached this basestation: what it offers, in `message`) | "arrived" | "failed"
  /// (a goal ended without arriving) | "recovering" (navigation gave up and the recovery tree runs: once when
  /// it starts and once per failed attempt) | "lost" (liveliness lapsed or state silent) | "left" (its
  /// process exited cleanly) | "back" | "over_budget" (it sends more than its stated link budget; `reason`:
  /// the busiest topic class) | "lock_granted" | "lock_released" | "lock_taken" | "control_requested"
  /// (`other` asks the holder for the lock: grant or deny) | "control_handover" (the holder's answer, a
  /// handover unasked, or a request that expired or was dropped: `reason`) | "stopped" (an operator's
  /// stop) | "staircase" | "proximity" | "component_failed" (a part of its agent threw or stalled and waits
  /// for its restart; `other`: the component, `reason`: why) | "component_restarted" |
  /// "component_restart_failed" | "component_escalated" (a part did not stop when asked: it is not restarted
  /// in the agent's process; a supervised agent restarts the process) | get-out-of-the-way:
  /// "yield_moving_aside" (it gets out of `other`'s way: where to, in `reason`), "yield_refused" (it refused
  /// `other`: why), "yield_returned" (its yield ended: back, or how), "yield_asking" (its route is blocked by
  /// `other` in a narrow passage: it asked it to yield), "yield_blocked" (`other` refused or found no spot:
  /// it holds, blocked; why). A yield is told to both operators: each basestation hears both robots' states.
  /// Fleet staircases (robot_id "", see FleetStaircases): "staircase" (a new one) | "staircase_merged" (two
  /// were one flight: the younger id, `merged_staircase_id`, merged into the older) | "staircase_removed" (no
  /// robot reports it any more; `reason`: why). Missions: "mission_paused" (a transient condition interrupted
  /// the operator's waypoint goal or exploration; `reason`: why; the robot resumes it by itself) |
  /// "mission_resumed" | "exploration_complete" (area, time, frontiers given up, in `message`) |
  /// "exploration_stopped" (it failed or was stopped; `reason`) | "goal_abandoned" (a goal ended without
  /// arriving; `reason`, `condition`) | "convoy_formed" (a follower found the robot ahead; `other`) |
  /// "convoy_holding" (a follower holds: the gap closed or the trail is not yet long enough).
  std::string kind;
  std::string robot_id;     ///< the robot concerned ("" for a fleet staircase)
  std::string other;        ///< proximity: the other robot; locks: the basestation; stopped: who stopped it
  std::string message;      ///< one line for people, e.g. "r2 arrived at (30.00, 10.00) (goal 12)"
  std::string reason;       ///< failed: why (operator words); lost: why; staircase_removed: why
  std::string condition;    ///< failed: the mode-tree condition behind it ("IsLocalPlannerHealthy"), or ""
  double distance_m = 0.0;  ///< proximity: centre distance, metres, frame map
  std::chrono::system_clock::time_point time = std::chrono::system_clock::now();
  /// Kinds "staircase" (the new one), "staircase_merged" (the one kept, after the merge), "staircase_removed"
  /// (its last estimate): the fleet staircase, frame map.
  std::optional<perception::StaircaseRegistry::Entry> staircase;
  /// staircase_merged: the fleet staircase id merged away (never used again); 0 otherwise.
  int merged_staircase_id = 0;
  std::uint64_t seq = 0;  ///< order of detection in this basestation, from 1 (FleetClient::EventsSince)
};

/// Options of the event detector.
struct FleetEventOptions {
  /// Two robots closer than this (centre to centre, metres, frame map) raise a proximity event; (0, 100].
  double proximity_m = 1.5;
  /// The pair raises it again only after being farther apart than this (hysteresis); >= proximity_m.
  double proximity_clear_m = 2.5;
  /// @return false and sets `*why` naming the field, value and rule when invalid.
  bool IsValid(std::string* why) const;
};

/// Turns successive views of the fleet into events, each change once. Not thread-safe.
class FleetEventDetector {
 public:
  /// @throws std::invalid_argument when `options` are invalid.
  explicit FleetEventDetector(FleetEventOptions options = {});

  /// Compares every robot in `views` (staleness applied) with its last view and returns what changed: robots
  /// joined (agent info seen), goals arrived or failed, robots lost, left or back, over their link budget,
  /// lock granted/released/taken, operator stops, robots closer than proximity_m. The robot's first whole
  /// state (RobotView::first_state; else its first view) only sets its baseline for the rest (a basestation
  /// that starts does not replay old news, and tells what changed after it arrived); presence
  /// (joined), a link over budget and proximity are present facts, not news, and are reported at once.
  std::vector<OperatorEvent> Observe(const std::vector<RobotView>& views);

  const FleetEventOptions& options() const { return options_; }

 private:
  struct Last;
  // What changed between `last` and `now` (both from whole states) of robot `robot_id` whose newest state is
  // `state`, one concern each, appended to `events`.
  void ObserveGoal(const std::string& robot_id, const cairn_msgs::RobotState& state, const Last& last,
                   const Last& now, std::vector<OperatorEvent>* events);
  void ObserveMission(const std::string& robot_id, const cairn_msgs::RobotState& state, const Last& last,
                      const Last& now, std::vector<OperatorEvent>* events);
  void ObserveConvoy(const std::string& robot_id, const cairn_msgs::RobotState& state, const Last& last,
                     const Last& now, std::vector<OperatorEvent>* events);
  void ObserveYield(const std::string& robot_id, const cairn_msgs::RobotState& state, const Last& last,
                    const Last& now, std::vector<OperatorEvent>* events);
  void ObserveStopAndLock(const std::string& robot_id, const cairn_msgs::RobotState& state, const Last& last,
                          const Last& now, std::vector<OperatorEvent>* events);
  // Presence: joined, over its link budget, left, lost or back.
  void ObservePresence(const RobotView& view, const Last* last, Last* now,
                       std::vector<OperatorEvent>* events);
  // Its components' failures and restarts, each new one once.
  void ObserveHealth(const RobotView& view, const Last& last, Last* now, std::vector<OperatorEvent>* events);
  struct Last {
    bool lost = false;
    bool left = false;
    bool announced = false;
    bool over_budget = false;
    bool has_state = false;
    std::string holder;
    std::string requester;   // RobotState::control_requester_id: who waits for the holder's answer
    uint32_t handovers = 0;  // RobotState::handovers
    uint32_t goal_id = 0;
    cairn_msgs::NavStatus nav_status = cairn_msgs::NAV_STATUS_NONE;
    uint32_t stops = 0;
    std::string nav_reason;
    std::string convoy_state;   // RobotState::convoy_state ("" before a state)
    std::string convoy_ahead;   // the robot it follows ("" when not in a convoy)
    std::string yield_state;    // RobotState::yield_state
    std::string yield_peer;     // RobotState::yield_peer_id
    std::string mission_state;  // RobotState::mission_state ("" | "paused")
    std::string explore_state;  // RobotState::explore_state
    uint32_t explore_task_id = 0;
    /// When this basestation first saw explore_task_id exploring (its clock): the exploration's time so far.
    std::chrono::steady_clock::time_point explore_seen;
    bool has_health = false;
    uint32_t health_events = 0;  // AgentHealth::events

    /// The fields a whole state carries (not explore_seen, presence or health).
    void SetFromState(const cairn_msgs::RobotState& state);
  };
  void ObserveRobot(const RobotView& view, std::vector<OperatorEvent>* events);
  void ObserveProximity(const std::vector<RobotView>& views, std::vector<OperatorEvent>* events);

  FleetEventOptions options_;
  std::map<std::string, Last> last_;
  std::set<std::pair<std::string, std::string>> close_pairs_;  // pairs reported close, not yet apart again
};

}  // namespace cairn::base
