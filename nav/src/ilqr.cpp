// Copyright Cairn authors.
#include "cairn/nav/ilqr.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace cairn::nav {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kInf = std::numeric_limits<double>::infinity();
// Consecutive path points closer than this are merged, metres.
constexpr double kMinSegment_m = 1e-9;
// Regularization schedule (Tassa, Erez & Todorov 2012): mu grows by factors of at least
// kRegFactor when a backward pass or line search fails and shrinks after a success; below kRegMin it is 0.
constexpr double kRegFactor = 1.6;
constexpr double kRegMin = 1e-6;
constexpr double kRegMax = 1e10;
// Line search: step sizes 1, 1/2, ..., 1/2^(kLineSearchSteps-1); a step is accepted when the actual cost
// decrease is at least kArmijo times the decrease predicted by the quadratic model.
constexpr int kLineSearchSteps = 10;
constexpr double kArmijo = 0.1;
// Cold guess: turn towards the reference point this far ahead, seconds, with this gain, 1/s.
constexpr double kGuessLookahead_s = 0.5;
constexpr double kGuessTurnGain_per_s = 1.5;

enum : int { kPx = 0, kPy = 1, kYaw = 2, kV = 3, kW = 4 };

using Vec5 = Eigen::Matrix<double, 5, 1>;
using Mat55 = Eigen::Matrix<double, 5, 5>;
using Mat52 = Eigen::Matrix<double, 5, 2>;
using Mat25 = Eigen::Matrix<double, 2, 5>;
using Mat22 = Eigen::Matrix<double, 2, 2>;

double Wrap(double angle_rad) {
  double a = std::fmod(angle_rad + kPi, 2.0 * kPi);
  if (a <= 0.0) a += 2.0 * kPi;
  return a - kPi;
}

std::string Num(double value) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%g", value);
  return buf;
}

// Range check of one field; appends "<prefix><field> = <value> must be finite and in [lo, hi]" on failure.
bool CheckRange(const char* prefix, const char* field, double value, double lo, bool lo_open, double hi,
                std::ostringstream* msg) {
  const bool ok = std::isfinite(value) && (lo_open ? value > lo : value >= lo) && value <= hi;
  if (!ok) {
    *msg << prefix << field << " = " << Num(value) << " must be finite and in " << (lo_open ? "(" : "[")
         << Num(lo) << ", " << Num(hi) << "]";
  }
  return ok;
}

bool CheckInt(const char* prefix, const char* field, int value, int lo, int hi, std::ostringstream* msg) {
  const bool ok = value >= lo && value <= hi;
  if (!ok) *msg << prefix << field << " = " << value << " must be in [" << lo << ", " << hi << "]";
  return ok;
}

// Copies `path_F` without consecutive duplicates into `path` and its cumulative lengths into `cum`.
void CleanPath(const std::vector<Eigen::Vector2d>& path_F, std::vector<Eigen::Vector2d>* path,
               std::vector<double>* cum) {
  path->clear();
  cum->clear();
  for (const Eigen::Vector2d& p : path_F) {
    if (path->empty()) {
      path->push_back(p);
      cum->push_back(0.0);
      continue;
    }
    const double len = (p - path->back()).norm();
    if (len <= kMinSegment_m) continue;
    path->push_back(p);
    cum->push_back(cum->back() + len);
  }
}

