// The operator commands and peer requests a robot receives and the replies it gives, as plain C++ (no DDS):
// the DDS adapter (AgentDds) turns the wire messages (idl/cairn_msgs.idl: ControlRequest, ModeRequest,
// WaypointGoal, StopRequest, TeleopTwist, AgentInfo, PathRequest) addressed to this robot into these, and
// CommandReply and PathAnswer into a CommandResponse and a PathResponse. The command interface
// (CommandInterface) applies the commands; the planning service (PlanningService) answers path queries.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "cairn/agent/modes/explore_mode.h"
#include "cairn/agent/modes/mode_module.h"

namespace cairn::agent {

/// Who sent a command: the operator (base id, owner of the lock), the process and the writer.
struct CommandSender {
  std::string base_id;      ///< the operator's basestation id, e.g. "opA"
  std::string participant;  ///< core::ParticipantIdOf the sending writer: the process
  std::string writer;  ///< core::WriterIdOf the sending writer: retries share it, other processes never do
};

/// Kind of a command (CommandResponse.kind).
enum class CommandKind : uint32_t {
  kControlRequest,
  kControlRelease,
  kMode,
  kWaypoint,
  kStop,
  kExplore,
  kHome,
  kRestart,
  kConvoy,
  kControlHandover,
  kControlDeny
};
/// Outcome of a command (CommandResponse.result).
enum class CommandResult {
  kAccepted,   ///< control granted or released, mode switched, goal accepted, stopped
  kDenied,     ///< refused: the reason says why
  kDiscarded,  ///< the sender does not hold the control lock: counted, not executed
};

/// What a control command does with the lock (ControlRequest.action).
enum class ControlAction {
  kRequest,   ///< request-control R: take it when free, else ask its holder (left pending)
  kRelease,   ///< release R: give it back (the robot stops)
  kHandover,  ///< grant R B / handover R B: the holder gives it to B, the robot's mode and goal kept
  kDeny,      ///< deny R B: the holder refuses B's pending request
};

/// request-control / release / grant / deny / handover.
struct ControlCommand {
  CommandSender sender;
  uint32_t request_id = 0;  ///< the writer's request id
  ControlAction action = ControlAction::kRequest;
  /// Non-empty: the message holds a value no basestation sends (e.g. an unknown action), named with the
  /// value; the command is refused with it and nothing else is read.
  std::string malformed;
  /// kHandover: the basestation id the lock goes to; kDeny: the one whose request is refused.
  std::string target_base_id;
};

/// mode R MODE.
struct ModeCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  std::string mode;  ///< the mode asked for, as the operator typed it
};

/// restart R COMPONENT: restart one component of the agent (the holder's only).
struct RestartCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  std::string component;  ///< as the operator typed it (core::HealthMonitor names)
};

/// stop R: an e-stop, honoured from any basestation.
struct StopCommand {
  CommandSender sender;
  uint32_t request_id = 0;
};

/// goto R X Y: a waypoint goal, as received (checked by CheckGoal()).
struct GoalCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  std::string frame_id;  ///< must be "map"
  double x_m = 0.0;      ///< goal point, frame M, metres
  double y_m = 0.0;
  double tolerance_m = 0.0;  ///< arrival radius, metres, [0, 5]; 0 = navigation's default
  /// Level: the walkable surface at (x_m, y_m) nearest this height, metres, frame M; NaN = the robot's level.
  double z_m = std::numeric_limits<double>::quiet_NaN();
  /// kWaypoint (goto) or kHome (home R: the point is the robot's start or the one named), for the reply.
  CommandKind kind = CommandKind::kWaypoint;
};

/// home R [POINT]: as received (HomeRequest). Without a point, the robot's start.
struct HomeCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  std::string frame_id;  ///< must be "map"
  bool has_point = false;
  double x_m = 0.0;  ///< metres, frame M (has_point)
  double y_m = 0.0;
  double z_m = std::numeric_limits<double>::quiet_NaN();  ///< its level; NaN = the robot's
};

/// Why `goal` cannot be driven as sent ("" when it can): a frame other than "map", a point that is not
/// finite, a tolerance outside [0, 5] m, an infinite level z_m. Each names the field and value.
std::string CheckGoal(const GoalCommand& goal);

