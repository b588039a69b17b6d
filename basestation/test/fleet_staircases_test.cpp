#include "cairn/base/fleet_staircases.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

namespace cairn::base {
namespace {

using perception::Staircase;
using Kind = StaircaseChange::Kind;

// The built-in tunnels' flight: 5 risers of 0.2 m, runs 0.5 m, first riser at x = 50 m, ascending +x;
// `scans` merged by the robot that reports it.
Staircase Flight(int scans = 10) {
  Staircase s;
  s.p_W_first_step = Eigen::Vector3d(50.0, 23.7, 0.0);
  s.yaw_rad = 0.0;
  s.rise_m = 0.2;
  s.run_m = 0.5;
  s.width_m = 2.4;
  s.num_steps = 5;
  s.confidence = 0.6;
  s.support_points = scans;
  return s;
}

// Risers first+1 .. first+count of the flight only, as a robot that saw just them reports it.
Staircase PartOfFlight(int first, int count) {
  Staircase s = Flight();
  s.p_W_first_step += first * Eigen::Vector3d(0.5, 0.0, 0.2);
  s.num_steps = count;
  return s;
}

// A flight in another room, ascending +y.
Staircase Elsewhere(double x_m, int scans = 10) {
  Staircase s = Flight(scans);
  s.p_W_first_step = Eigen::Vector3d(x_m, 5.0, 0.0);
  s.yaw_rad = M_PI / 2;
  return s;
}

std::vector<int> Ids(const FleetStaircases& fleet) {
  std::vector<int> ids;
  for (const auto& e : fleet.Entries()) ids.push_back(e.id);
  return ids;
}

perception::StaircaseRegistry::Entry Get(const FleetStaircases& fleet, int id) {
  for (const auto& e : fleet.Entries()) {
    if (e.id == id) return e;
  }
  ADD_FAILURE() << "no fleet staircase " << id;
  return {};
}

TEST(FleetStaircases, DefaultOptionsAreValidAndABadBoundIsNamed) {
  std::string why;
  EXPECT_TRUE(FleetStaircasesOptions{}.IsValid(&why)) << why;
  FleetStaircasesOptions options;
  options.max_reports = 0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "FleetStaircasesOptions.max_reports = 0 is not in [1, 1000000]");
  EXPECT_THROW(FleetStaircases{options}, std::invalid_argument);
}

TEST(FleetStaircases, ARefinedEstimateKeepsItsIdAndAnotherStaircaseGetsTheNextOne) {
  FleetStaircases fleet;
  auto changes = fleet.Report("r1", 1, PartOfFlight(2, 3));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kNew);
  EXPECT_EQ(changes[0].staircase.id, 1);
  // r1 refines it down to the foot of the flight: still staircase 1, nothing to tell.
  EXPECT_TRUE(fleet.Report("r1", 1, Flight(25)).empty());
  changes = fleet.Report("r2", 1, Elsewhere(12.0));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kNew);
  EXPECT_EQ(changes[0].staircase.id, 2);
  // r2 sees the tunnels' flight too: it joins staircase 1.
  EXPECT_TRUE(fleet.Report("r2", 2, Flight(8)).empty());
  EXPECT_EQ(Ids(fleet), (std::vector<int>{1, 2}));
  EXPECT_NEAR(Get(fleet, 1).staircase.p_W_first_step.x(), 50.0, 1e-9);
  EXPECT_EQ(Get(fleet, 1).staircase.num_steps, 5);
  EXPECT_EQ(Get(fleet, 1).sources, (std::vector<std::string>{"r1", "r2"}));
  EXPECT_EQ(Get(fleet, 1).detections, 2);
  EXPECT_NEAR(Get(fleet, 2).staircase.p_W_first_step.x(), 12.0, 1e-9);
}

