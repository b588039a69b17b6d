// The robot's last known safe state on disk: who held its control lock, its mode, the waypoint
// goal it was driving, its pose estimate and a snapshot of its map. Written atomically (temporary file,
// fsync, rename, fsync of the folder) whenever it changes, so that a robot restarted after a crash
// (cairn_agent
// --resume, or --supervise / systemd doing it) comes up idle with its lock, its map and its old goal offered,
// never resumed by itself.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace cairn::agent {

/// One journal record. Frames and units as in RobotState: metres, radians, map frame M.
struct JournalEntry {
  std::string robot_id;
  std::string holder_id;  ///< basestation holding the control lock, "" = free
  std::string mode;       ///< the active mode ("idle", "waypoint", ...)
  bool has_goal = false;  ///< a waypoint goal was being driven
  uint32_t goal_id = 0;
  double goal_x_m = 0.0, goal_y_m = 0.0;
  double goal_z_m = std::numeric_limits<double>::quiet_NaN();  ///< NaN: the robot's level
  double goal_tolerance_m = 0.0;                               ///< 0: navigation's default
  double x_m = 0.0, y_m = 0.0, z_m = 0.0, yaw_rad = 0.0;       ///< pose estimate, frame M
  std::string map_file;  ///< map snapshot (OctoMap .bt) in the journal's folder, "" = none yet

  /// Equal in everything but the pose.
  bool SameStateAs(const JournalEntry& other) const;
};

/// The journal file of folder `dir` ("<dir>/journal.json").
std::string JournalFile(const std::string& dir);

/// Reads `dir`'s journal: nullopt when there is none. @throws std::invalid_argument naming the file, the
/// field and the value when it is not a journal of robot `robot_id` (malformed JSON, a missing or non-finite
/// field, an id that is not one, another robot's journal, a map file that does not exist).
std::optional<JournalEntry> ReadJournal(const std::string& dir, const std::string& robot_id);

/// Writes journal entries and map snapshots on a thread of its own, so that the control loop never waits for
/// a disk: Submit() hands over the latest entry, and the thread writes it when it differs from the last one
/// written (its state, or its pose by more than 0.25 m or 0.2 rad, or 5 s after a pose change). Every
/// `map_every_s` it also saves a map snapshot through `save_map(path)` (write-then-rename), then refers to
/// it.
class JournalWriter {
 public:
  /// Creates `dir` when missing. @throws std::invalid_argument naming --journal and the folder when it cannot
  /// be created or written; `map_every_s` must be > 0 (finite) when `save_map` is set.
  JournalWriter(std::string dir, double map_every_s, std::function<void(const std::string& path)> save_map);
  ~JournalWriter();  ///< writes the last entry submitted, then stops
  JournalWriter(const JournalWriter&) = delete;
  JournalWriter& operator=(const JournalWriter&) = delete;

  /// The robot's state now (any thread; cheap).
  void Submit(const JournalEntry& entry);
  /// Entries written so far (tests).
  int writes() const;

 private:
  void Loop();
  void WriteEntry(JournalEntry entry);  // on the thread

  const std::string dir_;
  const double map_every_s_;
  const std::function<void(const std::string&)> save_map_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::optional<JournalEntry> pending_;
  bool stop_ = false;
  int writes_ = 0;
  std::optional<JournalEntry> written_;  // thread only
  double written_at_s_ = -1e9;           // thread only, steady seconds
  std::string map_file_;                 // thread only
  std::thread thread_;
};

}  // namespace cairn::agent
