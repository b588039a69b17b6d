// The basestation's perception view of the fleet: the merged fleet map built from every robot's map
// telemetry, the latest camera frame of each robot, and the fleet's staircases (Sriganesh et al. 2024,
// "Command Interface": downsampled map and camera streams to the operator).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/base/fleet_staircases.h"
#include "cairn/core/time.h"
#include "cairn/perception/map_telemetry.h"
#include "cairn/perception/staircase.h"
#include "cairn_msgs.h"

namespace cairn::core {
class Participant;
}

namespace cairn::base {

/// Latest camera frame of one robot.
struct CameraView {
  cairn_msgs::CompressedImage frame;  ///< JPEG bytes in frame.data()
  core::SteadyTime received{};
  std::uint64_t frames_received = 0;
  std::uint64_t frames_missed = 0;  ///< gaps in the frame counter (dropped under load or lost)
};

/// Something the operator should be told about once (printed by the shell between commands).
struct FleetEvent {
  /// "staircase" (a new fleet staircase) | "staircase_merged" (two fleet staircases were one flight: the
  /// younger id merged into the older) | "staircase_removed" (no robot reports it any more); see
  /// FleetStaircases.
  std::string kind;
  std::string message;  ///< one line for people, e.g. "new staircase 2: 5 steps at (50.00, ...), seen by r1"
  /// The fleet staircase, frame M: "staircase" the new one; "staircase_merged" the one kept, after the merge;
  /// "staircase_removed" its last estimate.
  perception::StaircaseRegistry::Entry staircase;
  int merged_id = 0;   ///< "staircase_merged": the id merged away (never used again); 0 otherwise
  std::string reason;  ///< "staircase_removed": why, in operator words; "" otherwise
};

/// Outcome of FleetPerception::SaveMap().
struct MapSaveResult {
  bool ok = false;
  std::string error;         ///< why not ok (names the robot, path or reason)
  std::size_t voxels = 0;    ///< known coarse voxels written
  std::size_t occupied = 0;  ///< of which occupied
  double resolution_m = 0;   ///< coarse voxel edge
};

/// One line for people: "5 steps at (50.00, 23.72, 0.00) heading 0 deg, rise 0.201 m, run 0.500 m, width
/// 2.38 m, seen by r1, r2".
std::string DescribeStaircase(const perception::StaircaseRegistry::Entry& entry);

/// The operator's event for one change among the fleet staircases: kind, message and fields as FleetEvent
/// documents them. Messages: "new staircase 2: <DescribeStaircase>", "staircase 3 merged into staircase 2
/// (same flight): <DescribeStaircase of the merged one>", "staircase 2 removed: <reason> (was
/// <DescribeStaircase>)".
FleetEvent StaircaseEvent(const StaircaseChange& change);

/// A robot's staircase detection as the basestation takes it (frame M = the fleet's map frame): its robot id
/// (core::CheckId) and every field checked, finite and within its physical range (position within 1e5 m of
/// the origin, rise (0, 1] m, run (0, 2] m, width (0, 20] m, 1-500 steps, confidence [0, 1]).
/// @return false, with *why naming the field, its value and the range, when the detection is refused.
bool StaircaseFromMessage(const cairn_msgs::StaircaseDetection& m, perception::Staircase* staircase,
                          std::string* why);

/// DDS readers and writers of the perception topics on a basestation's participant, and the fleet model
/// built from them. Thread-safe. Malformed map updates are dropped and counted (FleetMapStats::drops),
/// never applied.
class FleetPerception {
 public:
  /// @throws core::DdsError when an entity cannot be created.
  FleetPerception(core::Participant& participant, const std::string& base_id);
  ~FleetPerception();
  FleetPerception(const FleetPerception&) = delete;
  FleetPerception& operator=(const FleetPerception&) = delete;

  /// A robot's agent info arrived (once per robot session), announcing the voxel edge of the map it sends
  /// (`map_resolution_m`, metres; 0 or less: none, perception off): restart its map stream and ask it for a
  /// snapshot (late joiners, restarted robots). A robot without a map is never asked.
  void OnRobotSeen(const std::string& robot_id, double map_resolution_m);
  /// A robot is back from lost: if it sends a map, as OnRobotSeen (a restored link lost its deltas).
  void OnRobotBack(const std::string& robot_id);
  /// Asks `robot_id`, if it sends a map, for a snapshot again (at most once a second) while its map here has
  /// no base: a request written before the robot's reader matched (a link just restored) is lost, and a robot
  /// standing still sends no delta that would reveal the gap.
  void SyncIfIncomplete(const std::string& robot_id);

  /// Saves the coarse map of `target` (a robot id, or "fleet" for the merged map) as an OctoMap .bt. A robot
  /// whose map is incomplete (joined late, missed a delta) is asked for a snapshot and waited for up to
  /// `sync_timeout_s`. Fails with a reason for an unknown robot, an empty map or an unwritable path.
  MapSaveResult SaveMap(const std::string& target, const std::string& path, double sync_timeout_s);

  /// Waits up to `timeout_s` until the map of `robot_id` is complete (has a base, no snapshot pending).
  bool WaitForMapSync(const std::string& robot_id, double timeout_s);

  /// Latest frame of `robot_id`, if any.
  std::optional<CameraView> LatestFrame(const std::string& robot_id) const;
  /// Waits up to `timeout_s` for a frame of `robot_id` received after the first `after_received` (counted by
  /// arrival, not by the robot's frame counter, which restarts with the robot).
  std::optional<CameraView> WaitForFrame(const std::string& robot_id, std::uint64_t after_received,
                                         double timeout_s) const;

  /// Fleet staircases in id order: every robot's latest estimates merged (same staircase seen by several
  /// robots = one), frame M. An id names one staircase for good (FleetStaircases): kept as robots refine it,
  /// retired when it merges into an older one or is removed, never reused.
  std::vector<perception::StaircaseRegistry::Entry> Staircases() const;

  /// Events not yet taken, oldest first.
  std::vector<FleetEvent> TakeEvents();

  perception::FleetMapStats MapStats() const;
  /// The merged fleet map's known coarse voxels (occupied and free), frame map; see perception::FleetMap.
  std::vector<perception::CoarseVoxel> MapVoxels() const;
  /// The fleet map's coarse voxel edge, metres; 0 until a robot's map arrived.
  double MapResolution() const;
  /// false if no map message of `robot_id` was accepted yet.
  bool RobotMapStats(const std::string& robot_id, perception::RobotMapStats* out) const;

  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace cairn::base
