// Convoy over real processes and DDS: four cairn_agent processes in builtin:tunnels and one
// cairn_base, the convoy started and driven with the operator's commands (request-control, convoy, goto,
// peel). Each robot sees only its own sensors and pose estimate, and its peers' states over cairn/peer_state;
// the measures below are taken from the robots' own pose estimates as an observer hears them (10 Hz).
// The long in-process version (simulated clock, ground truth) is robot_agent/test/convoy_test.cpp.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "integration_util.h"

namespace cairn {
namespace {

using namespace testing_util;

// The convoy's start on the main tunnel's centre line (y = 20), 3 m apart (the default spacing): the leader
// "cl" first, then "c1", "c2", "c3".
const std::vector<std::string> kIds = {"cl", "c1", "c2", "c3"};
const std::vector<double> kStartX = {14.0, 11.0, 8.0, 5.0};
constexpr double kSpacingM = 3.0;             // config/agent.yaml convoy.spacing_m
constexpr double kTouchingM = 2 * 0.3;        // two wheeled footprints
const Eigen::Vector2d kJunction(30.0, 20.0);  // the X junction's centre

struct Track {
  double t_s;  // the robot's stamp, wall seconds
  Eigen::Vector2d p;
  bool in_contact;
};

std::vector<Track> TrackOf(Observer& observer, const std::string& robot) {
  std::vector<Track> track;
  for (const cairn_msgs::RobotState& s : observer.History(robot)) {
    track.push_back({WallSeconds(s.stamp()),
                     {s.pose_MB().position().x_m(), s.pose_MB().position().y_m()},
                     s.in_contact()});
  }
  return track;
}

// The position of `track` nearest in time to `t_s` (within 0.1 s), if any.
std::optional<Eigen::Vector2d> At(const std::vector<Track>& track, double t_s) {
  auto it =
      std::lower_bound(track.begin(), track.end(), t_s, [](const Track& a, double t) { return a.t_s < t; });
  std::optional<Eigen::Vector2d> best;
  double best_dt = 0.1;
  for (auto c : {it, it == track.begin() ? it : it - 1}) {
    if (c == track.end()) continue;
    if (std::abs(c->t_s - t_s) <= best_dt) {
      best_dt = std::abs(c->t_s - t_s);
      best = c->p;
    }
  }
  return best;
}

// Nearest point of polyline `path` to `p`: distance and arc length there, metres.
std::pair<double, double> Project(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity(), best_along = 0, along = 0;
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d ab = path[i + 1] - path[i];
    const double len = ab.norm();
    const double t = len > 0 ? std::clamp((p - path[i]).dot(ab) / (len * len), 0.0, 1.0) : 0.0;
    const double d = (path[i] + t * ab - p).norm();
    if (d < best) {
      best = d;
      best_along = along + t * len;
    }
    along += len;
  }
  return {best, best_along};
}

// Four agents at the convoy's start, an observer and a basestation "op".
class ConvoyFleet {
 public:
  ConvoyFleet(int domain, const std::string& test) : logs_(FreshLogs("convoy", test)), observer_(domain) {
    for (std::size_t i = 0; i < kIds.size(); ++i) {
      agents_.push_back(std::make_unique<ChildProcess>(
          std::vector<std::string>{kAgent, "--robot-id", kIds[i], "--start", Fixed(kStartX[i]) + ",20,0",
                                   "--domain", std::to_string(domain)},
          logs_ + "/" + kIds[i] + ".log"));
    }
    for (std::size_t i = 0; i < kIds.size(); ++i) {
      EXPECT_TRUE(agents_[i]->WaitForLine("READY", 60s)) << kIds[i] << " did not start; see " << logs_;
    }
    op_ = std::make_unique<Base>("op", domain, logs_);
    for (const std::string& id : kIds) EXPECT_EQ(op_->Run("wait " + id + " online 10")["ok"], true) << id;
  }
  Observer& observer() { return observer_; }
  Base& op() { return *op_; }
  const std::string& logs() const { return logs_; }

  // The leader's driven path: the convoy's start line (the tunnel's centre, last follower to leader), then
  // every pose it reported, 5 cm apart.
  std::vector<Eigen::Vector2d> LeaderPath() {
    std::vector<Eigen::Vector2d> path = {{kStartX.back(), 20.0}, {kStartX.front(), 20.0}};
    for (const Track& t : TrackOf(observer_, kIds[0])) {
      if ((t.p - path.back()).norm() >= 0.05) path.push_back(t.p);
    }
    return path;
  }

