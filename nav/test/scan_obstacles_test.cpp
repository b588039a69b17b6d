// ObstaclesFromPoints: walls and too high steps are obstacles, the floor and a ceiling are not, and the
// platform's step height decides a staircase.
#include "cairn/nav/scan_obstacles.h"

#include <gtest/gtest.h>

#include <cmath>

namespace cairn::nav {
namespace {

// A dense floor patch (points every 2 cm) over [x0, x1] x [y0, y1] at height z, frame M.
void AddPatch(double x0, double x1, double y0, double y1, double z, std::vector<Eigen::Vector3f>* points) {
  for (double x = x0; x <= x1 + 1e-9; x += 0.02) {
    for (double y = y0; y <= y1 + 1e-9; y += 0.02) points->emplace_back(x, y, z);
  }
}

// A vertical face at x = x_face over [y0, y1], from z0 to z1.
void AddFace(double x_face, double y0, double y1, double z0, double z1,
             std::vector<Eigen::Vector3f>* points) {
  for (double y = y0; y <= y1 + 1e-9; y += 0.02) {
    for (double z = z0; z <= z1 + 1e-9; z += 0.02) points->emplace_back(x_face, y, z);
  }
}

bool AnyObstacleNear(const std::vector<Eigen::Vector3f>& points_B, double x_B, double y_B, double radius_m) {
  for (const auto& p : points_B) {
    if (std::hypot(p.x() - x_B, p.y() - y_B) <= radius_m) return true;
  }
  return false;
}

TEST(ScanObstaclesTest, FloorAndCeilingAreFreeAWallIsAnObstacleInTheBodyFrame) {
  std::vector<Eigen::Vector3f> points_M;
  AddPatch(8.0, 12.0, 3.0, 7.0, 0.0, &points_M);  // floor around the robot at (10, 5)
  AddPatch(8.0, 12.0, 3.0, 7.0, 2.5, &points_M);  // ceiling 2.5 m up: above the robot's height
  AddFace(11.5, 3.0, 7.0, 0.0, 2.5, &points_M);   // a wall 1.5 m ahead (frame M +x)
  core::BaseState pose;
  pose.x_m = 10.0;
  pose.y_m = 5.0;
  pose.yaw_rad = M_PI / 2;  // facing +y of M: the wall is on the robot's right (-y of B)
  std::vector<Eigen::Vector3f> points_B;
  const ScanObstacleStats stats = ObstaclesFromPoints(points_M, pose, ScanObstacleOptions{}, &points_B);
  EXPECT_GT(stats.cells_observed, 1000);
  ASSERT_FALSE(points_B.empty());
  for (const auto& p : points_B) {
    EXPECT_NEAR(p.y(), -1.5, 0.1) << "obstacle at (" << p.x() << ", " << p.y() << ") is not the wall";
    EXPECT_EQ(p.z(), 0.0f);
  }
  EXPECT_TRUE(AnyObstacleNear(points_B, 0.0, -1.5, 0.1));
}

TEST(ScanObstaclesTest, AStepHigherThanThePlatformClimbsIsAnObstacleALowerOneIsNot) {
  std::vector<Eigen::Vector3f> points_M;
  AddPatch(0.0, 2.0, -1.0, 1.0, 0.0, &points_M);  // floor
  AddFace(2.0, -1.0, 1.0, 0.0, 0.2, &points_M);   // a 0.2 m riser
  AddPatch(2.0, 3.0, -1.0, 1.0, 0.2, &points_M);  // its tread
  core::BaseState pose;                           // at the origin, facing +x
  std::vector<Eigen::Vector3f> points_B;
  ScanObstacleOptions wheeled;
  wheeled.max_step_m = 0.15;
  ObstaclesFromPoints(points_M, pose, wheeled, &points_B);
  EXPECT_TRUE(AnyObstacleNear(points_B, 2.05, 0.0, 0.1)) << "the 0.2 m step must stop a 0.15 m climber";
  ScanObstacleOptions legged;
  legged.max_step_m = 0.25;
  ObstaclesFromPoints(points_M, pose, legged, &points_B);
  EXPECT_TRUE(points_B.empty()) << points_B.size() << " obstacles for a platform that climbs 0.25 m";
}

// The nearest obstacle is where the surface is, whatever the robot's position modulo a cell: a cell centre
// lies up to half a cell (5 cm) off the face, which in a 1.0 m doorway decides whether a 0.6 m robot fits.
// A robot on a landing (z 1.6) at the foot of a flight whose side wall reaches down past the landing to the
// floor below (its lower face seen from that floor earlier): the wall is an obstacle, the first tread beside
// it is not (a wall's lowest point is not ground the tread stands a step above).
TEST(ScanObstaclesTest, AWallReachingDownBesideAFlightLeavesItsTreadsClimbable) {
  std::vector<Eigen::Vector3f> points_M;
  AddPatch(-1.0, 0.5, -0.5, 0.5, 1.6, &points_M);  // the landing
  AddPatch(0.5, 1.5, -0.5, 0.5, 1.8, &points_M);   // the first tread, 0.2 m up
  AddFace(0.5, -0.5, 0.5, 1.6, 1.8, &points_M);    // its riser
  for (double x = -1.0; x <= 1.5 + 1e-9; x += 0.02) {
    for (double z = 0.3; z <= 2.6 + 1e-9; z += 0.02) points_M.emplace_back(x, 0.55, z);  // the side wall
  }
  core::BaseState pose;
  pose.z_m = 1.6;
  ScanObstacleOptions legged;
  legged.max_step_m = 0.3;
  std::vector<Eigen::Vector3f> points_B;
  ObstaclesFromPoints(points_M, pose, legged, &points_B);
  EXPECT_TRUE(AnyObstacleNear(points_B, 1.0, 0.55, 0.06)) << "the wall";
  for (const auto& p : points_B) {
    EXPECT_GT(p.y(), 0.53) << "obstacle at (" << p.x() << ", " << p.y() << ") on the landing or the tread";
  }
}

TEST(ScanObstaclesTest, TheNearestObstacleLiesOnTheSurfaceWhereverTheRobotStandsInItsCell) {
  std::vector<Eigen::Vector3f> points_M;
  AddPatch(-1.0, 3.0, -1.0, 1.0, 0.0, &points_M);
  AddFace(1.5, -1.0, 1.0, 0.0, 1.0, &points_M);  // a wall at x = 1.5
  double worst_m = 0.0;
  for (double x = 0.0; x < 0.1; x += 0.01) {
    core::BaseState pose;
    pose.x_m = x;
    std::vector<Eigen::Vector3f> points_B;
    ObstaclesFromPoints(points_M, pose, ScanObstacleOptions{}, &points_B);
    ASSERT_FALSE(points_B.empty());
    double nearest = 1e9;
    for (const auto& p : points_B) nearest = std::min(nearest, static_cast<double>(p.head<2>().norm()));
    worst_m = std::max(worst_m, std::abs(nearest - (1.5 - x)));
    for (const auto& p : points_B) EXPECT_GE(p.x(), 1.5 - x - 1e-4) << "an obstacle in front of the wall";
  }
  EXPECT_LT(worst_m, 1e-3) << "the nearest obstacle is " << worst_m << " m off the wall";
}

TEST(ScanObstaclesTest, BadInputIsNamedOrSkipped) {
  std::vector<Eigen::Vector3f> points_B;
  ScanObstacleOptions o;
  o.cell_size_m = 0;
  EXPECT_THROW(ObstaclesFromPoints({}, core::BaseState{}, o, &points_B), std::invalid_argument);
  std::string why;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("ScanObstacleOptions::cell_size_m = 0"), std::string::npos) << why;
  EXPECT_THROW(ObstaclesFromPoints({}, core::BaseState{}, ScanObstacleOptions{}, nullptr),
               std::invalid_argument);
  const float nan = std::nanf("");
  const std::vector<Eigen::Vector3f> bad = {{nan, 0, 0}, {1, nan, 5}, {1, 1, nan}};
  const ScanObstacleStats stats =
      ObstaclesFromPoints(bad, core::BaseState{}, ScanObstacleOptions{}, &points_B);
  EXPECT_EQ(stats.points_used, 0);
  EXPECT_TRUE(points_B.empty());
}

}  // namespace
}  // namespace cairn::nav
