// Staircase detection accuracy: precision, recall, rise and run errors of StaircaseDetector
// over fixed sets of views in
//  - every built-in world (sim::BuiltinWorldNames(), so a new world is picked up), exact;
//  - a survey copy of every built-in world (sim::MakeSurveyScan: floors thinned to 50 points/m², walls keep
//    70 %, 300 strays; written as a PCD and loaded with the default clean-up, as a user's sparse scan is);
//  - the degraded copy of data/geb079.bt (sim::DegradedGeb079Options(), seed 79; skipped with a
//    message when the file is absent);
//  - synthetic scenes at 1 cm voxels with the classic false positives (a wall, crates, a curb, a table, a
//    ramp, a flight seen side-on) and flights of 0.25 m run and 0.17-0.20 m rise (straight, rotated, open or
//    between walls, a switchback stairwell).
// Ground truth: the flights of the world definitions (BuiltinWorldInfo::staircases) and of the synthetic
// scenes. A view = 4 VLP-16 scans (sim::SimulatedLidar, 1 cm range noise, true poses, no SLAM drift) 0.5 m
// apart on a straight 1.5 m drive, sensor 0.5 m above the floor, accumulated in a LocalCloud as on the robot;
// the detector runs once at the last pose. Views are generated, never hand-placed: approaches to every flight
// (1.5, 2.5, 3.5 m before its foot, at 0 and +-30 deg), side-on views of every flight (1.5, 2.5, 3.5 m beside
// its middle, looking across the run), approaches to every synthetic object, and a grid of standing spots
// (every 3 m, each floor level); a pose counts only where a 0.3 m disc of floor at one level has 1.2 m free
// above (on the exact world).
// Scoring per view: a detection is a true positive when it matches a true flight of the scene: ascending
// direction within 15 deg, first riser within 0.15 m along the flight and 0.10 m in height of one of the
// flight's risers (a partial view may start higher), its centre within half the flight's width of the
// flight's centre line; a second detection of the same flight in a view, and any other detection, is a false
// positive. A flight is expected (counts for recall) in a view whose last sensor position stands on the
// flight's floor 1.0-4.0 m before its foot inside a 35 deg cone around its axis, with the centres of its
// first three treads in the lidar's field of view and in line of sight, and at least 3 points of the view's
// cloud on each of its first three step edges (the top 5 cm of the riser or the first 10 cm of the tread:
// from a few metres no beam of a 16-beam lidar may fall there, the robot sees them closer). Errors: |rise -
// true rise|, |run - true run| of the true positives. Usage: cairn_bench_staircase_accuracy [--only SUBSTRING
// [--view INDEX]] [--verbose] [--geb079 PATH]
// (--only: scenes whose name contains SUBSTRING; --view: only that view of each; --verbose: every detection.)
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "cairn/core/build_paths.h"
#include "cairn/perception/staircase.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"
#include "cairn/sim/survey_scan.h"
#include "cairn/sim/world.h"

