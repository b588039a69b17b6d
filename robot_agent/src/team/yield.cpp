#include "cairn/agent/team/yield.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "cairn/core/peer_input.h"
#include "cairn/core/range_check.h"
#include "cairn/fleet/robot_status.h"

namespace cairn::agent {

using core::Fixed;
using core::InRange;

const char* ToString(YieldStatus::State state) {
  switch (state) {
    case YieldStatus::State::kNone:
      return fleet::yield_state::kNone;
    case YieldStatus::State::kMovingAside:
      return fleet::yield_state::kMovingAside;
    case YieldStatus::State::kAside:
      return fleet::yield_state::kAside;
    case YieldStatus::State::kReturning:
      return fleet::yield_state::kReturning;
    case YieldStatus::State::kRefused:
      return fleet::yield_state::kRefused;
    case YieldStatus::State::kAsking:
      return fleet::yield_state::kAsking;
    case YieldStatus::State::kBlocked:
      return fleet::yield_state::kBlocked;
  }
  return fleet::yield_state::kNone;
}

namespace {

// Modes an operator drives: never yieldable.
bool OperatorDriven(const std::string& mode) { return mode == "manual" || mode == "smart_joystick"; }

std::string Point(const Eigen::Vector2d& p) { return "(" + Fixed(p.x(), 1) + ", " + Fixed(p.y(), 1) + ")"; }

// `way` (>= 1 point) up to its point nearest `p`, then `p`: the part of the way a robot that stopped at `p`
// has driven.
std::vector<Eigen::Vector2d> WayTo(const std::vector<Eigen::Vector2d>& way, const Eigen::Vector2d& p) {
  std::size_t best_i = 0;
  double best_d = (way.front() - p).norm();
  for (std::size_t i = 0; i + 1 < way.size(); ++i) {
    const Eigen::Vector2d ab = way[i + 1] - way[i];
    const double len2 = ab.squaredNorm();
    const double t = len2 > 1e-18 ? std::clamp((p - way[i]).dot(ab) / len2, 0.0, 1.0) : 0.0;
    const double d = (way[i] + t * ab - p).norm();
    if (d < best_d) {
      best_d = d;
      best_i = i;
    }
  }
  std::vector<Eigen::Vector2d> driven(way.begin(), way.begin() + static_cast<std::ptrdiff_t>(best_i) + 1);
  driven.push_back(p);
  return driven;
}

}  // namespace

std::string ParseYieldModes(const std::string& text, std::vector<std::string>* modes) {
  std::vector<std::string> parsed;
  std::string name;
  std::istringstream in(text);
  char c = 0;
  auto flush = [&]() -> std::string {
    if (name.empty()) return "";
    if (OperatorDriven(name) || name == "yield") {
      return "yield.modes: '" + name + "' cannot yield (" +
             (name == "yield" ? std::string("it is the yield itself") : "an operator drives the robot") + ")";
    }
    if (std::find(parsed.begin(), parsed.end(), name) == parsed.end()) parsed.push_back(name);
    name.clear();
    return "";
  };
  while (in.get(c)) {
    if (c == ' ' || c == ',' || c == '\t') {
      if (std::string why = flush(); !why.empty()) return why;
    } else if ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_') {
      name.push_back(c);
    } else {
      return "yield.modes = \"" + text.substr(0, 80) + "\": '" + std::string(1, c) +
             "' is not part of a mode name ([a-z0-9_], separated by spaces or commas)";
    }
  }
  if (std::string why = flush(); !why.empty()) return why;
  *modes = std::move(parsed);
  return "";
}

