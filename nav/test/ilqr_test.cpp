// Copyright Cairn authors.
#include "cairn/nav/ilqr.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

namespace cairn::nav {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kTol = 1e-9;

using Path = std::vector<Eigen::Vector2d>;

#define EXPECT_HAS(haystack, needle)                               \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) \
      << "'" << (haystack) << "' lacks '" << (needle) << "'"

IlqrState State(double x_m, double y_m, double yaw_rad, double v_mps = 0.0, double w_radps = 0.0) {
  IlqrState x;
  x << x_m, y_m, yaw_rad, v_mps, w_radps;
  return x;
}

// Platform stand-in: a velocity-commanded unicycle with the same limits as the controller, integrated at a
// finer step than the controller's model (velocities slew towards the command at the acceleration limits,
// then the pose advances at the mid-step heading).
class Platform {
 public:
  Platform(const IlqrLimits& limits, const IlqrState& x) : limits_(limits), x_(x) {}

  void Apply(double v_cmd_mps, double w_cmd_radps, double duration_s = 0.1, double step_s = 0.02) {
    const double v_cmd = std::clamp(v_cmd_mps, -limits_.max_reverse_speed_mps, limits_.max_speed_mps);
    const double w_cmd = std::clamp(w_cmd_radps, -limits_.max_yaw_rate_radps, limits_.max_yaw_rate_radps);
    const int steps = static_cast<int>(std::lround(duration_s / step_s));
    for (int i = 0; i < steps; ++i) {
      const double dv = limits_.max_accel_mps2 * step_s;
      const double dw = limits_.max_yaw_accel_radps2 * step_s;
      x_[3] += std::clamp(v_cmd - x_[3], -dv, dv);
      x_[4] += std::clamp(w_cmd - x_[4], -dw, dw);
      const double yaw_mid = x_[2] + 0.5 * x_[4] * step_s;
      x_[0] += x_[3] * step_s * std::cos(yaw_mid);
      x_[1] += x_[3] * step_s * std::sin(yaw_mid);
      x_[2] += x_[4] * step_s;
    }
  }
  const IlqrState& state() const { return x_; }

