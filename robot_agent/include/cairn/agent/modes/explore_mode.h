// Explore mode (Sriganesh et al. 2024, § Behavior Tree and Mux: exploration, the top level of
// sliding autonomy): the robot maps the unknown by itself. Frontiers of its own navigation map
// (nav::FindFrontiers, run on the map's thread after each update and handed in with OnFrontiers()) feed the
// target choice (nav::Explorer); each target is driven as a waypoint goal through navigation, with the
// waypoint recovery tree when navigation gives up; a target that still fails is barred with its reason.
// Exploration ends by itself when no reachable frontier is left ("exploration complete: no reachable frontier
// ...") and the robot goes idle.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <functional>
#include <future>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/modes/mode_module.h"
#include "cairn/agent/modes/waypoint_recovery.h"
#include "cairn/agent/team/explore_claims.h"
#include "cairn/nav/explorer.h"
#include "cairn/nav/frontier.h"
#include "cairn/nav/navigation.h"

namespace cairn::agent {

/// What to explore (explore R [--region X0,Y0,X1,Y1] [--z-range Z0,Z1]).
struct ExploreTask {
  /// Only frontiers inside this x-y box (metres, frame M); none (the default) = everywhere.
  std::optional<Eigen::AlignedBox2d> region_M;
  /// Only frontiers whose ground lies in [min_z_m, max_z_m] (metres, frame M; a floor); default: every
  /// height.
  double min_z_m = -std::numeric_limits<double>::infinity();
  double max_z_m = std::numeric_limits<double>::infinity();
  /// No basestation heard for this long while exploring -> the robot ends the exploration and drives back to
  /// its start by itself (the agent does; SubT robots returned to comms), seconds; 0 = never (the default).
  double home_after_silence_s = 0.0;
};

/// Why `task` cannot be explored as sent ("" when it can): a region corner that is not finite, a region with
/// x0 >= x1 or y0 >= y1, a NaN height bound, min_z_m >= max_z_m, home_after_silence_s not in [0, 86400].
/// Names the field and the value.
std::string CheckExploreTask(const ExploreTask& task);

/// How an exploration stands (RobotState.explore_*).
enum class ExplorationState {
  kNone,       ///< never started
  kExploring,  ///< running
  kComplete,   ///< ended by itself: no reachable frontier left
  kFailed,     ///< ended by itself otherwise (no map around the robot, in contact with occupied space)
  kStopped,    ///< ended by the operator or a mode switch
};
const char* ToString(ExplorationState state);

/// The exploration record: the one running, or the last one and how it ended.
struct ExplorationStatus {
  uint32_t task_id = 0;  ///< robot-assigned; 0 = none yet
  ExplorationState state = ExplorationState::kNone;
  std::string reason;  ///< how it ended ("exploration complete: ..."), or what it is doing now
  ExploreTask task;
  int frontier_clusters = 0;    ///< clusters in the latest frontier set (reachable or not)
  int reachable_frontiers = 0;  ///< of which reachable
  double explored_m2 = 0.0;     ///< known-free ground of the map in the task's region and height band, m²
  bool has_target = false;      ///< a frontier is being driven to
  Eigen::Vector2d target_M = Eigen::Vector2d::Zero();  ///< its target, metres, frame M
  double target_z_m = 0.0;                             ///< its ground height, metres, frame M
  double target_gain_m2 = 0.0;                         ///< unknown area behind it, m²
  int targets_reached = 0;
  int targets_failed = 0;
  int peers = 0;              ///< exploring peers heard within their claims' lease (ExploreTeam)
  double peer_seen_m2 = 0.0;  ///< floor the peers have seen (their coverage), m²
  double started_s = 0.0;     ///< agent clock, seconds
  bool active() const { return state == ExplorationState::kExploring; }
};

/// Options of ExploreMode (from AgentOptions, config section `explore`).
struct ExploreModeOptions {
  std::string robot_id;            ///< names the robot in log lines
  double channel_timeout_s = 0.5;  ///< the explore channel's staleness, seconds, (0, 60]
  double contact_timeout_s = 1.0;  ///< in contact longer than this -> exploration fails, seconds, > 0
  nav::FrontierOptions frontiers;  ///< frontier search (the task's region and heights are set per task)
  nav::ExplorerOptions explorer;   ///< target choice
  ExploreTeamOptions team;         ///< claims and coverage shared with peers (ExploreTeam)
  /// A frontier target counts as reached within this of it (navigation's arrival radius), metres, (0, 3].
  double target_tolerance_m = 0.6;
  /// After a target is reached or fails, the next choice waits for a frontier set computed at least this
  /// long after (the map has taken in what the robot sees from there), seconds, [0, 10].
  double settle_s = 1.0;
  /// "Exploration complete" is declared only from a frontier set computed at least this long after the robot
  /// stopped for good (it holds still meanwhile), seconds, [0, 30]: what it sees from where it ended needs
  /// perception's confirmation first (a staircase becomes a map prior, which a flight whose treads the lidar
  /// cannot see needs to read traversable, after two detections at the detector's 1 s period).
  double complete_settle_s = 3.0;
  /// No usable frontier set (no map around the robot) this long after the start -> exploration fails,
  /// seconds, (0, 600].
  double map_wait_s = 15.0;
  /// A target reached only through a tight gap (nav::FrontierCluster::through_tight_gap) is given up, with no
  /// recovery, when the robot moves less than 0.5 m in this long (its goal's stall timeout, see
  /// Navigation::AcceptGoal()), seconds, (0, 600]: such a gap may be narrower than the robot (the map's cells
  /// cannot tell), and the robot has other frontiers to go for meanwhile (navigation's own stall_timeout_s,
  /// 60 s by default, cost 3 min of a 15 min run on geb079). A second such stall within 0.5 m of the last is
  /// the robot wedged, not the gap: the waypoint recovery runs (back up, turn) as for any failed goal.
  double tight_gap_stall_s = 20.0;
  uint32_t first_task_id = 1;  ///< id of the first task (drawn at random by the agent), >= 1
  /// Which levels of the robot's map hold frontiers (config `explore.levels`: auto, main, all).
  enum class Levels {
    kAuto,  ///< every level when the platform climbs stairs (platform_max_step_m >= kStairRiseM), else main
    kMain,  ///< the level the robot drives on (nav::FindFrontiers on the map's main level)
    kAll,   ///< every level (nav::FindFrontiersMultiLevel): the stairs and the floors they lead to
  };
  Levels levels = Levels::kAuto;
  /// A stair rise a platform must climb for kAuto to explore every level, metres (a building's rise is
  /// 0.15-0.20 m; the legged profile climbs 0.30, the wheeled one 0.15).
  static constexpr double kStairRiseM = 0.18;
  /// The platform's highest step (nav::PlatformProfile::traversability.max_step_m), metres, [0, 10]: the
  /// agent sets it from its platform.
  double platform_max_step_m = 0.0;
  /// True when frontiers are searched on every level (see Levels).
  bool EveryLevel() const {
    return levels == Levels::kAll || (levels == Levels::kAuto && platform_max_step_m >= kStairRiseM);
  }