// Writes steps + 1 reference points into `out` (see BuildIlqrReference). `path` has >= 2 distinct points.
void FillReference(const std::vector<Eigen::Vector2d>& path, const std::vector<double>& cum,
                   const Eigen::Vector2d& p0, double v0, double cruise, bool stop_at_end, double accel,
                   int steps, double dt, IlqrReferencePoint* out) {
  const std::size_t last_seg = path.size() - 2;
  // Projection of p0: the nearest point of the polyline, the earliest one on ties.
  std::size_t seg = 0;
  double s = 0.0;
  double best_d2 = kInf;
  for (std::size_t i = 0; i <= last_seg; ++i) {
    const Eigen::Vector2d ab = path[i + 1] - path[i];
    const double t = std::clamp((p0 - path[i]).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    const double d2 = (path[i] + t * ab - p0).squaredNorm();
    if (d2 < best_d2) {
      best_d2 = d2;
      seg = i;
      s = cum[i] + t * (cum[i + 1] - cum[i]);
    }
  }
  const double length = cum.back();
  auto point_at = [&](double s_m, double v_mps, IlqrReferencePoint* r) {
    while (seg < last_seg && s_m >= cum[seg + 1]) ++seg;
    const Eigen::Vector2d ab = path[seg + 1] - path[seg];
    // t > 1 only on the last segment of a path that continues (extrapolation).
    const double t = (s_m - cum[seg]) / (cum[seg + 1] - cum[seg]);
    const Eigen::Vector2d p = path[seg] + t * ab;
    r->x_m = p.x();
    r->y_m = p.y();
    r->yaw_rad = std::atan2(ab.y(), ab.x());
    r->v_mps = v_mps;
    r->s_m = s_m;
  };
  auto braking_limit = [&](double s_m) { return std::sqrt(2.0 * accel * std::max(0.0, length - s_m)); };

  double v = std::max(0.0, v0);
  point_at(s, v, &out[0]);
  for (int k = 0; k < steps; ++k) {
    const double s_pred = s + v * dt;
    double target = cruise;
    if (stop_at_end) target = std::min(target, braking_limit(s_pred));
    double v_next = std::clamp(target, v - accel * dt, v + accel * dt);
    if (stop_at_end) v_next = std::min(v_next, braking_limit(s_pred));  // Brake harder rather than overshoot.
    v_next = std::max(0.0, v_next);
    s += 0.5 * (v + v_next) * dt;
    if (stop_at_end && s >= length) {
      s = length;
      v_next = 0.0;
    }
    v = v_next;
    point_at(s, v, &out[k + 1]);
  }
}

// State-dependent control bounds (see the header comment): lo <= u <= hi keeps v and w within the limits
// after one step. state_lo[i] / state_hi[i] tell whether the bound of control i comes from the velocity limit
// (then its derivative is -1/dt on v or w) rather than from the acceleration limit (constant).
struct ControlBox {
  IlqrControl lo;
  IlqrControl hi;
  bool state_lo[2];
  bool state_hi[2];
};

ControlBox BoxAt(const IlqrState& x, const IlqrLimits& lim, double dt) {
  ControlBox b;
  const double inv_dt = 1.0 / dt;
  const double a_lo = (-lim.max_reverse_speed_mps - x[kV]) * inv_dt;
  const double a_hi = (lim.max_speed_mps - x[kV]) * inv_dt;
  const double al_lo = (-lim.max_yaw_rate_radps - x[kW]) * inv_dt;
  const double al_hi = (lim.max_yaw_rate_radps - x[kW]) * inv_dt;
  b.state_lo[0] = a_lo > -lim.max_accel_mps2;
  b.state_hi[0] = a_hi < lim.max_accel_mps2;
  b.state_lo[1] = al_lo > -lim.max_yaw_accel_radps2;
  b.state_hi[1] = al_hi < lim.max_yaw_accel_radps2;
  b.lo[0] = b.state_lo[0] ? a_lo : -lim.max_accel_mps2;
  b.lo[1] = b.state_lo[1] ? al_lo : -lim.max_yaw_accel_radps2;
  b.hi[0] = b.state_hi[0] ? a_hi : lim.max_accel_mps2;
  b.hi[1] = b.state_hi[1] ? al_hi : lim.max_yaw_accel_radps2;
  // x has v and w within the limits, so lo <= 0 <= hi; guard rounding anyway.
  b.lo[0] = std::min(b.lo[0], b.hi[0]);
  b.lo[1] = std::min(b.lo[1], b.hi[1]);
  return b;
}

IlqrControl ClampTo(const IlqrControl& u, const ControlBox& b) { return u.cwiseMax(b.lo).cwiseMin(b.hi); }

// IlqrModelStep followed by clamping v and w to the limits: with u inside BoxAt(x) this only removes
// rounding, so the limits hold exactly on every state.
IlqrState StepClamped(const IlqrState& x, const IlqrControl& u, double dt, const IlqrLimits& lim) {
  IlqrState n = IlqrModelStep(x, u, dt);
  n[kV] = std::clamp(n[kV], -lim.max_reverse_speed_mps, lim.max_speed_mps);
  n[kW] = std::clamp(n[kW], -lim.max_yaw_rate_radps, lim.max_yaw_rate_radps);
  return n;
}

// Jacobians A = df/dx (5x5) and B = df/du (5x2) of IlqrModelStep at (x, u). The first two columns of A are
// those of the identity (the step does not depend on the position); Backward() relies on it.
void Linearize(const IlqrState& x, const IlqrControl& u, double dt, Mat55* A, Mat52* B) {
  const double v_bar = x[kV] + 0.5 * u[0] * dt;
  const double w_bar = x[kW] + 0.5 * u[1] * dt;
  const double yaw_mid = x[kYaw] + 0.5 * w_bar * dt;
  const double c = std::cos(yaw_mid);
  const double s = std::sin(yaw_mid);
  A->setIdentity();
  (*A)(kPx, kYaw) = -v_bar * dt * s;
  (*A)(kPx, kV) = dt * c;
  (*A)(kPx, kW) = -v_bar * dt * s * 0.5 * dt;
  (*A)(kPy, kYaw) = v_bar * dt * c;
  (*A)(kPy, kV) = dt * s;
  (*A)(kPy, kW) = v_bar * dt * c * 0.5 * dt;
  (*A)(kYaw, kW) = dt;
  B->setZero();
  (*B)(kPx, 0) = 0.5 * dt * dt * c;
  (*B)(kPx, 1) = -v_bar * dt * s * 0.25 * dt * dt;
  (*B)(kPy, 0) = 0.5 * dt * dt * s;
  (*B)(kPy, 1) = v_bar * dt * c * 0.25 * dt * dt;
  (*B)(kYaw, 1) = 0.5 * dt * dt;
  (*B)(kV, 0) = dt;
  (*B)(kW, 1) = dt;
}

// State part l(x, r) of the cost (see IlqrOptions) times `scale`; with kDerivatives also its gradient and
// Gauss-Newton Hessian (exact: l is a sum of squares of errors linear in x, the heading error up to
// wrapping).
template <bool kDerivatives>
double StateCost(const IlqrState& x, const IlqrReferencePoint& r, const Eigen::Vector2d& dir,
                 const IlqrOptions& o, double scale, Vec5* lx, Mat55* lxx) {
  const double ex = x[kPx] - r.x_m;
  const double ey = x[kPy] - r.y_m;
  const double c = dir.x();
  const double s = dir.y();
  const double e_t = c * ex + s * ey;
  const double e_n = -s * ex + c * ey;
  const double e_yaw = Wrap(x[kYaw] - r.yaw_rad);
  const double e_v = x[kV] - r.v_mps;
  const double w = x[kW];
  const double cost = o.along_track_weight * e_t * e_t + o.cross_track_weight * e_n * e_n +
                      o.heading_weight * e_yaw * e_yaw + o.speed_weight * e_v * e_v +
                      o.yaw_rate_weight * w * w;
  if constexpr (kDerivatives) {
    const double wt = 2.0 * scale * o.along_track_weight;
    const double wn = 2.0 * scale * o.cross_track_weight;
    (*lx)[kPx] = wt * e_t * c - wn * e_n * s;
    (*lx)[kPy] = wt * e_t * s + wn * e_n * c;
    (*lx)[kYaw] = 2.0 * scale * o.heading_weight * e_yaw;
    (*lx)[kV] = 2.0 * scale * o.speed_weight * e_v;
    (*lx)[kW] = 2.0 * scale * o.yaw_rate_weight * w;
    lxx->setZero();
    (*lxx)(kPx, kPx) = wt * c * c + wn * s * s;
    (*lxx)(kPx, kPy) = (wt - wn) * c * s;
    (*lxx)(kPy, kPx) = (*lxx)(kPx, kPy);
    (*lxx)(kPy, kPy) = wt * s * s + wn * c * c;
    (*lxx)(kYaw, kYaw) = 2.0 * scale * o.heading_weight;
    (*lxx)(kV, kV) = 2.0 * scale * o.speed_weight;
    (*lxx)(kW, kW) = 2.0 * scale * o.yaw_rate_weight;
  }
  return scale * cost;
}

// Minimizes q(d) = 0.5 d'H d + g'd over lo <= d <= hi (H symmetric positive definite, lo <= 0 <= hi) exactly:
// the unconstrained minimizer if feasible, else the best of the four edge minimizers (a convex 1-D problem on
// each edge). active[i] tells whether d[i] ends on a bound.
void SolveBoxQp2(const Mat22& H, const IlqrControl& g, const IlqrControl& lo, const IlqrControl& hi,
                 IlqrControl* d, bool active[2]) {
  const double det = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
  const IlqrControl free((-H(1, 1) * g[0] + H(0, 1) * g[1]) / det, (H(1, 0) * g[0] - H(0, 0) * g[1]) / det);
  if ((free.array() >= lo.array()).all() && (free.array() <= hi.array()).all()) {
    *d = free;
    active[0] = active[1] = false;
    return;
  }
  double best = kInf;
  for (int i = 0; i < 2; ++i) {
    const int j = 1 - i;
    for (const double bound : {lo[i], hi[i]}) {
      IlqrControl cand;
      cand[i] = bound;
      const double raw = -(g[j] + H(j, i) * bound) / H(j, j);
      cand[j] = std::clamp(raw, lo[j], hi[j]);
      const double q = 0.5 * cand.dot(H * cand) + g.dot(cand);
      if (q < best) {
        best = q;
        *d = cand;
        active[i] = true;
        active[j] = raw < lo[j] || raw > hi[j];
      }
    }
  }
}

// "" when Solve's inputs are usable, else what is wrong, naming the argument and value.
std::string CheckSolveInput(const IlqrState& x0_F, const std::vector<Eigen::Vector2d>& path_F,
                            double cruise_speed_mps, double elapsed_since_last_solve_s) {
  static const char* const kStateNames[5] = {"x_m", "y_m", "yaw_rad", "v_mps", "w_radps"};
  for (int i = 0; i < 5; ++i) {
    if (!std::isfinite(x0_F[i])) {
      return "x0[" + std::to_string(i) + "] (" + kStateNames[i] + ") = " + Num(x0_F[i]) + " is not finite";
    }
  }
  for (std::size_t i = 0; i < path_F.size(); ++i) {
    if (!path_F[i].allFinite()) {
      return "path_F[" + std::to_string(i) + "] = (" + Num(path_F[i].x()) + ", " + Num(path_F[i].y()) +
             ") is not finite";
    }
  }
  if (!std::isfinite(cruise_speed_mps) || cruise_speed_mps < 0.0) {
    return "cruise_speed_mps = " + Num(cruise_speed_mps) + " must be finite and >= 0";
  }
  if (!std::isfinite(elapsed_since_last_solve_s) || elapsed_since_last_solve_s < 0.0) {
    return "elapsed_since_last_solve_s = " + Num(elapsed_since_last_solve_s) + " must be finite and >= 0";
  }
  return "";
}

}  // namespace