 private:
  IlqrLimits limits_;
  IlqrState x_;
};

// Distance from p to the polyline, metres.
double DistanceToPath(const Path& path, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.size(); ++i) {
    const Eigen::Vector2d ab = path[i + 1] - path[i];
    const double t = std::clamp((p - path[i]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (path[i] + t * ab - p).norm());
  }
  return best;
}

// Half circle of radius 2 m from (0, 0) heading +x, turning left, 5 degree chords.
Path Arc() {
  Path path;
  for (int i = 0; i <= 36; ++i) {
    const double a = -kPi / 2 + i * kPi / 36;
    path.emplace_back(2.0 * std::cos(a), 2.0 + 2.0 * std::sin(a));
  }
  return path;
}

Path LCorner() { return {{0.0, 0.0}, {3.0, 0.0}, {3.0, 3.0}}; }

struct DriveStats {
  IlqrState final_state;
  double max_cross_track_m = 0.0;
  int solves = 0;
  int warm_solves = 0;
  int unusable = 0;
};

// Closed loop: every 0.1 s solve from the platform state and apply the first command for 0.1 s.
DriveStats Drive(IlqrController* controller, const Path& path, const IlqrState& x0, double cruise_mps,
                 double duration_s) {
  Platform platform(controller->limits(), x0);
  DriveStats stats;
  const int cycles = static_cast<int>(std::lround(duration_s / 0.1));
  for (int c = 0; c < cycles; ++c) {
    const IlqrSolution sol = controller->Solve(platform.state(), path, cruise_mps, true, 0.1);
    ++stats.solves;
    if (sol.warm_started) ++stats.warm_solves;
    if (!sol.IsUsable()) ++stats.unusable;
    platform.Apply(sol.command_v_mps, sol.command_w_radps);
    stats.max_cross_track_m =
        std::max(stats.max_cross_track_m, DistanceToPath(path, platform.state().head<2>()));
  }
  stats.final_state = platform.state();
  return stats;
}

// Checks the invariants every usable solution promises: sizes, limits, model consistency, the command, the
// cost history.
void ExpectWellFormed(const IlqrSolution& sol, const IlqrOptions& options, const IlqrLimits& lim) {
  ASSERT_TRUE(sol.IsUsable()) << sol.message;
  const int n = options.horizon_steps;
  ASSERT_EQ(sol.states.size(), static_cast<std::size_t>(n + 1));
  ASSERT_EQ(sol.controls.size(), static_cast<std::size_t>(n));
  for (int k = 0; k <= n; ++k) {
    const IlqrState& x = sol.states[k];
    ASSERT_TRUE(x.allFinite()) << "k " << k;
    EXPECT_LE(x[3], lim.max_speed_mps + kTol) << "k " << k;
    EXPECT_GE(x[3], -lim.max_reverse_speed_mps - kTol) << "k " << k;
    EXPECT_LE(std::abs(x[4]), lim.max_yaw_rate_radps + kTol) << "k " << k;
  }
  for (int k = 0; k < n; ++k) {
    const IlqrControl& u = sol.controls[k];
    EXPECT_LE(std::abs(u[0]), lim.max_accel_mps2 + kTol) << "k " << k;
    EXPECT_LE(std::abs(u[1]), lim.max_yaw_accel_radps2 + kTol) << "k " << k;
    const IlqrState predicted = IlqrModelStep(sol.states[k], sol.controls[k], options.dt_s);
    EXPECT_LE((predicted - sol.states[k + 1]).cwiseAbs().maxCoeff(), kTol) << "k " << k;
  }
  EXPECT_EQ(sol.command_v_mps, sol.states[1][3]);
  EXPECT_EQ(sol.command_w_radps, sol.states[1][4]);
  if (sol.status != IlqrSolution::Status::kNoPath) {
    ASSERT_FALSE(sol.cost_history.empty());
    EXPECT_EQ(sol.cost_history.front(), sol.initial_cost);
    EXPECT_EQ(sol.cost_history.back(), sol.cost);
    for (std::size_t i = 1; i < sol.cost_history.size(); ++i) {
      EXPECT_LT(sol.cost_history[i], sol.cost_history[i - 1]) << "iteration " << i;
    }
  }
}

// ----------------------------------------------------------------------------------------------------------------

TEST(IlqrOptionsTest, DefaultsAreValidAndMessagesNameFieldValueAndRule) {
  std::string why;
  EXPECT_TRUE(IlqrOptions{}.IsValid(&why)) << why;
  EXPECT_TRUE(IlqrLimits{}.IsValid(&why)) << why;

  IlqrOptions options;
  options.dt_s = 0.0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "IlqrOptions::dt_s = 0 must be finite and in (0, 1]");
  EXPECT_THROW(IlqrController controller(options), std::invalid_argument);

  options = IlqrOptions{};
  options.horizon_steps = 0;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "IlqrOptions::horizon_steps = 0 must be in [1, 500]");

  options = IlqrOptions{};
  options.cross_track_weight = kNaN;
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_HAS(why, "IlqrOptions::cross_track_weight = nan must be finite");

  options = IlqrOptions{};
  options.accel_weight = 0.0;  // Must stay > 0: Quu positive definite.
  EXPECT_FALSE(options.IsValid(&why));
  EXPECT_EQ(why, "IlqrOptions::accel_weight = 0 must be finite and in (0, 1e+06]");

  IlqrLimits limits;
  limits.max_yaw_rate_radps = -1.0;
  EXPECT_FALSE(limits.IsValid(&why));
  EXPECT_EQ(why, "VelocityLimits::max_yaw_rate_radps = -1 must be finite and in (0, 20]");
  try {
    IlqrController controller(IlqrOptions{}, limits);
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_HAS(e.what(), "max_yaw_rate_radps = -1");
  }
  EXPECT_TRUE(IlqrOptions{}.IsValid(nullptr));
  EXPECT_FALSE(limits.IsValid(nullptr));
}