TEST(FleetStaircases, OneReportOnTwoStaircasesMergesTheYoungerIntoTheOlderAndItsIdIsNeverReused) {
  FleetStaircases fleet;
  ASSERT_EQ(fleet.Report("r1", 1, PartOfFlight(2, 3)).size(), 1u);  // the upper three risers: 1
  ASSERT_EQ(fleet.Report("r3", 1, PartOfFlight(0, 2)).size(), 1u);  // the lower two, no overlap: 2
  EXPECT_EQ(Ids(fleet), (std::vector<int>{1, 2}));
  // r2 at the foot sees the whole flight, which both parts match: one flight.
  auto changes = fleet.Report("r2", 1, Flight());
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kMerged);
  EXPECT_EQ(changes[0].merged_id, 2);
  EXPECT_EQ(changes[0].staircase.id, 1);
  EXPECT_EQ(changes[0].staircase.staircase.num_steps, 5);
  EXPECT_EQ(changes[0].staircase.sources, (std::vector<std::string>{"r1", "r2", "r3"}));
  EXPECT_EQ(Ids(fleet), (std::vector<int>{1}));
  EXPECT_NEAR(Get(fleet, 1).staircase.p_W_first_step.x(), 50.0, 1e-9);
  EXPECT_NEAR(Get(fleet, 1).staircase.p_W_first_step.z(), 0.0, 1e-9);
  // The merged parts' robots refine them: they stay in staircase 1.
  EXPECT_TRUE(fleet.Report("r3", 1, PartOfFlight(0, 3)).empty());
  EXPECT_TRUE(fleet.Report("r1", 1, PartOfFlight(1, 4)).empty());
  changes = fleet.Report("r3", 2, Elsewhere(12.0));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].staircase.id, 3) << "2 was merged away: never given again";
}

TEST(FleetStaircases, AStaircaseTheRobotsPlaceElsewhereIsRemovedAndItsIdRetired) {
  FleetStaircases fleet;
  ASSERT_EQ(fleet.Report("r1", 1, Flight(10)).size(), 1u);
  ASSERT_EQ(fleet.Report("r2", 1, Flight(10)).size(), 0u);
  // r2 now places its staircase 1 in another room; r1 still reports the flight: staircase 1 stays, r1's.
  auto changes = fleet.Report("r2", 1, Elsewhere(12.0, 11));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kNew);
  EXPECT_EQ(changes[0].staircase.id, 2);
  EXPECT_EQ(Get(fleet, 1).sources, (std::vector<std::string>{"r1"}));
  // r1 does the same: nobody reports the flight any more.
  changes = fleet.Report("r1", 1, Elsewhere(12.0, 11));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kRemoved);
  EXPECT_EQ(changes[0].staircase.id, 1);
  EXPECT_NEAR(changes[0].staircase.staircase.p_W_first_step.x(), 50.0, 1e-9) << "its last estimate";
  EXPECT_EQ(
      changes[0].reason,
      "r1 now places its staircase 1 at (12.00, 5.00, 0.00), 42.35 m away, and no other report holds it");
  EXPECT_EQ(Ids(fleet), (std::vector<int>{2}));
  EXPECT_EQ(Get(fleet, 2).sources, (std::vector<std::string>{"r2", "r1"}));
  // The flight found again is a new staircase: 1 is not given again.
  changes = fleet.Report("r3", 1, Flight());
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kNew);
  EXPECT_EQ(changes[0].staircase.id, 3);
}

TEST(FleetStaircases, ARestartedRobotsReusedIdsLeaveItsEarlierStaircasesInPlace) {
  FleetStaircases fleet;
  ASSERT_EQ(fleet.Report("r1", 1, Flight(30)).size(), 1u);
  // r1 restarted: it numbers from 1 again, and its new staircase 1 is in another room (2 scans so far).
  auto changes = fleet.Report("r1", 1, Elsewhere(12.0, 2));
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].kind, Kind::kNew);
  EXPECT_EQ(changes[0].staircase.id, 2);
  EXPECT_EQ(Ids(fleet), (std::vector<int>{1, 2}));
  EXPECT_NEAR(Get(fleet, 1).staircase.p_W_first_step.x(), 50.0, 1e-9);
  EXPECT_EQ(fleet.reports(), 2u);
  // Its new session meets the flight again as its staircase 2: staircase 1, nothing new.
  EXPECT_TRUE(fleet.Report("r1", 2, Flight(3)).empty());
  EXPECT_EQ(Get(fleet, 1).detections, 2);
  EXPECT_EQ(Ids(fleet), (std::vector<int>{1, 2}));
}