bool IlqrOptions::IsValid(std::string* why) const {
  std::ostringstream msg;
  const char* p = "IlqrOptions::";
  const bool ok = CheckInt(p, "horizon_steps", horizon_steps, 1, 500, &msg) &&
                  CheckRange(p, "dt_s", dt_s, 0.0, true, 1.0, &msg) &&
                  CheckInt(p, "max_iterations", max_iterations, 1, 1000, &msg) &&
                  CheckInt(p, "max_iterations_warm", max_iterations_warm, 1, 1000, &msg) &&
                  CheckRange(p, "tolerance", tolerance, 0.0, true, 0.5, &msg) &&
                  CheckRange(p, "along_track_weight", along_track_weight, 0.0, false, 1e6, &msg) &&
                  CheckRange(p, "cross_track_weight", cross_track_weight, 0.0, false, 1e6, &msg) &&
                  CheckRange(p, "heading_weight", heading_weight, 0.0, false, 1e6, &msg) &&
                  CheckRange(p, "speed_weight", speed_weight, 0.0, false, 1e6, &msg) &&
                  CheckRange(p, "yaw_rate_weight", yaw_rate_weight, 0.0, false, 1e6, &msg) &&
                  CheckRange(p, "accel_weight", accel_weight, 0.0, true, 1e6, &msg) &&
                  CheckRange(p, "yaw_accel_weight", yaw_accel_weight, 0.0, true, 1e6, &msg) &&
                  CheckRange(p, "terminal_weight_s", terminal_weight_s, 0.0, false, 1000.0, &msg) &&
                  CheckRange(p, "reference_accel_fraction", reference_accel_fraction, 0.0, true, 1.0, &msg);
  if (!ok && why != nullptr) *why = msg.str();
  return ok;
}

