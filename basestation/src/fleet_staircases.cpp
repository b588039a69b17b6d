#include "cairn/base/fleet_staircases.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

namespace cairn::base {

namespace {

using perception::MatchStaircases;
using perception::Staircase;
using perception::StaircaseMatch;

constexpr std::size_t kMostReports = 1'000'000;

bool IsUsable(const Staircase& s) {
  return s.p_W_first_step.allFinite() && std::isfinite(s.yaw_rad) && std::isfinite(s.rise_m) &&
         std::isfinite(s.run_m) && std::isfinite(s.width_m) && std::isfinite(s.confidence) &&
         s.num_steps >= 1 && s.rise_m > 0 && s.run_m > 0 && s.width_m > 0;
}

std::string Point(const Eigen::Vector3d& p) {
  char text[96];
  std::snprintf(text, sizeof(text), "(%.2f, %.2f, %.2f)", p.x(), p.y(), p.z());
  return text;
}

}  // namespace

bool FleetStaircasesOptions::IsValid(std::string* why) const {
  std::string inner;
  if (!same_staircase.IsValid(&inner)) {
    if (why != nullptr) *why = "FleetStaircasesOptions.same_staircase: " + inner;
    return false;
  }
  if (max_reports < 1 || max_reports > kMostReports) {
    if (why != nullptr) {
      *why = "FleetStaircasesOptions.max_reports = " + std::to_string(max_reports) + " is not in [1, " +
             std::to_string(kMostReports) + "]";
    }
    return false;
  }
  return true;
}

FleetStaircases::FleetStaircases(FleetStaircasesOptions options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

std::vector<StaircaseChange> FleetStaircases::Report(const std::string& robot_id, std::uint32_t staircase_id,
                                                     const Staircase& staircase, std::string* refused) {
  std::vector<StaircaseChange> changes;
  if (refused != nullptr) refused->clear();
  if (!IsUsable(staircase)) {
    if (refused != nullptr)
      *refused = "a field is not finite, or num_steps, rise, run or width is not positive";
    return changes;
  }
  const std::pair<std::string, std::uint32_t> robot_key{robot_id, staircase_id};
  auto it = current_.find(robot_key);
  if (it != current_.end()) {
    Kept& kept = reports_.at(it->second);
    const bool same_session = staircase.support_points >= kept.staircase.support_points;
    if (same_session && MatchStaircases(kept.staircase, staircase, options_.same_staircase).same) {
      kept.staircase = staircase;  // The robot refined its estimate: same staircase, same fleet id.
      Refresh(kept.fleet_id, &changes);
      return changes;
    }
    if (same_session) {
      // The robot now places this staircase elsewhere: nobody reports the old place through it any more.
      const double moved_m = (staircase.p_W_first_step - kept.staircase.p_W_first_step).norm();
      char moved[32];
      std::snprintf(moved, sizeof(moved), "%.2f", moved_m);
      Drop(it->second,
           robot_id + " now places its staircase " + std::to_string(staircase_id) + " at " +
               Point(staircase.p_W_first_step) + ", " + moved + " m away, and no other report holds it",
           &changes);
    } else {
      kept.current = false;  // Kept: the staircase was seen in the robot's earlier session.
    }
    current_.erase(it);
  }
  if (reports_.size() >= options_.max_reports) {
    auto oldest =
        std::find_if(reports_.begin(), reports_.end(), [](const auto& r) { return !r.second.current; });
    if (oldest == reports_.end()) {
      if (refused != nullptr) *refused = std::to_string(reports_.size()) + " staircase reports already kept";
      return changes;
    }
    const Kept& gone = oldest->second;
    Drop(oldest->first,
         "its last report (" + gone.robot_id + "'s staircase " + std::to_string(gone.staircase_id) +
             ", from before " + gone.robot_id + " restarted) made room for a newer one (at most " +
             std::to_string(options_.max_reports) + " reports are kept)",
         &changes);
  }
  const std::uint64_t key = next_key_++;
  Kept& kept = reports_[key];
  kept.robot_id = robot_id;
  kept.staircase_id = staircase_id;
  kept.staircase = staircase;
  current_[robot_key] = key;
  Place(key, &changes);
  return changes;
}

void FleetStaircases::Place(std::uint64_t key, std::vector<StaircaseChange>* changes) {
  Kept& kept = reports_.at(key);
  // Every fleet staircase this report matches: the best first (largest overlap, then the oldest).
  std::vector<std::pair<double, int>> matched;
  for (const auto& [id, fleet] : fleet_) {
    const StaircaseMatch m = MatchStaircases(fleet.entry.staircase, kept.staircase, options_.same_staircase);
    if (m.same) matched.emplace_back(m.overlap, id);
  }
  std::stable_sort(matched.begin(), matched.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  if (matched.empty()) {
    const int id = next_id_++;
    Fleet& fleet = fleet_[id];
    fleet.entry.id = id;
    fleet.reports.push_back(key);
    kept.fleet_id = id;
    Estimate(&fleet);
    StaircaseChange change;
    change.kind = StaircaseChange::Kind::kNew;
    change.staircase = fleet.entry;
    changes->push_back(change);
    return;
  }
  int id = matched[0].second;
  fleet_.at(id).reports.push_back(key);
  kept.fleet_id = id;
  Estimate(&fleet_.at(id));
  // One report on several fleet staircases: they are one flight (e.g. its upper and lower part, seen apart).
  for (std::size_t i = 1; i < matched.size(); ++i) {
    if (fleet_.count(matched[i].second) > 0 && matched[i].second != id)
      id = Merge(id, matched[i].second, changes);
  }
  Refresh(id, changes);
}

void FleetStaircases::Drop(std::uint64_t key, const std::string& reason,
                           std::vector<StaircaseChange>* changes) {
  const int id = reports_.at(key).fleet_id;
  reports_.erase(key);
  auto it = fleet_.find(id);
  if (it == fleet_.end()) return;
  Fleet& fleet = it->second;
  fleet.reports.erase(std::remove(fleet.reports.begin(), fleet.reports.end(), key), fleet.reports.end());
  if (fleet.reports.empty()) {
    StaircaseChange change;
    change.kind = StaircaseChange::Kind::kRemoved;
    change.staircase = fleet.entry;
    change.reason = reason;
    changes->push_back(change);
    fleet_.erase(it);
    return;
  }
  Refresh(id, changes);
}

void FleetStaircases::Refresh(int id, std::vector<StaircaseChange>* changes) {
  Estimate(&fleet_.at(id));
  // Merging only ever lowers the number of fleet staircases: this ends.
  for (;;) {
    const Staircase& estimate = fleet_.at(id).entry.staircase;
    int best = 0;
    double best_overlap = 0;
    for (const auto& [other, fleet] : fleet_) {
      if (other == id) continue;
      const StaircaseMatch m = MatchStaircases(estimate, fleet.entry.staircase, options_.same_staircase);
      if (m.same && m.overlap > best_overlap) {
        best_overlap = m.overlap;
        best = other;
      }
    }
    if (best == 0) return;
    id = Merge(id, best, changes);
  }
}

int FleetStaircases::Merge(int a, int b, std::vector<StaircaseChange>* changes) {
  const int kept_id = std::min(a, b);
  const int gone_id = std::max(a, b);
  Fleet& kept = fleet_.at(kept_id);
  for (const std::uint64_t key : fleet_.at(gone_id).reports) {
    kept.reports.push_back(key);
    reports_.at(key).fleet_id = kept_id;
  }
  fleet_.erase(gone_id);
  Estimate(&kept);
  StaircaseChange change;
  change.kind = StaircaseChange::Kind::kMerged;
  change.staircase = kept.entry;
  change.merged_id = gone_id;
  changes->push_back(change);
  return kept_id;
}

void FleetStaircases::Estimate(Fleet* fleet) const {
  std::vector<Staircase> views;
  std::vector<std::string> sources;
  for (const std::uint64_t key : fleet->reports) {
    const Kept& kept = reports_.at(key);
    views.push_back(kept.staircase);
    if (std::find(sources.begin(), sources.end(), kept.robot_id) == sources.end())
      sources.push_back(kept.robot_id);
  }
  fleet->entry.staircase = perception::MergeStaircaseViews(views, options_.same_staircase);
  fleet->entry.sources = std::move(sources);
  fleet->entry.detections = static_cast<int>(fleet->reports.size());
}

std::vector<perception::StaircaseRegistry::Entry> FleetStaircases::Entries() const {
  std::vector<perception::StaircaseRegistry::Entry> entries;
  entries.reserve(fleet_.size());
  for (const auto& [id, fleet] : fleet_) entries.push_back(fleet.entry);
  return entries;
}

}  // namespace cairn::base
