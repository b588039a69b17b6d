// The team side of exploration. Each exploring robot sends an ExploreClaim (idl/cairn_msgs.idl, topic
// cairn/explore_claim) every claim_period_s: the frontier it goes for and how long it has held it; every
// coverage_period_s the claim also carries the floor the robot has seen, as a coarse bitmap
// (nav::SeenCoverage) compressed with zstd. Its peers keep the claims they heard (each expires lease_s after
// it arrived, on the receiver's clock: a lost robot's claim goes by itself, with no clock sync) and the union
// of the coverage (counted as no gain by their frontier search). Plain C++ without DDS: the agent's DDS
// adapter converts the messages; the in-process team (InProcessTeam, for agents stepped on a simulated clock)
// passes the same structs through the same rules.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "cairn/nav/explorer.h"
#include "cairn/nav/frontier.h"

namespace cairn::agent {

/// One robot's claim, as sent on cairn/explore_claim.
struct ExploreClaim {
  std::string robot_id;
  std::uint32_t task_id = 0;
  bool active = false;                                 ///< exploring; false releases any claim at once
  bool has_target = false;                             ///< a frontier is claimed
  Eigen::Vector3d target_M = Eigen::Vector3d::Zero();  ///< metres, frame M (shared by the team)
  double held_s = 0.0;                                 ///< seconds the sender has held the target, >= 0
  double lease_s = 6.0;  ///< (0, 600]: receivers drop the claim this long after it arrived
  /// The sender's seen floor (nav::SeenCoverage); none in most messages.
  std::optional<nav::CoverageBitmap> coverage;
};

/// Why `claim` cannot be taken ("" when it can), naming the field and value: an empty robot id, a target that
/// is not finite, held_s negative or not finite, lease_s not in (0, 600], coverage failing its Check().
std::string CheckExploreClaim(const ExploreClaim& claim);

/// The coverage bits as one zstd frame (perception::ZstdCompressAppend, level 3). A 0.5 m bitmap of a
/// 100 m x 100 m box (5 kB of bits) takes a few hundred bytes.
std::vector<std::uint8_t> CompressCoverageBits(const nav::CoverageBitmap& bitmap);
/// Fills `bitmap->bits` from `frame` made by CompressCoverageBits for the bitmap's nx and ny (set before).
/// Returns false with `*why` naming the fault: nx or ny negative or nx * ny over the limit, a bad zstd frame
/// (perception::ZstdDecompress), or a size other than ceil(nx * ny / 8) bytes.
bool DecompressCoverageBits(const std::vector<std::uint8_t>& frame, nav::CoverageBitmap* bitmap,
                            std::string* why);

/// How the team side runs (config section explore: claim_period_s, coverage_period_s, claim_lease_s,
/// coverage_cell_m).
struct ExploreTeamOptions {
  double claim_period_s = 1.0;     ///< (0, 60]: a claim this often while exploring
  double coverage_period_s = 5.0;  ///< [claim_period_s, 600]: coverage in a claim this often
  double lease_s = 6.0;            ///< (claim_period_s, 600]: what receivers keep a claim for
  double coverage_cell_m = 0.5;    ///< (0, 10]: the coverage bitmap's cell, metres
  /// "" or the fault naming the config field (explore.claim_period_s, ...) and value.
  bool IsValid(std::string* why) const;
};

/// One robot's view of its team: the peers' live claims and the union of their coverage, plus when its own
/// claim and coverage are due. Thread-safe (claims arrive on DDS threads).
class ExploreTeam {
 public:
  /// @throws std::invalid_argument for an empty own_id or invalid options (IsValid()'s message).
  ExploreTeam(std::string own_id, ExploreTeamOptions options);

  /// A peer's claim heard at `now_s` (the receiver's clock, seconds). Returns "" when taken, else why not
  /// (CheckExploreClaim's fault, or a coverage of another cell size); a refused claim changes nothing. The
  /// robot's own claims (its id) are ignored.
  std::string OnPeerClaim(const ExploreClaim& claim, double now_s);
  /// The peers' claims with a target that are active and within their lease at `now_s`.
  std::vector<nav::PeerClaim> LiveClaims(double now_s) const;
  /// Robots whose claim is live at `now_s` (active or not), by id.
  std::vector<std::string> LivePeers(double now_s) const;
  /// Of those, the ones exploring (active).
  int ExploringPeers(double now_s) const;
  /// Floor in the peers' coverage, m² (marked cells x cell area).
  double PeerSeenM2() const;
  /// The union of every peer's coverage so far (shared, immutable; a new object after each coverage heard);
  /// null before any.
  std::shared_ptr<const nav::PeerCoverage> Coverage() const;

  /// True when the robot's own claim is due at `now_s`: while active, claim_period_s after the last one sent
  /// or at once when the target moved (over 0.5 m) or came or went; once when it turns inactive; never else.
  bool ClaimDue(double now_s, bool active, bool has_target, const Eigen::Vector2d& target_M) const;
  /// True when the next claim should carry the coverage.
  bool CoverageDue(double now_s) const;
  /// Records a claim the robot sent at `now_s`.
  void Sent(const ExploreClaim& claim, double now_s);
  /// The claim the robot sends now: its exploration task and state, the target it holds (none: no target).
  ExploreClaim MakeClaim(std::uint32_t task_id, bool active, const std::optional<nav::PeerClaim>& own,
                         double target_z_m) const;

  const ExploreTeamOptions& options() const { return options_; }

 private:
  struct Heard {
    ExploreClaim claim;  // without its coverage
    double heard_s = 0.0;
  };
  std::string own_id_;
  ExploreTeamOptions options_;
  mutable std::mutex mutex_;
  std::map<std::string, Heard> peers_;
  std::shared_ptr<const nav::PeerCoverage> coverage_;
  // Own side (one caller: the control loop).
  double last_claim_s_ = -1e18;
  double last_coverage_s_ = -1e18;
  bool last_active_ = false;
  bool last_has_target_ = false;
  Eigen::Vector2d last_target_M_ = Eigen::Vector2d::Zero();
};

}  // namespace cairn::agent
