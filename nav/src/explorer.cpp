// Copyright Cairn authors.
#include "cairn/nav/explorer.h"

#include <algorithm>
#include <cmath>
#include <limits>
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
                  range("visited_radius_m", visited_radius_m, 0, 20, true) &&
                  range("claim_radius_m", claim_radius_m, 0, 50, true) &&
                  range("retry_after_s", retry_after_s, 0, 3600, false) &&
                  range("peer_influence_m", peer_influence_m, 0, 200, false) &&
                  range("same_place_dz_m", same_place_dz_m, 0, 10, true);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

Explorer::Explorer(ExplorerOptions options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw std::invalid_argument(why);
}

bool Explorer::SamePlace(const FrontierCluster& a, const Eigen::Vector2d& b_M, double b_z_m,
                         double radius_m) const {
  return (a.target_M - b_M).norm() <= radius_m &&
         std::abs(a.target_ground_z_m - b_z_m) <= options_.same_place_dz_m;
}

Explorer::Bar Explorer::Barred(const FrontierCluster& c, double now_s) const {
  Bar bar = Bar::kNone;
  for (const FailedTarget& f : failed_) {
    if (!SamePlace(c, f.target_M, f.target_ground_z_m, options_.blacklist_radius_m)) continue;
    if (f.failures >= 2) return Bar::kForGood;
    if (now_s - f.failed_at_s < options_.retry_after_s) bar = Bar::kUntilRetry;
  }
  return bar;
}

bool Explorer::Visited(const FrontierCluster& c) const {
  for (const Eigen::Vector3d& v : visited_) {
    if (SamePlace(c, v.head<2>(), v.z(), options_.visited_radius_m)) return true;
  }
  return false;
}

bool Explorer::ClaimedByPeer(const FrontierCluster& c, bool is_current, const TeamView& team,
                             std::string* by) const {
  const double mine_s = is_current ? HeldS(team.now_s) : 0.0;
  for (const PeerClaim& claim : team.claims) {
    if (claim.robot_id == team.own_id) continue;
    if ((claim.target_M - c.target_M).norm() > options_.claim_radius_m) continue;
    if (!is_current) {  // a peer's claim, however fresh, is the peer's: a robot never takes a claimed
                        // frontier
      *by = claim.robot_id;
      return true;
    }
    const bool older = claim.held_s > mine_s + 0.5;
    const bool tie = std::abs(claim.held_s - mine_s) <= 0.5 && claim.robot_id < team.own_id;
    if (older || tie) {
      *by = claim.robot_id;
      return true;
    }
  }
  return false;
}

ExplorerDecision Explorer::Decide(const FrontierSet& set, const TeamView& team) {
  // Coordination (Burgard et al., "Coordinated Multi-Robot Exploration", IEEE T-RO 21(3), 2005): what a peer
  // will see from its target is worth less here, so the team spreads out. Utility scaled by the distance to
  // the nearest peer claim over peer_influence_m (linear, within it).
  std::vector<FrontierCluster> clusters = set.clusters;
  if (options_.peer_influence_m > 0) {
    for (FrontierCluster& c : clusters) {
      double nearest = std::numeric_limits<double>::infinity();
      for (const PeerClaim& claim : team.claims) {
        if (claim.robot_id != team.own_id) nearest = std::min(nearest, (claim.target_M - c.target_M).norm());
      }
      if (nearest < options_.peer_influence_m)
        c.utility *= std::max(0.05, nearest / options_.peer_influence_m);
    }
  }
  return Choose(Classify(clusters, team), team);
}

