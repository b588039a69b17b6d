// Test-only (stepped_explore_team.h says why it is kept): one robot's autonomy stepped on the caller's clock,
// on the caller's thread, with no DDS: the components the
// agent runs on its threads (live obstacles, perception's map, the navigation map, the frontier search,
// navigation) fed from a core::PlatformIO the same way, and the agent's own modes (RobotModes: the mode
// tree and the mux over the mode modules, missions across interruptions, yields asked and asking) in the
// agent's order. For long scenarios that must run faster than real time (exploration coverage, several
// robots, benches): each capability's end-to-end test across real processes runs the agent itself.
//
// What differs from the agent: no command interface and no DDS (one operator holds the lock; a mission is
// started by a call, a peer's claim, state or yield request is handed in by the caller), the navigation map
// and the frontier search run inline at their period, and the caller waits in wall time for a plan computed
// on a worker (SteppedRobot::planning()) instead of the robot holding still meanwhile.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/agent_options.h"
#include "cairn/agent/modes/robot_modes.h"
#include "cairn/agent/services/live_obstacles.h"
#include "cairn/agent/services/nav_map.h"
#include "cairn/agent/services/navigation.h"
#include "cairn/agent/team/yield.h"
#include "cairn/core/platform_io.h"
#include "cairn/perception/perception_pipeline.h"

namespace cairn::agent {

/// See the file comment. Not thread-safe.
class SteppedRobot {
 public:
  /// `platform` is read and commanded at each Step(); its pose at time 0 centres the navigation map.
  /// `tree_file`: the mode tree (and its recovery trees) the agent would load ("" = the shipped
  /// config/mode_tree.xml). Goal and task ids count from 1 (deterministic runs).
  /// @throws std::invalid_argument for a null platform or invalid options (as the components throw);
  ///         bt::TreeError for a bad tree file.
  SteppedRobot(const AgentOptions& options, std::shared_ptr<core::PlatformIO> platform,
               const std::string& tree_file);

  /// Starts exploring `task` at `now_s`; "" or why not (CheckExploreTask).
  std::string Explore(const ExploreTask& task, double now_s);
  /// The mode running now (the mode tree's).
  std::string mode() const { return modes_->control().mode(); }
  /// Drives to (x_m, y_m) (frame M, metres) in waypoint mode, planned now on this thread; "" or why not (the
  /// plan's reason).
  std::string Goto(double x_m, double y_m, double now_s);
  /// Follows the robots `ahead_ids` (nearest first, the leader last) in convoy mode from `now_s` on; their
  /// states come through OnPeerState(). "" or why not (ConvoyMode::Start).
  std::string Follow(const std::vector<std::string>& ahead_ids, double now_s);
  /// One control cycle at `now_s` (seconds; cycles expected every 0.02 s): the platform's pose and scan,
  /// the map, at its period the navigation map and the frontier search, then the explore mode's twist to the
  /// platform (zero when not exploring).
  void Step(double now_s);
  /// True while a plan the next Step() needs is computed on a worker: the caller waits (wall time) before
  /// stepping on, so that results do not depend on the machine's speed.
  bool planning() const { return modes_->explore().planning() || modes_->missions().planning(); }

