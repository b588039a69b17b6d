#include "cairn/agent/team/explore_claims.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "cairn/core/range_check.h"
#include "cairn/perception/map_telemetry.h"

namespace cairn::agent {

std::string CheckExploreClaim(const ExploreClaim& claim) {
  std::ostringstream why;
  if (claim.robot_id.empty()) {
    why << "robot_id is empty";
  } else if (claim.has_target && !claim.target_M.allFinite()) {
    why << "target (" << claim.target_M.x() << ", " << claim.target_M.y() << ", " << claim.target_M.z()
        << ") must be finite, metres";
  } else if (!(std::isfinite(claim.held_s) && claim.held_s >= 0)) {
    why << "held_s = " << claim.held_s << " must be finite and >= 0";
  } else if (!(claim.lease_s > 0 && claim.lease_s <= 600)) {
    why << "lease_s = " << claim.lease_s << " must be in (0, 600]";
  } else if (claim.coverage) {
    if (const std::string fault = claim.coverage->Check(); !fault.empty()) why << "coverage: " << fault;
  }
  const std::string fault = why.str();
  return fault.empty() ? fault : "explore claim from \"" + claim.robot_id + "\": " + fault;
}

std::vector<std::uint8_t> CompressCoverageBits(const nav::CoverageBitmap& bitmap) {
  std::vector<std::uint8_t> out;
  perception::ZstdCompressAppend(bitmap.bits, 3, "CompressCoverageBits", &out);
  return out;
}

bool DecompressCoverageBits(const std::vector<std::uint8_t>& frame, nav::CoverageBitmap* bitmap,
                            std::string* why) {
  const std::int64_t cells = static_cast<std::int64_t>(bitmap->nx) * bitmap->ny;
  if (bitmap->nx < 0 || bitmap->ny < 0 || cells > nav::CoverageBitmap::kMaxCells) {
    if (why != nullptr) {
      *why = "coverage_nx = " + std::to_string(bitmap->nx) + ", coverage_ny = " + std::to_string(bitmap->ny) +
             " must be >= 0 with at most " + std::to_string(nav::CoverageBitmap::kMaxCells) + " cells";
    }
    return false;
  }
  const std::size_t want = static_cast<std::size_t>((cells + 7) / 8);
  std::string fault;
  if (!perception::ZstdDecompress(frame.data(), frame.size(), want, &bitmap->bits, &fault)) {
    if (why != nullptr) *why = "coverage_zstd: " + fault;
    return false;
  }
  if (bitmap->bits.size() != want) {
    if (why != nullptr) {
      *why = "coverage_zstd holds " + std::to_string(bitmap->bits.size()) + " bytes, " +
             std::to_string(want) + " expected for " + std::to_string(bitmap->nx) + " x " +
             std::to_string(bitmap->ny) + " cells";
    }
    bitmap->bits.clear();
    return false;
  }
  return true;
}

bool ExploreTeamOptions::IsValid(std::string* why) const {
  std::string msg;
  bool ok = core::InRange("explore.claim_period_s", claim_period_s, 0, 60, true, &msg) &&
            core::InRange("explore.coverage_period_s", coverage_period_s, claim_period_s, 600, false, &msg) &&
            core::InRange("explore.claim_lease_s", lease_s, claim_period_s, 600, true, &msg) &&
            core::InRange("explore.coverage_cell_m", coverage_cell_m, 0, 10, true, &msg);
  if (!ok && why != nullptr) *why = msg;
  return ok;
}

namespace {

const ExploreTeamOptions& Checked(const ExploreTeamOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument("ExploreTeam: " + why);
  return options;
}

}  // namespace

ExploreTeam::ExploreTeam(std::string own_id, ExploreTeamOptions options)
    : own_id_(std::move(own_id)), options_(Checked(options)) {
  if (own_id_.empty()) throw std::invalid_argument("ExploreTeam: own_id is empty");
}

std::string ExploreTeam::OnPeerClaim(const ExploreClaim& claim, double now_s) {
  if (std::string why = CheckExploreClaim(claim); !why.empty()) return why;
  if (claim.robot_id == own_id_) return "";
  if (claim.coverage && std::abs(claim.coverage->cell_m - options_.coverage_cell_m) > 1e-9) {
    return "explore claim from \"" + claim.robot_id +
           "\": coverage cell_m = " + std::to_string(claim.coverage->cell_m) +
           " differs from this robot's explore.coverage_cell_m = " + std::to_string(options_.coverage_cell_m);
  }
  std::shared_ptr<nav::PeerCoverage> merged;
  if (claim.coverage) {
    std::lock_guard<std::mutex> guard(mutex_);
    merged = coverage_ ? std::make_shared<nav::PeerCoverage>(*coverage_)
                       : std::make_shared<nav::PeerCoverage>(options_.coverage_cell_m);
  }
  if (merged) merged->Add(*claim.coverage);  // outside the lock: the control loop never waits for it
  std::lock_guard<std::mutex> guard(mutex_);
  if (merged)
    coverage_ = std::move(merged);  // (two peers' coverage at once: the later may miss the earlier's
                                    // newest cells until that peer's next coverage, a few seconds)
  Heard& heard = peers_[claim.robot_id];
  heard.claim = claim;
  heard.claim.coverage.reset();
  heard.heard_s = now_s;
  return "";
}

std::vector<nav::PeerClaim> ExploreTeam::LiveClaims(double now_s) const {
  std::vector<nav::PeerClaim> out;
  std::lock_guard<std::mutex> guard(mutex_);
  for (const auto& [id, heard] : peers_) {
    const ExploreClaim& c = heard.claim;
    if (!c.active || !c.has_target || now_s - heard.heard_s > c.lease_s) continue;
    out.push_back({id, c.target_M.head<2>(), c.held_s + std::max(0.0, now_s - heard.heard_s)});
  }
  return out;
}

std::vector<std::string> ExploreTeam::LivePeers(double now_s) const {
  std::vector<std::string> out;
  std::lock_guard<std::mutex> guard(mutex_);
  for (const auto& [id, heard] : peers_) {
    if (now_s - heard.heard_s <= heard.claim.lease_s) out.push_back(id);
  }
  return out;
}

int ExploreTeam::ExploringPeers(double now_s) const {
  int n = 0;
  std::lock_guard<std::mutex> guard(mutex_);
  for (const auto& [id, heard] : peers_)
    n += heard.claim.active && now_s - heard.heard_s <= heard.claim.lease_s;
  return n;
}

double ExploreTeam::PeerSeenM2() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return coverage_ ? static_cast<double>(coverage_->size()) * coverage_->cell_m() * coverage_->cell_m() : 0.0;
}

