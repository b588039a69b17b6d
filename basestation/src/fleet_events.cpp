#include "cairn/base/fleet_events.h"

#include <cmath>
#include <stdexcept>

#include "cairn/base/fleet.h"
#include "cairn/base/operator_text.h"
#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::base {

namespace msgs = cairn_msgs;

namespace {

// "camera 310.2 kbit/s": the class sending most.
std::string BusiestClass(const LinkView& link) {
  const ClassUsage* busiest = nullptr;
  for (const ClassUsage& u : link.usage) {
    if (busiest == nullptr || u.sent_kbps > busiest->sent_kbps) busiest = &u;
  }
  return busiest == nullptr ? "no usage reported"
                            : busiest->topic_class + " " + core::Fixed(busiest->sent_kbps, 1) + " kbit/s";
}

OperatorEvent Event(const std::string& kind, const std::string& robot, std::string message) {
  OperatorEvent e;
  e.kind = kind;
  e.robot_id = robot;
  e.message = std::move(message);
  return e;
}

}  // namespace

bool FleetEventOptions::IsValid(std::string* why) const {
  if (!(proximity_m > 0.0 && proximity_m <= 100.0)) {
    *why = "proximity_m = " + std::to_string(proximity_m) + " must be in (0, 100]";
    return false;
  }
  if (!(proximity_clear_m >= proximity_m && std::isfinite(proximity_clear_m))) {
    *why = "proximity_clear_m = " + std::to_string(proximity_clear_m) +
           " must be finite and >= proximity_m (" + std::to_string(proximity_m) + ")";
    return false;
  }
  return true;
}

FleetEventDetector::FleetEventDetector(FleetEventOptions options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

std::vector<OperatorEvent> FleetEventDetector::Observe(const std::vector<RobotView>& views) {
  std::vector<OperatorEvent> events;
  for (const RobotView& view : views) ObserveRobot(view, &events);
  ObserveProximity(views, &events);
  return events;
}

void FleetEventDetector::ObserveMission(const std::string& r, const cairn_msgs::RobotState& s,
                                        const Last& last, const Last& now,
                                        std::vector<OperatorEvent>* events) {
  if (now.mission_state == fleet::mission_state::kPaused &&
      last.mission_state != fleet::mission_state::kPaused) {
    OperatorEvent e =
        Event("mission_paused", r,
              r + " " + s.mission_kind() + " paused: " + s.mission_reason() + " (it resumes by itself)");
    e.reason = s.mission_reason();
    events->push_back(e);
  } else if (now.mission_state != fleet::mission_state::kPaused &&
             last.mission_state == fleet::mission_state::kPaused &&
             s.mission_reason().rfind("resumed", 0) == 0) {
    OperatorEvent e = Event("mission_resumed", r, r + " " + s.mission_reason());
    e.reason = s.mission_reason();
    events->push_back(e);
  }
  const bool explore_changed =
      now.explore_state != last.explore_state || now.explore_task_id != last.explore_task_id;
  if (explore_changed && now.explore_state == fleet::explore_state::kComplete) {
    const double minutes =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - last.explore_seen).count() / 60.0;
    OperatorEvent e =
        Event("exploration_complete", r,
              r + " exploration " + ShortId(now.explore_task_id) +
                  " complete: " + core::Fixed(s.explored_m2(), 1) + " m² in " + core::Fixed(minutes, 1) +
                  " min (as heard here), " + std::to_string(s.explore_targets_reached()) +
                  " frontiers reached, " + std::to_string(s.explore_targets_failed()) + " given up");
    e.reason = s.explore_reason();
    events->push_back(e);
  } else if (explore_changed && (now.explore_state == fleet::explore_state::kStopped ||
                                 now.explore_state == fleet::explore_state::kFailed)) {
    const OperatorReason why = ExplainReason(r, s.explore_reason());
    OperatorEvent e =
        Event("exploration_stopped", r,
              r + " exploration " + ShortId(now.explore_task_id) + " " + now.explore_state + ": " + why.text);
    e.reason = why.text;
    e.condition = why.condition;
    events->push_back(e);
  }
}

void FleetEventDetector::Last::SetFromState(const cairn_msgs::RobotState& state) {
  holder = state.holder_id();
  requester = state.control_requester_id();
  handovers = state.handovers();
  goal_id = state.nav_goal_id();
  nav_status = state.nav_status();
  stops = state.stops();
  nav_reason = state.nav_reason();
  convoy_state = state.convoy_state();
  convoy_ahead = state.convoy_ahead_ids().empty() ? "" : state.convoy_ahead_ids().front();
  yield_state = state.yield_state();
  yield_peer = state.yield_peer_id();
  mission_state = state.mission_state();
  explore_state = state.explore_state();
  explore_task_id = state.explore_task_id();
}