const char* ToString(IlqrSolution::Status status) {
  switch (status) {
    case IlqrSolution::Status::kConverged:
      return "kConverged";
    case IlqrSolution::Status::kMaxIterations:
      return "kMaxIterations";
    case IlqrSolution::Status::kStalled:
      return "kStalled";
    case IlqrSolution::Status::kNoPath:
      return "kNoPath";
    case IlqrSolution::Status::kInvalidInput:
      return "kInvalidInput";
  }
  return "?";
}

IlqrState IlqrModelStep(const IlqrState& x, const IlqrControl& u, double dt_s) {
  const double v_bar = x[kV] + 0.5 * u[0] * dt_s;
  const double w_bar = x[kW] + 0.5 * u[1] * dt_s;
  const double yaw_mid = x[kYaw] + 0.5 * w_bar * dt_s;
  IlqrState n;
  n[kPx] = x[kPx] + v_bar * dt_s * std::cos(yaw_mid);
  n[kPy] = x[kPy] + v_bar * dt_s * std::sin(yaw_mid);
  n[kYaw] = x[kYaw] + w_bar * dt_s;
  n[kV] = x[kV] + u[0] * dt_s;
  n[kW] = x[kW] + u[1] * dt_s;
  return n;
}

void IlqrModelJacobians(const IlqrState& x, const IlqrControl& u, double dt_s, Eigen::Matrix<double, 5, 5>* A,
                        Eigen::Matrix<double, 5, 2>* B) {
  Linearize(x, u, dt_s, A, B);
}

std::vector<IlqrReferencePoint> BuildIlqrReference(const std::vector<Eigen::Vector2d>& path_F,
                                                   const Eigen::Vector2d& p0_F, double v0_mps,
                                                   double cruise_speed_mps, bool stop_at_end,
                                                   double accel_mps2, int steps, double dt_s) {
  for (std::size_t i = 0; i < path_F.size(); ++i) {
    if (!path_F[i].allFinite()) {
      throw std::invalid_argument("BuildIlqrReference: path_F[" + std::to_string(i) + "] = (" +
                                  Num(path_F[i].x()) + ", " + Num(path_F[i].y()) + ") is not finite");
    }
  }
  if (!p0_F.allFinite() || !std::isfinite(v0_mps)) {
    throw std::invalid_argument("BuildIlqrReference: p0_F = (" + Num(p0_F.x()) + ", " + Num(p0_F.y()) +
                                "), v0_mps = " + Num(v0_mps) + " must be finite");
  }
  if (!std::isfinite(cruise_speed_mps) || cruise_speed_mps < 0.0) {
    throw std::invalid_argument("BuildIlqrReference: cruise_speed_mps = " + Num(cruise_speed_mps) +
                                " must be finite and >= 0");
  }
  if (!std::isfinite(accel_mps2) || accel_mps2 <= 0.0) {
    throw std::invalid_argument("BuildIlqrReference: accel_mps2 = " + Num(accel_mps2) +
                                " must be finite and > 0");
  }
  if (steps < 1)
    throw std::invalid_argument("BuildIlqrReference: steps = " + std::to_string(steps) + " must be >= 1");
  if (!std::isfinite(dt_s) || dt_s <= 0.0) {
    throw std::invalid_argument("BuildIlqrReference: dt_s = " + Num(dt_s) + " must be finite and > 0");
  }
  std::vector<Eigen::Vector2d> path;
  std::vector<double> cum;
  CleanPath(path_F, &path, &cum);
  if (path.size() < 2) {
    throw std::invalid_argument("BuildIlqrReference: path_F has " + std::to_string(path.size()) +
                                " distinct point(s), needs at least 2");
  }
  std::vector<IlqrReferencePoint> ref(static_cast<std::size_t>(steps) + 1);
  FillReference(path, cum, p0_F, v0_mps, cruise_speed_mps, stop_at_end, accel_mps2, steps, dt_s, ref.data());
  return ref;
}