TEST(IlqrReferenceTest, StartsAtProjectionRampsUpAndStopsAtTheEnd) {
  const Path path = {{0.0, 0.0}, {2.0, 0.0}, {2.0, 2.0}};
  // From rest, 0.5 m left of the first segment; 10 s horizon: long enough to arrive.
  const auto ref = BuildIlqrReference(path, {0.5, 0.5}, 0.0, 0.6, true, 0.5, 100, 0.1);
  ASSERT_EQ(ref.size(), 101u);
  EXPECT_NEAR(ref[0].x_m, 0.5, 1e-12);
  EXPECT_NEAR(ref[0].y_m, 0.0, 1e-12);
  EXPECT_NEAR(ref[0].s_m, 0.5, 1e-12);
  EXPECT_EQ(ref[0].v_mps, 0.0);
  double v_max = 0.0;
  for (std::size_t k = 1; k < ref.size(); ++k) {
    EXPECT_LE(ref[k].v_mps - ref[k - 1].v_mps, 0.5 * 0.1 + 1e-12) << "k " << k;  // Accelerates gently.
    EXPECT_GE(ref[k].s_m, ref[k - 1].s_m);
    v_max = std::max(v_max, ref[k].v_mps);
  }
  EXPECT_NEAR(v_max, 0.6, 1e-12);
  EXPECT_NEAR(ref.back().x_m, 2.0, 1e-12);  // Stopped on the last point.
  EXPECT_NEAR(ref.back().y_m, 2.0, 1e-12);
  EXPECT_EQ(ref.back().v_mps, 0.0);
  EXPECT_NEAR(ref.back().yaw_rad, kPi / 2, 1e-12);  // Tangent of the last segment.
  EXPECT_NEAR(ref[1].yaw_rad, 0.0, 1e-12);

  // The path continues: cruise on beyond the end along the last segment.
  const auto cont = BuildIlqrReference(path, {0.5, 0.5}, 0.6, 0.6, false, 0.5, 100, 0.1);
  EXPECT_NEAR(cont.back().v_mps, 0.6, 1e-12);
  EXPECT_NEAR(cont.back().s_m, 0.5 + 6.0, 1e-9);
  EXPECT_NEAR(cont.back().x_m, 2.0, 1e-12);
  EXPECT_NEAR(cont.back().y_m, 6.5 - 2.0, 1e-9);

  EXPECT_THROW(BuildIlqrReference({{1.0, 1.0}, {1.0, 1.0}}, {0, 0}, 0, 0.5, true, 0.5, 10, 0.1),
               std::invalid_argument);
  EXPECT_THROW(BuildIlqrReference(path, {kNaN, 0}, 0, 0.5, true, 0.5, 10, 0.1), std::invalid_argument);
  EXPECT_THROW(BuildIlqrReference(path, {0, 0}, 0, -0.5, true, 0.5, 10, 0.1), std::invalid_argument);
}

TEST(IlqrModelTest, JacobiansMatchFiniteDifferences) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> value(-2.0, 2.0);
  for (int trial = 0; trial < 50; ++trial) {
    const IlqrState x = State(value(rng), value(rng), 3.0 * value(rng), value(rng), value(rng));
    const IlqrControl u(value(rng), value(rng));
    const double dt = 0.1;
    Eigen::Matrix<double, 5, 5> A;
    Eigen::Matrix<double, 5, 2> B;
    IlqrModelJacobians(x, u, dt, &A, &B);
    const double h = 1e-6;
    for (int i = 0; i < 5; ++i) {
      const IlqrState e = IlqrState::Unit(i) * h;
      const IlqrState column = (IlqrModelStep(x + e, u, dt) - IlqrModelStep(x - e, u, dt)) / (2.0 * h);
      EXPECT_LT((column - A.col(i)).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial << " d/dx" << i;
    }
    for (int i = 0; i < 2; ++i) {
      const IlqrControl e = IlqrControl::Unit(i) * h;
      const IlqrState column = (IlqrModelStep(x, u + e, dt) - IlqrModelStep(x, u - e, dt)) / (2.0 * h);
      EXPECT_LT((column - B.col(i)).cwiseAbs().maxCoeff(), 1e-8) << "trial " << trial << " d/du" << i;
    }
  }
  // Straight drive: 1 m/s for 0.1 s with 1 m/s^2 moves 0.105 m (mean speed 1.05 m/s).
  const IlqrState next = IlqrModelStep(State(0, 0, 0, 1.0, 0.0), IlqrControl(1.0, 0.0), 0.1);
  EXPECT_NEAR(next[0], 0.105, 1e-12);
  EXPECT_NEAR(next[3], 1.1, 1e-12);
}