void FleetEventDetector::ObserveRobot(const RobotView& view, std::vector<OperatorEvent>* events) {
  const std::string& r = view.robot_id;
  auto found = last_.find(r);
  Last now;
  now.lost = view.lost;
  now.left = view.left;
  now.announced = view.announced;
  now.has_state = view.state.has_value();
  if (view.state) {
    now.SetFromState(*view.state);
    now.explore_seen = found != last_.end() && found->second.explore_task_id == now.explore_task_id
                           ? found->second.explore_seen
                           : std::chrono::steady_clock::now();
  }
  ObservePresence(view, found == last_.end() ? nullptr : &found->second, &now, events);
  if (found == last_.end()) {
    // First sight: presence and loss are as they are now; the state's baseline is the first whole state this
    // basestation received (below), so that what changed since (its own request-control, granted before
    // this first look) is still told.
    found = last_.emplace(r, now).first;
    found->second.has_state = false;
  }
  Last& last = found->second;
  if (view.state && !last.has_state && view.first_state) {
    last.SetFromState(*view.first_state);
    last.has_state = true;
  }
  if (view.state && last.has_state) {
    const auto& s = *view.state;
    ObserveGoal(r, s, last, now, events);
    ObserveMission(r, s, last, now, events);
    ObserveConvoy(r, s, last, now, events);
    ObserveYield(r, s, last, now, events);
    ObserveStopAndLock(r, s, last, now, events);
  }
  ObserveHealth(view, last, &now, events);
  if (!view.state) {
    now.holder = last.holder;
    now.requester = last.requester;
    now.handovers = last.handovers;
    now.goal_id = last.goal_id;
    now.nav_status = last.nav_status;
    now.stops = last.stops;
    now.nav_reason = last.nav_reason;
    now.has_state = last.has_state;
  }
  last = now;
}

void FleetEventDetector::ObservePresence(const RobotView& view, const Last* last, Last* now,
                                         std::vector<OperatorEvent>* events) {
  const std::string& r = view.robot_id;
  // Joining is presence, not old news: a basestation that starts hears who is there.
  if (now->announced && (last == nullptr || !last->announced)) {
    events->push_back(Event("joined", r, r + " joined: " + DescribeAgent(view)));
  }
  // Over budget from the first view on; back within it below 90 % (no flapping at the edge).
  const LinkView& link = view.link;
  const bool was_over = last != nullptr && last->over_budget;
  now->over_budget =
      was_over ? link.budget_kbps > 0 && link.sent_kbps > 0.9 * link.budget_kbps : link.over_budget;
  if (now->over_budget && !was_over) {
    const std::string busiest = BusiestClass(link);
    OperatorEvent e =
        Event("over_budget", r,
              r + " sends " + core::Fixed(link.sent_kbps, 1) + " kbit/s, over its link budget of " +
                  core::Fixed(link.budget_kbps, 1) + " kbit/s (" + busiest + ")");
    e.reason = busiest;
    events->push_back(e);
  }
  // At first sight loss and leaving are as they are now: not news.
  const bool last_left = last != nullptr ? last->left : now->left;
  const bool last_lost = last != nullptr ? last->lost : now->lost;
  if (now->left && !last_left) {
    OperatorEvent e = Event("left", r, r + " left (" + view.lost_reason + ")");
    e.reason = view.lost_reason;
    events->push_back(e);
  } else if (now->lost != last_lost && !(now->lost && now->left)) {
    OperatorEvent e = Event(now->lost ? "lost" : "back", r,
                            now->lost ? r + " lost (" + view.lost_reason + ")" : r + " is back");
    e.reason = now->lost ? view.lost_reason : "";
    events->push_back(e);
  }
}

