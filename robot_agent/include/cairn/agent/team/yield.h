// Get-out-of-the-way (Sriganesh et al. 2024, § Advanced Multi-agent Coordination): a robot whose
// route is blocked by a peer in a passage too narrow to pass asks that peer to yield (YieldAsker), and a peer
// asked (by a robot, or by an operator's `yield R`) that is idle or in a yieldable mode drives to the nearest
// spot on its own map that clears the other's route (nav::FindYieldSpot: a side passage, a junction's arm, a
// wide spot), waits there until the other has passed, and then returns to where it stood (an idle robot) or
// hands back to its task (YieldMode; the agent resumes the waypoint goal or the exploration). A robot in
// manual control (or any mode outside the policy, YieldOptions::modes) refuses and says why; the asking robot
// then holds before the peer and reports itself blocked, with the reason.
//
// Messages: cairn/yield_request (YieldRequest; YieldCommand here) from the asking robot or a basestation; the
// answer rides on the asked robot's PeerState and RobotState (yield_state, yield_to_id / yield_peer_id,
// yield_reason), which both operators see.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/modes/mode_module.h"
#include "cairn/agent/team/peers.h"
#include "cairn/nav/navigation.h"
#include "cairn/nav/traversability.h"
#include "cairn/nav/yield_spot.h"

namespace cairn::agent {

/// Options of get-out-of-the-way (config section `yield`).
struct YieldOptions {
  /// The modes in which this robot yields when asked (the policy). Never "manual" or "smart_joystick" (an
  /// operator drives the robot) nor "yield"; names [a-z0-9_]+.
  std::vector<std::string> modes = {"idle", "waypoint", "explore"};
  /// True: a robot blocked by a peer in a narrow passage asks it to yield.
  bool ask_peers = true;
  /// A spot clears the passing robot's route by both footprint radii plus this, metres, (0, 2]; a robot can
  /// pass a peer where there is that much room beside it.
  double margin_m = 0.5;
  /// Longest drive to a spot, metres, (0, 200].
  double max_drive_m = 30.0;
  /// A yielding robot returns after this long aside even if the other has not passed, seconds, (0, 3600].
  double max_wait_s = 120.0;
  /// Peers this far along the robot's route are checked for blocking it, metres, (0, 16] (PeerState carries
  /// 16 m of route).
  double lookahead_m = 8.0;
  /// A robot waiting for a peer to yield holds this far before the peer's body, metres, (0, 10].
  double standoff_m = 1.5;
  /// A request not answered is sent again after this long, seconds, (0, 60]; after a refusal, after 5 times
  /// as long (the peer's operator may put it in a yieldable mode meanwhile).
  double ask_every_s = 2.0;

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// Parses a policy's list of modes ("idle waypoint explore", spaces or commas between names) into `*modes`.
/// "" or why not (the field `yield.modes`, the value; manual and smart_joystick are refused).
std::string ParseYieldModes(const std::string& text, std::vector<std::string>* modes);

/// A yield request as the robot asked receives it (YieldRequest).
struct YieldCommand {
  std::string sender_id;  ///< the asking robot, or a basestation for its operator
  std::uint32_t request_id = 0;
  std::string passing_id;         ///< the robot to let pass
  double passing_radius_m = 0.3;  ///< its footprint radius, metres, (0, 5]
  /// Its route from where it is (the first point), metres, frame M; 1..32 points.
  std::vector<Eigen::Vector2d> keep_clear_M;
};

/// "" when `c` can be acted on, else why not, naming the field and value.
std::string CheckYieldCommand(const YieldCommand& c);

/// DecideYield()'s answer: accepted with the spot, or refused with the reason.
struct YieldDecision {
  bool accepted = false;
  nav::YieldSpot spot;       ///< accepted: where to stand aside and the way there
  double clearance_m = 0.0;  ///< the spot's clearance asked for: both footprint radii + margin, metres
  std::string refusal;       ///< !accepted: why, for the asking robot and both operators
  /// !accepted and not to be shown as a refusal: the passing robot is itself getting out of this robot's way
  /// (its state may lag by a peer period; it asks again if it still needs to).
  bool ignore = false;
};

/// Where a robot stands in a yield (RobotState::yield_state; the first four also PeerState::yield_state).
struct YieldStatus {
  enum class State {
    kNone,
    kMovingAside,  ///< asked: driving to the spot
    kAside,        ///< asked: at the spot, waiting for the other to pass
    kReturning,    ///< asked: driving back to where it stood
    kRefused,      ///< asked: refused (policy, no spot); shown for kRefusalShownS
    kAsking,       ///< asking: a peer blocks its route; asked it, or it is getting out of the way
    kBlocked,      ///< asking: the peer refused (or does not answer); holding before it
  };
  State state = State::kNone;
  std::string peer_id;  ///< the other robot
  std::string reason;   ///< what it does and where, or why refused / blocked
};

const char* ToString(YieldStatus::State state);

/// True when `peer`'s state says it is getting out of `robot_id`'s way (moving aside, aside or returning).
bool YieldsTo(const Peer& peer, const std::string& robot_id);

/// What the robot asked to yield is doing when the request comes (DecideYield()).
struct YieldSituation {
  std::string own_id;
  std::string mode;                               ///< its mode now ("idle" when it has no task)
  core::BaseState pose_M;                         ///< frame M
  double radius_m = 0.3;                          ///< its footprint radius, metres
  const nav::TraversabilityGrid* grid = nullptr;  ///< its traversability grid; null: no map
  YieldStatus asking;                             ///< its own asking status (YieldAsker::status())
  bool passing_yields_to_me = false;  ///< the passing robot's peer state says it yields to this robot
  std::string ended_lately;           ///< YieldMode::EndedLately() for the passing robot
};

/// The policy on a checked request `c`: refused in a mode outside options.modes (manual control and smart
/// joystick named as such); while an operator's ending of the last yield for that robot is recent
/// (situation.ended_lately); when the passing robot is already getting out of this robot's way; when the two
/// robots asked each other (head-on in a tunnel), by the one with the smaller id, unless the other already
/// refused it (so that exactly one gives way); or when no spot clears the passing robot's route within
/// options.max_drive_m on the robot's grid (nav::FindYieldSpot's reason).
YieldDecision DecideYield(const YieldOptions& options, const YieldCommand& c,
                          const YieldSituation& situation);

/// The robot asked to yield: drives to the spot, waits there until the passing robot has passed, and returns
/// to where it stood (or ends there, for the agent to resume its task). Not thread-safe (the agent calls it
/// under its lock, on its control thread).
class YieldMode : public ModeModule {
 public:
  static constexpr const char* kName = "yield";
  static constexpr const char* kChannel = "yield";
  /// A refusal stays in the robot's state this long, seconds (the asking robot asks again meanwhile).
  static constexpr double kRefusalShownS = 10.0;
  /// The passing robot not heard for this long counts as gone (passed, or out of radio range), seconds.
  static constexpr double kUnheardS = 10.0;
  /// A robot that cannot reach its spot aside but has moved this far from where it stood, metres, waits
  /// where it stopped (and returns from there) instead of ending the yield.
  static constexpr double kShortOfSpotM = 0.25;