 private:
  static std::string Fixed(double v) { return std::to_string(static_cast<int>(std::lround(v))); }

  std::string logs_;
  Observer observer_;
  std::vector<std::unique_ptr<ChildProcess>> agents_;
  std::unique_ptr<Base> op_;
};

// Every follower's state a few seconds after the leader stopped: holding, `gap` within 1 m of the spacing.
void ExpectHolding(Observer& observer, const std::vector<std::string>& followers,
                   const std::vector<std::string>& ahead) {
  for (std::size_t i = 0; i < followers.size(); ++i) {
    const cairn_msgs::RobotState s = observer.FreshState(followers[i]);
    EXPECT_EQ(s.mode(), "convoy") << followers[i];
    EXPECT_EQ(s.convoy_state(), "holding") << followers[i] << ": " << s.convoy_reason();
    ASSERT_FALSE(s.convoy_ahead_ids().empty()) << followers[i];
    EXPECT_EQ(s.convoy_ahead_ids().front(), ahead[i]) << followers[i];
    EXPECT_NEAR(s.convoy_gap_m(), kSpacingM, 1.0) << followers[i] << " behind " << ahead[i];
  }
}

// Three followers behind a leader driven by one waypoint from the main tunnel through the X junction into the
// north branch, started in three operator commands: on straight stretches each keeps within 1 m of the 3 m
// spacing along the leader's path, none strays 0.5 m from that path, no two robots touch, nothing touches a
// wall, and at the end all hold at the spacing.
TEST(ConvoyOverDds, ThreeFollowersKeepTheSpacingOnTheLeadersPathThroughTheXJunction) {
  ConvoyFleet fleet(93, "x_junction");
  Base& op = fleet.op();
  // The operator's three commands.
  json r = op.Run("request-control cl c1 c2 c3");
  ASSERT_EQ(r["ok"], true) << r;
  r = op.Run("convoy cl c1 c2 c3");
  ASSERT_EQ(r["ok"], true) << r;
  ASSERT_EQ(r["robots"].size(), 3u) << r;
  r = op.Run("goto cl 30 32 --wait 120", 130s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << fleet.logs();
  std::this_thread::sleep_for(10s);  // the followers close up behind the stopped leader
  ExpectHolding(fleet.observer(), {"c1", "c2", "c3"}, {"cl", "c1", "c2"});

  const std::vector<Eigen::Vector2d> path = fleet.LeaderPath();
  std::vector<std::vector<Track>> tracks;
  for (const std::string& id : kIds) tracks.push_back(TrackOf(fleet.observer(), id));
  std::vector<double> errors;
  double worst_deviation_m = 0, closest_m = std::numeric_limits<double>::infinity();
  std::string worst_at;  // which follower, where
  bool contact = false;
  for (std::size_t i = 1; i < kIds.size(); ++i) {
    for (const Track& t : tracks[i]) {
      contact = contact || t.in_contact;
      if (const double d = Project(path, t.p).first; d > worst_deviation_m) {
        worst_deviation_m = d;
        worst_at = kIds[i] + " at (" + std::to_string(t.p.x()) + ", " + std::to_string(t.p.y()) + ")";
      }
      for (std::size_t j = 0; j < kIds.size(); ++j) {
        if (j == i) continue;
        if (const auto other = At(tracks[j], t.t_s)) closest_m = std::min(closest_m, (*other - t.p).norm());
      }
      const auto ahead = At(tracks[i - 1], t.t_s);
      if (!ahead || (*ahead - kJunction).norm() <= 2.0 || (t.p - kJunction).norm() <= 2.0) continue;
      errors.push_back(Project(path, *ahead).second - Project(path, t.p).second - kSpacingM);
    }
  }
  for (const Track& t : tracks[0]) contact = contact || t.in_contact;
  ASSERT_GT(errors.size(), 300u) << "too few samples on straight stretches";
  std::sort(errors.begin(), errors.end());
  double mean = 0;
  for (double e : errors) mean += e / static_cast<double>(errors.size());
  Figure("spacing_error_mean_m", mean);
  Figure("spacing_error_p95_abs_m",
         std::max(std::abs(errors[errors.size() / 20]), std::abs(errors[errors.size() * 19 / 20])));
  Figure("spacing_error_min_m", errors.front());
  Figure("spacing_error_max_m", errors.back());
  Figure("worst_path_deviation_m", worst_deviation_m);
  Figure("closest_robots_m", closest_m);
  // Peer-state traffic: what each robot sent in link class "team" (its peer states; no explore claims here),
  // the highest of its once-a-second readings while the convoy drove.
  for (const std::string& id : kIds) {
    double team_kbps = 0;
    for (const cairn_msgs::RobotState& s : fleet.observer().History(id)) {
      for (const auto& usage : s.link_usage()) {
        if (usage.topic_class() == "team") team_kbps = std::max(team_kbps, usage.sent_kbps());
      }
    }
    Figure("peer_state_kbps_" + id, team_kbps);
    EXPECT_GT(team_kbps, 0.0) << id << " sent no peer state";
  }
  EXPECT_GE(errors.front(), -1.0);
  EXPECT_LE(errors.back(), 1.0);
  EXPECT_LE(worst_deviation_m, 0.5) << worst_at;
  EXPECT_GT(closest_m, kTouchingM);
  EXPECT_FALSE(contact);
  for (const json& e : op.events()) {
    const std::string kind = e.value("event", "");
    EXPECT_TRUE(kind != "convoy_lost" && kind != "convoy_blocked") << "no follower stopped on its own: " << e;
  }
  r = op.Run("convoy-stop cl");
  EXPECT_EQ(r["ok"], true) << r;
  for (const char* id : {"c1", "c2", "c3"}) {
    EXPECT_EQ(op.Run("wait " + std::string(id) + " idle 5")["ok"], true) << id;
  }
}

// A follower in the middle peels off at the X junction to a goal straight on, while the leader turns north:
// it arrives, the follower behind it re-links to the leader (the operator sees it) and the convoy closes up
// at the spacing behind the leader.
TEST(ConvoyOverDds, APeeledFollowerArrivesAndTheConvoyClosesUp) {
  ConvoyFleet fleet(94, "peel");
  Base& op = fleet.op();
  ASSERT_EQ(op.Run("request-control cl c1 c2 c3")["ok"], true);
  ASSERT_EQ(op.Run("convoy cl c1 c2 c3")["ok"], true);
  ASSERT_EQ(op.Run("goto cl 30 32")["ok"], true);
  // c1 nears the junction.
  const auto deadline = Clock::now() + 60s;
  while (Clock::now() < deadline) {
    const auto s = fleet.observer().Latest("c1");
    if (s && s->pose_MB().position().x_m() >= 24.0) break;
    std::this_thread::sleep_for(50ms);
  }
  json r = op.Run("peel c1 40 20");
  ASSERT_EQ(r["ok"], true) << r;
  ASSERT_EQ(r["robots"].size(), 3u) << r << ": c1's goal, c2 and c3 re-linked";
  r = op.Run("wait c1 arrived 60", 70s);
  EXPECT_EQ(r["ok"], true) << r << "; see " << fleet.logs();
  r = op.Run("wait cl arrived 90", 100s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << fleet.logs();
  std::this_thread::sleep_for(10s);
  ExpectHolding(fleet.observer(), {"c2", "c3"}, {"cl", "c2"});
  const cairn_msgs::RobotState c1 = fleet.observer().FreshState("c1");
  EXPECT_NE(c1.mode(), "convoy");
  EXPECT_TRUE(c1.convoy_ahead_ids().empty());
  EXPECT_LT(std::hypot(c1.pose_MB().position().x_m() - 40.0, c1.pose_MB().position().y_m() - 20.0), 0.5);
  const bool told = std::any_of(op.events().begin(), op.events().end(), [](const json& e) {
    return e.value("event", "") == "convoy_relinked" && e.value("robot", "") == "c2";
  });
  EXPECT_TRUE(told) << "the operator is told that c2 now follows cl";
  for (const std::string& id : kIds) {
    for (const Track& t : TrackOf(fleet.observer(), id)) EXPECT_FALSE(t.in_contact) << id;
  }
}

}  // namespace
}  // namespace cairn
