#include "cairn/base/places.h"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <regex>
#include <stdexcept>

#include "cairn/core/config.h"

namespace cairn::base {

bool Places::IsValidName(const std::string& name, std::string* why) {
  static const std::regex kName("[A-Za-z][A-Za-z0-9_-]{0,63}");
  if (std::regex_match(name, kName)) return true;
  *why = "place name '" + name + "' must start with a letter and be 1-64 characters of A-Z a-z 0-9 _ -";
  return false;
}

Places Places::Load(const std::string& path) {
  Places places;
  places.path_ = path;
  if (path.empty() || !std::filesystem::exists(path)) return places;
  YAML::Node root;
  try {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument("places file " + path + " cannot be read");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    core::RejectYamlAliases(text, "places file " + path);
    root = YAML::Load(text);
  } catch (const core::ConfigError& e) {
    throw std::invalid_argument(e.what());
  } catch (const YAML::Exception& e) {
    throw std::invalid_argument("places file " + path + ": not valid YAML: " + e.what());
  }
  if (!root || root.IsNull()) return places;
  const YAML::Node list = root["places"];
  if (!root.IsMap() || (list && !list.IsMap() && !list.IsNull())) {
    throw std::invalid_argument("places file " + path + ": expected a map 'places: {NAME: {x_m, y_m, z_m}}'");
  }
  if (!list || list.IsNull()) return places;
  for (const auto& entry : list) {
    const std::string name = entry.first.as<std::string>();
    Place place;
    place.name = name;
    const YAML::Node& fields = entry.second;
    if (!fields.IsMap())
      throw std::invalid_argument("places file " + path + ": place '" + name + "' is not a map");
    for (const auto& field : fields) {
      const std::string key = field.first.as<std::string>();
      double* value = key == "x_m"   ? &place.x_m
                      : key == "y_m" ? &place.y_m
                      : key == "z_m" ? &place.z_m
                                     : nullptr;
      if (value == nullptr) {
        throw std::invalid_argument("places file " + path + ": place '" + name + "': unknown key '" + key +
                                    "' (keys: x_m, y_m, z_m)");
      }
      try {
        *value = field.second.as<double>();
      } catch (const YAML::Exception&) {
        throw std::invalid_argument("places file " + path + ": place '" + name + "': " + key + " = '" +
                                    field.second.as<std::string>("?") + "' is not a number");
      }
    }
    if (!fields["x_m"] || !fields["y_m"]) {
      throw std::invalid_argument("places file " + path + ": place '" + name + "' needs x_m and y_m");
    }
    try {
      places.Add(place);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument("places file " + path + ": " + e.what());
    }
  }
  return places;
}

void Places::Add(const Place& place) {
  std::string why;
  if (!IsValidName(place.name, &why)) throw std::invalid_argument(why);
  if (!std::isfinite(place.x_m) || !std::isfinite(place.y_m) || !std::isfinite(place.z_m)) {
    char text[160];
    std::snprintf(text, sizeof(text), "place '%s': (%g, %g, %g) is not a finite point", place.name.c_str(),
                  place.x_m, place.y_m, place.z_m);
    throw std::invalid_argument(text);
  }
  places_[place.name] = place;
}

bool Places::Remove(const std::string& name) { return places_.erase(name) > 0; }

std::optional<Place> Places::Find(const std::string& name) const {
  auto it = places_.find(name);
  if (it == places_.end()) return std::nullopt;
  return it->second;
}

std::optional<Place> Places::Nearest(double x_m, double y_m, double z_m, double within_m) const {
  std::optional<Place> best;
  double best_m = within_m;
  for (const auto& [name, place] : places_) {
    const double d = std::hypot(place.x_m - x_m, place.y_m - y_m);
    if (d <= best_m && std::abs(place.z_m - z_m) <= 2.0) {
      best = place;
      best_m = d;
    }
  }
  return best;
}

std::vector<Place> Places::All() const {
  std::vector<Place> all;
  for (const auto& [name, place] : places_) all.push_back(place);
  return all;
}

std::vector<std::string> Places::Names() const {
  std::vector<std::string> names;
  for (const auto& [name, place] : places_) names.push_back(name);
  return names;
}

void Places::Save() const {
  if (path_.empty()) return;
  YAML::Emitter out;
  out << YAML::Comment("Cairn named places: points in the map frame, metres (cairn_base: place add, places)");
  out << YAML::BeginMap << YAML::Key << "places" << YAML::Value << YAML::BeginMap;
  for (const auto& [name, p] : places_) {
    out << YAML::Key << name << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_m"
        << YAML::Value << p.x_m << YAML::Key << "y_m" << YAML::Value << p.y_m << YAML::Key << "z_m"
        << YAML::Value << p.z_m << YAML::EndMap;
  }
  out << YAML::EndMap << YAML::EndMap;
  const std::filesystem::path target(path_);
  if (target.has_parent_path()) {
    std::error_code ignored;
    std::filesystem::create_directories(target.parent_path(), ignored);
  }
  const std::string temp = path_ + ".tmp";
  {
    std::ofstream file(temp);
    file << out.c_str() << "\n";
    if (!file) throw std::runtime_error("cannot write places file " + temp);
  }
  std::error_code error;
  std::filesystem::rename(temp, target, error);
  if (error) throw std::runtime_error("cannot write places file " + path_ + ": " + error.message());
}

}  // namespace cairn::base