// ---------------------------------------------------------------------------------------------------------------

struct IlqrController::Impl {
  IlqrOptions options;
  IlqrLimits limits;
  int n = 0;        // Horizon steps.
  double dt = 0.0;  // Step, seconds.
  Mat22 luu;        // Control Hessian of the running cost (constant, diagonal).

  // Path and reference (reused between solves; capacity kept).
  std::vector<Eigen::Vector2d> path;
  std::vector<double> cum;
  std::vector<IlqrReferencePoint> ref;   // n + 1
  std::vector<Eigen::Vector2d> ref_dir;  // n + 1: (cos, sin) of the reference heading.

  // Nominal and candidate trajectories.
  IlqrState x0;
  std::vector<IlqrState> x, x_new;    // n + 1
  std::vector<IlqrControl> u, u_new;  // n
  // Per-step derivatives at the nominal trajectory.
  std::vector<Mat55> A;         // n
  std::vector<Mat52> B;         // n
  std::vector<Vec5> lx;         // n + 1
  std::vector<Mat55> lxx;       // n + 1
  std::vector<IlqrControl> lu;  // n
  std::vector<ControlBox> box;  // n
  // Feedforward and feedback gains of the last backward pass.
  std::vector<IlqrControl> kff;  // n
  std::vector<Mat25> Kfb;        // n

  // Warm start: controls of the previous solution.
  std::vector<IlqrControl> prev_u;  // n
  bool has_prev = false;

  Impl(const IlqrOptions& o, const IlqrLimits& l) : options(o), limits(l), n(o.horizon_steps), dt(o.dt_s) {
    luu.setZero();
    luu(0, 0) = 2.0 * dt * o.accel_weight;
    luu(1, 1) = 2.0 * dt * o.yaw_accel_weight;
    const std::size_t n1 = static_cast<std::size_t>(n) + 1;
    const std::size_t n0 = static_cast<std::size_t>(n);
    ref.resize(n1);
    ref_dir.resize(n1);
    x.resize(n1);
    x_new.resize(n1);
    u.resize(n0);
    u_new.resize(n0);
    A.resize(n0);
    B.resize(n0);
    lx.resize(n1);
    lxx.resize(n1);
    lu.resize(n0);
    box.resize(n0);
    kff.resize(n0);
    Kfb.resize(n0);
    prev_u.resize(n0);
  }

  double ControlCost(const IlqrControl& uk) const {
    return dt * (options.accel_weight * uk[0] * uk[0] + options.yaw_accel_weight * uk[1] * uk[1]);
  }

  // Rolls out `controls` (clamped into the box of each state, in place) from x0 into `states`; returns J.
  double Rollout(std::vector<IlqrControl>* controls, std::vector<IlqrState>* states) const {
    double cost = 0.0;
    IlqrState xk = x0;
    (*states)[0] = xk;
    for (int k = 0; k < n; ++k) {
      IlqrControl& uk = (*controls)[k];
      uk = ClampTo(uk, BoxAt(xk, limits, dt));
      cost += StateCost<false>(xk, ref[k], ref_dir[k], options, dt, nullptr, nullptr) + ControlCost(uk);
      xk = StepClamped(xk, uk, dt, limits);
      (*states)[k + 1] = xk;
    }
    cost += StateCost<false>(xk, ref[n], ref_dir[n], options, options.terminal_weight_s, nullptr, nullptr);
    return cost;
  }

  // Cold guess into u_new (then rolled out): accelerate along the reference speed profile, turn towards the
  // reference point kGuessLookahead_s ahead, slow down while facing away from it.
  void ColdGuess() {
    const int look = std::max(1, static_cast<int>(std::lround(kGuessLookahead_s / dt)));
    IlqrState xk = x0;
    for (int k = 0; k < n; ++k) {
      const IlqrReferencePoint& target = ref[std::min(k + look, n)];
      const double dx = target.x_m - xk[kPx];
      const double dy = target.y_m - xk[kPy];
      const double err = (dx * dx + dy * dy > 0.05 * 0.05) ? Wrap(std::atan2(dy, dx) - xk[kYaw])
                                                           : Wrap(ref[k].yaw_rad - xk[kYaw]);
      const double v_target = ref[k + 1].v_mps * std::max(0.0, std::cos(err));
      const double w_target = kGuessTurnGain_per_s * err;
      IlqrControl uk((v_target - xk[kV]) / dt, (w_target - xk[kW]) / dt);
      uk = ClampTo(uk, BoxAt(xk, limits, dt));
      u_new[k] = uk;
      xk = StepClamped(xk, uk, dt, limits);
    }
  }

