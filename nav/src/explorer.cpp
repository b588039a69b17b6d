// Copyright Cairn authors.
#include "cairn/nav/explorer.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "option_range.h"

namespace cairn::nav {

bool ExplorerOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  auto range = [&msg](const char* field, double value, double lo, double hi, bool lo_open) {
    return internal::InOptionRange(msg, "ExplorerOptions", field, value, lo, hi, lo_open);
  };
  const bool ok = range("switch_utility_ratio", switch_utility_ratio, 1, 100, false) &&
                  range("follow_radius_m", follow_radius_m, 0, 10, true) &&
                  range("blacklist_radius_m", blacklist_radius_m, 0, 20, true) &&
                  range("visited_radius_m", visited_radius_m, 0, 20, true);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

Explorer::Explorer(ExplorerOptions options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

bool Explorer::Barred(const Eigen::Vector2d& target_M) const {
  for (const FailedTarget& f : failed_) {
    if ((f.target_M - target_M).norm() <= options_.blacklist_radius_m) return true;
  }
  return false;
}

bool Explorer::Visited(const Eigen::Vector2d& target_M) const {
  for (const Eigen::Vector2d& v : visited_) {
    if ((v - target_M).norm() <= options_.visited_radius_m) return true;
  }
  return false;
}

ExplorerDecision Explorer::Decide(const FrontierSet& set) {
  ExplorerDecision decision;
  const FrontierCluster* best = nullptr;
  const FrontierCluster* followed = nullptr;
  int candidates = 0;
  int unreachable = 0;
  int barred = 0;
  int visited = 0;
  for (const FrontierCluster& c : set.clusters) {
    if (!c.reachable()) {
      ++unreachable;
      continue;
    }
    if (Barred(c.target_M)) {
      ++barred;
      continue;
    }
    if (Visited(c.target_M)) {
      ++visited;
      continue;
    }
    ++candidates;
    if (best == nullptr || c.utility > best->utility) best = &c;
    if (current_ && (c.target_M - current_->target_M).norm() <= options_.follow_radius_m &&
        (followed == nullptr ||
         (c.target_M - current_->target_M).norm() < (followed->target_M - current_->target_M).norm())) {
      followed = &c;
    }
  }
  if (best == nullptr) {
    std::ostringstream why;
    why << "exploration complete: no reachable frontier";
    if (unreachable > 0 || barred > 0 || visited > 0) {
      why << " (" << unreachable << " seen but unreachable, " << barred << " given up on, " << visited
          << " reached but still unseen beyond)";
    }
    decision.kind = ExplorerDecision::Kind::kComplete;
    decision.reason = why.str();
    current_.reset();
    return decision;
  }
  if (followed != nullptr && !(best->utility > options_.switch_utility_ratio * followed->utility)) {
    decision.kind = ExplorerDecision::Kind::kKeep;
    decision.target = *followed;
    decision.reason = "the current frontier is still the one to explore (" + std::to_string(candidates) +
                      " reachable)";
  } else {
    decision.kind = ExplorerDecision::Kind::kGoTo;
    decision.target = *best;
    decision.reason = followed != nullptr
                          ? "a frontier " + std::to_string(best->utility / followed->utility).substr(0, 4) +
                                " times as worth it as the current one"
                          : "best of " + std::to_string(candidates) + " reachable frontiers";
  }
  current_ = decision.target;
  return decision;
}

void Explorer::Reached() {
  if (!current_) return;
  visited_.push_back(current_->target_M);
  current_.reset();
}

void Explorer::Fail(const std::string& reason) {
  if (!current_) return;
  failed_.push_back(FailedTarget{current_->target_M, reason});
  current_.reset();
}

}  // namespace cairn::nav
