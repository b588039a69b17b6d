// Get-out-of-the-way over real processes and DDS: three cairn_agent processes in builtin:narrow
// (two 2 m wide tunnels, each with one bay on its north wall) and one cairn_base. Robot "ya" drives along the
// south tunnel through "yb", parked in it; "ye" drives the same route in the empty north tunnel at the same
// time (the time ya loses to the yield). Each robot sees only its own sensors and pose estimate, and its
// peers over cairn/peer_state and cairn/yield_request; the measures are taken from the robots' own states as
// an observer hears them.

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "integration_util.h"

namespace cairn {
namespace {

using namespace testing_util;

constexpr double kTouchingM = 2 * 0.3;  // two wheeled footprints
const Eigen::Vector2d kParkedAt(14.0, 5.0);

Eigen::Vector2d PositionOf(const cairn_msgs::RobotState& s) {
  return {s.pose_MB().position().x_m(), s.pose_MB().position().y_m()};
}

// The robot's first state at or after `from_s` (wall seconds) with its goal arrived; NaN when none.
double ArrivedAt(Observer& observer, const std::string& robot, double from_s) {
  for (const cairn_msgs::RobotState& s : observer.History(robot)) {
    if (WallSeconds(s.stamp()) >= from_s && s.nav_status() == cairn_msgs::NAV_STATUS_ARRIVED)
      return WallSeconds(s.stamp());
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Waits up to `timeout` for `robot`'s state to satisfy `done`; the last state seen.
template <class Pred>
std::optional<cairn_msgs::RobotState> WaitForState(Observer& observer, const std::string& robot,
                                                   std::chrono::seconds timeout, Pred done) {
  const auto deadline = Clock::now() + timeout;
  std::optional<cairn_msgs::RobotState> last;
  while (Clock::now() < deadline) {
    last = observer.Latest(robot);
    if (last && done(*last)) return last;
    std::this_thread::sleep_for(50ms);
  }
  return last;
}

bool Told(const std::vector<json>& events, const std::string& kind, const std::string& robot) {
  return std::any_of(events.begin(), events.end(), [&](const json& e) {
    return e.value("event", "") == kind && e.value("robot", "") == robot;
  });
}

// ya's route along the south tunnel is blocked by yb, parked in it (2 m wide: no room to pass): ya asks, yb
// (idle, released by its operator: no lock is needed) drives into the bay, waits until ya has passed and
// returns to where it stood; ya arrives. Then yb in manual control refuses with the reason, ya holds before
// it and reports itself blocked; once yb's operator puts it back to idle, ya's next request is granted and ya
// arrives. Both operators' events name each step (one basestation hears both robots here).
TEST(YieldOverDds, AParkedRobotGetsOutOfTheWayAndOneInManualRefuses) {
  const int domain = 95;
  const std::string logs = FreshLogs("yield", "narrow_tunnel");
  Observer observer(domain);
  std::vector<std::unique_ptr<ChildProcess>> agents;
  const std::vector<std::pair<std::string, std::string>> robots = {
      {"ya", "4,5,0"}, {"yb", "26,5,3.14159"}, {"ye", "4,15,0"}};
  agents.reserve(robots.size());
  for (const auto& [id, start] : robots) {
    agents.push_back(std::make_unique<ChildProcess>(
        std::vector<std::string>{kAgent, "--robot-id", id, "--world", "builtin:narrow", "--start", start,
                                 "--domain", std::to_string(domain), "--config", kLightLidarConfig},
        logs + "/" + id + ".log"));
  }
  for (std::size_t i = 0; i < agents.size(); ++i) {
    ASSERT_TRUE(agents[i]->WaitForLine("READY", 60s)) << robots[i].first << " did not start; see " << logs;
  }
  Base op("op", domain, logs);
  for (const auto& [id, start] : robots) ASSERT_EQ(op.Run("wait " + id + " online 10")["ok"], true) << id;
  ASSERT_EQ(op.Run("request-control ya yb ye")["ok"], true);

  // yb drives west past the bay (it maps it on the way) and parks in the tunnel; its operator lets it go.
  json r = op.Run("goto yb 14 5 --wait 90", 100s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << logs;
  ASSERT_EQ(op.Run("release yb")["ok"], true);

  // ya through yb's tunnel, ye through the empty one, at the same time.
  const double start_s = WallSeconds(observer.FreshState("ya").stamp());
  r = op.Run("goto ya 30 5");
  ASSERT_EQ(r["ok"], true) << r;
  const double start_e_s = WallSeconds(observer.FreshState("ye").stamp());
  r = op.Run("goto ye 30 15");
  ASSERT_EQ(r["ok"], true) << r;
  r = op.Run("wait ya arrived 150", 160s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << logs;
  r = op.Run("wait ye arrived 60", 70s);
  ASSERT_EQ(r["ok"], true) << r << "; see " << logs;
  // yb comes back to where it stood.
  const auto back = WaitForState(observer, "yb", 60s, [](const cairn_msgs::RobotState& s) {
    return s.yield_state().empty() && s.mode() == "idle" && s.yield_reason().find("back at") == 0;
  });
  ASSERT_TRUE(back) << "see " << logs;
  EXPECT_EQ(back->yield_reason().find("back at"), 0u) << back->yield_reason() << "; see " << logs;
  EXPECT_LT((PositionOf(*back) - kParkedAt).norm(), 0.5) << "yb returned to where it stood";

  // What yb did, in order: moving aside for ya, aside (clear of ya's route: in the bay), back.
  bool moved_aside = false, aside_in_bay = false;
  for (const cairn_msgs::RobotState& s : observer.History("yb")) {
    if (s.yield_state() == "moving_aside" && s.yield_peer_id() == "ya") moved_aside = true;
    if (s.yield_state() == "aside" && s.pose_MB().position().y_m() > 5.9) aside_in_bay = true;
  }
  EXPECT_TRUE(moved_aside) << "see " << logs;
  EXPECT_TRUE(aside_in_bay) << "yb stood aside in the bay; see " << logs;
  // No contact, no touching.
  double closest_m = std::numeric_limits<double>::infinity();
  const auto yb_history = observer.History("yb");
  for (const cairn_msgs::RobotState& a : observer.History("ya")) {
    EXPECT_FALSE(a.in_contact());
    for (const cairn_msgs::RobotState& b : yb_history) {
      if (std::abs(WallSeconds(a.stamp()) - WallSeconds(b.stamp())) <= 0.05)
        closest_m = std::min(closest_m, (PositionOf(a) - PositionOf(b)).norm());
    }
  }
  for (const cairn_msgs::RobotState& b : yb_history) EXPECT_FALSE(b.in_contact());
  EXPECT_GT(closest_m, kTouchingM);
  // The time ya lost to the yield, against ye in the empty tunnel.
  const double ya_s = ArrivedAt(observer, "ya", start_s) - start_s;
  const double ye_s = ArrivedAt(observer, "ye", start_e_s) - start_e_s;
  Figure("ya_through_yb_s", ya_s);
  Figure("ye_empty_tunnel_s", ye_s);
  Figure("time_lost_to_yield_s", ya_s - ye_s);
  Figure("ya_over_ye_ratio", ya_s / ye_s);
  Figure("closest_ya_yb_m", closest_m);
  EXPECT_TRUE(Told(op.events(), "yield_asking", "ya"));
  EXPECT_TRUE(Told(op.events(), "yield_moving_aside", "yb"));

  // yb in manual control refuses, with the reason; ya, driving back west, holds before it, blocked.
  ASSERT_EQ(op.Run("request-control yb")["ok"], true);
  ASSERT_EQ(op.Run("mode yb manual")["ok"], true);
  r = op.Run("goto ya 4 5");
  ASSERT_EQ(r["ok"], true) << r;
  const auto blocked = WaitForState(
      observer, "ya", 90s, [](const cairn_msgs::RobotState& s) { return s.yield_state() == "blocked"; });
  ASSERT_TRUE(blocked && blocked->yield_state() == "blocked") << "see " << logs;
  EXPECT_EQ(blocked->yield_peer_id(), "yb");
  EXPECT_NE(blocked->yield_reason().find("manual control"), std::string::npos) << blocked->yield_reason();
  EXPECT_EQ(blocked->mode(), "waypoint") << "ya keeps its goal and holds";
  const cairn_msgs::RobotState yb = observer.FreshState("yb");
  EXPECT_EQ(yb.yield_state(), "refused");
  EXPECT_NE(yb.yield_reason().find("manual control"), std::string::npos) << yb.yield_reason();
  EXPECT_GT((PositionOf(*blocked) - PositionOf(yb)).norm(), kTouchingM + 0.5);
  // The operator's own `yield` is refused the same way.
  r = op.Run("yield yb for ya");
  EXPECT_EQ(r["ok"], false) << r;
  EXPECT_NE(r.value("reason", "").find("manual control"), std::string::npos) << r;
  // yb's operator lets it yield: ya's next request is granted and it arrives.
  ASSERT_EQ(op.Run("mode yb idle")["ok"], true);
  r = op.Run("wait ya arrived 120", 130s);
  EXPECT_EQ(r["ok"], true) << r << "; see " << logs;
  op.Run("sleep 1");  // the last events
  EXPECT_TRUE(Told(op.events(), "yield_refused", "yb"));
  EXPECT_TRUE(Told(op.events(), "yield_blocked", "ya"));
  EXPECT_TRUE(Told(op.events(), "yield_returned", "yb"));
}

}  // namespace
}  // namespace cairn