namespace {

using cairn::perception::Staircase;
using cairn::sim::StaircaseFlight;
using cairn::sim::World;
constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// ---- Scoring rules (see the header)
// ------------------------------------------------------------------------
constexpr double kMatchYawRad = 15.0 * kDeg;
constexpr double kMatchAlongM = 0.15;
constexpr double kMatchHeightM = 0.10;
constexpr double kExpectMinM = 1.0, kExpectMaxM = 4.0;
constexpr double kExpectConeRad = 35.0 * kDeg;
constexpr double kLidarHalfFovRad = 15.0 * kDeg;
// ---- Views
// -------------------------------------------------------------------------------------------------
constexpr double kSensorHeightM = 0.5;
constexpr double kDriveM = 1.5;
constexpr int kScansPerView = 4;
constexpr double kFootprintRadiusM = 0.3;
constexpr double kBodyHeightM = 1.2;
constexpr double kGridSpacingM = 3.0;

// A sensor pose: position (metres, frame W), heading (radians about +z of W), level.
struct Pose {
  Eigen::Vector3d p_W;
  double yaw_rad = 0.0;
};

struct View {
  std::string kind;         // "approach", "side-on", "object", "grid".
  std::vector<Pose> poses;  // The drive; the detector runs at the last.
  double floor_z_m = 0.0;
};

struct Scene {
  std::string group;  // Row of the table.
  std::string name;
  std::shared_ptr<const World> truth;    // Exact geometry: views and visibility.
  std::shared_ptr<const World> scanned;  // What the lidar scans (the truth, or a survey copy of it).
  std::vector<StaircaseFlight> flights;
  std::vector<View> views;
};

Eigen::Vector2d Dir(double yaw_rad) { return {std::cos(yaw_rad), std::sin(yaw_rad)}; }

// Height of the top of the highest occupied voxel of column (x, y) within `tol_m` of `z_m`, if any.
std::optional<double> SurfaceNear(const World& w, double x, double y, double z_m, double tol_m) {
  const double res = w.resolution_m();
  for (double z = z_m + tol_m - 0.5 * res; z >= z_m - tol_m - res; z -= res) {
    const std::optional<Eigen::Vector3i> i = w.IndexOf({x, y, z});
    if (!i || !w.IsOccupiedIndex(*i)) continue;
    const double top = w.CenterOf(*i).z() + 0.5 * res;
    if (std::abs(top - z_m) <= tol_m) return top;
    return std::nullopt;
  }
  return std::nullopt;
}

// True if a robot can stand at (x, y) on a floor at `floor_z_m`: floor within a voxel of that height under
// a disc of kFootprintRadiusM, kBodyHeightM free above it, inside the grid.
bool CanStand(const World& w, double x, double y, double floor_z_m) {
  const double res = w.resolution_m();
  const double tol = std::max(res, 0.04);
  if (floor_z_m + kBodyHeightM > w.p_W_max().z()) return false;
  for (int k = 0; k <= 8; ++k) {
    const double a = k * kPi / 4.0;
    const double r = k == 8 ? 0.0 : kFootprintRadiusM;
    const double px = x + r * std::cos(a), py = y + r * std::sin(a);
    if (!SurfaceNear(w, px, py, floor_z_m, tol)) return false;
    for (double z = floor_z_m + std::max(0.05, res); z < floor_z_m + kBodyHeightM; z += res) {
      if (w.IsOccupied({px, py, z})) return false;
    }
  }
  return true;
}

// A straight drive of kDriveM ending at `end` heading `yaw_rad`, if every pose can stand on `floor_z_m`.
std::optional<View> Drive(const World& w, const std::string& kind, const Eigen::Vector2d& end, double yaw_rad,
                          double floor_z_m) {
  View view;
  view.kind = kind;
  view.floor_z_m = floor_z_m;
  const Eigen::Vector2d d = Dir(yaw_rad);
  for (int i = 0; i < kScansPerView; ++i) {
    const Eigen::Vector2d p = end - (kDriveM * (kScansPerView - 1 - i) / (kScansPerView - 1)) * d;
    if (!CanStand(w, p.x(), p.y(), floor_z_m)) return std::nullopt;
    view.poses.push_back({Eigen::Vector3d(p.x(), p.y(), floor_z_m + kSensorHeightM), yaw_rad});
  }
  return view;
}

// Views looking at `target` (x, y; on a floor at floor_z_m) along `facing_rad`: from each distance and each
// angle off that direction.
void AddViewsOf(Scene* scene, const std::string& kind, const Eigen::Vector2d& target, double facing_rad,
                double floor_z_m, const std::vector<double>& distances_m,
                const std::vector<double>& angles_rad) {
  for (double d : distances_m) {
    for (double a : angles_rad) {
      const Eigen::Vector2d end = target - d * Dir(facing_rad + a);
      // Driving towards the target, else arriving from the side or from beyond (the lidar sees all around).
      for (double turn : {0.0, 0.5 * kPi, -0.5 * kPi, kPi}) {
        if (auto v = Drive(*scene->truth, kind, end, facing_rad + a + turn, floor_z_m)) {
          scene->views.push_back(std::move(*v));
          break;
        }
      }
    }
  }
}

// Approach and side-on views of every flight of the scene.
void AddFlightViews(Scene* scene) {
  for (const StaircaseFlight& f : scene->flights) {
    const Eigen::Vector2d foot = f.p_W_first_riser.head<2>();
    const Eigen::Vector2d u = Dir(f.yaw_rad), v(-u.y(), u.x());
    AddViewsOf(scene, "approach", foot, f.yaw_rad, f.p_W_first_riser.z(), {1.5, 2.5, 3.5},
               {0.0, 15 * kDeg, -15 * kDeg, 30 * kDeg, -30 * kDeg});
    const Eigen::Vector2d middle = foot + 0.5 * f.num_steps * f.run_m * u;
    for (int side : {1, -1}) {
      AddViewsOf(scene, "side-on", middle + side * 0.5 * f.width_m * v, f.yaw_rad - side * 0.5 * kPi,
                 f.p_W_first_riser.z(), {1.5, 2.5, 3.5}, {0.0});
    }
  }
}

// Standing spots every kGridSpacingM on every floor level (a surface with kBodyHeightM free above), each
// with the first of the four headings along which a drive ends there.
void AddGridViews(Scene* scene) {
  const World& w = *scene->truth;
  const double res = w.resolution_m();
  const Eigen::Vector3d lo = w.p_W_min(), hi = w.p_W_max();
  int n = 0;
  for (double x = lo.x() + 0.5 * kGridSpacingM; x < hi.x(); x += kGridSpacingM) {
    for (double y = lo.y() + 0.5 * kGridSpacingM; y < hi.y(); y += kGridSpacingM) {
      // Floor levels of the column, from the top down.
      std::vector<double> levels;
      int free_run = 0;
      for (double z = hi.z() - 0.5 * res; z > lo.z(); z -= res) {
        if (!w.IsOccupied({x, y, z})) {
          ++free_run;
          continue;
        }
        if (free_run * res >= kBodyHeightM && z + 0.5 * res + kBodyHeightM <= hi.z() - res) {
          levels.push_back(z + 0.5 * res);
        }
        free_run = 0;
      }
      for (double level : levels) {
        for (int k = 0; k < 4; ++k) {
          const double yaw = ((n + k) % 4) * 0.5 * kPi;
          if (auto v = Drive(w, "grid", {x, y}, yaw, level)) {
            scene->views.push_back(std::move(*v));
            break;
          }
        }
        ++n;
      }
    }
  }
}

// ---- Synthetic scenes (1 cm voxels)
// ------------------------------------------------------------------------

// Voxels of the scenes with flights (rises of 0.17-0.20 m need 1 cm) and of the other scenes.
constexpr double kFlightSceneRes = 0.01;
constexpr double kObjectSceneRes = 0.02;

// Fills the voxels whose centres lie in the prism over the rectangle [s0, s1] x [t0, t1] of the frame at
// `origin` rotated by `yaw_rad`, from z0 up to top(s) (s measured from origin along yaw).
void FillPrism(World* w, const Eigen::Vector2d& origin, double yaw_rad, double s0, double s1, double t0,
               double t1, double z0, const std::function<double(double)>& top) {
  const Eigen::Vector2d u = Dir(yaw_rad), v(-u.y(), u.x());
  Eigen::Vector2d bmin(1e9, 1e9), bmax(-1e9, -1e9);
  for (double s : {s0, s1}) {
    for (double t : {t0, t1}) {
      const Eigen::Vector2d c = origin + s * u + t * v;
      bmin = bmin.cwiseMin(c);
      bmax = bmax.cwiseMax(c);
    }
  }
  const double res = w->resolution_m();
  for (double x = bmin.x() - res; x <= bmax.x() + res; x += res) {
    for (double y = bmin.y() - res; y <= bmax.y() + res; y += res) {
      const std::optional<Eigen::Vector3i> i = w->IndexOf({x, y, z0 + 0.5 * res});
      if (!i) continue;
      const Eigen::Vector3d c = w->CenterOf(*i);
      const Eigen::Vector2d d = c.head<2>() - origin;
      const double s = u.dot(d), t = v.dot(d);
      if (s < s0 || s >= s1 || t < t0 || t >= t1) continue;
      const double z1 = top(s);
      for (Eigen::Vector3i j = *i; w->Contains(j) && w->CenterOf(j).z() < z1; ++j.z()) w->SetOccupied(j);
    }
  }
}

void FillBox(World* w, const Eigen::Vector2d& origin, double yaw_rad, double s0, double s1, double t0,
             double t1, double z0, double z1) {
  FillPrism(w, origin, yaw_rad, s0, s1, t0, t1, z0, [z1](double) { return z1; });
}

// A 12 x 12 m floor (surface z = 0) with 2.6 m of air above, at `res_m` voxels.
std::shared_ptr<World> EmptyScene(const std::string& name, double res_m) {
  const int n = static_cast<int>(std::lround(12.0 / res_m));
  auto w = std::make_shared<World>(name, Eigen::Vector3d(0.0, 0.0, -0.06), res_m,
                                   Eigen::Vector3i(n, n, static_cast<int>(std::lround(2.66 / res_m))));
  FillBox(w.get(), {0.0, 0.0}, 0.0, 0.0, 12.0, 0.0, 12.0, -0.06, 0.0);
  return w;
}

// A flight of `f.num_steps` steps plus a `landing_m` landing, solid down to z = 0, optionally between two
// walls (0.1 m thick, 1 m above the nosing line, from the first riser to the end of the landing).
void AddFlight(World* w, const StaircaseFlight& f, double landing_m, bool walls) {
  const Eigen::Vector2d foot = f.p_W_first_riser.head<2>();
  const double len = f.num_steps * f.run_m;
  const double z0 = f.p_W_first_riser.z();
  FillPrism(w, foot, f.yaw_rad, 0.0, len + landing_m, -0.5 * f.width_m, 0.5 * f.width_m, 0.0,
            [&f, len, z0](double s) {
              return z0 + f.rise_m * (s < len ? std::floor(s / f.run_m) + 1.0 : f.num_steps);
            });
  if (!walls) return;
  for (int side : {1, -1}) {
    const double t0 = side > 0 ? 0.5 * f.width_m : -0.5 * f.width_m - 0.1;
    FillPrism(w, foot, f.yaw_rad, 0.0, len + landing_m, t0, t0 + 0.1, 0.0,
              [&f, len, z0](double s) { return z0 + 1.0 + f.rise_m * std::min(s, len) / f.run_m; });
  }
}

StaircaseFlight Flight(const Eigen::Vector3d& foot, double yaw_rad, double rise_m, double width_m) {
  StaircaseFlight f;
  f.p_W_first_riser = foot;
  f.yaw_rad = yaw_rad;
  f.rise_m = rise_m;
  f.run_m = 0.25;
  f.width_m = width_m;
  f.num_steps = 8;
  return f;
}

// Builds a scene on demand (one scene in memory at a time), with the scene's name known beforehand.
struct SceneMaker {
  std::string name;
  std::function<Scene()> make;
  Scene operator()() const { return make(); }
};

// A synthetic scene: `build` fills the world and names the flights and the objects to look at (target on
// the floor, facing direction); views are generated for both, and on a grid.
struct ObjectTarget {
  Eigen::Vector2d target;
  double facing_rad;
};
SceneMaker Synthetic(
    const std::string& name,
    const std::function<void(World*, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>*)>& build,
    bool approach_flights = true, double res_m = kFlightSceneRes) {
  return {name, [name, build, approach_flights, res_m] {
            auto w = EmptyScene(name, res_m);
            Scene scene;
            scene.group = "synthetic scenes (1-2 cm voxels)";
            scene.name = name;
            std::vector<ObjectTarget> objects;
            build(w.get(), &scene.flights, &objects);
            scene.truth = w;
            scene.scanned = w;
            for (const ObjectTarget& o : objects) {
              AddViewsOf(&scene, "object", o.target, o.facing_rad, 0.0, {1.5, 2.5, 3.5},
                         {0.0, 30 * kDeg, -30 * kDeg});
            }
            if (approach_flights) {
              AddFlightViews(&scene);
            } else {  // Side-on only: from both sides, along the flight, looking across the run.
              for (const StaircaseFlight& f : scene.flights) {
                const Eigen::Vector2d u = Dir(f.yaw_rad), v(-u.y(), u.x());
                for (int side : {1, -1}) {
                  for (double along : {0.25, 0.5, 0.75}) {
                    const Eigen::Vector2d at = f.p_W_first_riser.head<2>() +
                                               along * f.num_steps * f.run_m * u + side * 0.5 * f.width_m * v;
                    AddViewsOf(&scene, "side-on", at, f.yaw_rad - side * 0.5 * kPi, 0.0, {1.5, 2.5, 3.5},
                               {0.0, 15 * kDeg, -15 * kDeg});
                  }
                }
              }
            }
            AddGridViews(&scene);
            return scene;
          }};
}

// A scene without flights, at kObjectSceneRes.
SceneMaker ObjectScene(
    const std::string& name,
    const std::function<void(World*, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>*)>& build) {
  return Synthetic(name, build, true, kObjectSceneRes);
}

std::vector<SceneMaker> SyntheticScenes() {
  std::vector<SceneMaker> makers;
  const Eigen::Vector2d c(6.0, 6.0);  // Scene centre.
  // A wall, 4 m wide and 2.5 m high, and a 0.9 m parapet at 20 deg.
  makers.push_back(
      ObjectScene("wall", [c](World* w, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>* o) {
        FillBox(w, c + Eigen::Vector2d(0.0, -2.0), 0.5 * kPi, 0.0, 4.0, 0.0, 0.2, 0.0, 2.5);
        const Eigen::Vector2d parapet = c + Eigen::Vector2d(-4.0, 3.5);
        FillBox(w, parapet, 20 * kDeg, 0.0, 3.0, 0.0, 0.15, 0.0, 0.9);
        o->push_back({c, 0.0});
        o->push_back({parapet + 1.5 * Dir(20 * kDeg), 20 * kDeg + 0.5 * kPi});
      }));
  // Crates: one 0.6 x 0.4 x 0.45 m; a 1.2 x 1.0 m pallet (0.15 m) with a 0.8 m cube set back on it; a stack
  // of two crates (0.6 x 0.4 x 0.3 m each) at 15 deg.
  makers.push_back(
      ObjectScene("crates", [c](World* w, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>* o) {
        FillBox(w, c + Eigen::Vector2d(0.0, -2.5), 0.0, 0.0, 0.4, 0.0, 0.6, 0.0, 0.45);
        FillBox(w, c + Eigen::Vector2d(0.0, -0.6), 0.0, 0.0, 1.0, 0.0, 1.2, 0.0, 0.15);
        FillBox(w, c + Eigen::Vector2d(0.1, -0.4), 0.0, 0.1, 0.9, 0.0, 0.8, 0.15, 0.95);
        FillBox(w, c + Eigen::Vector2d(0.0, 2.0), 15 * kDeg, 0.0, 0.4, 0.0, 0.6, 0.0, 0.6);
        for (double dy : {-2.2, 0.0, 2.3}) o->push_back({c + Eigen::Vector2d(0.0, dy), 0.0});
      }));
  // A 0.15 m curb, 6 m long, and a 0.27 m kerb 0.3 m behind it (two edges).
  makers.push_back(
      ObjectScene("curb", [c](World* w, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>* o) {
        FillBox(w, c + Eigen::Vector2d(0.0, -3.0), 0.5 * kPi, 0.0, 6.0, -0.2, 0.0, 0.0, 0.15);
        FillBox(w, c + Eigen::Vector2d(0.3, -3.0), 0.5 * kPi, 0.0, 6.0, -0.2, 0.0, 0.0, 0.27);
        o->push_back({c, 0.0});
      }));
  // A table (1.2 x 0.8 m, top 0.72-0.76 m, four legs) and a 0.45 m bench in front of it.
  makers.push_back(
      ObjectScene("table", [c](World* w, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>* o) {
        FillBox(w, c + Eigen::Vector2d(0.5, -0.6), 0.0, 0.0, 0.8, 0.0, 1.2, 0.72, 0.76);
        for (double ls : {0.0, 0.76}) {
          for (double lt : {0.0, 1.16})
            FillBox(w, c + Eigen::Vector2d(0.5 + ls, -0.6 + lt), 0.0, 0.0, 0.04, 0.0, 0.04, 0.0, 0.72);
        }
        FillBox(w, c + Eigen::Vector2d(0.0, -0.6), 0.0, 0.0, 0.3, 0.0, 1.2, 0.0, 0.45);
        o->push_back({c, 0.0});
      }));
  // A 15 deg ramp up to 0.8 m, 1.5 m wide, then a platform; a 7 deg ramp beside it.
  makers.push_back(
      ObjectScene("ramp", [c](World* w, std::vector<StaircaseFlight>*, std::vector<ObjectTarget>* o) {
        const double len = 0.8 / std::tan(15 * kDeg);
        FillPrism(w, c + Eigen::Vector2d(0.0, -2.0), 0.0, 0.0, len + 1.0, 0.0, 1.5, 0.0,
                  [len](double s) { return 0.8 * std::min(s, len) / len; });
        FillPrism(w, c + Eigen::Vector2d(0.0, 1.0), 0.0, 0.0, 4.0, 0.0, 1.5, 0.0,
                  [](double s) { return s * std::tan(7 * kDeg); });
        o->push_back({c + Eigen::Vector2d(0.0, -1.25), 0.0});
        o->push_back({c + Eigen::Vector2d(0.0, 1.75), 0.0});
      }));
  // Flights of 8 steps of 0.25 m run, 1 m landing, foot at the centre: (rise, yaw, width, walls), straight
  // and rotated, open or between walls.
  struct FlightSpec {
    const char* name;
    double rise_m, yaw_rad, width_m;
    bool walls;
  };
  for (const FlightSpec& spec : {FlightSpec{"flight_r17_open", 0.17, 0.0, 1.0, false},
                                 FlightSpec{"flight_r18_walled_yaw30", 0.18, 30 * kDeg, 1.0, true},
                                 FlightSpec{"flight_r19_walled", 0.19, 0.0, 1.0, true},
                                 FlightSpec{"flight_r20_open_yaw-60", 0.20, -60 * kDeg, 1.2, false},
                                 FlightSpec{"flight_r19_open_yaw45", 0.19, 45 * kDeg, 1.0, false}}) {
    makers.push_back(Synthetic(
        spec.name, [c, spec](World* w, std::vector<StaircaseFlight>* flights, std::vector<ObjectTarget>*) {
          flights->push_back(Flight({c.x(), c.y(), 0.0}, spec.yaw_rad, spec.rise_m, spec.width_m));
          AddFlight(w, flights->back(), 1.0, spec.walls);
        }));
  }
  // A switchback stairwell: two 1.0 m flights of 8 steps (rise 0.19 m, run 0.25 m) side by side, a 1.2 m
  // landing across both, the upper flight ascending back above the floor beside the lower one (solid below).
  makers.push_back(Synthetic(
      "switchback", [c](World* w, std::vector<StaircaseFlight>* flights, std::vector<ObjectTarget>*) {
        const StaircaseFlight lower = Flight({c.x(), c.y(), 0.0}, 0.0, 0.19, 1.0);
        const StaircaseFlight upper = Flight({c.x() + 2.0, c.y() + 1.0, 8 * 0.19}, kPi, 0.19, 1.0);
        AddFlight(w, lower, 1.2, false);
        AddFlight(w, upper, 0.5, false);
        FillBox(w, c + Eigen::Vector2d(2.0, 0.5), 0.0, 0.0, 1.2, 0.0, 1.0, 0.0,
                8 * 0.19);  // Landing's other half.
        flights->push_back(lower);
        flights->push_back(upper);
      }));
  // A flight seen only side-on (8 steps, rise 0.18 m, run 0.25 m, 1.2 m wide, solid to the floor: its sides
  // are sawtooth profiles on vertical planes).
  makers.push_back(Synthetic(
      "side_on",
      [c](World* w, std::vector<StaircaseFlight>* flights, std::vector<ObjectTarget>*) {
        flights->push_back(Flight({c.x() - 1.0, c.y(), 0.0}, 0.0, 0.18, 1.2));
        AddFlight(w, flights->back(), 1.0, false);
      },
      /*approach_flights=*/false));
  return makers;
}

// ---- Worlds
// ------------------------------------------------------------------------------------------------

std::string TempDir() {
  char pattern[] = "/tmp/cairn_staircase_accuracy_XXXXXX";
  const char* dir = ::mkdtemp(pattern);
  return dir != nullptr ? dir : "/tmp";
}

// A survey copy of `truth` (MakeSurveyScan with `options`), written as a PCD and loaded at 0.1 m with the
// default clean-up.
std::shared_ptr<World> SurveyCopy(const World& truth, const cairn::sim::SurveyScanOptions& options,
                                  std::uint32_t seed, const std::string& name, double res_m = 0.1) {
  const cairn::sim::SurveyScan scan = cairn::sim::MakeSurveyScan(truth, options, seed);
  const std::string dir = TempDir();
  const std::string path = dir + "/" + name + ".pcd";
  cairn::sim::WritePcd(path, scan.points_W);
  cairn::sim::WorldLoadReport report;
  cairn::sim::WorldLoadOptions load;
  load.pcd_resolution_m = res_m;
  auto world = std::make_shared<World>(cairn::sim::LoadWorld(path, load, &report));
  std::printf("  %s survey copy: %s\n", name.c_str(), report.Summary().c_str());
  std::remove(path.c_str());
  ::rmdir(dir.c_str());
  return world;
}

// The survey copy of a scene loaded at `res_m` (0.1 m: the loader's default): the same truth, views and
// flights, the lidar scans the copy. Surfaces keep wall_keep_fraction scaled to the scene's voxels so that,
// at 0.1 m, walls are as sparse as in the copy of geb079 (70 % of the voxels of a face).
SceneMaker SurveyOf(const SceneMaker& exact, const std::string& group, double res_m = 0.1) {
  return {"survey:" + exact.name, [exact, group, res_m] {
            Scene scene = exact();
            scene.group = group;
            cairn::sim::SurveyScanOptions options;
            const double scale = scene.truth->resolution_m() / 0.1;
            options.wall_keep_fraction = std::min(1.0, options.wall_keep_fraction * scale * scale);
            options.num_strays =
                100;  // 144 m² of floor: about the density of the geb079 copy (300 over ~400 m²).
            scene.scanned = SurveyCopy(*scene.truth, options, 11, scene.name, res_m);
            scene.name = "survey:" + scene.name;
            return scene;
          }};
}

std::vector<SceneMaker> AllScenes(const std::string& geb079_path) {
  std::vector<SceneMaker> makers;
  std::vector<SceneMaker> surveys;
  for (const std::string& name : cairn::sim::BuiltinWorldNames()) {
    const SceneMaker exact{"builtin:" + name, [name] {
                             auto truth = std::make_shared<World>(cairn::sim::MakeBuiltinWorld(name));
                             Scene scene;
                             scene.group = "built-in worlds";
                             scene.name = "builtin:" + name;
                             scene.truth = truth;
                             scene.scanned = truth;
                             scene.flights = cairn::sim::GetBuiltinWorldInfo(name).staircases;
                             AddFlightViews(&scene);
                             AddGridViews(&scene);
                             return scene;
                           }};
    makers.push_back(exact);
    surveys.push_back(SurveyOf(exact, "survey copies (0.1 m) of the built-in worlds"));
  }
  makers.insert(makers.end(), surveys.begin(), surveys.end());
  makers.push_back({"geb079-degraded", [geb079_path] {
                      Scene scene;
                      scene.group = "degraded geb079 (0.1 m)";
                      scene.name = "geb079-degraded";
                      if (!std::ifstream(geb079_path).good()) {
                        std::printf("  %s is absent: degraded geb079 skipped (it lives in data)\n",
                                    geb079_path.c_str());
                        return scene;
                      }
                      cairn::sim::WorldLoadOptions raw;
                      raw.support_radius_m = 0.0;
                      raw.fill_hole_max_m = 0.0;
                      auto truth = std::make_shared<World>(cairn::sim::LoadWorld(geb079_path, raw));
                      scene.truth = truth;
                      scene.scanned = SurveyCopy(*truth, cairn::sim::DegradedGeb079Options(), 79, "geb079");
                      AddGridViews(&scene);
                      return scene;
                    }});
  const std::vector<SceneMaker> synthetic = SyntheticScenes();
  makers.insert(makers.end(), synthetic.begin(), synthetic.end());
  // Survey copies: objects at the loader's default 0.1 m (the false positives users met); flights at 0.05 m,
  // the coarsest voxels that keep a 0.25 m run (at 0.1 m its risers would alternate 0.2 and 0.3 m apart).
  for (const SceneMaker& m : synthetic) {
    const bool flights = m.name.find("flight") != std::string::npos || m.name == "switchback";
    makers.push_back(flights ? SurveyOf(m, "survey copies (0.05 m) of the synthetic flights", 0.05)
                             : SurveyOf(m, "survey copies (0.1 m) of the synthetic objects"));
  }
  return makers;
}

// ---- Scoring
// -----------------------------------------------------------------------------------------------

// Match of a detection with a true flight: the flight riser its first riser lies on, or nothing.
std::optional<int> MatchRiser(const Staircase& d, const StaircaseFlight& f) {
  if (std::abs(std::remainder(d.yaw_rad - f.yaw_rad, 2 * kPi)) > kMatchYawRad) return std::nullopt;
  const Eigen::Vector2d u = Dir(f.yaw_rad), v(-u.y(), u.x());
  const Eigen::Vector2d rel = (d.p_W_first_step - f.p_W_first_riser).head<2>();
  const int k = static_cast<int>(std::lround(u.dot(rel) / f.run_m));
  if (k < 0 || k >= f.num_steps) return std::nullopt;
  if (std::abs(u.dot(rel) - k * f.run_m) > kMatchAlongM) return std::nullopt;
  if (std::abs(d.p_W_first_step.z() - (f.p_W_first_riser.z() + k * f.rise_m)) > kMatchHeightM)
    return std::nullopt;
  if (std::abs(v.dot(rel)) > 0.5 * f.width_m) return std::nullopt;
  return k;
}

// True if the cloud holds at least kMinEdgePoints points on each of the first three step edges of `f`: the
// top 5 cm of riser k's face or the first 10 cm of the tread behind it (what gives a step's height; a riser
// seen only lower down gives a lower bound).
constexpr int kMinEdgePoints = 3;
bool StepEdgesSeen(const std::vector<Eigen::Vector3f>& cloud, const StaircaseFlight& f) {
  const Eigen::Vector2d u = Dir(f.yaw_rad), v(-u.y(), u.x());
  int seen[3] = {0, 0, 0};
  for (const Eigen::Vector3f& q : cloud) {
    const Eigen::Vector3d rel = q.cast<double>() - f.p_W_first_riser;
    const double s = u.dot(rel.head<2>()), t = v.dot(rel.head<2>());
    if (std::abs(t) > 0.5 * f.width_m - 0.05) continue;
    for (int k = 0; k < 3; ++k) {
      const double ds = s - k * f.run_m, dz = rel.z() - (k + 1) * f.rise_m;
      if (ds >= -0.03 && ds <= 0.10 && dz >= -0.05 && dz <= 0.03) ++seen[k];
    }
  }
  return seen[0] >= kMinEdgePoints && seen[1] >= kMinEdgePoints && seen[2] >= kMinEdgePoints;
}

// True if flight `f` is expected in a view ending at sensor position `p` on a floor at `floor_z_m`.
bool Expected(const World& truth, const StaircaseFlight& f, const Eigen::Vector3d& p, double floor_z_m) {
  if (std::abs(floor_z_m - f.p_W_first_riser.z()) > 0.1) return false;
  const Eigen::Vector2d u = Dir(f.yaw_rad), v(-u.y(), u.x());
  const Eigen::Vector2d rel = p.head<2>() - f.p_W_first_riser.head<2>();
  const double before = -u.dot(rel);
  if (before < kExpectMinM || before > kExpectMaxM) return false;
  if (std::abs(v.dot(rel)) > 0.5 * f.width_m + before * std::tan(kExpectConeRad)) return false;
  for (int k = 1; k <= 3; ++k) {
    const Eigen::Vector2d c = f.p_W_first_riser.head<2>() + (k - 0.5) * f.run_m * u;
    const Eigen::Vector3d target(c.x(), c.y(), f.p_W_first_riser.z() + k * f.rise_m + 0.02);
    const Eigen::Vector3d ray = target - p;
    const double dist = ray.norm();
    if (std::abs(std::asin(ray.z() / dist)) > kLidarHalfFovRad) return false;
    const auto hit = cairn::sim::CastRay(truth, p, ray / dist, dist);
    if (hit && hit->range_m < dist - 0.05) return false;
  }
  return true;
}

struct Tally {
  int views = 0, expected = 0, found = 0, tp = 0, fp = 0;
  std::vector<double> rise_err_m, run_err_m, run25_err_m;
  void Add(const Tally& o) {
    views += o.views;
    expected += o.expected;
    found += o.found;
    tp += o.tp;
    fp += o.fp;
    rise_err_m.insert(rise_err_m.end(), o.rise_err_m.begin(), o.rise_err_m.end());
    run_err_m.insert(run_err_m.end(), o.run_err_m.begin(), o.run_err_m.end());
    run25_err_m.insert(run25_err_m.end(), o.run25_err_m.begin(), o.run25_err_m.end());
  }
};

std::string MedianMaxCm(std::vector<double> v) {
  if (v.empty()) return "-";
  std::sort(v.begin(), v.end());
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.1f / %.1f", 100 * v[v.size() / 2], 100 * v.back());
  return buf;
}

std::string Ratio(int num, int den) {
  if (den == 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.3f", static_cast<double>(num) / den);
  return buf;
}

std::string Describe(const Staircase& d) {
  char buf[200];
  std::snprintf(buf, sizeof(buf),
                "(%.2f, %.2f, %.2f) yaw %.0f deg, %d steps, rise %.3f, run %.3f, width %.2f",
                d.p_W_first_step.x(), d.p_W_first_step.y(), d.p_W_first_step.z(), d.yaw_rad / kDeg,
                d.num_steps, d.rise_m, d.run_m, d.width_m);
  return buf;
}

// All rejection reasons of a Detect() call, '; '-separated.
std::string Rejections(const cairn::perception::DetectStats& stats) {
  std::string out;
  for (const std::string& r : stats.rejections) out += (out.empty() ? "" : "; ") + r;
  return out.empty() ? "no chain of >= 3 risers" : out;
}

Tally RunScene(const Scene& scene, const cairn::perception::StaircaseDetector& detector, std::uint32_t seed,
               bool verbose, int only_view) {
  Tally t;
  cairn::sim::LidarScan scan;
  for (std::size_t vi = 0; vi < scene.views.size(); ++vi) {
    if (only_view >= 0 && static_cast<int>(vi) != only_view) continue;
    const View& view = scene.views[vi];
    cairn::sim::SimulatedLidar lidar(cairn::sim::LidarOptions{}, seed + static_cast<std::uint32_t>(vi));
    cairn::perception::LocalCloud cloud;
    double stamp_s = 0.0;
    for (const Pose& pose : view.poses) {
      Eigen::Isometry3d T_W_S = Eigen::Isometry3d::Identity();
      T_W_S.translation() = pose.p_W;
      T_W_S.linear() = Eigen::AngleAxisd(pose.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      lidar.Scan(*scene.scanned, T_W_S, &scan);
      cloud.AddScan(scan.points_S, T_W_S, stamp_s);
      stamp_s += 0.5;
    }
    const Eigen::Vector3d p = view.poses.back().p_W;
    cairn::perception::DetectStats stats;
    const std::vector<Eigen::Vector3f> points = cloud.Points();
    const std::vector<Staircase> found = detector.Detect(points, p, &stats);
    ++t.views;
    std::vector<bool> expected(scene.flights.size()), seen(scene.flights.size(), false);
    for (std::size_t i = 0; i < scene.flights.size(); ++i) {
      expected[i] = Expected(*scene.truth, scene.flights[i], p, view.floor_z_m) &&
                    StepEdgesSeen(points, scene.flights[i]);
      t.expected += expected[i];
    }
    for (const Staircase& d : found) {
      int match = -1;
      for (std::size_t i = 0; i < scene.flights.size() && match < 0; ++i) {
        if (!seen[i] && MatchRiser(d, scene.flights[i])) match = static_cast<int>(i);
      }
      if (match < 0) {
        ++t.fp;
        std::printf("    FP %s view %zu (%s) at (%.2f, %.2f, %.2f) yaw %.0f: %s\n", scene.name.c_str(), vi,
                    view.kind.c_str(), p.x(), p.y(), p.z(), view.poses.back().yaw_rad / kDeg,
                    Describe(d).c_str());
        continue;
      }
      const StaircaseFlight& f = scene.flights[static_cast<std::size_t>(match)];
      seen[static_cast<std::size_t>(match)] = true;
      ++t.tp;
      t.found += expected[static_cast<std::size_t>(match)];
      t.rise_err_m.push_back(std::abs(d.rise_m - f.rise_m));
      t.run_err_m.push_back(std::abs(d.run_m - f.run_m));
      // Run error on 0.25 m runs where the scanned world keeps them: a flight voxelized at 0.1 m has risers
      // alternately 0.2 and 0.3 m apart (the side-on flight's survey copy), whatever the detector does.
      const double run_voxels = f.run_m / scene.scanned->resolution_m();
      if (std::abs(f.run_m - 0.25) < 1e-6 && std::abs(run_voxels - std::round(run_voxels)) < 1e-6) {
        t.run25_err_m.push_back(std::abs(d.run_m - f.run_m));
      }
      if (verbose) {
        std::printf("    TP %s view %zu (%s) at (%.2f, %.2f) yaw %.0f: %s\n", scene.name.c_str(), vi,
                    view.kind.c_str(), p.x(), p.y(), view.poses.back().yaw_rad / kDeg, Describe(d).c_str());
      }
    }
    if (verbose && !stats.rejections.empty()) {
      std::printf("    rejected in %s view %zu (%s): %s\n", scene.name.c_str(), vi, view.kind.c_str(),
                  Rejections(stats).c_str());
    }
    for (std::size_t i = 0; i < scene.flights.size(); ++i) {
      if (expected[i] && !seen[i]) {
        std::printf(
            "    FN %s view %zu (%s) at (%.2f, %.2f, %.2f) yaw %.0f: flight %zu missed (rejected: %s)\n",
            scene.name.c_str(), vi, view.kind.c_str(), p.x(), p.y(), p.z(), view.poses.back().yaw_rad / kDeg,
            i, Rejections(stats).c_str());
      }
    }
  }
  return t;
}

void PrintRow(const std::string& name, const Tally& t) {
  std::printf("| %s | %d | %d | %d | %d | %d | %s | %s | %s | %s |\n", name.c_str(), t.views, t.expected,
              t.tp, t.fp, t.expected - t.found, Ratio(t.tp, t.tp + t.fp).c_str(),
              Ratio(t.found, t.expected).c_str(), MedianMaxCm(t.rise_err_m).c_str(),
              MedianMaxCm(t.run_err_m).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  std::string only;
  bool verbose = false;
  int only_view = -1;
  std::string geb079 = cairn::core::SourceDir() + "/data/geb079.bt";
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--only") == 0 && i + 1 < argc) {
      only = argv[++i];
    } else if (std::strcmp(argv[i], "--geb079") == 0 && i + 1 < argc) {
      geb079 = argv[++i];
    } else if (std::strcmp(argv[i], "--view") == 0 && i + 1 < argc) {
      only_view = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--verbose") == 0) {
      verbose = true;
    } else {
      std::fprintf(stderr, "usage: %s [--only SUBSTRING [--view INDEX]] [--verbose] [--geb079 PATH]\n",
                   argv[0]);
      return 2;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  std::printf(
      "Staircase detection accuracy (scoring rules: bench/staircase_accuracy.cpp)\nBuilding scenes:\n");
  const std::vector<SceneMaker> makers = AllScenes(geb079);
  const cairn::perception::StaircaseDetector detector;
  std::map<std::string, Tally> groups;
  std::vector<std::string> group_order;
  std::vector<std::pair<std::string, Tally>> rows;
  std::uint32_t seed = 1000;
  for (const SceneMaker& make : makers) {
    seed += 1000;
    if (!only.empty() && make.name.find(only) == std::string::npos) continue;
    const auto t_scene = std::chrono::steady_clock::now();
    const Scene scene = make();
    if (scene.truth == nullptr) continue;
    const Tally t = RunScene(scene, detector, seed, verbose, only_view);
    std::printf("  %s: %d views, %.1f s\n", scene.name.c_str(), t.views,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t_scene).count());
    std::fflush(stdout);
    rows.emplace_back(scene.name, t);
    if (groups.count(scene.group) == 0) group_order.push_back(scene.group);
    groups[scene.group].Add(t);
  }
  std::printf(
      "\nPer scene: views, expected flights (view x flight), true positives, false positives, missed, "
      "precision, recall, |rise error| and |run error| median / max (cm)\n\n");
  std::printf(
      "| scene | views | expected | TP | FP | missed | precision | recall | rise err cm | run err cm |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [name, t] : rows) PrintRow(name, t);
  std::printf("\nPer group\n\n");
  std::printf(
      "| group | views | expected | TP | FP | missed | precision | recall | rise err cm | run err cm |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  Tally all;
  for (const std::string& g : group_order) {
    PrintRow(g, groups[g]);
    all.Add(groups[g]);
  }
  PrintRow("**all**", all);
  std::printf(
      "\nFIGURE staircase_accuracy views %d expected %d tp %d fp %d missed %d precision %s recall %s "
      "rise_err_cm(median/max) %s run_err_cm(median/max) %s run_err_cm_on_0.25m_runs(median/max) %s "
      "(%zu detections) wall_s %.0f\n",
      all.views, all.expected, all.tp, all.fp, all.expected - all.found,
      Ratio(all.tp, all.tp + all.fp).c_str(), Ratio(all.found, all.expected).c_str(),
      MedianMaxCm(all.rise_err_m).c_str(), MedianMaxCm(all.run_err_m).c_str(),
      MedianMaxCm(all.run25_err_m).c_str(), all.run25_err_m.size(),
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}
