// Bench: exploration coverage against time for a team of 1, 2 and 3 robots, in process on a
// simulated clock (each the shipping agent stepped, RobotAgent::Stepped: lidar -> OctoMap -> navigation map
// -> frontiers -> explore mode -> navigation, explore claims, coverage and peer states sent as the agent
// sends them), scored against the world's ground truth. The baseline is one robot in the same run: the figure
// is its time to 90 % coverage over the team's.
//
//   build/bench/cairn_bench_explore [--world builtin:NAME] [--robots 1,2,3] [--kill]
//                                   [--csv FILE] [--timeout S] [--platform wheeled|legged] [--floors
//                                   Z0:Z1,...]
//                                   [--start X,Y[,YAW]]
//     robots start from a gate: the world's first suggested start (--start: this one, e.g. in a .bt world)
//     and 2 m steps along its heading; --kill also runs the largest team with robot 2 gone for good at 60 s;
//     --csv writes "robots,t_s,coverage" rows (the plot: tools/plot_explore_coverage.sh); --floors scores
//     each height band (a building's floors, metres) over the map's levels at the end (e.g. builtin:building
//     with a legged robot: --floors -0.5:0.5,2.7:3.7).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "../robot_agent/test/explore_team.h"
#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/lidar.h"

namespace {

using namespace cairn;
using agent::explore_team::RunTeam;
using agent::explore_team::TeamOptions;
using agent::explore_team::TeamRun;

// The bench's figures are the shipping lidar's (tests run a sparser one to save CPU).
const int kShippingLidarPointsPerBeam = sim::LidarOptions{}.points_per_beam;

std::vector<core::PlanarPose> Gate(const std::string& world, int robots,
                                   const std::optional<core::PlanarPose>& start) {
  const std::string name = world.rfind("builtin:", 0) == 0 ? world.substr(8) : world;
  const core::PlanarPose first = start ? *start : sim::GetBuiltinWorldInfo(name).suggested_starts.front();
  std::vector<core::PlanarPose> starts;
  starts.reserve(robots);
  for (int i = 0; i < robots; ++i) {
    starts.push_back({first.x_m + 2.0 * i * std::cos(first.yaw_rad),
                      first.y_m + 2.0 * i * std::sin(first.yaw_rad), first.yaw_rad});
  }
  return starts;
}

void Print(const char* label, int robots, const TeamRun& r, double baseline_90_s) {
  double reached = 0, driven = 0;
  for (std::size_t i = 0; i < r.statuses.size(); ++i) {
    reached += r.statuses[i].targets_reached;
    driven += r.driven_m[i];
  }
  // Claims on the wire: 88 bytes of CDR (encapsulation, a 2-character id, the fixed fields, the sequence's
  // length) plus the compressed coverage.
  const double claim_bits_per_s =
      robots > 0 && r.end_s > 0 ? 8.0 * (88.0 * r.claims_sent + r.coverage_bytes_sent) / r.end_s / robots
                                : 0.0;
  std::printf(
      "%-22s robots %d: 90 %% after %6.0f s (ratio 1 robot / team %.2f), end %5.0f s at %.1f %%, "
      "%d claim overlaps, %.0f targets, %.0f m driven, contact %s, claims %.0f bit/s per robot, "
      "%.0f s wall\n",
      label, robots, r.time_to_90_s,
      baseline_90_s > 0 && r.time_to_90_s > 0 ? baseline_90_s / r.time_to_90_s : 0.0, r.end_s,
      100 * r.coverage, r.claim_overlaps, reached, driven, r.contact ? "YES" : "no", claim_bits_per_s,
      r.wall_s);
}

}  // namespace