  /// @return false and sets `*why` (field, value, rule) when a field is invalid.
  bool IsValid(std::string* why) const;
};

/// The explore mode module. Not thread-safe (the agent calls it under its lock, on its control thread).
class ExploreMode : public ModeModule {
 public:
  static constexpr const char* kName = "explore";
  static constexpr const char* kChannel = "explore";

  /// `navigation` (not owned) outlives this; `recovery` runs when navigation gives up on a target (null or
  /// not enabled = the target fails at once). @throws std::invalid_argument for a null navigation or invalid
  /// options.
  ExploreMode(ExploreModeOptions options, nav::Navigation* navigation,
              std::unique_ptr<WaypointRecovery> recovery);
  ~ExploreMode() override;

  /// Starts exploring `task` (checked with CheckExploreTask) at `now_s`, then `enter_mode` asks the mode tree
  /// for this mode with the task in place. Refused (the reason is the tree's failed condition, or the
  /// task's fault): the previous record is kept. Accepted: any previous exploration is replaced. Returns the
  /// reason when refused, "" when accepted. `resume_task_id` != 0: a paused exploration goes on under its id
  /// (MissionKeeper), else a new id is drawn.
  std::string Start(const ExploreTask& task, double now_s, const std::function<ModeDecision()>& enter_mode,
                    uint32_t resume_task_id = 0);
  /// A paused exploration `task_id` (not running) that will not be resumed ends as stopped with `reason`.
  void EndPaused(uint32_t task_id, const std::string& reason);

  /// The frontier search the map thread should run now (the task's region and heights), while exploring.
  std::optional<nav::FrontierOptions> frontier_search() const;
  /// True when that search covers every level of the map (ExploreModeOptions::EveryLevel()).
  bool every_level() const { return options_.EveryLevel(); }
  /// A frontier set of the robot's map computed at `computed_at_s` (agent clock): the newest is used at the
  /// next Step().
  void OnFrontiers(nav::FrontierSet set, double computed_at_s);

