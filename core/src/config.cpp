#include "cairn/core/config.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include <yaml-cpp/yaml.h>

namespace cairn::core {

struct ConfigSection::Impl {
  YAML::Node node;
  std::string origin;  // file name
  std::string path;    // dotted path of this section ("" at top level)
};

ConfigSection::ConfigSection(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ConfigSection::ConfigSection(const ConfigSection& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
ConfigSection& ConfigSection::operator=(const ConfigSection& other) {
  impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
ConfigSection::~ConfigSection() = default;

namespace {

ConfigSection::Impl Parse(const std::string& text, const std::string& origin) {
  ConfigSection::Impl impl;
  impl.origin = origin;
  try {
    impl.node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin + ": not valid YAML: " + e.what());
  }
  if (impl.node.IsNull()) impl.node = YAML::Node(YAML::NodeType::Map);
  if (!impl.node.IsMap()) throw ConfigError(origin + ": the top level must be a mapping of key: value");
  return impl;
}

}  // namespace

ConfigSection ConfigSection::LoadFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ConfigError("config file '" + path + "' cannot be read");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return ConfigSection(std::make_unique<Impl>(Parse(text, path)));
}

ConfigSection ConfigSection::LoadText(const std::string& text, const std::string& origin) {
  return ConfigSection(std::make_unique<Impl>(Parse(text, origin)));
}

std::string ConfigSection::Where(const std::string& key) const {
  return impl_->origin + ": " + (impl_->path.empty() ? key : impl_->path + "." + key);
}

ConfigSection ConfigSection::Section(const std::string& key) const {
  auto impl = std::make_unique<Impl>();
  impl->origin = impl_->origin;
  impl->path = impl_->path.empty() ? key : impl_->path + "." + key;
  const YAML::Node child = impl_->node[key];
  if (!child || child.IsNull()) {
    impl->node = YAML::Node(YAML::NodeType::Map);
  } else if (!child.IsMap()) {
    throw ConfigError(Where(key) + " must be a mapping");
  } else {
    impl->node = child;
  }
  return ConfigSection(std::move(impl));
}

void ConfigSection::ReadDouble(const std::string& key, double* value, bool allow_infinity) const {
  const YAML::Node child = impl_->node[key];
  if (!child) return;
  double parsed = 0.0;
  const std::string text = child.IsScalar() ? child.Scalar() : std::string("<not a scalar>");
  try {
    parsed = child.as<double>();
  } catch (const YAML::Exception&) {
    throw ConfigError(Where(key) + " = '" + text + "' is not a number");
  }
  if (std::isnan(parsed) || (std::isinf(parsed) && !(allow_infinity && parsed > 0))) {
    throw ConfigError(Where(key) + " = '" + text + "' must be a finite number" +
                      (allow_infinity ? " or .inf" : ""));
  }
  *value = parsed;
}

void ConfigSection::ReadInt(const std::string& key, int* value) const {
  const YAML::Node child = impl_->node[key];
  if (!child) return;
  const std::string text = child.IsScalar() ? child.Scalar() : std::string("<not a scalar>");
  try {
    *value = child.as<int>();
  } catch (const YAML::Exception&) {
    throw ConfigError(Where(key) + " = '" + text + "' is not an integer");
  }
}

void ConfigSection::ReadBool(const std::string& key, bool* value) const {
  const YAML::Node child = impl_->node[key];
  if (!child) return;
  const std::string text = child.IsScalar() ? child.Scalar() : std::string("<not a scalar>");
  try {
    *value = child.as<bool>();
  } catch (const YAML::Exception&) {
    throw ConfigError(Where(key) + " = '" + text + "' is not true/false");
  }
}

void ConfigSection::ReadString(const std::string& key, std::string* value) const {
  const YAML::Node child = impl_->node[key];
  if (!child) return;
  if (!child.IsScalar()) throw ConfigError(Where(key) + " must be a string");
  *value = child.Scalar();
}

void ConfigSection::RejectUnknownKeys(const std::vector<std::string>& known) const {
  for (const auto& entry : impl_->node) {
    const std::string key = entry.first.as<std::string>();
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
      throw ConfigError(Where(key) + " is not a known setting (known: " + list + ")");
    }
  }
}

}  // namespace cairn::core