/// explore R [--region X0,Y0,X1,Y1] [--z-range Z0,Z1]: as received (ExploreRequest; checked by
/// CheckExploreTask()).
struct ExploreCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  std::string frame_id;  ///< must be "map"
  ExploreTask task;
};

/// convoy L R1 R2 ... / convoy-stop / peel, as one follower receives it (ConvoyRequest): follow `ahead_ids`
/// (nearest first, the leader last) or leave the convoy. Checked by ConvoyMode::Start.
struct ConvoyCommand {
  CommandSender sender;
  uint32_t request_id = 0;
  bool stop = false;                   ///< true: leave the convoy (idle)
  std::vector<std::string> ahead_ids;  ///< !stop: the robots ahead, nearest first
  /// Non-empty: the message holds a value no basestation sends (an unknown action), named with the value.
  std::string malformed;
};

/// The operator's stick (TeleopTwist), best effort; no reply.
struct TeleopCommand {
  std::string base_id;
  OperatorTwist twist_B;  ///< may be non-finite as received: the command interface drops those
};

/// A basestation process announced itself (AgentInfo of kind basestation).
struct BaseAnnouncement {
  std::string writer;         ///< core::WriterIdOf its agent-info writer
  std::string participant;    ///< core::ParticipantIdOf that writer
  std::string base_id;        ///< the id it announced
  bool has_joystick = false;  ///< it advertises the "joystick" capability
};

/// A change of an agent-info writer's liveliness (from Fast DDS's LivelinessChangedStatus).
struct WriterLiveliness {
  std::string writer;      ///< core::WriterIdOf the writer
  bool lost = false;       ///< core::IsLivelinessLoss: its lease lapsed or it left
  bool unmatched = false;  ///< it is gone for good (forget it)
  bool regained = false;   ///< alive again
};

/// The answer to one command (CommandResponse on the wire, where the adapter adds the robot id).
struct CommandReply {
  std::string base_id;                ///< the sender's base id
  std::string requester_participant;  ///< the sender's process: others with the same base id ignore the reply
  uint32_t request_id = 0;
  CommandKind kind = CommandKind::kControlRequest;
  CommandResult result = CommandResult::kDenied;
  std::string reason;                    ///< why refused or discarded; what was done when accepted
  std::string holder_id;                 ///< the lock's holder after the command ("" = free)
  std::string mode;                      ///< the mode after the command
  uint32_t goal_id = 0;                  ///< the accepted goal's id (waypoint commands), task id (explore)
  std::vector<std::string> valid_modes;  ///< the operator's valid actions now
  bool goal_acceptable = false;          ///< a goal would be accepted now
};

/// What the robot did with a command it carried out (a goal once planned).
struct CommandOutcome {
  bool accepted = false;
  std::string reason;    ///< why refused; when accepted, what was done (e.g. "path 26.0 m, ETA 26 s")
  uint32_t goal_id = 0;  ///< the goal's id when accepted
};

/// A peer's path query (PathRequest): the global planner service, answered by a PathAnswer.
struct PathQuery {
  std::string participant;   ///< core::ParticipantIdOf the asking process: the answer is addressed to it
  uint32_t request_id = 0;   ///< unique per requester
  std::string requester_id;  ///< agent id of the asker
  std::string frame_id;      ///< must be "map"
  Eigen::Vector2d start_M = Eigen::Vector2d::Zero();  ///< metres, frame M
  Eigen::Vector2d goal_M = Eigen::Vector2d::Zero();   ///< metres, frame M
  std::string platform;  ///< plan for this platform's limits; "" = the robot's own
};

/// The answer to a PathQuery (PathResponse on the wire, frame "map", where the adapter adds the robot id).
struct PathAnswer {
  uint32_t request_id = 0;
  std::string requester_id;
  std::string requester_participant;
  bool success = false;
  std::string status;  ///< A* status ("kSuccess", "kUnreachable", ...), "kInvalidFrame", "kUnknownPlatform",
                       ///< "kRateLimited"
  std::string reason;  ///< why not, naming the value at fault ("" on success)
  std::vector<Eigen::Vector3d> path_M;  ///< N x 3, metres, frame M, z = ground height
  double length_m = 0.0;
  uint64_t map_version = 0;
  double planning_time_s = 0.0;
};

}  // namespace cairn::agent
