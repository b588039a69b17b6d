// iLQR tracking benchmark: solve time of cairn::nav::IlqrController (horizon 30, dt 0.1 s) warm-started in a
// closed loop along a path, against the baseline of cold solves of the same problems (same initial states, a
// second controller reset before each solve), measured in the same run. Prints medians, means, 90th
// percentiles, iteration counts and the ratios warm/cold. Usage: cairn_bench_ilqr [--laps N]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

#include "cairn/nav/ilqr.h"

namespace {

using Clock = std::chrono::steady_clock;
using cairn::nav::IlqrController;
using cairn::nav::IlqrLimits;
using cairn::nav::IlqrSolution;
using cairn::nav::IlqrState;
constexpr double kPi = 3.14159265358979323846;

struct Stats {
  double mean_ms = 0.0;
  double median_ms = 0.0;
  double p90_ms = 0.0;
  double max_ms = 0.0;
};

Stats Summarize(std::vector<double> samples_ms) {
  std::sort(samples_ms.begin(), samples_ms.end());
  Stats s;
  s.median_ms = samples_ms[samples_ms.size() / 2];
  s.p90_ms = samples_ms[std::min(samples_ms.size() - 1, samples_ms.size() * 9 / 10)];
  s.max_ms = samples_ms.back();
  double sum = 0.0;
  for (double v : samples_ms) sum += v;
  s.mean_ms = sum / static_cast<double>(samples_ms.size());
  return s;
}

// A 15 m course (frame W): 3 m straight, a 90 degree left arc of radius 2 m, 3 m straight, a sharp right
// corner, 4 m straight to the goal.
std::vector<Eigen::Vector2d> Course() {
  std::vector<Eigen::Vector2d> path;
  for (int i = 0; i <= 6; ++i) path.emplace_back(0.5 * i, 0.0);
  for (int i = 1; i <= 18; ++i) {
    const double a = -kPi / 2 + i * (kPi / 2) / 18;
    path.emplace_back(3.0 + 2.0 * std::cos(a), 2.0 + 2.0 * std::sin(a));
  }
  for (int i = 1; i <= 6; ++i) path.emplace_back(5.0, 2.0 + 0.5 * i);
  for (int i = 1; i <= 8; ++i) path.emplace_back(5.0 + 0.5 * i, 5.0);
  return path;
}

// Velocity-commanded platform with the controller's limits, integrated at 0.02 s.
void Apply(const IlqrLimits& lim, double v_cmd, double w_cmd, IlqrState* x) {
  v_cmd = std::clamp(v_cmd, -lim.max_reverse_speed_mps, lim.max_speed_mps);
  w_cmd = std::clamp(w_cmd, -lim.max_yaw_rate_radps, lim.max_yaw_rate_radps);
  const double h = 0.02;
  for (int i = 0; i < 5; ++i) {
    (*x)[3] += std::clamp(v_cmd - (*x)[3], -lim.max_accel_mps2 * h, lim.max_accel_mps2 * h);
    (*x)[4] += std::clamp(w_cmd - (*x)[4], -lim.max_yaw_accel_radps2 * h, lim.max_yaw_accel_radps2 * h);
    const double yaw_mid = (*x)[2] + 0.5 * (*x)[4] * h;
    (*x)[0] += (*x)[3] * h * std::cos(yaw_mid);
    (*x)[1] += (*x)[3] * h * std::sin(yaw_mid);
    (*x)[2] += (*x)[4] * h;
  }
}

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

int main(int argc, char** argv) {
  int laps = 20;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--laps") == 0 && i + 1 < argc) {
      laps = std::max(1, std::atoi(argv[++i]));
    } else {
      std::fprintf(stderr, "usage: %s [--laps N]\n", argv[0]);
      return 2;
    }
  }
  const std::vector<Eigen::Vector2d> path_W = Course();
  IlqrController warm;  // Default options: horizon 30, dt 0.1 s; default limits (small wheeled robot).
  IlqrController cold;
  const IlqrLimits& lim = warm.limits();
  const double cruise_mps = 0.6;
  const int cycles = 320;  // 32 s: the whole course and the stop.

  std::vector<double> warm_ms;
  std::vector<double> cold_ms;
  long warm_iterations = 0;
  long cold_iterations = 0;
  int warm_started = 0;
  int not_converged = 0;
  double max_command_diff_v = 0.0;
  double max_command_diff_w = 0.0;
  double final_error_m = 0.0;
  for (int lap = -1; lap < laps; ++lap) {  // Lap -1 warms caches up and is not recorded.
    warm.Reset();
    IlqrState x = IlqrState::Zero();
    for (int c = 0; c < cycles; ++c) {
      const Clock::time_point t0 = Clock::now();
      const IlqrSolution w = warm.Solve(x, path_W, cruise_mps, true, 0.1);
      const Clock::time_point t1 = Clock::now();
      cold.Reset();
      const Clock::time_point t2 = Clock::now();
      const IlqrSolution k = cold.Solve(x, path_W, cruise_mps, true, 0.1);
      const Clock::time_point t3 = Clock::now();
      if (lap >= 0) {
        warm_ms.push_back(Ms(t0, t1));
        cold_ms.push_back(Ms(t2, t3));
        warm_iterations += w.iterations;
        cold_iterations += k.iterations;
        warm_started += w.warm_started ? 1 : 0;
        not_converged +=
            (w.status != IlqrSolution::Status::kConverged) + (k.status != IlqrSolution::Status::kConverged);
        max_command_diff_v = std::max(max_command_diff_v, std::abs(w.command_v_mps - k.command_v_mps));
        max_command_diff_w = std::max(max_command_diff_w, std::abs(w.command_w_radps - k.command_w_radps));
      }
      Apply(lim, w.command_v_mps, w.command_w_radps, &x);
    }
    final_error_m = (x.head<2>() - path_W.back()).norm();
  }

  const Stats ws = Summarize(warm_ms);
  const Stats cs = Summarize(cold_ms);
  const double n = static_cast<double>(warm_ms.size());
  std::printf(
      "iLQR tracking, horizon 30 x 0.1 s, closed loop on a 15 m course at %.1f m/s, %d laps x %d solves\n",
      cruise_mps, laps, cycles);
  std::printf(
      "  cold (baseline): median %.4f ms  mean %.4f ms  p90 %.4f ms  max %.4f ms  mean iterations %.2f\n",
      cs.median_ms, cs.mean_ms, cs.p90_ms, cs.max_ms, cold_iterations / n);
  std::printf(
      "  warm:            median %.4f ms  mean %.4f ms  p90 %.4f ms  max %.4f ms  mean iterations %.2f"
      "  (%.1f %% warm-started)\n",
      ws.median_ms, ws.mean_ms, ws.p90_ms, ws.max_ms, warm_iterations / n, 100.0 * warm_started / n);
  std::printf("  ratio warm/cold: median time %.3f, mean time %.3f, p90 time %.3f, iterations %.3f\n",
              ws.median_ms / cs.median_ms, ws.mean_ms / cs.mean_ms, ws.p90_ms / cs.p90_ms,
              static_cast<double>(warm_iterations) / static_cast<double>(cold_iterations));
  std::printf("  goals: warm median <= 0.3 ms %s, cold median <= 1 ms %s\n",
              ws.median_ms <= 0.3 ? "met" : "MISSED", cs.median_ms <= 1.0 ? "met" : "MISSED");
  std::printf(
      "  checks: %d solves not kConverged, largest warm/cold command difference %.4f m/s %.4f rad/s, "
      "final distance to goal %.3f m\n",
      not_converged, max_command_diff_v, max_command_diff_w, final_error_m);
  return 0;
}