bool YieldOptions::IsValid(std::string* why) const {
  for (const std::string& m : modes) {
    std::vector<std::string> one;
    if (std::string problem = ParseYieldModes(m, &one); !problem.empty() || one.size() != 1) {
      *why = problem.empty() ? "yield.modes: '" + m + "' is not one mode name" : problem;
      return false;
    }
  }
  return InRange("yield.margin_m", margin_m, 0, 2, true, why) &&
         InRange("yield.max_drive_m", max_drive_m, 0, 200, true, why) &&
         InRange("yield.max_wait_s", max_wait_s, 0, 3600, true, why) &&
         InRange("yield.lookahead_m", lookahead_m, 0, 16, true, why) &&
         InRange("yield.standoff_m", standoff_m, 0, 10, true, why) &&
         InRange("yield.ask_every_s", ask_every_s, 0, 60, true, why);
}

std::string CheckYieldCommand(const YieldCommand& c) {
  if (std::string why = core::CheckId("sender_id", c.sender_id); !why.empty()) return "yield request: " + why;
  if (std::string why = core::CheckId("passing_id", c.passing_id); !why.empty())
    return "yield request: " + why;
  if (!(c.passing_radius_m > 0 && c.passing_radius_m <= 5.0)) {
    return "yield request from " + c.sender_id + ": passing_radius_m = " + Fixed(c.passing_radius_m, 3) +
           " must be in (0, 5]";
  }
  if (c.keep_clear_M.empty() || c.keep_clear_M.size() > 32) {
    return "yield request from " + c.sender_id + ": keep_clear_M has " +
           std::to_string(c.keep_clear_M.size()) + " points (1..32)";
  }
  for (std::size_t i = 0; i < c.keep_clear_M.size(); ++i) {
    const Eigen::Vector2d& p = c.keep_clear_M[i];
    if (!p.allFinite() || p.cwiseAbs().maxCoeff() > 1e6) {
      return "yield request from " + c.sender_id + ": keep_clear_M[" + std::to_string(i) + "] = (" +
             std::to_string(p.x()) + ", " + std::to_string(p.y()) + ") must be finite, within 1e6 m";
    }
  }
  return "";
}

bool YieldsTo(const Peer& peer, const std::string& robot_id) {
  return peer.yield_to_id == robot_id && fleet::GivesWay(peer.yield_state);
}

YieldDecision DecideYield(const YieldOptions& options, const YieldCommand& c,
                          const YieldSituation& situation) {
  const std::string& mode = situation.mode;
  const core::BaseState& pose_M = situation.pose_M;
  const double radius_m = situation.radius_m;
  const nav::TraversabilityGrid* grid = situation.grid;
  YieldDecision d;
  if (std::find(options.modes.begin(), options.modes.end(), mode) == options.modes.end()) {
    std::string allowed;
    for (const std::string& m : options.modes) allowed += (allowed.empty() ? "" : ", ") + m;
    d.refusal = mode == "manual"           ? "in manual control: its operator drives it"
                : mode == "smart_joystick" ? "driven by its operator (smart joystick)"
                                           : "in mode " + mode + ", which does not yield (yield.modes: " +
                                                 (allowed.empty() ? std::string("none") : allowed) + ")";
    return d;
  }
  if (!situation.ended_lately.empty()) {
    d.refusal = situation.ended_lately;
    return d;
  }
  if (situation.passing_yields_to_me) {
    d.refusal = c.passing_id + " is getting out of " + situation.own_id + "'s way";
    d.ignore = true;
    return d;
  }
  if (situation.asking.peer_id == c.passing_id && situation.asking.state == YieldStatus::State::kAsking &&
      situation.own_id < c.passing_id) {
    d.refusal =
        "both asked each other: " + c.passing_id + " gives way (the larger id does, unless it cannot)";
    return d;
  }
  if (grid == nullptr) {
    d.refusal = "no navigation map to find a spot on";
    return d;
  }
  nav::YieldSpotRequest request;
  request.from_W = {pose_M.x_m, pose_M.y_m};
  request.keep_clear_W = c.keep_clear_M;
  request.clearance_m = radius_m + c.passing_radius_m + options.margin_m;
  request.robot_radius_m = radius_m;
  request.keep_off_m = request.clearance_m;  // not even squeezing past it
  request.max_drive_m = options.max_drive_m;
  d.clearance_m = request.clearance_m;
  d.spot = nav::FindYieldSpot(*grid, request);
  d.accepted = d.spot.found;
  if (!d.accepted) d.refusal = "no spot to stand aside on its map: " + d.spot.reason;
  return d;
}

