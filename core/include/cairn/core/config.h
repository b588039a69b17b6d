// Configuration files (YAML, parsed by yaml-cpp) with validation that names the file, field, value and rule.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace cairn::core {

/// A configuration file or value is invalid. The message names the file, the field, the value and the rule.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// One key of a config section and the variable its value is read into (ConfigSection::ReadFields). A double
/// may allow infinity (YAML `.inf`).
struct ConfigField {
  ConfigField(std::string key_in, double* value_in, bool allow_infinity_in = false)
      : key(std::move(key_in)), value(value_in), allow_infinity(allow_infinity_in) {}
  ConfigField(std::string key_in, int* value_in) : key(std::move(key_in)), value(value_in) {}
  ConfigField(std::string key_in, bool* value_in) : key(std::move(key_in)), value(value_in) {}
  ConfigField(std::string key_in, std::string* value_in) : key(std::move(key_in)), value(value_in) {}

  std::string key;
  std::variant<double*, int*, bool*, std::string*> value;
  bool allow_infinity = false;
};

/// Read-only view of one YAML mapping (a config file or a section of it). Unknown keys are an error, so a
/// typo such as `lock_keep_sec` is reported instead of silently ignored.
class ConfigSection {
 public:
  /// Parses `path`. @throws ConfigError when the file is missing, unreadable, not YAML, uses an alias
  /// (RejectYamlAliases), or is not a mapping.
  static ConfigSection LoadFile(const std::string& path);
  /// Parses YAML text (for tests); `origin` names it in errors.
  static ConfigSection LoadText(const std::string& text, const std::string& origin);

  ConfigSection(const ConfigSection&);
  ConfigSection& operator=(const ConfigSection&);
  ~ConfigSection();

  /// The sub-mapping `key`, or an empty section when absent. @throws ConfigError if present but not a map.
  ConfigSection Section(const std::string& key) const;

  /// Reads `key` as a finite number, keeping `*value` when absent. @throws ConfigError (non-number, NaN, and
  /// inf unless `allow_infinity`; YAML spells infinity `.inf`).
  void ReadDouble(const std::string& key, double* value, bool allow_infinity = false) const;
  void ReadInt(const std::string& key, int* value) const;
  void ReadBool(const std::string& key, bool* value) const;
  void ReadString(const std::string& key, std::string* value) const;

  /// Throws ConfigError when a key other than `known` is present.
  void RejectUnknownKeys(const std::vector<std::string>& known) const;
  /// The section's keys are exactly some of `fields`' (else ConfigError, as RejectUnknownKeys); each present
  /// is read into its variable (as ReadDouble, ReadInt, ReadBool, ReadString), each absent keeps its value.
  void ReadFields(const std::vector<ConfigField>& fields) const;

  /// "file.yaml: agent.lock_keep_s" — the dotted path of `key` for error messages.
  std::string Where(const std::string& key) const;

  struct Impl;  ///< yaml-cpp state, kept out of this header.

 private:
  explicit ConfigSection(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Throws ConfigError when YAML `text` uses an alias (`*name`), naming `origin` (the file), the line, the
/// column and the alias; also when the text is not valid YAML. Every YAML file Cairn reads is checked with it
/// before it is loaded: yaml-cpp shares aliased nodes, and walking a tree of nested aliases ("billion
/// laughs": each level refers 9 times to the one before) visits 9^levels nodes. Anchors (`&name`) alone are
/// harmless and allowed. Runs in time linear in the text's length.
void RejectYamlAliases(const std::string& text, const std::string& origin);

/// "" when a file can be written at `path` (its folder exists and is writable, the path is not a folder, an
/// existing file is writable), else the fault naming `field` (a flag, e.g. "--map-save") and the path:
/// checked at start, so that a file written at exit is not found unwritable only then.
std::string CheckOutputFile(const std::string& field, const std::string& path);

}  // namespace cairn::core
