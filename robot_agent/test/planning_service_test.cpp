// The planning service without DDS or threads: the holder's goals before peers' queries, the per-process rate
// limit and the queue bound with the answers they give, and the answers to queries.
#include "cairn/agent/services/planning_service.h"

#include <gtest/gtest.h>

#include "../../nav/test/nav_test_util.h"
#include "cairn/agent/services/nav_map.h"

namespace cairn::agent {
namespace {

const core::SteadyTime kT0 = core::SteadyTime{} + std::chrono::seconds(100);

core::SteadyTime At(double s) {
  return kT0 + std::chrono::duration_cast<core::SteadyClock::duration>(std::chrono::duration<double>(s));
}

// A service on an empty navigation map (unknown space is traversable), recording what it hands on.
struct Service {
  explicit Service(double queries_per_s = 2.0, std::size_t max_waiting = 32) {
    NavMapOptions map;
    map.half_extent_m = 10.0;
    planner = NavMap::MakePlanner(map, 0.1, core::BaseState{}, {nav::GetPlatformProfile("wheeled")});
    PlanningServiceOptions o;
    o.robot_id = "r1";
    o.platform = "wheeled";
    o.path_queries_per_s = queries_per_s;
    o.max_waiting_queries = max_waiting;
    o.map_max_extent_m = 20.0;
    service = std::make_unique<PlanningService>(
        o, planner,
        PlanningService::Hooks{[this](const GoalCommand& g, const nav::GlobalPlan& p) {
                                 order.push_back("goal " + std::to_string(g.request_id));
                                 goal_plans.push_back(p);
                               },
                               [this](const PathAnswer& a) {
                                 order.push_back("query " + std::to_string(a.request_id));
                                 answers.push_back(a);
                               },
                               [this](const Eigen::Vector2d& goal_M) {
                                 covered.push_back(goal_M);
                                 return goal_M.x() > 50.0
                                            ? std::string("too far: navigation.map_max_extent_m")
                                            : std::string();
                               },
                               {}});
  }
  static PathQuery Query(uint32_t id, const std::string& participant = "pA", double x = 3.0) {
    PathQuery q;
    q.participant = participant;
    q.request_id = id;
    q.requester_id = "opA";
    q.frame_id = "map";
    q.goal_M = {x, 1.0};
    return q;
  }