// ---- YieldMode --------------------------------------------------------------------------------------------

namespace {
nav::Navigation* Required(nav::Navigation* navigation) {
  if (navigation == nullptr) throw std::invalid_argument("YieldMode: navigation is null");
  return navigation;
}
const YieldOptions& Valid(const YieldOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  return options;
}
}  // namespace

YieldMode::YieldMode(const YieldOptions& options, double channel_timeout_s, nav::Navigation* navigation)
    : ModeModule(kName, MuxChannelOptions{kChannel, channel_timeout_s}),
      options_(Valid(options)),
      navigation_(Required(navigation)) {}

bool YieldMode::active() const {
  return status_.state == YieldStatus::State::kMovingAside || status_.state == YieldStatus::State::kAside ||
         status_.state == YieldStatus::State::kReturning;
}

bool YieldMode::TakeFinished() {
  const bool finished = finished_;
  finished_ = false;
  return finished;
}

void YieldMode::Start(const YieldCommand& command, const nav::YieldSpot& spot, const core::BaseState& pose_M,
                      double spot_clearance_m, bool return_home, double now_s) {
  DropGoal();
  passing_id_ = command.passing_id;
  way_M_ = spot.path_W;
  if (way_M_.empty()) way_M_ = {Eigen::Vector2d(pose_M.x_m, pose_M.y_m), spot.p_W};
  z_m_ = pose_M.z_m;
  clearance_m_ = spot_clearance_m;
  return_home_ = return_home;
  finished_ = false;
  passed_ = false;
  passed_reason_.clear();
  last_heard_s_ = now_s;
  aside_since_s_ = now_s;
  status_.state = YieldStatus::State::kMovingAside;
  status_.peer_id = command.passing_id;
  status_.reason = "moving aside for " + command.passing_id + " to " + Point(spot.p_W) + ", " +
                   Fixed(spot.drive_m, 1) + " m away (" + Fixed(spot.clearance_m, 1) + " m from its route)";
  Drive(way_M_, z_m_, "the way to a spot aside", now_s);
}

bool YieldMode::InTheWayOf(const YieldCommand& command) const {
  return status_.state == YieldStatus::State::kAside && command.passing_id == passing_id_ &&
         !way_M_.empty() && nav::DistanceToPolyline(command.keep_clear_M, way_M_.back()) < clearance_m_;
}

bool YieldMode::MoveOn(const YieldCommand& command, const nav::YieldSpot& spot, double now_s) {
  if (!InTheWayOf(command) || spot.path_W.empty()) return false;
  // The way back goes through the spot it leaves: home -> old spot -> new spot, reversed on return.
  way_M_.insert(way_M_.end(), spot.path_W.begin() + 1, spot.path_W.end());
  passed_ = false;
  passed_reason_.clear();
  last_heard_s_ = now_s;
  aside_since_s_ = now_s;
  status_.state = YieldStatus::State::kMovingAside;
  status_.reason = "moving on for " + passing_id_ + " (its route changed) to " + Point(spot.p_W) + ", " +
                   Fixed(spot.drive_m, 1) + " m away";
  Drive(spot.path_W, z_m_, "the way to a spot aside", now_s);
  return true;
}

void YieldMode::Refuse(const std::string& passing_id, const std::string& why, double now_s) {
  if (active()) return;  // already yielding (to another robot): the refusal is the caller's log line only
  status_.state = YieldStatus::State::kRefused;
  status_.peer_id = passing_id;
  status_.reason = why;
  refused_at_s_ = now_s;
}