void FleetEventDetector::ObserveGoal(const std::string& r, const cairn_msgs::RobotState& s, const Last& last,
                                     const Last& now, std::vector<OperatorEvent>* events) {
  const bool goal_changed = now.goal_id != last.goal_id || now.nav_status != last.nav_status;
  if (goal_changed && now.nav_status == msgs::NAV_STATUS_ARRIVED) {
    events->push_back(Event("arrived", r,
                            r + " arrived at (" + core::Fixed(s.nav_goal_M().x_m(), 2) + ", " +
                                core::Fixed(s.nav_goal_M().y_m(), 2) + ") (goal " + ShortId(now.goal_id) +
                                ")"));
  } else if (goal_changed && now.nav_status == msgs::NAV_STATUS_FAILED) {
    const OperatorReason why = ExplainReason(r, s.nav_reason());
    OperatorEvent e =
        Event("goal_abandoned", r, r + " goal " + ShortId(now.goal_id) + " abandoned: " + why.text);
    e.reason = why.text;
    e.condition = why.condition;
    events->push_back(e);
  }
  if (now.nav_status == msgs::NAV_STATUS_ACTIVE && now.goal_id == last.goal_id && !now.nav_reason.empty() &&
      now.nav_reason != last.nav_reason) {
    // The recovery report grows by one "; attempt N (...): why" per failed attempt: show what is new.
    const std::string added = now.nav_reason.rfind(last.nav_reason, 0) == 0 && !last.nav_reason.empty()
                                  ? now.nav_reason.substr(last.nav_reason.size() + 2)
                                  : now.nav_reason;
    OperatorEvent e = Event("recovering", r, r + " goal " + ShortId(now.goal_id) + " " + added);
    e.reason = added;
    events->push_back(e);
  }
}

void FleetEventDetector::ObserveConvoy(const std::string& r, const cairn_msgs::RobotState& s,
                                       const Last& last, const Last& now,
                                       std::vector<OperatorEvent>* events) {
  // A convoy follower that stops on its own (lost or blocked) or re-links is news, and so are its forming
  // (following at first) and its holding.
  if (now.convoy_state != last.convoy_state && now.convoy_state == fleet::convoy_state::kFollowing &&
      (last.convoy_state.empty() || last.convoy_state == fleet::convoy_state::kNone)) {
    OperatorEvent e = Event("convoy_formed", r, r + " follows " + now.convoy_ahead + " in the convoy");
    e.other = now.convoy_ahead;
    events->push_back(e);
  } else if (now.convoy_state != last.convoy_state && now.convoy_state == fleet::convoy_state::kHolding) {
    OperatorEvent e = Event("convoy_holding", r, r + " holds in the convoy: " + s.convoy_reason());
    e.reason = s.convoy_reason();
    e.other = now.convoy_ahead;
    events->push_back(e);
  }
  if (now.convoy_state != last.convoy_state &&
      (now.convoy_state == fleet::convoy_state::kLost || now.convoy_state == fleet::convoy_state::kBlocked)) {
    OperatorEvent e = Event("convoy_" + now.convoy_state, r,
                            r + " stopped in the convoy (" + now.convoy_state + "): " + s.convoy_reason());
    e.reason = s.convoy_reason();
    e.other = now.convoy_ahead;
    events->push_back(e);
  } else if (!now.convoy_ahead.empty() && !last.convoy_ahead.empty() &&
             now.convoy_ahead != last.convoy_ahead) {
    OperatorEvent e = Event("convoy_relinked", r,
                            r + " now follows " + now.convoy_ahead + " (was " + last.convoy_ahead + ")");
    e.other = now.convoy_ahead;
    events->push_back(e);
  }
}

void FleetEventDetector::ObserveYield(const std::string& r, const cairn_msgs::RobotState& s, const Last& last,
                                      const Last& now, std::vector<OperatorEvent>* events) {
  // Get-out-of-the-way: a yield starting, refused, ended; a robot asking, or blocked by a refusal.
  if ((now.yield_state == last.yield_state && now.yield_peer == last.yield_peer) ||
      (now.yield_state == fleet::yield_state::kAside && last.yield_state == fleet::yield_state::kMovingAside))
    return;
  const std::string& peer = now.yield_state.empty() ? last.yield_peer : now.yield_peer;
  const std::string& why = s.yield_reason();
  std::string kind, message;
  if (now.yield_state == fleet::yield_state::kMovingAside || now.yield_state == fleet::yield_state::kAside) {
    kind = "yield_moving_aside";
    message = r + " gets out of " + peer + "'s way: " + why;
  } else if (now.yield_state == fleet::yield_state::kRefused) {
    kind = "yield_refused";
    message = r + " refused to yield to " + peer + ": " + why;
  } else if (now.yield_state == fleet::yield_state::kAsking) {
    kind = "yield_asking";
    message = r + ": " + why;
  } else if (now.yield_state == fleet::yield_state::kBlocked) {
    kind = "yield_blocked";
    message = r + " " + why;
  } else if (now.yield_state.empty() && fleet::GivesWay(last.yield_state)) {
    kind = "yield_returned";
    message = r + ": " + why;
  }
  if (kind.empty()) return;
  OperatorEvent e = Event(kind, r, message);
  e.other = peer;
  e.reason = why;
  events->push_back(e);
}