  /// The live claims of the other exploring robots (their ExploreClaim, expired ones left out), used at the
  /// next choice: a frontier a peer claimed first is left to it.
  void SetPeerClaims(std::vector<nav::PeerClaim> claims) { peer_claims_ = std::move(claims); }
  /// The team as heard, for the status: `peers` exploring peers, `peer_seen_m2` of floor they have seen.
  void SetTeamView(int peers, double peer_seen_m2) {
    status_.peers = peers;
    status_.peer_seen_m2 = peer_seen_m2;
  }
  /// This robot's claim at `now_s` (agent clock): its target and how long it has held it; none without one.
  std::optional<nav::PeerClaim> OwnClaim(double now_s) const;

  const ExplorationStatus& status() const { return status_; }
  /// True while exploring (the tree's HasExploreTask).
  bool exploring() const { return status_.active(); }
  /// True while a plan this mode waits for runs on a worker: a target's plan (the robot holds still), a
  /// recovery attempt's, or navigation's replan. A simulated clock waits for it (RobotAgent::planning()), so
  /// that a run does not depend on how busy the machine is.
  bool planning() const;
  /// The target choice (its failed and reached targets).
  const nav::Explorer& explorer() const { return explorer_; }

  /// Ends the exploration, if one runs: stopped with `why`.
  void Deactivate(const std::string& why) override;
  ModeOutput Step(const ModeInputs& in) override;
  /// In contact with occupied space longer than contact_timeout_s: the exploration fails, done.
  ModeOutput OnPlatformStatus(const core::PlatformStatus& status, const ModeInputs& in) override;
  bool uses_local_planner() const override { return true; }

 private:
  // The level of the target being planned or driven for the planner (metres, frame M): NaN for one on the
  // main level (FrontierCluster::on_main_level).
  double goal_z_m_ = std::numeric_limits<double>::quiet_NaN();
  // Ends the exploration with `state` and `reason`, dropping the target.
  void Finish(ExplorationState state, const std::string& reason);
  // Drops the target being planned or driven (navigation's goal, the recovery).
  void DropTarget();
  // A target ended (reached, or failed with `reason`): the explorer learns it; the next choice waits.
  void EndTarget(bool reached, const std::string& reason, double now_s);
  // Applies the newest frontier set: complete, keep, or plan a new target.
  void Choose(const core::BaseState& pose_M, double now_s, ModeOutput* out);

  ExploreModeOptions options_;
  nav::Navigation* navigation_;
  std::unique_ptr<WaypointRecovery> recovery_;
  nav::Explorer explorer_;
  ExplorationStatus status_;
  uint32_t next_task_id_;
  std::vector<nav::PeerClaim> peer_claims_;
  std::optional<nav::FrontierSet> frontiers_;  // newest set not used yet
  double frontiers_at_s_ = -1e9;
  double settle_until_s_ = -1e9;   // no choice from a set computed before this
  bool complete_pending_ = false;  // the last set had no target: confirm with the next one, at rest
  std::future<nav::GlobalPlan> plan_;
  bool driving_ = false;           // navigation (or the recovery) holds the target as its goal
  std::uint64_t goal_serial_ = 0;  // Navigation::goal_serial() of that goal (DropTarget clears only it)
  bool target_through_tight_gap_ = false;  // the current target's FrontierCluster::through_tight_gap
  // Where the last tight-gap stall happened (NaN: none yet); a second one within kWedgedRadiusM runs the
  // recovery.
  static constexpr double kWedgedRadiusM = 0.5;
  Eigen::Vector2d last_tight_stall_M_ = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  ContactTimer contact_;  // the task's contact with occupied space
};

/// The claim `mode`'s robot sends at `now_s` (ExploreTeam::ClaimDue: every claim_period_s while exploring, at
/// once on a new target, once when it stops), recorded with team.Sent(); none when nothing is due. When the
/// coverage is due too, `coverage` (may be empty) gives the robot's seen floor (nav::SeenCoverage of its
/// navigation map; none: not ready, sent next time).
std::optional<ExploreClaim> DueClaim(const ExploreMode& mode, ExploreTeam& team, double now_s,
                                     const std::function<std::optional<nav::CoverageBitmap>()>& coverage);

}  // namespace cairn::agent