  /// `navigation` (not owned) outlives this. @throws std::invalid_argument for a null navigation or invalid
  /// options.
  YieldMode(const YieldOptions& options, double channel_timeout_s, nav::Navigation* navigation);

  /// Starts standing aside for `command` at `spot` (found on this robot's map, spot.found) from `pose_M`
  /// (frame M) at `now_s`. `return_home`: drive back to where it stood once the other has passed (an idle
  /// robot); else the mode ends at the spot (the agent resumes the robot's task). `spot_clearance_m`: how far
  /// the passing robot's route must stay from the robot's way to the spot and back for it to count as passed.
  void Start(const YieldCommand& command, const nav::YieldSpot& spot, const core::BaseState& pose_M,
             double spot_clearance_m, bool return_home, double now_s);
  /// While aside for `command`'s passing robot, which asks again with a route that now comes within the
  /// clearance of the spot (its route changed): moves on to `spot` (found from where it stands), keeping the
  /// way back to where it first stood. False (nothing changes) when not aside for that robot, or when the
  /// spot is still clear of the new route.
  bool MoveOn(const YieldCommand& command, const nav::YieldSpot& spot, double now_s);
  /// True while aside for `command`'s passing robot at a spot within the clearance of its route (MoveOn()).
  bool InTheWayOf(const YieldCommand& command) const;
  /// Refuses `passing_id` with `why` at `now_s` (the state shows it for kRefusalShownS).
  void Refuse(const std::string& passing_id, const std::string& why, double now_s);
  /// The peers heard lately (PeerTracker::Live()) at `now_s`: the passing robot's progress; a refusal
  /// expires.
  void SetPeers(const std::vector<Peer>& peers, double now_s);
  /// Leaves the yield (an operator's stop or mode switch): the goal is dropped, no task is resumed.
  void Deactivate(const std::string& why) override;
  /// A yield for `passing_id` ended by Deactivate() (an operator's stop or mode switch) less than
  /// kEndedHoldOffS before `now_s`: why it is not taken up again yet, else "". The robot's operator took
  /// over; a robot asking right away would otherwise undo that.
  std::string EndedLately(const std::string& passing_id, double now_s) const;
  static constexpr double kEndedHoldOffS = 30.0;
  /// One control cycle: a navigation step to the spot or back, or held at rest at the spot. `done` when back
  /// (or at the spot without return_home, or the way failed).
  ModeOutput Step(const ModeInputs& in) override;
  bool uses_local_planner() const override { return true; }