  // Previous controls shifted by `shift_steps` (>= 0, < n), linearly interpolated, padded with zeros, into
  // u_new.
  void WarmGuess(double shift_steps) {
    for (int k = 0; k < n; ++k) {
      const double t = k + shift_steps;
      const int j = static_cast<int>(std::floor(t));
      const double f = t - j;
      const IlqrControl a = j < n ? prev_u[j] : IlqrControl::Zero();
      const IlqrControl b = j + 1 < n ? prev_u[j + 1] : IlqrControl::Zero();
      u_new[k] = (1.0 - f) * a + f * b;
    }
  }

  // Derivatives of dynamics and cost along (x, u).
  void ComputeDerivatives() {
    for (int k = 0; k < n; ++k) {
      Linearize(x[k], u[k], dt, &A[k], &B[k]);
      StateCost<true>(x[k], ref[k], ref_dir[k], options, dt, &lx[k], &lxx[k]);
      lu[k] = luu * u[k];
      box[k] = BoxAt(x[k], limits, dt);
    }
    StateCost<true>(x[n], ref[n], ref_dir[n], options, options.terminal_weight_s, &lx[n], &lxx[n]);
  }

  // Backward pass with control regularization mu (Quu + mu I). Fills kff, Kfb and the expected decrease terms
  // (decrease of a step alpha = -(alpha dv1 + alpha^2 dv2)). False if a regularized Quu is not positive
  // definite.
  bool Backward(double mu, double* dv1, double* dv2) {
    Vec5 Vx = lx[n];
    Mat55 Vxx = lxx[n];
    *dv1 = 0.0;
    *dv2 = 0.0;
    for (int k = n - 1; k >= 0; --k) {
      // Products of the 5x5 / 5x2 blocks written out with noalias(): small fixed-size, no temporaries.
      // A = I except in its last three columns (yaw, v, w), so A' V A touches only those.
      const Mat55& Ak = A[k];
      const Mat52& Bk = B[k];
      Mat55 VA;
      VA.leftCols<2>() = Vxx.leftCols<2>();
      VA.rightCols<3>().noalias() = Vxx * Ak.rightCols<3>();
      Mat52 VB;
      VB.noalias() = Vxx * Bk;
      Vec5 Qx = lx[k];
      Qx.noalias() += Ak.transpose() * Vx;
      IlqrControl Qu = lu[k];
      Qu.noalias() += Bk.transpose() * Vx;
      Mat55 Qxx = lxx[k];
      Qxx.topRows<2>() += VA.topRows<2>();
      Qxx.bottomRows<3>().noalias() += Ak.rightCols<3>().transpose() * VA;
      Mat22 Quu = luu;
      Quu.noalias() += Bk.transpose() * VB;
      Mat25 Qux;
      Qux.noalias() = Bk.transpose() * VA;
      Mat22 H = Quu;
      H(0, 0) += mu;
      H(1, 1) += mu;
      H(0, 1) = H(1, 0) = 0.5 * (H(0, 1) + H(1, 0));
      const double det = H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0);
      if (!(H(0, 0) > 0.0) || !(det > 0.0)) return false;

      const ControlBox& b = box[k];
      IlqrControl d;
      bool active[2];
      SolveBoxQp2(H, Qu, b.lo - u[k], b.hi - u[k], &d, active);
      // Feedback: a control held at a velocity bound follows the bound (-1/dt on v or w), one held at an
      // acceleration bound gets none; free controls respond optimally given the held ones.
      Mat25 K = Mat25::Zero();
      for (int i = 0; i < 2; ++i) {
        if (!active[i]) continue;
        const bool at_lo = std::abs(d[i] - (b.lo[i] - u[k][i])) <= std::abs(d[i] - (b.hi[i] - u[k][i]));
        if (at_lo ? b.state_lo[i] : b.state_hi[i]) K(i, i == 0 ? kV : kW) = -1.0 / dt;
      }
      if (!active[0] && !active[1]) {
        const Mat22 Hinv = (Mat22() << H(1, 1), -H(0, 1), -H(1, 0), H(0, 0)).finished() / det;
        K = -Hinv * Qux;
      } else if (active[0] != active[1]) {
        const int f = active[0] ? 1 : 0;
        const int c = 1 - f;
        K.row(f) = -(Qux.row(f) + H(f, c) * K.row(c)) / H(f, f);
      }
      kff[k] = d;
      Kfb[k] = K;

      // Value function update (Tassa, Erez & Todorov 2012), valid for the general K of the box-constrained
      // pass: Vx = Qx + K' (Quu d + Qu) + Qux' d,  Vxx = Qxx + K' (Quu K + Qux) + Qux' K.
      const IlqrControl Quu_d = Quu * d;
      const IlqrControl g = Qu + Quu_d;
      *dv1 += d.dot(Qu);
      *dv2 += 0.5 * d.dot(Quu_d);
      Mat25 M = Qux;
      M.noalias() += Quu * K;
      Vx = Qx;
      Vx.noalias() += K.transpose() * g;
      Vx.noalias() += Qux.transpose() * d;
      // Two rank-2 updates, symmetrized; written out, as they profiled faster than Eigen's lazy products
      // here.
      for (int i = 0; i < 5; ++i) {
        for (int j = i; j < 5; ++j) {
          const double ij = K(0, i) * M(0, j) + K(1, i) * M(1, j) + Qux(0, i) * K(0, j) + Qux(1, i) * K(1, j);
          const double ji = K(0, j) * M(0, i) + K(1, j) * M(1, i) + Qux(0, j) * K(0, i) + Qux(1, j) * K(1, i);
          Vxx(i, j) = Vxx(j, i) = 0.5 * (Qxx(i, j) + Qxx(j, i) + ij + ji);
        }
      }
    }
    return true;
  }

  // Forward pass with step alpha from the nominal (x, u) into (x_new, u_new); returns J (inf if not finite).
  double Forward(double alpha) {
    double cost = 0.0;
    IlqrState xk = x0;
    x_new[0] = xk;
    for (int k = 0; k < n; ++k) {
      IlqrControl uk = u[k] + alpha * kff[k] + Kfb[k] * (xk - x[k]);
      uk = ClampTo(uk, BoxAt(xk, limits, dt));
      u_new[k] = uk;
      cost += StateCost<false>(xk, ref[k], ref_dir[k], options, dt, nullptr, nullptr) + ControlCost(uk);
      xk = StepClamped(xk, uk, dt, limits);
      x_new[k + 1] = xk;
    }
    cost += StateCost<false>(xk, ref[n], ref_dir[n], options, options.terminal_weight_s, nullptr, nullptr);
    return std::isfinite(cost) ? cost : kInf;
  }
  // No path to follow: brakes both velocities to zero as fast as the limits allow (status kNoPath).
  void BrakeToRest(IlqrSolution* sol) {
    has_prev = false;
    sol->status = IlqrSolution::Status::kNoPath;
    sol->message = "path_F has " + std::to_string(path.size()) +
                   " distinct point(s) (needs at least 2): braking to rest";
    sol->states.resize(static_cast<std::size_t>(n) + 1);
    sol->controls.resize(static_cast<std::size_t>(n));
    IlqrState xk = x0;
    sol->states[0] = xk;
    for (int k = 0; k < n; ++k) {
      const IlqrControl uk = ClampTo(IlqrControl(-xk[kV] / dt, -xk[kW] / dt), BoxAt(xk, limits, dt));
      sol->controls[k] = uk;
      xk = StepClamped(xk, uk, dt, limits);
      sol->states[k + 1] = xk;
    }
    sol->command_v_mps = sol->states[1][kV];
    sol->command_w_radps = sol->states[1][kW];
  }

  // Initial guess into (u, x): the cheaper of the cold guess and the previous controls shifted by the time
  // since the last solve. Returns its cost; `*warm_started` says which.
  double InitialGuess(double elapsed_since_last_solve_s, bool* warm_started) {
    *warm_started = false;
    ColdGuess();
    std::swap(u, u_new);
    double cost = Rollout(&u, &x);
    const double shift_steps = elapsed_since_last_solve_s / dt;
    if (has_prev && shift_steps < n) {
      WarmGuess(shift_steps);
      const double warm_cost = Rollout(&u_new, &x_new);
      if (warm_cost <= cost) {
        std::swap(u, u_new);
        std::swap(x, x_new);
        cost = warm_cost;
        *warm_started = true;
      }
    }
    return cost;
  }

  // The Levenberg-Marquardt style schedule of the backward pass's regularization mu (Tassa, Erez & Todorov
  // 2012): grows by at least kRegFactor after a failure, shrinks after a success, 0 below kRegMin.
  struct Regularization {
    double mu = 0.0;
    double factor = 1.0;
    void Increase() {
      factor = std::max(kRegFactor, factor * kRegFactor);
      mu = std::max(kRegMin, mu * factor);
    }
    void Decrease() {
      factor = std::min(1.0 / kRegFactor, factor / kRegFactor);
      mu = mu * factor > kRegMin ? mu * factor : 0.0;
    }
  };

  // iLQR iterations from the nominal (u, x) of cost `*cost` (Li & Todorov 2004; regularization and line
  // search of Tassa, Erez & Todorov 2012), at most `max_iterations`: each accepted cost is appended to
  // `*history`. Leaves the best trajectory in (u, x).
  IlqrSolution::Status Iterate(int max_iterations, double* cost, int* iterations,
                               std::vector<double>* history) {
    const double tol = options.tolerance;
    Regularization reg;
    bool derivatives_current = false;  // False after an accepted step changed the nominal trajectory.
    while (*iterations < max_iterations) {
      ++*iterations;
      if (!derivatives_current) ComputeDerivatives();
      derivatives_current = true;
      double dv1 = 0.0;
      double dv2 = 0.0;
      bool ok = Backward(reg.mu, &dv1, &dv2);
      while (!ok && reg.mu < kRegMax) {
        reg.Increase();
        ok = Backward(reg.mu, &dv1, &dv2);
      }
      if (!ok) return IlqrSolution::Status::kStalled;
      // The full step would not gain enough: converged.
      if (-(dv1 + dv2) <= tol * *cost) return IlqrSolution::Status::kConverged;
      double new_cost = *cost;
      if (!LineSearch(*cost, dv1, dv2, &new_cost)) {
        reg.Increase();
        if (reg.mu >= kRegMax) return IlqrSolution::Status::kStalled;
        continue;
      }
      std::swap(x, x_new);
      std::swap(u, u_new);
      derivatives_current = false;
      reg.Decrease();
      const double decrease = *cost - new_cost;
      *cost = new_cost;
      history->push_back(*cost);
      if (decrease <= tol * (*cost + decrease)) return IlqrSolution::Status::kConverged;
    }
    return IlqrSolution::Status::kMaxIterations;
  }

  // Step sizes 1, 1/2, ... until one decreases the cost by at least kArmijo of the predicted decrease: true
  // with the step's trajectory in (u_new, x_new) and its cost in `*new_cost`.
  bool LineSearch(double cost, double dv1, double dv2, double* new_cost) {
    double alpha = 1.0;
    for (int i = 0; i < kLineSearchSteps; ++i, alpha *= 0.5) {
      *new_cost = Forward(alpha);
      const double expected = -(alpha * dv1 + alpha * alpha * dv2);
      if (*new_cost < cost && (expected <= 0.0 || (cost - *new_cost) >= kArmijo * expected)) return true;
    }
    return false;
  }
};

