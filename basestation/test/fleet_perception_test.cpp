// FleetPerception's fleet staircases as the robots' staircase detections reach it over DDS (one participant
// in this test's private network namespace: a robots' writer and the basestation's reader).
#include "cairn/base/fleet_perception.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cairn/core/dds.h"
#include "cairn_msgsPubSubTypes.h"

namespace cairn::base {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using perception::Staircase;

// The built-in tunnels' flight: 5 risers of 0.2 m, runs 0.5 m, first riser at x = 50 m, ascending +x.
Staircase TunnelsFlight() {
  Staircase s;
  s.p_W_first_step = Eigen::Vector3d(50.0, 23.7, 0.0);
  s.yaw_rad = 0.0;
  s.rise_m = 0.2;
  s.run_m = 0.5;
  s.width_m = 2.4;
  s.num_steps = 5;
  s.confidence = 0.6;
  s.support_points = 10;  // scans merged by the robot
  return s;
}

// Risers first+1 .. first+count of `flight` (first = 0: from its foot), as a robot that saw only them reports
// it.
Staircase PartOf(const Staircase& flight, int first, int count) {
  Staircase s = flight;
  s.p_W_first_step += first * Eigen::Vector3d(flight.run_m * std::cos(flight.yaw_rad),
                                              flight.run_m * std::sin(flight.yaw_rad), flight.rise_m);
  s.num_steps = count;
  return s;
}

// A flight in another room, ascending +y.
Staircase OtherRoomFlight() {
  Staircase s = TunnelsFlight();
  s.p_W_first_step = Eigen::Vector3d(12.0, 5.0, 0.0);
  s.yaw_rad = M_PI / 2;
  return s;
}

// A FleetPerception and a robots' writer of cairn/staircase on one participant.
class Rig {
 public:
  Rig() {
    core::ParticipantOptions options;
    options.domain_id = 61;
    options.name = "fleet-perception-test";
    participant_ = std::make_unique<core::Participant>(options);
    perception_ = std::make_unique<FleetPerception>(*participant_, "op1");
    writer_ = std::make_unique<core::Writer<cairn_msgs::StaircaseDetectionPubSubType>>(
        *participant_, "cairn/staircase", "cairn.latched");
    matched_ = writer_->WaitForMatched(1, 5s);
  }

  bool matched() const { return matched_; }
  FleetPerception& perception() { return *perception_; }

  // Robot `robot`'s estimate of its staircase `id` (support_points: the scans it merged).
  void Report(const std::string& robot, std::uint32_t id, const Staircase& s) {
    cairn_msgs::StaircaseDetection m;
    m.robot_id(robot);
    m.staircase_id(id);
    m.p_M_first_step().x_m(s.p_W_first_step.x());
    m.p_M_first_step().y_m(s.p_W_first_step.y());
    m.p_M_first_step().z_m(s.p_W_first_step.z());
    m.yaw_rad(s.yaw_rad);
    m.rise_m(s.rise_m);
    m.run_m(s.run_m);
    m.width_m(s.width_m);
    m.num_steps(static_cast<std::uint16_t>(s.num_steps));
    m.confidence(s.confidence);
    m.detections(static_cast<std::uint32_t>(s.support_points));
    ASSERT_TRUE(writer_->Write(m));
  }

  // The events that come within 5 s until `count` have come (then 0.3 s more, to catch extra ones).
  std::vector<FleetEvent> WaitForEvents(std::size_t count) {
    std::vector<FleetEvent> events;
    const auto deadline = Clock::now() + 5s;
    while (events.size() < count && Clock::now() < deadline) {
      for (FleetEvent& e : perception_->TakeEvents()) events.push_back(std::move(e));
      std::this_thread::sleep_for(20ms);
    }
    std::this_thread::sleep_for(300ms);
    for (FleetEvent& e : perception_->TakeEvents()) events.push_back(std::move(e));
    return events;
  }

