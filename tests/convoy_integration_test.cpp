// Convoy over real processes and DDS: four cairn_agent processes in builtin:tunnels and one
// cairn_base, the convoy started and driven with the operator's commands (request-control, convoy, goto,
// peel). Each robot sees only its own sensors and pose estimate, and its peers' states over cairn/peer_state;
// the measures below are taken from the robots' own pose estimates as an observer hears them (10 Hz).
// The spacing kept along the leader's path through the X junction, scored against ground truth, and the
// other convoy scenarios run in process on a simulated clock: robot_agent/test/convoy_test.cpp.

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
constexpr double kSpacingM = 3.0;  // config/agent.yaml convoy.spacing_m

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

// Four agents at the convoy's start, an observer and a basestation "op".
class ConvoyFleet {
 public:
  ConvoyFleet(int domain, const std::string& test) : logs_(FreshLogs("convoy", test)), observer_(domain) {
    for (std::size_t i = 0; i < kIds.size(); ++i) {
      agents_.push_back(std::make_unique<ChildProcess>(
          std::vector<std::string>{kAgent, "--robot-id", kIds[i], "--start", Fixed(kStartX[i]) + ",20,0",
                                   "--domain", std::to_string(domain), "--config", kLightLidarConfig},
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
