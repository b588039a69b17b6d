#include "cairn/core/config.h"

#include <unistd.h>
#include <yaml-cpp/eventhandler.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

namespace cairn::core {

struct ConfigSection::Impl {
  YAML::Node node;
  std::string origin;  // file name
#include <sstream>
  std::string path;  // dotted path of this section ("" at top level)
};

ConfigSection::ConfigSection(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ConfigSection::ConfigSection(const ConfigSection& other) : impl_(std::make_unique<Impl>(*other.impl_)) {}
ConfigSection& ConfigSection::operator=(const ConfigSection& other) {
  impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
ConfigSection::~ConfigSection() = default;

namespace {

// yaml-cpp keeps both entries of a key written twice in one mapping (its lookup then reads the first): a
// second `lock_keep_s` further down a file would be ignored silently. Throws ConfigError naming the key, its
// mapping and the line of its second appearance.
void RejectDuplicateKeys(const YAML::Node& node, const std::string& origin, const std::string& path) {
  if (node.IsSequence()) {
    for (std::size_t i = 0; i < node.size(); ++i) {
      RejectDuplicateKeys(node[i], origin, path + "[" + std::to_string(i) + "]");
    }
    return;
  }
  if (!node.IsMap()) return;
  std::set<std::string> seen;
  for (auto it = node.begin(); it != node.end(); ++it) {
    const std::string key = it->first.IsScalar() ? it->first.Scalar() : "(a non-scalar key)";
    const std::string where = path.empty() ? key : path + "." + key;
    if (!seen.insert(key).second) {
      throw ConfigError(origin + ": " + where + " appears twice (line " +
                        std::to_string(it->first.Mark().line + 1) + "): remove one");
    }
    RejectDuplicateKeys(it->second, origin, where);
  }
}

// Parser events of a YAML text: throws at the first alias. yaml-cpp shares an aliased node rather than
// copying it, so loading is fast, but every walk of the tree (the duplicate-key check, lookups) visits each
// alias again: nested aliases ("billion laughs") made a 486-byte file take minutes.
class AliasRefuser : public YAML::EventHandler {
 public:
  AliasRefuser(const std::string& text, const std::string& origin) : text_(text), origin_(origin) {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override {
    // The parser numbers anchors; the alias's name is read back from the text at its mark ('*name').
    std::string name;
    if (mark.pos >= 0 && static_cast<std::size_t>(mark.pos) < text_.size()) {
      const std::size_t end = text_.find_first_of(" \t\r\n,]}", static_cast<std::size_t>(mark.pos));
      name = text_.substr(static_cast<std::size_t>(mark.pos), end - static_cast<std::size_t>(mark.pos));
    }
    if (name.size() > 64) name = name.substr(0, 64) + "...";
    throw ConfigError(origin_ + ":" + std::to_string(mark.line + 1) + ":" + std::to_string(mark.column + 1) +
                      ": YAML alias '" + name +
                      "' is not allowed (Cairn's config files refuse aliases: write the value out)");
  }
  void OnDocumentStart(const YAML::Mark&) override {}
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
  }
  void OnMapEnd() override {}

 private:
  const std::string& text_;
  const std::string& origin_;
};

ConfigSection::Impl Parse(const std::string& text, const std::string& origin) {
  ConfigSection::Impl impl;
  impl.origin = origin;
  RejectYamlAliases(text, origin);
  try {
    impl.node = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin + ": not valid YAML: " + e.what());
  }
  if (impl.node.IsNull()) impl.node = YAML::Node(YAML::NodeType::Map);
  if (!impl.node.IsMap()) throw ConfigError(origin + ": the top level must be a mapping of key: value");
  RejectDuplicateKeys(impl.node, origin, "");
  return impl;
}

}  // namespace

void RejectYamlAliases(const std::string& text, const std::string& origin) {
  std::istringstream in(text);
  AliasRefuser refuser(text, origin);
  try {
    // The first document only: the one YAML::Load reads. (yaml-cpp 0.7's HandleNextDocument can report a
    // next document forever on some malformed input, e.g. the 5 bytes ",\xadQ\b\x91": a fuzzed config.)
    YAML::Parser parser(in);
    parser.HandleNextDocument(refuser);
  } catch (const YAML::Exception& e) {
    throw ConfigError(origin + ": not valid YAML: " + e.what());
  }
}

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

void ConfigSection::ReadFields(const std::vector<ConfigField>& fields) const {
  std::vector<std::string> known;
  known.reserve(fields.size());
  for (const ConfigField& field : fields) known.push_back(field.key);
  RejectUnknownKeys(known);
  for (const ConfigField& field : fields) {
    if (auto* const* d = std::get_if<double*>(&field.value)) {
      ReadDouble(field.key, *d, field.allow_infinity);
    } else if (auto* const* i = std::get_if<int*>(&field.value)) {
      ReadInt(field.key, *i);
    } else if (auto* const* b = std::get_if<bool*>(&field.value)) {
      ReadBool(field.key, *b);
    } else {
      ReadString(field.key, std::get<std::string*>(field.value));
    }
  }
}

std::string CheckOutputFile(const std::string& field, const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path file(path);
  if (path.empty()) return field + " '' names no file";
  if (fs::is_directory(file, ec)) return field + " '" + path + "' is a directory, not a file";
  const fs::path folder = file.has_parent_path() ? file.parent_path() : fs::path(".");
  if (!fs::is_directory(folder, ec))
    return field + " '" + path + "': its folder '" + folder.string() + "' does not exist";
  if (::access(folder.c_str(), W_OK | X_OK) != 0) {
    return field + " '" + path + "': its folder '" + folder.string() + "' is not writable";
  }
  if (fs::exists(file, ec) && ::access(file.c_str(), W_OK) != 0)
    return field + " '" + path + "' is not writable";
  return "";
}

}  // namespace cairn::core
