// Copyright Cairn authors.
//
// cairn_survey_pcd: writes a sparse, noisy survey scan of a world (sim::MakeSurveyScan) as a PCD that
// `cairn_agent --world FILE.pcd` and sim::LoadWorld() read: the kind of point cloud a low-resolution lidar
// survey of a site gives, to reproduce on a known world what users meet on their own scans. See --help.
#include <CLI/CLI.hpp>
#include <Eigen/Core>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/survey_scan.h"
#include "cairn/sim/world.h"

namespace {

// Defaults: on builtin:plant (seed 1) they give about 275 k points, the size of the 259 k point survey of an
// industrial building this tool was made to reproduce (~20 floor points/m^2; walls, ceilings and racks keep
// 13 % of their 0.1 m surface voxels, ~13 points/m^2).
constexpr double kDefaultFloorPointsPerM2 = 20.0;
constexpr double kDefaultWallKeepFraction = 0.13;
constexpr int kDefaultStrays = 300;

// Exit codes.
constexpr int kExitOk = 0;
constexpr int kExitFailed = 1;   // The survey or the write failed after the input was accepted.
constexpr int kExitInvalid = 2;  // A flag, the world or the output path is invalid.

// Invalid input, reported with the flag and value and exit code 2.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

std::uint32_t ParseSeed(const std::string& text) {
  std::size_t used = 0;
  unsigned long long value = 0;
  try {
    value = std::stoull(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (text.empty() || used != text.size() || text[0] == '-' || value > 0xFFFFFFFFull) {
    throw InputError("--seed '" + text + "' must be an integer in [0, 4294967295]");
  }
  return static_cast<std::uint32_t>(value);
}

// X0,Y0,X1,Y1,WIDTH (metres, frame W) -> a strip of floor with no return.
cairn::sim::SurveyStrip ParseStrip(const std::string& text) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  bool ok = true;
  while (ok && std::getline(in, item, ',')) {
    std::size_t used = 0;
    try {
      values.push_back(std::stod(item, &used));
    } catch (const std::exception&) {
      used = 0;
    }
    ok = !item.empty() && used == item.size() && std::isfinite(values.back());
  }
  if (!ok || values.size() != 5 || text.back() == ',') {
    throw InputError("--missing-strip '" + text +
                     "' must be X0,Y0,X1,Y1,WIDTH (five finite numbers, metres)");
  }
  if (!(values[4] > 0.0 && values[4] <= 10.0)) {
    throw InputError("--missing-strip '" + text + "': WIDTH " + item + " must be in (0, 10] m");
  }
  cairn::sim::SurveyStrip strip;
  strip.p_W_start = Eigen::Vector2d(values[0], values[1]);
  strip.p_W_end = Eigen::Vector2d(values[2], values[3]);
  strip.width_m = values[4];
  return strip;
}

void CheckOutputPath(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path file(path);
  if (file.extension() != ".pcd") throw InputError("--out '" + path + "' must end in .pcd");
  if (fs::is_directory(file, ec)) throw InputError("--out '" + path + "' is a directory, not a file");
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (!fs::is_directory(folder, ec)) {
    throw InputError("--out '" + path + "': its folder '" + folder.string() + "' does not exist");
  }
}

std::string Range(const char* axis, float lo, float hi) {
  std::ostringstream out;
  out.setf(std::ios::fixed);
  out.precision(2);
  out << axis << " [" << lo << ", " << hi << "]";
  return out.str();
}

// The scan's density, keep fraction and strays within their ranges; else InputError naming the flag.
void CheckSurveyOptions(const cairn::sim::SurveyScanOptions& options) {
  if (!(options.floor_points_per_m2 > 0.0 && options.floor_points_per_m2 <= 100.0)) {
    throw InputError("--floor-points-per-m2 " + std::to_string(options.floor_points_per_m2) +
                     " must be in (0, 100] points/m^2");
  }
  if (!(options.wall_keep_fraction >= 0.0 && options.wall_keep_fraction <= 1.0)) {
    throw InputError("--wall-keep-fraction " + std::to_string(options.wall_keep_fraction) +
                     " must be in [0, 1]");
  }
  if (options.num_strays < 0 || options.num_strays > 100000) {
    throw InputError("--strays " + std::to_string(options.num_strays) + " must be in [0, 100000]");
  }
}

// The built-in worlds' names, comma separated.
std::string BuiltinWorldList() {
  std::string worlds;
  for (const std::string& name : cairn::sim::BuiltinWorldNames())
    worlds += (worlds.empty() ? "" : ", ") + name;
  return worlds;
}

// "x [lo, hi] y [lo, hi] z [lo, hi]" of non-empty `points`, metres.
std::string ExtentText(const std::vector<Eigen::Vector3f>& points) {
  Eigen::Vector3f lo = points.front();
  Eigen::Vector3f hi = lo;
  for (const Eigen::Vector3f& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return Range("x", lo.x(), hi.x()) + " " + Range("y", lo.y(), hi.y()) + " " + Range("z", lo.z(), hi.z());
}

}  // namespace

int main(int argc, char** argv) {
  std::string world_spec, out_path, seed_text = "1";
  std::vector<std::string> strip_texts;
  cairn::sim::SurveyScanOptions options;
  options.floor_points_per_m2 = kDefaultFloorPointsPerM2;
  options.wall_keep_fraction = kDefaultWallKeepFraction;
  options.num_strays = kDefaultStrays;
  // A survey is made inside the site: the outer faces of a grid that ends at the building's shell (the roof's
  // top, the outside of the outer walls) are never seen.
  options.outside_is_solid = true;
  const std::string worlds = BuiltinWorldList();

  CLI::App app{
      "cairn_survey_pcd: writes a sparse, noisy survey scan of a world as a PCD (binary, fields x y z, "
      "metres, "
      "the world's frame) for `cairn_agent --world FILE.pcd`. Floors are thinned to --floor-points-per-m2, "
      "walls, ceilings and other surfaces keep --wall-keep-fraction of their voxels, single stray returns "
      "are "
      "added in open space, and floor returns are missing in each --missing-strip. Only the inside of the "
      "world's grid is seen. Prints the point count and extent.\nExit codes: 0 written; 1 the survey or the "
      "write failed; 2 invalid input (a flag, the world, the output path)."};
  app.add_option("--world", world_spec,
                 "world to survey: builtin:NAME (" + worlds + ") or a .bt/.ot/.pcd file")
      ->required();
  app.add_option("--out", out_path, "PCD file to write (FILE.pcd; its folder must exist)")->required();
  app.add_option("--seed", seed_text, "seed of the builtin world's generator and of the scan, 0..4294967295")
      ->capture_default_str();
  app.add_option("--floor-points-per-m2", options.floor_points_per_m2,
                 "points per m^2 kept on floors (top surfaces), range (0, 100]")
      ->capture_default_str();
  app.add_option("--wall-keep-fraction", options.wall_keep_fraction,
                 "fraction of the other surface voxels (walls, ceilings, racks) giving a point, range [0, 1]")
      ->capture_default_str();
  app.add_option("--strays", options.num_strays,
                 "single stray returns added in open space, range [0, 100000]")
      ->capture_default_str();
  app.add_option("--missing-strip", strip_texts,
                 "X0,Y0,X1,Y1,WIDTH: no floor return within WIDTH/2 of the segment (X0,Y0)-(X1,Y1), metres, "
                 "frame of the world (repeatable)");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);  // Prints the help, or the error naming the flag.
    return code == 0 ? kExitOk : kExitInvalid;
  }