TEST(IlqrControllerTest, ConvergesOnAStraightLineFromRest) {
  IlqrController controller;
  const IlqrSolution sol = controller.Solve(State(0, 0, 0), {{0.0, 0.0}, {5.0, 0.0}}, 0.6, true, 0.0);
  ExpectWellFormed(sol, controller.options(), controller.limits());
  EXPECT_EQ(sol.status, IlqrSolution::Status::kConverged) << sol.message;
  EXPECT_FALSE(sol.warm_started);
  EXPECT_GE(sol.cost_history.size(), 2u);
  EXPECT_LT(sol.cost, sol.initial_cost);
  EXPECT_GT(sol.command_v_mps, 0.0);
  EXPECT_NEAR(sol.command_w_radps, 0.0, 1e-9);
  for (const IlqrState& x : sol.states) EXPECT_NEAR(x[1], 0.0, 1e-9);
  EXPECT_HAS(sol.message, "kConverged");

  // A harder start (off the path, facing away from it, moving): more iterations, still monotone.
  controller.Reset();
  const IlqrSolution hard =
      controller.Solve(State(1.0, 1.0, 2.5, 0.4, -0.5), {{0.0, 0.0}, {5.0, 0.0}}, 0.6, true, 0.0);
  ExpectWellFormed(hard, controller.options(), controller.limits());
  EXPECT_EQ(hard.status, IlqrSolution::Status::kConverged) << hard.message;
  EXPECT_GE(hard.cost_history.size(), 3u);
  EXPECT_LT(hard.cost, 0.9 * hard.initial_cost);
}

TEST(IlqrControllerTest, TracksAnArcAndStopsAtItsEnd) {
  IlqrController controller;
  const Path path = Arc();
  const DriveStats stats = Drive(&controller, path, State(0, 0, 0), 0.6, 14.0);
  EXPECT_EQ(stats.unusable, 0);
  EXPECT_LT(stats.max_cross_track_m, 0.05);
  EXPECT_LT((stats.final_state.head<2>() - path.back()).norm(), 0.05);
  EXPECT_LT(std::abs(stats.final_state[3]), 0.02);
}

TEST(IlqrControllerTest, TracksAnLCornerAndStopsAtItsEnd) {
  IlqrController controller;
  const Path path = LCorner();
  const DriveStats stats = Drive(&controller, path, State(0, 0, 0), 0.6, 14.0);
  EXPECT_EQ(stats.unusable, 0);
  EXPECT_LT(stats.max_cross_track_m, 0.2);  // The corner is cut a little.
  EXPECT_LT((stats.final_state.head<2>() - path.back()).norm(), 0.05);
  EXPECT_LT(std::abs(stats.final_state[3]), 0.02);
}

TEST(IlqrControllerTest, ReachesAPathBehindTheRobot) {
  IlqrController controller;
  const Path path = {{0.0, 0.0}, {5.0, 0.0}};
  const DriveStats stats = Drive(&controller, path, State(0.0, 0.5, kPi), 0.6, 14.0);
  EXPECT_EQ(stats.unusable, 0);
  EXPECT_LT((stats.final_state.head<2>() - path.back()).norm(), 0.05);
}

TEST(IlqrControllerTest, RespectsLimitsOnRandomProblems) {
  std::mt19937 rng(20240611);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * unit(rng); };
  int solves = 0;
  for (int trial = 0; trial < 60; ++trial) {
    IlqrLimits lim;
    lim.max_speed_mps = uniform(0.3, 2.0);
    lim.max_reverse_speed_mps = trial % 3 == 0 ? 0.0 : uniform(0.1, 1.0);
    lim.max_accel_mps2 = uniform(0.3, 2.0);
    lim.max_yaw_rate_radps = uniform(0.5, 2.0);
    lim.max_yaw_accel_radps2 = uniform(0.5, 4.0);
    IlqrOptions options;
    options.horizon_steps = 10 + trial % 30;
    IlqrController controller(options, lim);
    Path path;
    const int points = 2 + trial % 5;
    for (int i = 0; i < points; ++i) path.emplace_back(uniform(-4, 4), uniform(-4, 4));
    // Start anywhere, velocities up to 30 % beyond the limits (clamped by the controller).
    IlqrState x0 = State(uniform(-4, 4), uniform(-4, 4), uniform(-2 * kPi, 2 * kPi),
                         uniform(-1.3 * lim.max_reverse_speed_mps, 1.3 * lim.max_speed_mps),
                         uniform(-1.3, 1.3) * lim.max_yaw_rate_radps);
    const double cruise = uniform(0.0, 1.5 * lim.max_speed_mps);
    const bool stop = trial % 2 == 0;
    Platform platform(lim, x0);
    for (int cycle = 0; cycle < 5; ++cycle) {  // A few closed-loop cycles: cold, then warm starts.
      const IlqrSolution sol = controller.Solve(platform.state(), path, cruise, stop, 0.1);
      SCOPED_TRACE("trial " + std::to_string(trial) + " cycle " + std::to_string(cycle) + ": " + sol.message);
      ExpectWellFormed(sol, options, lim);
      EXPECT_NE(sol.status, IlqrSolution::Status::kStalled);
      platform.Apply(sol.command_v_mps, sol.command_w_radps);
      ++solves;
    }
  }
  EXPECT_EQ(solves, 300);
}