int main(int argc, char** argv) {
  std::string world = "builtin:tunnels";
  std::vector<int> teams = {1, 2, 3};
  bool kill = false;
  std::string csv;
  double timeout_s = 1800;
  std::string platform = "wheeled";
  std::optional<core::PlanarPose> start;
  std::vector<std::pair<double, double>> floors;
  std::optional<Eigen::AlignedBox2d> region;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--world" && i + 1 < argc) {
      world = argv[++i];
    } else if (a == "--robots" && i + 1 < argc) {
      teams.clear();
      std::stringstream list(argv[++i]);
      for (std::string n; std::getline(list, n, ',');) teams.push_back(std::stoi(n));
    } else if (a == "--kill") {
      kill = true;
    } else if (a == "--csv" && i + 1 < argc) {
      csv = argv[++i];
    } else if (a == "--timeout" && i + 1 < argc) {
      timeout_s = std::stod(argv[++i]);
    } else if (a == "--start" && i + 1 < argc) {
      double x = 0, y = 0, yaw = 0;
      if (std::sscanf(argv[++i], "%lf,%lf,%lf", &x, &y, &yaw) < 2) {
        std::fprintf(stderr, "--start '%s' must be X,Y[,YAW] (metres, radians)\n", argv[i]);
        return 2;
      }
      start = core::PlanarPose{x, y, yaw};
    } else if (a == "--region" && i + 1 < argc) {
      double x0 = 0, y0 = 0, x1 = 0, y1 = 0;
      if (std::sscanf(argv[++i], "%lf,%lf,%lf,%lf", &x0, &y0, &x1, &y1) != 4 || !(x0 < x1) || !(y0 < y1)) {
        std::fprintf(stderr, "--region '%s' must be X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1 (metres)\n",
                     argv[i]);
        return 2;
      }
      region = Eigen::AlignedBox2d(Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y1));
    } else if (a == "--platform" && i + 1 < argc) {
      platform = argv[++i];
    } else if (a == "--floors" && i + 1 < argc) {
      std::stringstream list(argv[++i]);
      for (std::string band; std::getline(list, band, ',');) {
        const std::size_t colon = band.find(':');
        if (colon == std::string::npos) {
          std::fprintf(stderr, "--floors '%s': each band is Z0:Z1 (metres)\n", band.c_str());
          return 2;
        }
        floors.emplace_back(std::stod(band.substr(0, colon)), std::stod(band.substr(colon + 1)));
      }
    } else {
      std::fprintf(
          stderr,
          "usage: %s [--world builtin:NAME] [--robots 1,2,3] [--kill] [--csv FILE] [--timeout S] "
          "[--platform wheeled|legged] [--floors Z0:Z1,...] [--start X,Y[,YAW]] [--region X0,Y0,X1,Y1]\n",
          argv[0]);
      return 2;
    }
  }
  std::ofstream out;
  if (!csv.empty()) {
    out.open(csv);
    out << "robots,t_s,coverage\n";
  }
  double baseline_90_s = -1;
  for (int robots : teams) {
    TeamOptions o;
    o.world = world;
    o.starts = Gate(world, robots, start);
    o.timeout_s = timeout_s;
    o.stop_at_coverage = 0.95;  // the 90 % figure and a little beyond; the rest is the last corners
    o.platform = platform;
    o.level_bands = floors;
    o.task.region_M = region;
    o.lidar_points_per_beam = kShippingLidarPointsPerBeam;
    if (!floors.empty())
      o.stop_at_coverage = 2.0;  // the floors are scored at the end: run until every robot ends
    const TeamRun r = RunTeam(o);
    if (robots == 1) baseline_90_s = r.time_to_90_s;
    Print(world.c_str(), robots, r, baseline_90_s);
    for (std::size_t k = 0; k < floors.size(); ++k) {
      std::printf("  floor z [%.1f, %.1f] m: %.1f %% of its reachable surfaces in the robots' maps\n",
                  floors[k].first, floors[k].second, 100 * r.level_coverage[k]);
    }
    if (!floors.empty()) {
      std::printf("  highest ground stood on: z %.2f m; %s: %s\n", r.highest_z_m,
                  agent::ToString(r.statuses[0].state), r.statuses[0].reason.c_str());
    }
    for (const auto& [t, c] : r.coverage_over_time) out << robots << "," << t << "," << c << "\n";
    std::fflush(stdout);
  }
  if (kill && !teams.empty()) {
    TeamOptions o;
    o.world = world;
    o.starts = Gate(world, teams.back(), start);
    o.timeout_s = timeout_s;
    o.kill_index = 1;
    o.kill_at_s = 60.0;
    o.stop_at_coverage = 0.9;
    o.lidar_points_per_beam = kShippingLidarPointsPerBeam;
    const TeamRun r = RunTeam(o);
    Print("(r2 gone at 60 s)", teams.back(), r, baseline_90_s);
  }
  return 0;
}