Explorer::Tally Explorer::Classify(const std::vector<FrontierCluster>& clusters, const TeamView& team) const {
  Tally t;
  for (const FrontierCluster& c : clusters) {
    if (!c.reachable()) {
      ++t.unreachable;
      continue;
    }
    const bool is_current =
        current_ && SamePlace(c, current_->target_M, current_->target_ground_z_m, options_.follow_radius_m);
    if (const Bar bar = Barred(c, team.now_s); bar != Bar::kNone) {
      ++t.barred;
      std::string by;
      if (bar == Bar::kUntilRetry && !Visited(c) && !ClaimedByPeer(c, is_current, team, &by) &&
          (t.retry == nullptr || c.utility > t.retry->utility)) {
        t.retry = &c;
      }
      continue;
    }
    if (Visited(c)) {
      ++t.visited;
      continue;
    }
    if (std::string by; ClaimedByPeer(c, is_current, team, &by)) {
      ++t.claimed;
      if (std::find(t.claimers.begin(), t.claimers.end(), by) == t.claimers.end()) t.claimers.push_back(by);
      continue;
    }
    ++t.candidates;
    if (t.best == nullptr || c.utility > t.best->utility) t.best = &c;
    if (is_current && (t.followed == nullptr || (c.target_M - current_->target_M).norm() <
                                                    (t.followed->target_M - current_->target_M).norm())) {
      t.followed = &c;
    }
  }
  return t;
}

ExplorerDecision Explorer::Choose(const Tally& t, const TeamView& team) {
  ExplorerDecision decision;
  if (t.best == nullptr && t.claimed > 0) {
    std::ostringstream why;
    why << "every reachable frontier (" << t.claimed << ") is claimed by a peer (";
    for (std::size_t i = 0; i < t.claimers.size(); ++i) why << (i == 0 ? "" : ", ") << t.claimers[i];
    why << "): waiting";
    decision.kind = ExplorerDecision::Kind::kWait;
    decision.reason = why.str();
    current_.reset();
    return decision;
  }
  // Nothing else to do: a frontier barred until its retry is retried now (its second failure bars it for
  // good) rather than left behind by a completion: it failed while the map around it was thinner, and an
  // exploration that ends is never retried.
  if (t.best == nullptr && t.retry != nullptr) {
    const bool retrying = current_ && SamePlace(*t.retry, current_->target_M, current_->target_ground_z_m,
                                                options_.follow_radius_m);
    decision.kind = retrying ? ExplorerDecision::Kind::kKeep : ExplorerDecision::Kind::kGoTo;
    decision.target = *t.retry;
    decision.reason = "a frontier given up on once, retried before its time: no other reachable frontier";
  } else if (t.best == nullptr) {
    std::ostringstream why;
    why << "exploration complete: no reachable frontier";
    if (t.unreachable > 0 || t.barred > 0 || t.visited > 0) {
      why << " (" << t.unreachable << " seen but unreachable, " << t.barred << " given up on, " << t.visited
          << " reached but still unseen beyond)";
    }
    decision.kind = ExplorerDecision::Kind::kComplete;
    decision.reason = why.str();
    current_.reset();
    return decision;
  } else if (t.followed != nullptr &&
             !(t.best->utility > options_.switch_utility_ratio * t.followed->utility)) {
    decision.kind = ExplorerDecision::Kind::kKeep;
    decision.target = *t.followed;
    decision.reason =
        "the current frontier is still the one to explore (" + std::to_string(t.candidates) + " reachable)";
  } else {
    decision.kind = ExplorerDecision::Kind::kGoTo;
    decision.target = *t.best;
    decision.reason = t.followed != nullptr
                          ? "a frontier " +
                                std::to_string(t.best->utility / t.followed->utility).substr(0, 4) +
                                " times as worth it as the current one"
                          : "best of " + std::to_string(t.candidates) + " reachable frontiers";
  }
  if (decision.kind == ExplorerDecision::Kind::kGoTo) current_since_s_ = team.now_s;
  current_ = decision.target;
  return decision;
}

void Explorer::Reached() {
  if (!current_) return;
  visited_.emplace_back(current_->target_M.x(), current_->target_M.y(), current_->target_ground_z_m);
  current_.reset();
}

void Explorer::Fail(const std::string& reason, double now_s) {
  if (!current_) return;
  for (FailedTarget& f : failed_) {
    if (SamePlace(*current_, f.target_M, f.target_ground_z_m, options_.blacklist_radius_m)) {
      ++f.failures;  // the second time here: barred for good
      f.reason = reason;
      f.failed_at_s = now_s;
      current_.reset();
      return;
    }
  }
  failed_.push_back(FailedTarget{current_->target_M, current_->target_ground_z_m, reason, 1, now_s});
  current_.reset();
}

}  // namespace cairn::nav