TEST(IlqrControllerTest, HoldsTheSpeedLimitWhenCruisingAtIt) {
  IlqrLimits lim;
  lim.max_speed_mps = 0.8;
  IlqrController controller(IlqrOptions{}, lim);
  // Asks for more than the limit on a long straight path: v runs into the bound and stays there.
  const IlqrSolution sol = controller.Solve(State(0, 0, 0, 0.8), {{0.0, 0.0}, {50.0, 0.0}}, 5.0, false, 0.0);
  ExpectWellFormed(sol, controller.options(), lim);
  EXPECT_EQ(sol.status, IlqrSolution::Status::kConverged) << sol.message;
  for (const IlqrState& x : sol.states) EXPECT_NEAR(x[3], 0.8, 1e-6);
}

TEST(IlqrControllerTest, WarmStartsNeedFewerIterationsAndGiveCloseCommands) {
  for (const Path& path : {Arc(), LCorner()}) {
    IlqrController warm;
    IlqrController cold;
    Platform platform(warm.limits(), State(0, 0, 0));
    int warm_iterations = 0;
    int cold_iterations = 0;
    int warm_started = 0;
    const int cycles = 120;
    for (int c = 0; c < cycles; ++c) {
      const IlqrSolution w = warm.Solve(platform.state(), path, 0.6, true, 0.1);
      cold.Reset();
      const IlqrSolution k = cold.Solve(platform.state(), path, 0.6, true, 0.1);
      ASSERT_TRUE(w.IsUsable() && k.IsUsable());
      EXPECT_FALSE(k.warm_started);
      if (w.warm_started) ++warm_started;
      warm_iterations += w.iterations;
      cold_iterations += k.iterations;
      EXPECT_NEAR(w.command_v_mps, k.command_v_mps, 0.01) << "cycle " << c;
      EXPECT_NEAR(w.command_w_radps, k.command_w_radps, 0.02) << "cycle " << c;
      platform.Apply(w.command_v_mps, w.command_w_radps);
    }
    EXPECT_GE(warm_started, cycles * 9 / 10);
    EXPECT_LT(warm_iterations, cold_iterations);
  }
}

TEST(IlqrControllerTest, WarmStartIsFrameIndependent) {
  // One controller gets everything in the world frame W, the other the path in the body frame B of each cycle
  // (x0 = (0, 0, 0, v, w)): their commands must agree, warm starts included.
  IlqrController in_world;
  IlqrController in_body;
  const Path path_W = Arc();
  Platform platform(in_world.limits(), State(0.1, -0.1, 0.2));
  for (int c = 0; c < 60; ++c) {
    const IlqrState& x_W = platform.state();
    Eigen::Matrix2d R_WB;
    R_WB << std::cos(x_W[2]), -std::sin(x_W[2]), std::sin(x_W[2]), std::cos(x_W[2]);
    const Eigen::Vector2d p_WB = x_W.head<2>();
    Path path_B;
    for (const Eigen::Vector2d& p_W : path_W) path_B.push_back(R_WB.transpose() * (p_W - p_WB));
    const IlqrSolution a = in_world.Solve(x_W, path_W, 0.6, true, 0.1);
    const IlqrSolution b = in_body.Solve(State(0, 0, 0, x_W[3], x_W[4]), path_B, 0.6, true, 0.1);
    EXPECT_EQ(a.warm_started, b.warm_started) << "cycle " << c;
    EXPECT_EQ(a.iterations, b.iterations) << "cycle " << c;
    EXPECT_NEAR(a.command_v_mps, b.command_v_mps, 1e-6) << "cycle " << c;
    EXPECT_NEAR(a.command_w_radps, b.command_w_radps, 1e-6) << "cycle " << c;
    platform.Apply(a.command_v_mps, a.command_w_radps);
  }
}