  std::shared_ptr<nav::GlobalPlanner> planner;
  std::unique_ptr<PlanningService> service;
  std::vector<std::string> order;
  std::vector<nav::GlobalPlan> goal_plans;
  std::vector<PathAnswer> answers;
  std::vector<Eigen::Vector2d> covered;  // goals the cover hook was asked about
};

TEST(PlanningService, TheHoldersGoalsGoBeforePeersQueries) {
  Service s;
  s.service->SubmitPathQuery(Service::Query(1), At(0));
  nav::GlobalPlanRequest goal;
  goal.goal_W = {4.0, 0.0};
  goal.platform = "wheeled";
  s.service->SubmitGoal(GoalCommand{CommandSender{"opA", "pA", "wA"}, 9, "map", 4.0, 0.0, 0.0}, goal);
  EXPECT_TRUE(s.service->RunOnce(std::chrono::milliseconds(0)));
  EXPECT_TRUE(s.service->RunOnce(std::chrono::milliseconds(0)));
  EXPECT_FALSE(s.service->RunOnce(std::chrono::milliseconds(0))) << "nothing left";
  EXPECT_EQ(s.order, (std::vector<std::string>{"goal 9", "query 1"}));
  ASSERT_EQ(s.goal_plans.size(), 1u);
  EXPECT_TRUE(s.goal_plans[0].IsUsable()) << s.goal_plans[0].reason;
}

TEST(PlanningService, AFloodFromOneProcessIsRefusedOnceASecondAndOthersAreNotHeldUp) {
  Service s(2.0);  // 2 per second, burst 4
  for (uint32_t id = 1; id <= 6; ++id) s.service->SubmitPathQuery(Service::Query(id), At(0));
  ASSERT_EQ(s.answers.size(), 1u) << "one refusal says why; the rest of the flood is dropped unanswered";
  EXPECT_EQ(s.answers[0].request_id, 5u);
  EXPECT_EQ(s.answers[0].status, "kRateLimited");
  EXPECT_EQ(s.answers[0].reason, "rate limited: more than 2 path requests/s (burst 4) from this process");
  EXPECT_EQ(s.answers[0].requester_participant, "pA");
  EXPECT_FALSE(s.answers[0].success);
  EXPECT_EQ(s.service->queries_refused(), 2u);
  s.service->SubmitPathQuery(Service::Query(7, "pB"), At(0));
  EXPECT_EQ(s.answers.size(), 1u) << "another process has its own budget";
  s.service->SubmitPathQuery(Service::Query(8), At(0.6));  // one token back
  EXPECT_EQ(s.answers.size(), 1u);
  while (s.service->RunOnce(std::chrono::milliseconds(0))) {
  }
  EXPECT_EQ(s.answers.size(), 7u) << "1 refusal + 4 + 1 + 1 answered";
}

TEST(PlanningService, AFullQueueIsBusy) {
  Service s(100.0, 2);
  for (uint32_t id = 1; id <= 3; ++id) s.service->SubmitPathQuery(Service::Query(id), At(0));
  ASSERT_EQ(s.answers.size(), 1u);
  EXPECT_EQ(s.answers[0].request_id, 3u);
  EXPECT_EQ(s.answers[0].reason, "busy: 2 path requests are waiting");
}

TEST(PlanningService, AnswersNameTheFrameThePlatformOrTheMapExtent) {
  Service s(100.0);
  PathQuery odom = Service::Query(1);
  odom.frame_id = "odom";
  PathQuery hover = Service::Query(2);
  hover.platform = "hovercraft";
  s.service->SubmitPathQuery(odom, At(0));
  s.service->SubmitPathQuery(hover, At(0));
  s.service->SubmitPathQuery(Service::Query(3), At(0));
  s.service->SubmitPathQuery(Service::Query(4, "pA", 30.0), At(0));  // beyond the 10 m half extent
  while (s.service->RunOnce(std::chrono::milliseconds(0))) {
  }
  ASSERT_EQ(s.answers.size(), 4u);
  EXPECT_EQ(s.answers[0].status, "kInvalidFrame");
  EXPECT_EQ(s.answers[0].reason, "frame_id 'odom' is not supported (use 'map')");
  EXPECT_EQ(s.answers[1].status, "kUnknownPlatform");
  EXPECT_FALSE(s.answers[1].success);
  EXPECT_TRUE(s.answers[2].success) << s.answers[2].reason;
  EXPECT_GE(s.answers[2].path_M.size(), 2u);
  EXPECT_GT(s.answers[2].length_m, 2.9);
  EXPECT_FALSE(s.answers[3].success);
  EXPECT_NE(s.answers[3].reason.find("up to 20 m along x and y: navigation.map_max_extent_m = 20)"),
            std::string::npos)
      << s.answers[3].reason;
  EXPECT_TRUE(s.covered.empty()) << "path queries do not grow the map";
}

// A goal beyond the navigation map is planned to the map's edge toward it (a partial plan, extended as the
// map grows over it); one the map cannot grow to is refused with the cover hook's reason, unplanned.
TEST(PlanningService, GoalsBeyondTheMapArePlannedToItsEdgeOrRefused) {
  Service s;
  nav::GlobalPlanRequest beyond;
  beyond.goal_W = {25.0, 2.0};
  beyond.platform = "wheeled";
  beyond.allow_partial = true;
  beyond.start_is_robot = true;
  s.service->SubmitGoal(GoalCommand{CommandSender{"opA", "pA", "wA"}, 1, "map", 25.0, 2.0, 0.0}, beyond);
  nav::GlobalPlanRequest too_far = beyond;
  too_far.goal_W = {80.0, 0.0};
  s.service->SubmitGoal(GoalCommand{CommandSender{"opA", "pA", "wA"}, 2, "map", 80.0, 0.0, 0.0}, too_far);
  while (s.service->RunOnce(std::chrono::milliseconds(0))) {
  }
  ASSERT_EQ(s.goal_plans.size(), 2u);
  ASSERT_EQ(s.covered.size(), 2u);
  const nav::GlobalPlan& edge = s.goal_plans[0];
  ASSERT_TRUE(edge.IsUsable()) << edge.reason;
  EXPECT_TRUE(edge.result.partial);
  EXPECT_NE(edge.result.message.find("beyond the navigation map"), std::string::npos) << edge.result.message;
  // The map spans the start +- 10 m: the plan ends 1 m inside its edge, toward the goal.
  EXPECT_NEAR(edge.result.path_W.back().x(), 9.0, 0.15);
  EXPECT_NEAR(edge.result.path_W.back().y(), 2.0, 0.15);
  const nav::GlobalPlan& refused = s.goal_plans[1];
  EXPECT_FALSE(refused.IsUsable());
  EXPECT_EQ(refused.result.status, nav::PlanResult::Status::kOutOfMap);
  EXPECT_EQ(s.service->PlanReason(refused), "too far: navigation.map_max_extent_m");
}

// A goal the robot's map knows is inside an obstacle is refused at once, naming the nearest free point; a
// goal where the map has seen nothing is accepted with a notice; a goal on seen floor with none.
TEST(PlanningService,
     AGoalInsideAnObstacleIsRefusedNamingTheNearestFreePointAndAnUnmappedOneComesWithANotice) {
  sim::World world = nav::testing::FlatWorld(16, 8);
  nav::testing::FillBox(&world, {10.0, 2.0, 0.0}, {12.0, 6.0, 1.6});  // rock the robot saw
  nav::testing::FillBox(&world, {13.0, 0.0, -0.2}, {16.0, 8.0, 1.6}, /*occupied=*/false);  // not seen
  nav::GlobalPlannerOptions options;
  options.reading.unknown_is_lethal = false;  // as the robot reads its own map
  const auto planner = std::make_shared<nav::GlobalPlanner>(
      std::make_shared<const sim::World>(std::move(world)),
      std::vector<nav::PlatformProfile>{nav::GetPlatformProfile("wheeled")}, options);
  std::vector<nav::GlobalPlan> plans;
  PlanningServiceOptions o;
  o.robot_id = "r2";
  o.platform = "wheeled";
  PlanningService service(
      o, planner,
      PlanningService::Hooks{[&](const GoalCommand&, const nav::GlobalPlan& p) { plans.push_back(p); },
                             [](const PathAnswer&) {},
                             {},
                             {}});
  auto submit = [&](uint32_t id, double x, double y) {
    nav::GlobalPlanRequest request;
    request.start_W = {2.0, 4.0};
    request.goal_W = {x, y};
    request.platform = "wheeled";
    request.start_is_robot = true;
    request.allow_partial = true;
    service.SubmitGoal(GoalCommand{CommandSender{"opA", "pA", "wA"}, id, "map", x, y, 0.0}, request);
    EXPECT_TRUE(service.RunOnce(std::chrono::milliseconds(0)));
  };
  submit(1, 10.5, 3.52);
  submit(2, 14.5, 4.0);
  submit(3, 6.0, 4.0);
  ASSERT_EQ(plans.size(), 3u);
  EXPECT_FALSE(plans[0].IsUsable());
  const std::string reason = service.PlanReason(plans[0]);
  EXPECT_EQ(
      reason,
      "goal (10.50, 3.52) is inside an obstacle on r2's map (cell state obstacle); nearest free point (9.65, "
      "3.55)");
  // The block's west face is at x = 10: cells are free of it for the 0.3 m radius from centre x = 9.65.
  EXPECT_NEAR(plans[0].nearest_free_W.x(), 9.65, 0.01) << reason;
  EXPECT_NEAR(plans[0].nearest_free_W.y(), 3.55, 0.01) << reason;
  EXPECT_EQ(GoalNotice("r2", plans[0]), "");
  ASSERT_TRUE(plans[1].IsUsable()) << plans[1].reason;
  EXPECT_EQ(GoalNotice("r2", plans[1]), "goal in unmapped space: r2 will look");
  ASSERT_TRUE(plans[2].IsUsable()) << plans[2].reason;
  EXPECT_EQ(GoalNotice("r2", plans[2]), "");
}

// A goal on another level the planner finds no route to, with no step in its reason, is told of the nearest
// detected staircase the platform cannot climb.
TEST(PlanningService, AnUnreachableLevelNamesTheNearestStaircaseThePlatformCannotClimb) {
  Service s;
  const auto flight = [](double x, double rise_m) {
    perception::Staircase f;
    f.p_W_first_step = Eigen::Vector3d(x, 1.0, 0.0);
    f.rise_m = rise_m;
    f.run_m = 0.3;
    f.width_m = 1.0;
    f.num_steps = 6;
    return f;
  };
  // Nearest to (0, 1): a 0.12 m flight the wheeled robot climbs, then a 0.2 m one at x = 4, another at x = 8.
  const std::vector<perception::Staircase> seen = {flight(8.0, 0.2), flight(1.0, 0.12), flight(4.0, 0.2)};
  EXPECT_EQ(
      PlanningService::StairNote(*s.planner, "wheeled", seen, {0.0, 1.0}),
      "; the staircase seen at (4.00, 1.00, 0.00) rises 0.20 m per step, above platform wheeled's max_step_m "
      "0.15 m");
  EXPECT_EQ(PlanningService::StairNote(*s.planner, "wheeled", {flight(1.0, 0.12)}, {0.0, 1.0}), "");
  EXPECT_EQ(PlanningService::StairNote(*s.planner, "wheeled", {}, {0.0, 1.0}), "");
  EXPECT_EQ(PlanningService::StairNote(*s.planner, "hovercraft", seen, {0.0, 1.0}), "");
}

TEST(PlanningService, RefusesANullPlannerMissingHooksAndABadRate) {
  Service s;
  PlanningService::Hooks hooks{
      [](const GoalCommand&, const nav::GlobalPlan&) {}, [](const PathAnswer&) {}, {}, {}};
  EXPECT_THROW(PlanningService(PlanningServiceOptions{}, nullptr, hooks), std::invalid_argument);
  EXPECT_THROW(PlanningService(PlanningServiceOptions{}, s.planner, PlanningService::Hooks{}),
               std::invalid_argument);
  PlanningServiceOptions zero;
  zero.path_queries_per_s = 0.0;
  EXPECT_THROW(PlanningService(zero, s.planner, hooks), std::invalid_argument);
}

}  // namespace
}  // namespace cairn::agent
