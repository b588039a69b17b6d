// The fleet's staircases as a basestation keeps them: every robot's latest estimate of each of its
// staircases, merged into fleet staircases whose ids an operator can rely on ("staircase 2" in the console,
// the GUI and every event). Pure logic, no DDS; FleetPerception feeds it the robots' cairn/staircase
// detections.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "cairn/perception/staircase.h"

namespace cairn::base {

/// One change among the fleet's staircases that the operator is told about, once.
struct StaircaseChange {
  enum class Kind {
    kNew,     ///< a report matched no fleet staircase: a new one, with an id never used before
    kMerged,  ///< two fleet staircases turned out to be one flight: the younger id merged into the older one
    kRemoved  ///< no robot reports the staircase any more
  };
  Kind kind = Kind::kNew;
  /// kNew: the new staircase; kMerged: the one kept, as it is after the merge; kRemoved: its last estimate.
  /// Frame M (the fleet's map frame), metres.
  perception::StaircaseRegistry::Entry staircase;
  /// kMerged: the id merged away (retired: never used again); 0 otherwise.
  int merged_id = 0;
  /// kRemoved: why, in operator words (the robot and its staircase id, what it reports now); "" otherwise.
  std::string reason;
};

/// Options of FleetStaircases.
struct FleetStaircasesOptions {
  /// When two estimates are the same staircase (StaircaseRegistry's same-staircase rule).
  perception::StaircaseRegistryOptions same_staircase;
  /// Most robot reports kept: one per (robot, robot's staircase id), plus those from a robot's earlier
  /// session; range [1, 1e6].
  std::size_t max_reports = 4096;

  /// True when every field is in range; otherwise false and, if `why` is not null, a message naming the
  /// field, its value and the rule.
  bool IsValid(std::string* why) const;
};

/// The fleet's staircases with ids that each name one staircase for good. Not thread-safe (one owner, e.g.
/// FleetPerception under its lock).
///
/// Reports. A robot numbers its own staircases (perception::StaircaseRegistry) and publishes its latest
/// estimate of each; the latest one per (robot, staircase id) is a report. A robot's update that still
/// matches its report (the same-staircase rule) revises the report in place. An update with fewer scans
/// merged than the report had comes from a new session of the robot (a restarted robot numbers its
/// staircases from 1 again): the report is kept as one from the robot's earlier session (the staircase was
/// seen; a restart is no sign it is gone) and the update becomes a new report. An update that no longer
/// matches, with as many scans or more, is the robot placing that staircase elsewhere: the report is
/// replaced.
///
/// Fleet staircases and their ids. Each report belongs to one fleet staircase, whose estimate is its reports
/// merged afresh (perception::MergeStaircaseViews, each report once, so a robot's repeated updates do not
/// outweigh another robot's view). A new report joins the fleet staircase whose estimate it matches best
/// (largest footprint overlap) and leaves its id as it is; one that matches none is a new fleet staircase
/// with the next id never used (from 1). When one report matches several fleet staircases, or a fleet
/// staircase's estimate comes to match another's, they are one flight: the younger merges into the older
/// (lower) id, which keeps every report, and the younger id is retired. A fleet staircase whose last report
/// is replaced or dropped is removed and its id retired. So an id never moves to another staircase and is
/// never reused.
///
/// Bounded: at most max_reports reports (and so fleet staircases). A report beyond that (a new robot and
/// staircase id, or a new session's report beside the earlier one) displaces the oldest report from an
/// earlier session (possibly the one just kept), or is refused when there is none.
class FleetStaircases {
 public:
  /// @throws std::invalid_argument with the message of FleetStaircasesOptions::IsValid() if `options` is
  ///         invalid.
  explicit FleetStaircases(FleetStaircasesOptions options = {});

  /// Robot `robot_id`'s latest estimate of its staircase `staircase_id`: `staircase` in frame M, its
  /// support_points the number of scans the robot merged into it. A staircase with a non-finite field,
  /// num_steps < 1 or a non-positive rise, run or width is refused.
  /// @param refused if not null: set to why the report was not kept, "" when it was.
  /// @return what changed for the operator, in the order it happened (a new staircase; merges; a removal).
  std::vector<StaircaseChange> Report(const std::string& robot_id, std::uint32_t staircase_id,
                                      const perception::Staircase& staircase, std::string* refused = nullptr);

  /// The fleet staircases in id order. Each entry's staircase is the merged estimate (frame M; its
  /// support_points: the scans its reports merged), sources the robots whose reports it holds (in order of
  /// their first report), detections the number of reports.
  std::vector<perception::StaircaseRegistry::Entry> Entries() const;

  /// Number of reports kept, [0, max_reports].
  std::size_t reports() const { return reports_.size(); }

  const FleetStaircasesOptions& options() const { return options_; }

 private:
  struct Kept {
    std::string robot_id;
    std::uint32_t staircase_id = 0;
    bool current = true;  // false: from the robot's earlier session
    perception::Staircase staircase;
    int fleet_id = 0;
  };
  struct Fleet {
    perception::StaircaseRegistry::Entry entry;
    std::vector<std::uint64_t> reports;  // keys of reports_, in the order they joined
  };

  // Places report `key` (not yet in a fleet staircase) into the fleet staircases it matches, or a new one.
  void Place(std::uint64_t key, std::vector<StaircaseChange>* changes);
  // Takes report `key` out of its fleet staircase and forgets it; the fleet staircase goes if it was its last
  // report (`reason` then says why).
  void Drop(std::uint64_t key, const std::string& reason, std::vector<StaircaseChange>* changes);
  // Re-estimates fleet staircase `id`, then merges into one every fleet staircase its estimate now matches.
  void Refresh(int id, std::vector<StaircaseChange>* changes);
  // Merges fleet staircases `a` and `b` into the older; returns the id kept.
  int Merge(int a, int b, std::vector<StaircaseChange>* changes);
  void Estimate(Fleet* fleet) const;

  FleetStaircasesOptions options_;
  std::map<std::uint64_t, Kept> reports_;                                   // by arrival: oldest first
  std::map<std::pair<std::string, std::uint32_t>, std::uint64_t> current_;  // (robot, its id) -> report
  std::map<int, Fleet> fleet_;
  std::uint64_t next_key_ = 1;
  int next_id_ = 1;
};

}  // namespace cairn::base