TEST(IlqrControllerTest, ColdStartsWithoutAUsableWarmStart) {
  IlqrController controller;
  const Path path = {{0.0, 0.0}, {5.0, 0.0}};
  EXPECT_FALSE(controller.has_warm_start());
  const IlqrSolution first = controller.Solve(State(0, 0, 0), path, 0.6, true, 0.1);
  EXPECT_FALSE(first.warm_started);
  EXPECT_TRUE(controller.has_warm_start());
  // Where the plan said the robot would be after one step: the shifted plan is the better guess.
  const IlqrSolution second = controller.Solve(first.states[1], path, 0.6, true, 0.1);
  EXPECT_TRUE(second.warm_started);
  EXPECT_LE(second.iterations, first.iterations);
  // Longer ago than the horizon: nothing left to shift.
  EXPECT_FALSE(controller.Solve(second.states[1], path, 0.6, true, 3.0).warm_started);
  controller.Reset();
  EXPECT_FALSE(controller.has_warm_start());
  EXPECT_FALSE(controller.Solve(second.states[1], path, 0.6, true, 0.1).warm_started);
}

TEST(IlqrControllerTest, RejectsNonFiniteInputWithAZeroCommand) {
  IlqrController controller;
  const Path path = {{0.0, 0.0}, {5.0, 0.0}};
  ASSERT_TRUE(controller.Solve(State(0, 0, 0), path, 0.6, true, 0.0).IsUsable());
  ASSERT_TRUE(controller.has_warm_start());

  IlqrSolution sol = controller.Solve(State(0, 0, kNaN, 0.5, 0.1), path, 0.6, true, 0.1);
  EXPECT_EQ(sol.status, IlqrSolution::Status::kInvalidInput);
  EXPECT_FALSE(sol.IsUsable());
  EXPECT_EQ(sol.command_v_mps, 0.0);
  EXPECT_EQ(sol.command_w_radps, 0.0);
  EXPECT_TRUE(sol.states.empty());
  EXPECT_EQ(sol.message, "x0[2] (yaw_rad) = nan is not finite");
  EXPECT_FALSE(controller.has_warm_start());

  sol = controller.Solve(State(0, 0, 0), {{0.0, 0.0}, {1.0, std::numeric_limits<double>::infinity()}}, 0.6,
                         true, 0.1);
  EXPECT_EQ(sol.status, IlqrSolution::Status::kInvalidInput);
  EXPECT_EQ(sol.command_v_mps, 0.0);
  EXPECT_EQ(sol.message, "path_F[1] = (1, inf) is not finite");

  sol = controller.Solve(State(0, 0, 0), path, kNaN, true, 0.1);
  EXPECT_EQ(sol.status, IlqrSolution::Status::kInvalidInput);
  EXPECT_EQ(sol.message, "cruise_speed_mps = nan must be finite and >= 0");

  sol = controller.Solve(State(0, 0, 0), path, 0.6, true, -0.1);
  EXPECT_EQ(sol.status, IlqrSolution::Status::kInvalidInput);
  EXPECT_EQ(sol.message, "elapsed_since_last_solve_s = -0.1 must be finite and >= 0");
  EXPECT_EQ(std::string(ToString(sol.status)), "kInvalidInput");
}

TEST(IlqrControllerTest, BrakesToRestWithoutAPath) {
  IlqrController controller;
  const IlqrState moving = State(1.0, 2.0, 0.3, 0.8, -0.9);
  for (const Path& path : {Path{}, Path{{4.0, 4.0}}, Path{{4.0, 4.0}, {4.0, 4.0}}}) {
    const IlqrSolution sol = controller.Solve(moving, path, 0.6, true, 0.1);
    ExpectWellFormed(sol, controller.options(), controller.limits());
    EXPECT_EQ(sol.status, IlqrSolution::Status::kNoPath);
    EXPECT_HAS(sol.message, "braking to rest");
    EXPECT_FALSE(controller.has_warm_start());
    // Braking at the limits: 0.8 m/s at 1 m/s^2, 0.9 rad/s at 3 rad/s^2.
    EXPECT_NEAR(sol.command_v_mps, 0.7, 1e-12);
    EXPECT_NEAR(sol.command_w_radps, -0.6, 1e-12);
    EXPECT_EQ(sol.states.back()[3], 0.0);
    EXPECT_EQ(sol.states.back()[4], 0.0);
    EXPECT_LT((sol.states.back().head<2>() - moving.head<2>()).norm(), 0.8 * 0.8 / 2.0 + 1e-9);
  }
}

}  // namespace
}  // namespace cairn::nav