std::shared_ptr<const nav::PeerCoverage> ExploreTeam::Coverage() const {
  std::lock_guard<std::mutex> guard(mutex_);
  return coverage_;
}

bool ExploreTeam::ClaimDue(double now_s, bool active, bool has_target,
                           const Eigen::Vector2d& target_M) const {
  if (active != last_active_ || has_target != last_has_target_) return true;
  if (!active) return false;  // the release went out
  if (has_target && (target_M - last_target_M_).norm() > 0.5) return true;
  return now_s - last_claim_s_ >= options_.claim_period_s;
}

bool ExploreTeam::CoverageDue(double now_s) const {
  return now_s - last_coverage_s_ >= options_.coverage_period_s;
}

void ExploreTeam::Sent(const ExploreClaim& claim, double now_s) {
  last_claim_s_ = now_s;
  if (claim.coverage) last_coverage_s_ = now_s;
  last_active_ = claim.active;
  last_has_target_ = claim.has_target;
  last_target_M_ = claim.target_M.head<2>();
}

ExploreClaim ExploreTeam::MakeClaim(std::uint32_t task_id, bool active,
                                    const std::optional<nav::PeerClaim>& own, double target_z_m) const {
  ExploreClaim claim;
  claim.robot_id = own_id_;
  claim.task_id = task_id;
  claim.active = active;
  claim.has_target = active && own.has_value();
  if (claim.has_target) {
    claim.target_M = {own->target_M.x(), own->target_M.y(), std::isfinite(target_z_m) ? target_z_m : 0.0};
    claim.held_s = std::max(0.0, own->held_s);
  }
  claim.lease_s = options_.lease_s;
  return claim;
}

}  // namespace cairn::agent