void YieldMode::SetPeers(const std::vector<Peer>& peers, double now_s) {
  if (!ended_for_.empty() && ended_at_s_ < 0) ended_at_s_ = now_s;
  if (status_.state == YieldStatus::State::kRefused && now_s - refused_at_s_ > kRefusalShownS) {
    status_ = YieldStatus{};
  }
  if (status_.state != YieldStatus::State::kAside || passed_) return;
  auto it =
      std::find_if(peers.begin(), peers.end(), [&](const Peer& p) { return p.robot_id == passing_id_; });
  if (it != peers.end()) {
    last_heard_s_ = now_s;
    // Passed: its route from where it is no longer comes near the way here and back.
    std::vector<Eigen::Vector2d> route = {Eigen::Vector2d(it->pose_M.x_m, it->pose_M.y_m)};
    for (const Eigen::Vector3d& q : it->path_ahead_M) route.emplace_back(q.head<2>());
    double nearest_m = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector2d& q : way_M_)
      nearest_m = std::min(nearest_m, nav::DistanceToPolyline(route, q));
    if (nearest_m >= clearance_m_) {
      passed_ = true;
      passed_reason_ = passing_id_ + " has passed";
    } else if (it->path_ahead_M.empty() && std::abs(it->pose_M.v_mps) < 0.05) {
      passed_ = true;  // it no longer drives (arrived, or its operator stopped it): the way is not needed
      passed_reason_ = passing_id_ + " has stopped with no route";
    }
  } else if (now_s - last_heard_s_ > kUnheardS) {
    passed_ = true;
    passed_reason_ = passing_id_ + " not heard for " + Fixed(now_s - last_heard_s_, 0) + " s";
  }
  if (!passed_ && now_s - aside_since_s_ > options_.max_wait_s) {
    passed_ = true;
    passed_reason_ =
        passing_id_ + " did not pass within " + Fixed(options_.max_wait_s, 0) + " s (yield.max_wait_s)";
  }
}

std::string YieldMode::EndedLately(const std::string& passing_id, double now_s) const {
  if (passing_id != ended_for_ || ended_at_s_ < 0 || now_s - ended_at_s_ >= kEndedHoldOffS) return "";
  return "its last yield for " + passing_id + " was ended " + Fixed(now_s - ended_at_s_, 0) + " s ago (" +
         ended_why_ + "): not again for " + Fixed(kEndedHoldOffS, 0) + " s";
}

void YieldMode::Deactivate(const std::string& why) {
  if (!active()) return;
  ended_for_ = passing_id_;
  ended_why_ = why;
  ended_at_s_ = -1.0;  // stamped by the next SetPeers()
  DropGoal();
  status_ =
      YieldStatus{YieldStatus::State::kNone, passing_id_, "yield for " + passing_id_ + " ended: " + why};
  finished_ = false;
}

void YieldMode::DropGoal() {
  if (has_goal_) navigation_->ClearGoal(goal_serial_);
  has_goal_ = false;
}

void YieldMode::Drive(const std::vector<Eigen::Vector2d>& way_M, double z_m, const std::string& what,
                      double now_s) {
  std::vector<Eigen::Vector3d> path;
  path.reserve(way_M.size());
  for (const Eigen::Vector2d& p : way_M) path.emplace_back(p.x(), p.y(), z_m);
  if (path.size() == 1) path.push_back(path.front());
  const Eigen::Vector2d end = way_M.back();
  navigation_->AcceptGoal(nav::PlanAlong(path, navigation_->global_plan().map_version, what), end.x(),
                          end.y(),
                          /*tolerance_m=*/0.0, now_s);
  goal_serial_ = navigation_->goal_serial();
  has_goal_ = true;
}

ModeOutput YieldMode::Hold(const ModeInputs& in) const {
  ModeOutput out;
  out.twist_B = Twist2{0.0, 0.0};  // the channel stays fresh: held at rest, not left stale
  out.stamp = in.now;
  return out;
}