  /// Team exploration, as the agents do over DDS (ExploreTeam): ClaimToSend() is the claim this robot sends
  /// at `now_s` if one is due (with its seen floor when that is due too); OnPeerClaim() takes a peer's, heard
  /// at `now_s` ("" or why it was refused). The peers' live claims and coverage feed the next choice and
  /// search.
  std::optional<ExploreClaim> ClaimToSend(double now_s);
  std::string OnPeerClaim(const ExploreClaim& claim, double now_s) { return team_.OnPeerClaim(claim, now_s); }
  /// Peers, as the agents do over cairn/peer_state (PeerTracker): PeerState() is this robot as its peers see
  /// it after the last Step() (Navigation::AsPeer; mode "explore" while exploring, else "idle");
  /// OnPeerState() takes a peer's, heard at `now_s` ("" or why it was dropped). Peers heard within
  /// options.peers.timeout_s are obstacles from the next Step() on, as in the agent.
  PeerBody PeerState() const { return modes_->AsPeer(pose_M_); }
  /// Get-out-of-the-way, as the agents do over cairn/yield_request (YieldCoordination): YieldRequestToSend()
  /// is the request this robot's last Step() made (to the robot named first), if any; OnYieldRequest() takes
  /// a peer's at `now_s` (sent by the robot it names as sender, whose states this robot hears): "" when the
  /// robot now moves aside, else why not. A yield that ends by itself hands back the mission it interrupted
  /// (MissionResumption) or leaves an idle robot where it stood.
  std::optional<std::pair<std::string, YieldCommand>> YieldRequestToSend() {
    return modes_->yielding().TakeRequestToSend();
  }
  std::string OnYieldRequest(const YieldCommand& request, double now_s);
  const YieldMode& yield() const { return modes_->yield(); }
  std::string OnPeerState(const PeerBody& peer, double now_s) { return peers_.OnPeerState(peer, now_s); }
  /// The target this robot holds now (none: none).
  std::optional<nav::PeerClaim> OwnClaim(double now_s) const { return modes_->explore().OwnClaim(now_s); }
  const ExploreTeam& team() const { return team_; }

  const ExploreMode& explore() const { return modes_->explore(); }
  const WaypointMode& waypoint() const { return modes_->waypoint(); }
  const ConvoyMode& convoy() const { return modes_->convoy(); }
  const RobotModes& modes() const { return *modes_; }
  const NavMap& nav_map() const { return *nav_map_; }
  const Navigation& navigation() const { return *navigation_; }
  const perception::PerceptionPipeline& perception() const { return *perception_; }
  /// Seconds spent in the frontier searches so far, and their number (benches).
  double frontier_search_s() const { return frontier_search_s_; }
  int frontier_searches() const { return frontier_searches_; }
  /// Wall time spent so far, seconds: the platform (pose, lidar), perception (live obstacles, map), the
  /// navigation map updates and the explore mode's steps (navigation) — where a long run's time goes.
  struct Timing {
    double platform_s = 0, perception_s = 0, nav_map_s = 0, explore_s = 0;
  };
  const Timing& timing() const { return timing_; }
  /// True when the platform reported contact with occupied space at any step.
  bool ever_in_contact() const { return ever_in_contact_; }

 private:
  // The mode tree's facts now: one operator holds the lock; localization as the platform reports it.
  ModeConditions Conditions() const;
  // The platform's pose and scan, the live obstacles and the map, at its period the navigation map and the
  // frontier search.
  void StepPerception(double now_s);

  AgentOptions options_;
  // The modes' clock: the time of the last Step() (0 before the first).
  std::shared_ptr<core::SimulatedClock> clock_ = std::make_shared<core::SimulatedClock>();
  std::shared_ptr<core::PlatformIO> platform_;
  std::unique_ptr<perception::PerceptionPipeline> perception_;
  std::shared_ptr<nav::GlobalPlanner> planner_;
  std::unique_ptr<NavMap> nav_map_;
  std::unique_ptr<Navigation> navigation_;
  std::unique_ptr<LiveObstacles> live_obstacles_;
  std::unique_ptr<RobotModes> modes_;
  core::LidarScan scan_;
  std::vector<Eigen::Vector3f> points_B_;
  double next_map_update_s_ = 0.0;
  ExploreTeam team_;
  PeerTracker peers_;
  core::BaseState pose_M_;              // at the last Step()
  bool localized_ = true;               // the platform's pose estimate is healthy
  double now_s_ = 0.0;                  // the last Step()'s
  std::uint64_t mission_commands_ = 0;  // the operator's commands so far (Explore, Goto, Follow)
  double frontier_search_s_ = 0.0;
  int frontier_searches_ = 0;
  bool ever_in_contact_ = false;
  Timing timing_;
};

}  // namespace cairn::agent