  const YieldStatus& status() const { return status_; }
  /// True while moving aside, aside or returning.
  bool active() const;
  /// True once after a yield ended by itself (the other passed, or the way there or back failed; not a
  /// Deactivate): the agent resumes the task it interrupted.
  bool TakeFinished();
  /// The robot the current (or last) yield was for.
  const std::string& passing_id() const { return passing_id_; }

 private:
  ModeOutput Hold(const ModeInputs& in) const;
  ModeOutput Finish(const std::string& reason, const ModeInputs& in);
  void Drive(const std::vector<Eigen::Vector2d>& way_M, double z_m, const std::string& what, double now_s);
  void DropGoal();

  YieldOptions options_;
  nav::Navigation* navigation_;
  YieldStatus status_;
  std::string passing_id_;
  std::vector<Eigen::Vector2d> way_M_;  // from where it stood to the spot
  double z_m_ = 0.0;
  double clearance_m_ = 0.9;
  bool return_home_ = true;
  bool finished_ = false;
  double aside_since_s_ = 0.0;
  double last_heard_s_ = 0.0;
  double refused_at_s_ = 0.0;
  bool passed_ = false;  // SetPeers: the passing robot has passed (or is gone, or the wait is over)
  // Deactivate(): the yield ended early, for whom and why; stamped by the next SetPeers() (no clock there).
  std::string ended_for_, ended_why_;
  double ended_at_s_ = -1.0;
  std::string passed_reason_;
  bool has_goal_ = false;
  std::uint64_t goal_serial_ = 0;
};

/// The route a robot asks peers to keep clear of: its global path from where it stands (`pose_M`, frame M)
/// to the goal, in at most 31 points at least 1 m apart (the whole way, not only the next metres a peer state
/// carries: a spot beyond those may still be on it). Empty without a goal.
std::vector<Eigen::Vector3d> YieldRouteAhead(const nav::Navigation& navigation,
                                             const core::BaseState& pose_M);

/// What YieldAsker::Update() reads, once per control cycle of a robot driving a goal.
struct YieldAskInputs {
  core::BaseState pose_M;  ///< the robot, frame M
  double radius_m = 0.3;   ///< its footprint radius, metres
  /// Its route ahead from where it is, frame M (YieldRouteAhead()); empty: no route.
  std::vector<Eigen::Vector3d> route_M;
  std::vector<Peer> peers;  ///< heard lately (PeerTracker::Live())
  /// Its traversability grid (the passage's width), fetched only when a peer is on the route; null: no peer
  /// counts as blocking.
  std::function<std::shared_ptr<const nav::TraversabilityGrid>()> grid;
  double now_s = 0.0;
};

/// YieldAsker::Update()'s inputs for a robot in `mode` at `pose_M` (frame M) of footprint `radius_m`: empty
/// (nothing asked, nothing held) unless options.ask_peers, the mode drives a goal (waypoint, explore) and a
/// peer is heard; only then is the route taken from `navigation` (YieldRouteAhead: not every control cycle).
YieldAskInputs AskInputs(const YieldOptions& options, const std::string& mode,
                         const nav::Navigation& navigation, const core::BaseState& pose_M, double radius_m,
                         std::vector<Peer> peers,
                         std::function<std::shared_ptr<const nav::TraversabilityGrid>()> grid, double now_s);

/// `situation` with what the passing robot's state and this robot's last yield say: passing_yields_to_me
/// (YieldsTo, from `peers`: PeerTracker::Live()) and ended_lately (yield.EndedLately()).
YieldSituation WithPeerAndHistory(YieldSituation situation, const YieldCommand& c,
                                  const std::vector<Peer>& peers, const YieldMode& yield, double now_s);

/// YieldAsker::Update()'s answer.
struct YieldAsk {
  std::optional<YieldCommand> request;  ///< to send now to `to_id`
  std::string to_id;
  /// Non-empty: the robot holds where it is (Navigation::SetHold) and this says why.
  std::string hold_reason;
};

/// The asking side: finds the nearest peer that blocks the robot's route where the passage is too narrow to
/// pass it (nav::CanPassBeside), asks it to yield, and holds the robot standoff_m before it until it is out
/// of the way; while it moves aside, standoff_m from the rest of its way too (PeerState's path: a bay
/// between the two robots must stay free for it). Not thread-safe.
class YieldAsker {
 public:
  /// @throws std::invalid_argument for invalid options or an empty id.
  YieldAsker(const YieldOptions& options, std::string own_id);
  /// See YieldAsk. An empty route (no goal) resets the status.
  YieldAsk Update(const YieldAskInputs& in);
  const YieldStatus& status() const { return status_; }

 private:
  YieldOptions options_;
  std::string own_id_;
  YieldStatus status_;
  std::uint32_t next_request_id_ = 1;
  std::map<std::string, double> last_ask_s_;  // by peer
};

}  // namespace cairn::agent