ModeOutput YieldMode::Finish(const std::string& reason, const ModeInputs& in) {
  DropGoal();
  status_ = YieldStatus{YieldStatus::State::kNone, passing_id_, reason};
  finished_ = true;
  ModeOutput out = Hold(in);
  out.done = true;
  return out;
}

ModeOutput YieldMode::Step(const ModeInputs& in) {
  if (!active()) return {};
  if (status_.state == YieldStatus::State::kAside) {
    if (!passed_) return Hold(in);
    if (!return_home_) return Finish("yielded to " + passing_id_ + ": " + passed_reason_, in);
    std::vector<Eigen::Vector2d> back(way_M_.rbegin(), way_M_.rend());
    back.front() = Eigen::Vector2d(in.pose_M.x_m, in.pose_M.y_m);
    Drive(back, z_m_, "the way back from a spot aside", in.now_s);
    status_.state = YieldStatus::State::kReturning;
    status_.reason = passed_reason_ + ": returning to " + Point(way_M_.front());
  }
  const nav::NavigationStep step = navigation_->StepWaypoint(in.pose_M, in.now_s);
  if (step.failed) {
    has_goal_ = false;
    const bool returning = status_.state == YieldStatus::State::kReturning;
    DropGoal();
    const Eigen::Vector2d here(in.pose_M.x_m, in.pose_M.y_m);
    if (!returning && !way_M_.empty() && (here - way_M_.front()).norm() > kShortOfSpotM) {
      // Stopped short of the spot (the map there changed): it has left where it stood, so it waits here and
      // later returns along the part of the way it drove, as from the spot; the asking robot asks it again
      // if it is still in the way.
      way_M_ = WayTo(way_M_, here);
      status_.state = YieldStatus::State::kAside;
      status_.reason = "aside at " + Point(here) + ", short of the spot (" + step.reason + "), waiting for " +
                       passing_id_ + " to pass";
      aside_since_s_ = in.now_s;
      return Hold(in);
    }
    status_ = YieldStatus{returning ? YieldStatus::State::kNone : YieldStatus::State::kRefused, passing_id_,
                          (returning ? "could not return to " + Point(way_M_.front()) + ": "
                                     : "could not reach the spot aside: ") +
                              step.reason};
    refused_at_s_ = in.now_s;
    finished_ = true;  // the task it interrupted goes on from here (an idle robot stays where it is)
    ModeOutput out = Hold(in);
    out.done = true;
    return out;
  }
  if (step.arrived) {
    has_goal_ = false;
    if (status_.state == YieldStatus::State::kReturning) {
      return Finish("back at " + Point(way_M_.front()) + " after yielding to " + passing_id_, in);
    }
    status_.state = YieldStatus::State::kAside;
    status_.reason = "aside at " + Point(way_M_.back()) + ", waiting for " + passing_id_ + " to pass";
    aside_since_s_ = in.now_s;
    return Hold(in);
  }
  ModeOutput out;
  out.twist_B = Twist2{step.linear_x_mps, step.angular_z_radps};
  out.stamp = in.now;
  return out;
}

std::vector<Eigen::Vector3d> YieldRouteAhead(const nav::Navigation& navigation,
                                             const core::BaseState& pose_M) {
  if (!navigation.has_goal()) return {};
  const std::vector<Eigen::Vector3d>& path = navigation.global_plan().result.path_W;
  double length_m = 0.0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) length_m += (path[i + 1] - path[i]).head<2>().norm();
  return nav::PathAhead(path, {pose_M.x_m, pose_M.y_m}, std::max(1.0, length_m / 30.0), 31);
}

