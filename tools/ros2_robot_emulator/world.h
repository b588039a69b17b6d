// Copyright Cairn authors.
//
// The emulator's world: vertical wall segments standing on a flat floor. Frame W is the world (x, y on the
// floor, z up, the floor at z = 0); every wall is the vertical rectangle over its segment from z = 0 to
// kWallHeight_m. Pure geometry, no DDS: the lidar (lidar.h) and the drive (robot_model.h) ask it for ray hits
// and clearances.
//
// This is the emulator's own model of the world. It shares no code with Cairn's simulator on purpose: the
// emulator is the "implementation that is not ours" that Cairn's ROS 2 driver is tested against.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace ros2_emulator {

/// Height of every wall, metres (walls stand on the floor, z from 0 to this).
constexpr double kWallHeight_m = 2.5;

/// pi (M_PI is not standard C++).
constexpr double kPi = 3.14159265358979323846;

/// A planar pose: position on the floor, metres, and heading about z, radians (counter-clockwise from +x).
struct Pose2 {
  double x_m = 0.0;
  double y_m = 0.0;
  double yaw_rad = 0.0;
};

/// One wall's footprint on the floor, from (x1_m, y1_m) to (x2_m, y2_m), metres, frame W; never zero length.
struct Segment {
  double x1_m = 0.0;
  double y1_m = 0.0;
  double x2_m = 0.0;
  double y2_m = 0.0;
};

/// A world: its walls and the robot's start pose when --start does not give one.
struct World {
  /// "corner", "room" or the file the walls came from (for messages).
  std::string name;
  std::vector<Segment> walls;
  /// Pose of the robot's base in W at start.
  Pose2 default_start;
};

/// A world file that cannot be read; what() names the file, the line number and the offending value.
class WorldFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The built-in world called `name` ("corner" or "room"); nullopt for any other name.
///   corner: an L-shaped corridor 2.5 m wide, closed at both ends: a 12 m leg along +x, then a 90 deg turn
///           to the left and 10 m more along +y; a 0.6 m box in the first leg; start 1 m from the start end.
///   room:   a closed 8 x 6 m room with two boxes; start near a corner.
std::optional<World> BuiltinWorld(const std::string& name);

/// The names BuiltinWorld knows, for --help and error messages: "corner, room".
std::string BuiltinWorldNames();

/// Reads a world file: one wall per line, `x1 y1 x2 y2` in metres (frame W), blank lines and anything after
/// `#` ignored. The default start is the origin (give --start). Throws WorldFileError naming file, line and
/// value on a missing/unreadable file, a non-number, a non-finite number, a wrong count of numbers on a
/// line, a zero-length wall or a file with no wall.
World LoadWorldFile(const std::string& path);

/// Distance from the point (x_m, y_m) to the nearest wall footprint, metres (infinity with no walls).
double DistanceToNearestWall(const World& world, double x_m, double y_m);

/// Distance along the horizontal ray from (x_m, y_m) in the unit direction (dx, dy) to the first wall
/// footprint it crosses, metres; nullopt if it crosses none. A ray starting on a wall hits it at 0.
std::optional<double> RaycastWalls2d(const World& world, double x_m, double y_m, double dx, double dy);

}  // namespace ros2_emulator
