// Named places (operators say "junction", not coordinates): a small YAML file of points in the map frame,
// shared by the consoles that load it.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace cairn::base {

/// A named point, frame map, metres.
struct Place {
  std::string name;  ///< [A-Za-z][A-Za-z0-9_-]{0,63}
  double x_m = 0.0;
  double y_m = 0.0;
  double z_m = 0.0;
};

/// Named places backed by a YAML file:
///   places:
///     junction: {x_m: 30.0, y_m: 20.0, z_m: 0.0}
class Places {
 public:
  Places() = default;
  /// Reads `path`; a file that does not exist is an empty list (saved on the first Add).
  /// @throws std::invalid_argument naming the file, the place and the field at fault (bad YAML, a name that
  ///         is not [A-Za-z][A-Za-z0-9_-]{0,63}, a coordinate that is not a finite number).
  static Places Load(const std::string& path);

  /// Adds or replaces `place`. @throws std::invalid_argument for a bad name or a non-finite coordinate.
  void Add(const Place& place);
  /// Removes `name`; false if there is no such place.
  bool Remove(const std::string& name);
  std::optional<Place> Find(const std::string& name) const;
  /// The place nearest (x_m, y_m) within `within_m` horizontally and 2 m in height (another floor is never
  /// "near"), metres, frame map; nullopt when none is.
  std::optional<Place> Nearest(double x_m, double y_m, double z_m, double within_m) const;
  std::vector<Place> All() const;
  std::vector<std::string> Names() const;
  const std::string& path() const { return path_; }

  /// Writes the file (to a temporary file, then renamed over it). No-op without a path.
  /// @throws std::runtime_error naming the path when it cannot be written.
  void Save() const;

  /// @return false and sets `*why` when `name` is not a valid place name.
  static bool IsValidName(const std::string& name, std::string* why);

 private:
  std::string path_;
  std::map<std::string, Place> places_;
};

}  // namespace cairn::base