IlqrController::IlqrController(const IlqrOptions& options, const IlqrLimits& limits) {
  std::string why;
  if (!options.IsValid(&why)) throw std::invalid_argument(why);
  if (!limits.IsValid(&why)) throw std::invalid_argument(why);
  impl_ = std::make_unique<Impl>(options, limits);
}

IlqrController::~IlqrController() = default;
IlqrController::IlqrController(IlqrController&&) noexcept = default;
IlqrController& IlqrController::operator=(IlqrController&&) noexcept = default;

void IlqrController::Reset() { impl_->has_prev = false; }
bool IlqrController::has_warm_start() const { return impl_->has_prev; }
const IlqrOptions& IlqrController::options() const { return impl_->options; }
const IlqrLimits& IlqrController::limits() const { return impl_->limits; }

IlqrSolution IlqrController::Solve(const IlqrState& x0_F, const std::vector<Eigen::Vector2d>& path_F,
                                   double cruise_speed_mps, bool stop_at_end,
                                   double elapsed_since_last_solve_s) {
  using Clock = std::chrono::steady_clock;
  const Clock::time_point start = Clock::now();
  Impl& m = *impl_;
  IlqrSolution sol;
  auto finish = [&]() {
    sol.solve_time_s = std::chrono::duration<double>(Clock::now() - start).count();
    return std::move(sol);
  };
  auto invalid = [&](const std::string& message) {
    m.has_prev = false;
    sol.status = IlqrSolution::Status::kInvalidInput;
    sol.message = message;
    return finish();
  };
  if (const std::string why = CheckSolveInput(x0_F, path_F, cruise_speed_mps, elapsed_since_last_solve_s);
      !why.empty()) {
    return invalid(why);
  }
  const IlqrLimits& lim = m.limits;
  m.x0 = x0_F;
  m.x0[kV] = std::clamp(m.x0[kV], -lim.max_reverse_speed_mps, lim.max_speed_mps);
  m.x0[kW] = std::clamp(m.x0[kW], -lim.max_yaw_rate_radps, lim.max_yaw_rate_radps);

  CleanPath(path_F, &m.path, &m.cum);
  if (m.path.size() < 2) {
    m.BrakeToRest(&sol);
    return finish();
  }
  const double cruise = std::min(cruise_speed_mps, lim.max_speed_mps);
  FillReference(m.path, m.cum, m.x0.head<2>(), m.x0[kV], cruise, stop_at_end,
                m.options.reference_accel_fraction * lim.max_accel_mps2, m.n, m.dt, m.ref.data());
  for (int k = 0; k <= m.n; ++k) {
    m.ref_dir[k] = Eigen::Vector2d(std::cos(m.ref[k].yaw_rad), std::sin(m.ref[k].yaw_rad));
  }
  double cost = m.InitialGuess(elapsed_since_last_solve_s, &sol.warm_started);
  if (!std::isfinite(cost)) {
    return invalid("the cost of the initial guess is not finite (coordinates too large?)");
  }
  sol.initial_cost = cost;
  const int max_iterations = sol.warm_started ? m.options.max_iterations_warm : m.options.max_iterations;
  sol.cost_history.reserve(static_cast<std::size_t>(max_iterations) + 1);
  sol.cost_history.push_back(cost);
  int iterations = 0;
  const IlqrSolution::Status status = m.Iterate(max_iterations, &cost, &iterations, &sol.cost_history);

  // Output and warm start.
  m.prev_u = m.u;
  m.has_prev = true;
  sol.status = status;
  sol.iterations = iterations;
  sol.cost = cost;
  sol.states = m.x;
  sol.controls = m.u;
  sol.reference = m.ref;
  sol.command_v_mps = m.x[1][kV];
  sol.command_w_radps = m.x[1][kW];
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%s after %d iterations (%s): cost %.6g -> %.6g", ToString(status),
                iterations, sol.warm_started ? "warm start" : "cold start", sol.initial_cost, cost);
  sol.message = buf;
  return finish();
}

}  // namespace cairn::nav