YieldAskInputs AskInputs(const YieldOptions& options, const std::string& mode,
                         const nav::Navigation& navigation, const core::BaseState& pose_M, double radius_m,
                         std::vector<Peer> peers,
                         std::function<std::shared_ptr<const nav::TraversabilityGrid>()> grid, double now_s) {
  YieldAskInputs in;
  if (!options.ask_peers || (mode != "waypoint" && mode != "explore") || peers.empty()) return in;
  in.pose_M = pose_M;
  in.radius_m = radius_m;
  in.route_M = YieldRouteAhead(navigation, pose_M);
  in.peers = std::move(peers);
  in.grid = std::move(grid);
  in.now_s = now_s;
  return in;
}

YieldSituation WithPeerAndHistory(YieldSituation situation, const YieldCommand& c,
                                  const std::vector<Peer>& peers, const YieldMode& yield, double now_s) {
  for (const Peer& p : peers) {
    if (p.robot_id == c.passing_id) situation.passing_yields_to_me = YieldsTo(p, situation.own_id);
  }
  situation.ended_lately = yield.EndedLately(c.passing_id, now_s);
  return situation;
}

namespace {

// The point of a route (a polyline, metres) nearest `p`: its distance from p, how far along the route it
// lies, and the route's direction there (unit; zero on a route of one point).
struct RoutePoint {
  double distance_m = std::numeric_limits<double>::infinity();
  double along_m = 0.0;
  Eigen::Vector2d direction = Eigen::Vector2d::Zero();
};
RoutePoint NearestOnRoute(const std::vector<Eigen::Vector2d>& route, const Eigen::Vector2d& p) {
  RoutePoint nearest;
  double s_along = 0.0;
  for (std::size_t i = 0; i + 1 < route.size(); ++i) {
    const Eigen::Vector2d ab = route[i + 1] - route[i];
    const double len = ab.norm();
    const double t = len > 1e-9 ? std::clamp((p - route[i]).dot(ab) / (len * len), 0.0, 1.0) : 0.0;
    const double d = (route[i] + t * ab - p).norm();
    if (d < nearest.distance_m) {
      nearest.distance_m = d;
      nearest.along_m = s_along + t * len;
      if (len > 1e-9) nearest.direction = ab / len;
    }
    s_along += len;
  }
  return nearest;
}

// The request `own_id` sends a peer in its way: let it pass, keeping clear its route (the first 32 points).
YieldCommand AskToPass(const std::string& own_id, std::uint32_t request_id, double radius_m,
                       const std::vector<Eigen::Vector2d>& route) {
  YieldCommand c;
  c.sender_id = own_id;
  c.request_id = request_id;
  c.passing_id = own_id;
  c.passing_radius_m = radius_m;
  for (std::size_t i = 0; i < route.size() && i < 32; ++i) c.keep_clear_M.push_back(route[i]);
  return c;
}

}  // namespace

// ---- YieldAsker -------------------------------------------------------------------------------------------

YieldAsker::YieldAsker(const YieldOptions& options, std::string own_id)
    : options_(Valid(options)), own_id_(std::move(own_id)) {
  if (own_id_.empty()) throw std::invalid_argument("YieldAsker: own id is empty");
}