 private:
  std::unique_ptr<core::Participant> participant_;
  std::unique_ptr<FleetPerception> perception_;
  std::unique_ptr<core::Writer<cairn_msgs::StaircaseDetectionPubSubType>> writer_;
  bool matched_ = false;
};

// The fleet staircase with `id`, or null.
const perception::StaircaseRegistry::Entry* Find(
    const std::vector<perception::StaircaseRegistry::Entry>& entries, int id) {
  for (const auto& e : entries) {
    if (e.id == id) return &e;
  }
  return nullptr;
}

std::string Describe(const std::vector<FleetEvent>& events) {
  std::string text;
  for (const auto& e : events) text += "[" + e.kind + "] " + e.message + "\n";
  return text;
}

// The field report: a robot's view of the upper half of a flight was announced with an id that another
// staircase already had, then the ids moved between staircases as more detections came. An id names one
// staircase for good: kept while robots refine it, retired when it merges into an older one, never reused.
TEST(FleetPerceptionStaircases, AnIdAlwaysMeansOneStaircase) {
  Rig rig;
  ASSERT_TRUE(rig.matched());

  // r2 finds a flight in another room.
  rig.Report("r2", 1, OtherRoomFlight());
  std::vector<FleetEvent> events = rig.WaitForEvents(1);
  ASSERT_EQ(events.size(), 1u) << Describe(events);
  EXPECT_EQ(events[0].kind, "staircase");
  const int other_room = events[0].staircase.id;
  EXPECT_EQ(events[0].message.rfind(
                "new staircase " + std::to_string(other_room) + ": 5 steps at (12.00, 5.00, ", 0),
            0u)
      << events[0].message;

  // r1, at the top of the tunnels' flight, sees its upper three risers: a new staircase, a new id.
  rig.Report("r1", 1, PartOf(TunnelsFlight(), 2, 3));
  events = rig.WaitForEvents(1);
  ASSERT_EQ(events.size(), 1u) << Describe(events);
  EXPECT_EQ(events[0].kind, "staircase");
  const int upper = events[0].staircase.id;
  EXPECT_NE(upper, other_room);
  EXPECT_NEAR(events[0].staircase.staircase.p_W_first_step.x(), 51.0, 1e-6);
  auto entries = rig.perception().Staircases();
  ASSERT_EQ(entries.size(), 2u);
  ASSERT_NE(Find(entries, other_room), nullptr);
  EXPECT_NEAR(Find(entries, other_room)->staircase.p_W_first_step.x(), 12.0, 1e-6)
      << "the id moved to another staircase";
  ASSERT_NE(Find(entries, upper), nullptr);
  EXPECT_NEAR(Find(entries, upper)->staircase.p_W_first_step.x(), 51.0, 1e-6);

  // r3, at the foot, sees the lowest two risers only (no overlap with the upper three yet): another id.
  rig.Report("r3", 4, PartOf(TunnelsFlight(), 0, 2));
  events = rig.WaitForEvents(1);
  ASSERT_EQ(events.size(), 1u) << Describe(events);
  EXPECT_EQ(events[0].kind, "staircase");
  const int lower = events[0].staircase.id;
  EXPECT_NE(lower, upper);
  EXPECT_NE(lower, other_room);

  // r1 comes down and sees the whole flight: its staircase 1 grows down to the foot, and the two are one
  // flight. The younger id merges into the older one, and the operator is told.
  Staircase whole = TunnelsFlight();
  whole.support_points = 25;
  rig.Report("r1", 1, whole);
  events = rig.WaitForEvents(1);
  ASSERT_EQ(events.size(), 1u) << Describe(events);
  EXPECT_EQ(events[0].kind, "staircase_merged");
  EXPECT_EQ(events[0].staircase.id, std::min(upper, lower));
  EXPECT_EQ(events[0].merged_id, std::max(upper, lower));
  EXPECT_EQ(events[0].message.rfind("staircase " + std::to_string(std::max(upper, lower)) +
                                        " merged into staircase " + std::to_string(std::min(upper, lower)) +
                                        " (same flight): 5 steps at (50.00, ",
                                    0),
            0u)
      << events[0].message;
  EXPECT_NE(events[0].message.find("seen by r1, r3"), std::string::npos) << events[0].message;
  entries = rig.perception().Staircases();
  ASSERT_EQ(entries.size(), 2u);
  ASSERT_NE(Find(entries, upper), nullptr);
  EXPECT_EQ(Find(entries, lower), nullptr) << "a merged id is retired";
  EXPECT_NEAR(Find(entries, upper)->staircase.p_W_first_step.x(), 50.0, 1e-6);
  EXPECT_EQ(Find(entries, upper)->staircase.num_steps, 5);
  EXPECT_NEAR(Find(entries, other_room)->staircase.p_W_first_step.x(), 12.0, 1e-6);

  // A flight one floor up is a new staircase, with an id never used before (not the retired one).
  Staircase upstairs = TunnelsFlight();
  upstairs.p_W_first_step.z() += 3.0;
  rig.Report("r2", 2, upstairs);
  events = rig.WaitForEvents(1);
  ASSERT_EQ(events.size(), 1u) << Describe(events);
  EXPECT_EQ(events[0].kind, "staircase");
  EXPECT_GT(events[0].staircase.id, std::max({other_room, upper, lower}));
  entries = rig.perception().Staircases();
  ASSERT_EQ(entries.size(), 3u);
  EXPECT_NEAR(Find(entries, upper)->staircase.p_W_first_step.z(), 0.0, 1e-6);
  EXPECT_NEAR(Find(entries, other_room)->staircase.p_W_first_step.x(), 12.0, 1e-6);
}

}  // namespace
}  // namespace cairn::base