void FleetEventDetector::ObserveStopAndLock(const std::string& r, const cairn_msgs::RobotState& s,
                                            const Last& last, const Last& now,
                                            std::vector<OperatorEvent>* events) {
  if (now.stops > last.stops) {
    OperatorEvent e = Event("stopped", r, r + " stopped by " + s.stopped_by());
    e.other = s.stopped_by();
    events->push_back(e);
  }
  // A request for the lock: the holder's operator answers it (grant or deny); everyone is told.
  if (!now.requester.empty() && now.requester != last.requester) {
    const int left_s = static_cast<int>(std::ceil(s.control_request_left_s()));
    OperatorEvent e = Event("control_requested", r,
                            r + ": " + now.requester + " asks for control (held by " + now.holder +
                                "): grant " + r + " " + now.requester + " or deny " + r + " " +
                                now.requester + " within " + std::to_string(left_s) + " s");
    e.other = now.requester;
    events->push_back(e);
  }
  // The holder's answer, a handover unasked, or a request that expired: the robot's own words.
  const bool handed_over = now.handovers != last.handovers && !s.handover_outcome().empty();
  if (handed_over) {
    OperatorEvent e = Event("control_handover", r, r + ": " + s.handover_outcome());
    e.other = now.holder;
    e.reason = s.handover_outcome();
    events->push_back(e);
  }
  if (now.holder == last.holder || (handed_over && !now.holder.empty() && !last.holder.empty())) return;
  OperatorEvent e;
  if (last.holder.empty()) {
    e = Event("lock_granted", r, r + " control granted to " + now.holder);
    e.other = now.holder;
  } else if (now.holder.empty()) {
    e = Event("lock_released", r, r + " control released by " + last.holder);
    e.other = last.holder;
  } else {
    e = Event("lock_taken", r, r + " control taken by " + now.holder + " from " + last.holder);
    e.other = now.holder;
  }
  events->push_back(e);
}

void FleetEventDetector::ObserveHealth(const RobotView& view, const Last& last, Last* now,
                                       std::vector<OperatorEvent>* events) {
  // A restarted agent counts from 0 again: its first health is a new baseline.
  if (!view.health) {
    now->has_health = last.has_health;
    now->health_events = last.health_events;
    return;
  }
  const cairn_msgs::AgentHealth& h = *view.health;
  now->has_health = true;
  now->health_events = h.events();
  if (last.has_health && h.events() > last.health_events && !h.last_event_kind().empty()) {
    OperatorEvent e =
        Event("component_" + h.last_event_kind(), view.robot_id, view.robot_id + ": " + h.last_event());
    e.other = h.last_event_component();
    e.reason = h.last_event();
    events->push_back(e);
  }
}

void FleetEventDetector::ObserveProximity(const std::vector<RobotView>& views,
                                          std::vector<OperatorEvent>* events) {
  for (std::size_t i = 0; i < views.size(); ++i) {
    for (std::size_t j = i + 1; j < views.size(); ++j) {
      const RobotView& a = views[i];
      const RobotView& b = views[j];
      const auto pair = std::make_pair(a.robot_id, b.robot_id);
      if (a.lost || b.lost || !a.state || !b.state) {
        close_pairs_.erase(pair);
        continue;
      }
      const auto& pa = a.state->pose_MB().position();
      const auto& pb = b.state->pose_MB().position();
      const double d = std::hypot(pa.x_m() - pb.x_m(), pa.y_m() - pb.y_m());
      if (d < options_.proximity_m && close_pairs_.insert(pair).second) {
        OperatorEvent e = Event("proximity", a.robot_id,
                                a.robot_id + " and " + b.robot_id + " are " + core::Fixed(d, 2) +
                                    " m apart (closer than " + core::Fixed(options_.proximity_m, 2) + " m)");
        e.other = b.robot_id;
        e.distance_m = d;
        events->push_back(e);
      } else if (d > options_.proximity_clear_m) {
        close_pairs_.erase(pair);
      }
    }
  }
}

}  // namespace cairn::base