TEST(FleetStaircases, ReportsAreBoundedEarlierSessionsMakeRoomFirst) {
  FleetStaircasesOptions options;
  options.max_reports = 3;
  FleetStaircases fleet(options);
  ASSERT_EQ(fleet.Report("r1", 1, Flight(30)).size(), 1u);  // 1
  ASSERT_EQ(fleet.Report("r1", 1, Elsewhere(12.0, 2)).size(),
            1u);                                                 // r1 restarted: 2; its flight report stays
  ASSERT_EQ(fleet.Report("r2", 1, Elsewhere(20.0)).size(), 1u);  // 3
  EXPECT_EQ(fleet.reports(), 3u);
  // Full: r3's report displaces the oldest report from an earlier session, staircase 1's only one.
  auto changes = fleet.Report("r3", 1, Elsewhere(30.0));
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].kind, Kind::kRemoved);
  EXPECT_EQ(changes[0].staircase.id, 1);
  EXPECT_EQ(
      changes[0].reason,
      "its last report (r1's staircase 1, from before r1 restarted) made room for a newer one (at most 3 "
      "reports are kept)");
  EXPECT_EQ(changes[1].kind, Kind::kNew);
  EXPECT_EQ(changes[1].staircase.id, 4);
  EXPECT_EQ(fleet.reports(), 3u);
  // Full of current reports: a fourth robot's is refused; updates of the kept ones still count.
  std::string refused;
  EXPECT_TRUE(fleet.Report("r4", 1, Elsewhere(40.0), &refused).empty());
  EXPECT_EQ(refused, "3 staircase reports already kept");
  EXPECT_EQ(Ids(fleet), (std::vector<int>{2, 3, 4}));
  EXPECT_TRUE(fleet.Report("r2", 1, Elsewhere(20.02, 12), &refused).empty());
  EXPECT_EQ(refused, "");
  EXPECT_NEAR(Get(fleet, 3).staircase.p_W_first_step.x(), 20.02, 1e-9);
}

TEST(FleetStaircases, ARestartedRobotStaysWithinTheBound) {
  FleetStaircasesOptions options;
  options.max_reports = 2;
  FleetStaircases fleet(options);
  ASSERT_EQ(fleet.Report("r1", 1, Flight(30)).size(), 1u);       // 1
  ASSERT_EQ(fleet.Report("r2", 1, Elsewhere(20.0)).size(), 1u);  // 2
  // r1 restarted and reuses its id 1 elsewhere: its earlier report would be a third; it makes room.
  const auto changes = fleet.Report("r1", 1, Elsewhere(12.0, 2));
  ASSERT_EQ(changes.size(), 2u);
  EXPECT_EQ(changes[0].kind, Kind::kRemoved);
  EXPECT_EQ(changes[0].staircase.id, 1);
  EXPECT_EQ(changes[1].kind, Kind::kNew);
  EXPECT_EQ(changes[1].staircase.id, 3);
  EXPECT_EQ(fleet.reports(), 2u);
  EXPECT_EQ(Ids(fleet), (std::vector<int>{2, 3}));
}

TEST(FleetStaircases, AnUnusableReportIsRefused) {
  FleetStaircases fleet;
  Staircase bad = Flight();
  bad.run_m = std::nan("");
  std::string refused;
  EXPECT_TRUE(fleet.Report("r1", 1, bad, &refused).empty());
  EXPECT_FALSE(refused.empty());
  EXPECT_EQ(fleet.reports(), 0u);
}

}  // namespace
}  // namespace cairn::base