YieldAsk YieldAsker::Update(const YieldAskInputs& in) {
  YieldAsk ask;
  const Eigen::Vector2d self(in.pose_M.x_m, in.pose_M.y_m);
  if (in.route_M.empty()) {
    status_ = YieldStatus{};
    return ask;
  }
  std::vector<Eigen::Vector2d> route = {self};
  for (const Eigen::Vector3d& q : in.route_M) route.emplace_back(q.head<2>());
  // The nearest peer on the route (within lookahead) that cannot be passed where it stands.
  std::shared_ptr<const nav::TraversabilityGrid> grid;  // fetched for the first peer on the route
  const Peer* blocker = nullptr;
  double blocker_s = std::numeric_limits<double>::infinity();
  for (const Peer& peer : in.peers) {
    if (std::abs(peer.pose_M.z_m - in.pose_M.z_m) > 1.0) continue;  // another level
    // Moving aside for this robot: wait for it. Aside (or on its way back) it is out of the way unless this
    // robot's route changed to pass within reach of its spot: then it is asked again (it moves on).
    const bool yielding_to_me =
        peer.yield_to_id == own_id_ && peer.yield_state == fleet::yield_state::kMovingAside;
    if (std::abs(peer.pose_M.v_mps) > 0.2 && !yielding_to_me)
      continue;  // it drives on: not parked in the way
    const Eigen::Vector2d p(peer.pose_M.x_m, peer.pose_M.y_m);
    const double pass_m = in.radius_m + peer.footprint_radius_m + options_.margin_m;
    const RoutePoint nearest = NearestOnRoute(route, p);
    if (nearest.distance_m >= pass_m || nearest.along_m > options_.lookahead_m ||
        nearest.along_m >= blocker_s) {
      continue;
    }
    if (!yielding_to_me) {
      if (!grid && in.grid) grid = in.grid();
      if (!grid || nav::CanPassBeside(*grid, p, nearest.direction, pass_m, in.radius_m, /*along_m=*/0.5))
        continue;
    }
    blocker = &peer;
    blocker_s = nearest.along_m;
  }
  if (blocker == nullptr) {
    if (status_.state != YieldStatus::State::kNone) status_ = YieldStatus{};
    return ask;
  }
  const Peer& peer = *blocker;
  const double gap_m = blocker_s - in.radius_m - peer.footprint_radius_m;
  const bool refused = peer.yield_to_id == own_id_ && peer.yield_state == fleet::yield_state::kRefused;
  const bool yielding = peer.yield_to_id == own_id_ && peer.yield_state == fleet::yield_state::kMovingAside;
  const auto asked = last_ask_s_.find(peer.robot_id);
  const double since_ask_s =
      asked == last_ask_s_.end() ? std::numeric_limits<double>::infinity() : in.now_s - asked->second;
  if (!yielding && since_ask_s >= (refused ? 5.0 : 1.0) * options_.ask_every_s) {
    ask.request = AskToPass(own_id_, next_request_id_++, in.radius_m, route);
    ask.to_id = peer.robot_id;
    last_ask_s_[peer.robot_id] = in.now_s;
  }
  if (refused) {
    status_ = YieldStatus{YieldStatus::State::kBlocked, peer.robot_id,
                          "blocked by " + peer.robot_id + " " + Fixed(blocker_s, 1) +
                              " m ahead in a passage too "
                              "narrow to pass; it refused to yield: " +
                              peer.yield_reason};
  } else if (yielding) {
    status_ = YieldStatus{YieldStatus::State::kAsking, peer.robot_id,
                          peer.robot_id + " is getting out of the way (" + peer.yield_state + ")"};
  } else if (status_.state != YieldStatus::State::kBlocked || status_.peer_id != peer.robot_id) {
    status_ = YieldStatus{YieldStatus::State::kAsking, peer.robot_id,
                          "asked " + peer.robot_id + ", " + Fixed(blocker_s, 1) +
                              " m ahead in a passage too narrow to pass, to get out of the way"};
  }
  if (yielding) {
    // It drives to its spot, possibly toward this robot (a bay between them): this robot keeps standoff_m
    // from the rest of its way, not only from where it is now.
    std::vector<Eigen::Vector2d> way = {Eigen::Vector2d(peer.pose_M.x_m, peer.pose_M.y_m)};
    for (const Eigen::Vector3d& q : peer.path_ahead_M) way.emplace_back(q.head<2>());
    const double to_way_m = nav::DistanceToPolyline(way, self) - in.radius_m - peer.footprint_radius_m;
    if (to_way_m < options_.standoff_m || gap_m < options_.standoff_m) ask.hold_reason = status_.reason;
  } else if (gap_m < options_.standoff_m) {
    ask.hold_reason = status_.reason;
  }
  return ask;
}

}  // namespace cairn::agent
