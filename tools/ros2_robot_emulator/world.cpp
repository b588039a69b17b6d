// Copyright Cairn authors.
#include "world.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

namespace ros2_emulator {
namespace {

/// Appends the four walls of the axis-aligned box centred on (cx_m, cy_m), size_x_m by size_y_m.
void AddBox(World& world, double cx_m, double cy_m, double size_x_m, double size_y_m) {
  const double x0 = cx_m - 0.5 * size_x_m, x1 = cx_m + 0.5 * size_x_m;
  const double y0 = cy_m - 0.5 * size_y_m, y1 = cy_m + 0.5 * size_y_m;
  world.walls.push_back({x0, y0, x1, y0});
  world.walls.push_back({x1, y0, x1, y1});
  world.walls.push_back({x1, y1, x0, y1});
  world.walls.push_back({x0, y1, x0, y0});
}

/// The L-shaped corridor (see BuiltinWorld). Leg 1: x in [0, 12], y in [-1.25, 1.25]; leg 2 turns left at
/// its end: x in [9.5, 12], y up to 11.25 (10 m past leg 1's side wall).
World CornerWorld() {
  World world;
  world.name = "corner";
  world.walls = {
      {0.0, -1.25, 0.0, 1.25},     // closed start end
      {0.0, -1.25, 12.0, -1.25},   // leg 1, right side (continues as the outer corner)
      {12.0, -1.25, 12.0, 11.25},  // outer side of the turn and leg 2's right side
      {0.0, 1.25, 9.5, 1.25},      // leg 1, left side, up to the inner corner
      {9.5, 1.25, 9.5, 11.25},     // leg 2, left side
      {9.5, 11.25, 12.0, 11.25},   // closed far end
  };
  // A 0.6 m box against the left half of leg 1: a robot passes on its right (1.45 m gap), not on its left
  // (0.45 m).
  AddBox(world, 6.0, 0.5, 0.6, 0.6);
  world.default_start = {1.0, 0.0, 0.0};
  return world;
}

/// The closed 8 x 6 m room (see BuiltinWorld): x in [0, 8], y in [0, 6].
World RoomWorld() {
  World world;
  world.name = "room";
  world.walls = {
      {0.0, 0.0, 8.0, 0.0},
      {8.0, 0.0, 8.0, 6.0},
      {8.0, 6.0, 0.0, 6.0},
      {0.0, 6.0, 0.0, 0.0},
  };
  AddBox(world, 2.5, 4.0, 0.8, 0.8);
  AddBox(world, 5.5, 2.0, 1.0, 0.6);
  world.default_start = {1.0, 1.0, 0.0};
  return world;
}

/// Distance from (px, py) to the segment s, metres.
double DistanceToSegment(const Segment& s, double px, double py) {
  const double dx = s.x2_m - s.x1_m, dy = s.y2_m - s.y1_m;
  const double length_sq = dx * dx + dy * dy;
  double t = length_sq > 0.0 ? ((px - s.x1_m) * dx + (py - s.y1_m) * dy) / length_sq : 0.0;
  t = std::clamp(t, 0.0, 1.0);
  return std::hypot(px - (s.x1_m + t * dx), py - (s.y1_m + t * dy));
}

/// Parses `token` as a finite double; nullopt if it is not one (trailing characters included).
std::optional<double> ParseFiniteDouble(const std::string& token) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(token.c_str(), &end);
  if (end == token.c_str() || *end != '\0' || errno == ERANGE || !std::isfinite(value)) return std::nullopt;
  return value;
}

}  // namespace

std::optional<World> BuiltinWorld(const std::string& name) {
  if (name == "corner") return CornerWorld();
  if (name == "room") return RoomWorld();
  return std::nullopt;
}

std::string BuiltinWorldNames() { return "corner, room"; }

World LoadWorldFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw WorldFileError(path + ": cannot open the world file");
  World world;
  world.name = path;
  std::string line;
  for (int line_number = 1; std::getline(in, line); ++line_number) {
    const std::string where = path + ":" + std::to_string(line_number) + ": ";
    const std::string content = line.substr(0, line.find('#'));
    std::istringstream tokens(content);
    std::vector<double> values;
    for (std::string token; tokens >> token;) {
      const std::optional<double> value = ParseFiniteDouble(token);
      if (!value) throw WorldFileError(where + "'" + token + "' is not a finite number (metres)");
      values.push_back(*value);
    }
    if (values.empty()) continue;  // blank or comment-only line
    if (values.size() != 4) {
      throw WorldFileError(where + "'" + content + "' has " + std::to_string(values.size()) +
                           " numbers; a wall is 'x1 y1 x2 y2' (4 numbers, metres)");
    }
    const Segment wall{values[0], values[1], values[2], values[3]};
    if (wall.x1_m == wall.x2_m && wall.y1_m == wall.y2_m) {
      throw WorldFileError(where + "'" + content + "' is a wall of zero length");
    }
    world.walls.push_back(wall);
  }
  if (in.bad()) throw WorldFileError(path + ": read error");
  if (world.walls.empty()) throw WorldFileError(path + ": no wall in the file (one 'x1 y1 x2 y2' a line)");
  return world;
}

double DistanceToNearestWall(const World& world, double x_m, double y_m) {
  double nearest_m = std::numeric_limits<double>::infinity();
  for (const Segment& wall : world.walls) nearest_m = std::min(nearest_m, DistanceToSegment(wall, x_m, y_m));
  return nearest_m;
}

std::optional<double> RaycastWalls2d(const World& world, double x_m, double y_m, double dx, double dy) {
  // Ray p + t d (t >= 0) against segment a + u (b - a) (u in [0, 1]): solve with 2D cross products.
  std::optional<double> nearest_m;
  for (const Segment& wall : world.walls) {
    const double ex = wall.x2_m - wall.x1_m, ey = wall.y2_m - wall.y1_m;
    const double denominator = dx * ey - dy * ex;  // cross(d, e); 0 when parallel (a grazing ray: no hit)
    if (std::abs(denominator) < 1e-12) continue;
    const double ax = wall.x1_m - x_m, ay = wall.y1_m - y_m;
    const double t = (ax * ey - ay * ex) / denominator;  // cross(a - p, e) / cross(d, e)
    const double u = (ax * dy - ay * dx) / denominator;  // cross(a - p, d) / cross(d, e)
    if (t < 0.0 || u < 0.0 || u > 1.0) continue;
    if (!nearest_m || t < *nearest_m) nearest_m = t;
  }
  return nearest_m;
}

}  // namespace ros2_emulator