  std::optional<cairn::sim::World> world;
  std::uint32_t seed = 0;
  try {
    seed = ParseSeed(seed_text);
    CheckSurveyOptions(options);
    for (const std::string& text : strip_texts) options.missing_strips.push_back(ParseStrip(text));
    CheckOutputPath(out_path);
    cairn::sim::WorldLoadOptions load;
    load.builtin_seed = seed;
    try {
      world = cairn::sim::LoadWorld(world_spec, load);
    } catch (const cairn::sim::WorldError& e) {
      throw InputError("--world '" + world_spec + "': " + e.what());
    }
  } catch (const InputError& e) {
    std::cerr << "cairn_survey_pcd: " << e.what() << std::endl;
    return kExitInvalid;
  }

  try {
    const cairn::sim::SurveyScan scan = cairn::sim::MakeSurveyScan(*world, options, seed);
    if (scan.points_W.empty()) throw std::runtime_error("the survey of '" + world_spec + "' has no point");
    cairn::sim::WritePcd(out_path, scan.points_W);
    std::cout << "cairn_survey_pcd: wrote " << out_path << ": " << scan.points_W.size() << " points ("
              << std::fixed << std::setprecision(1) << scan.floor_points_per_m2 << " floor points/m^2, "
              << scan.strays_W.size() << " strays, " << options.missing_strips.size()
              << " missing strips); extent " << ExtentText(scan.points_W) << " m" << std::endl;
  } catch (const std::exception& e) {
    std::cerr << "cairn_survey_pcd: " << e.what() << std::endl;
    return kExitFailed;
  }
  return kExitOk;
}
