// Blackboard: the key/value store shared by the nodes of a behavior tree, and the string conversions used for
// literal port values written in XML.
#pragma once

#include <any>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace cairn::bt {

/// Converts XML/blackboard text to a value of type T. Specialised for bool, int, double and std::string;
/// specialise it for your own types (set kAvailable = true and provide a static Convert) to make literal port
/// values of that type work. The primary template has kAvailable == false: such types can still be passed
/// through the blackboard, but text never converts to them.
template <class T, class Enable = void>
struct StringConverter {
  static constexpr bool kAvailable = false;
};

/// Text to bool: "true", "True", "TRUE", "1" -> true; "false", "False", "FALSE", "0" -> false; else nullopt.
template <>
struct StringConverter<bool> {
  static constexpr bool kAvailable = true;
  static std::optional<bool> Convert(const std::string& text);
};

/// Text to int: the whole text must be a base-10 integer in range (e.g. "-3"); else nullopt.
template <>
struct StringConverter<int> {
  static constexpr bool kAvailable = true;
  static std::optional<int> Convert(const std::string& text);
};

/// Text to double: the whole text must be a decimal or scientific number (e.g. "1.5", "-2e-3"); else nullopt.
template <>
struct StringConverter<double> {
  static constexpr bool kAvailable = true;
  static std::optional<double> Convert(const std::string& text);
};

/// Text to std::string: always the text itself.
template <>
struct StringConverter<std::string> {
  static constexpr bool kAvailable = true;
  static std::optional<std::string> Convert(const std::string& text) { return text; }
};

namespace detail {

/// Formats a double as the shortest text that reads back to the same value (e.g. 1.5 -> "1.5").
std::string FormatDouble(double value);

/// Reads `value` as a T: an exact T; else text converted by StringConverter<T>; else int widened to double;
/// else bool/int/double formatted as text when T is std::string. nullopt when none applies.
template <class T>
std::optional<T> AnyTo(const std::any& value) {
  if (const T* exact = std::any_cast<T>(&value)) return *exact;
  if constexpr (StringConverter<T>::kAvailable) {
    if (const std::string* text = std::any_cast<std::string>(&value))
      return StringConverter<T>::Convert(*text);
  }
  if constexpr (std::is_same_v<T, double>) {
    if (const int* i = std::any_cast<int>(&value)) return static_cast<double>(*i);
  }
  if constexpr (std::is_same_v<T, std::string>) {
    if (const bool* b = std::any_cast<bool>(&value)) return std::string(*b ? "true" : "false");
    if (const int* i = std::any_cast<int>(&value)) return std::to_string(*i);
    if (const double* d = std::any_cast<double>(&value)) return FormatDouble(*d);
  }
  return std::nullopt;
}

}  // namespace detail

/// A thread-safe map from string keys to values of any copyable type (stored as std::any).
///
/// Values are read back with Get<T>, which converts where that is unambiguous (see detail::AnyTo): text
/// stored by XML (e.g. "1.5" from SetBlackboard or a SubTree literal) reads as bool, int, double or
/// std::string; an int reads as a double; bool/int/double read as text.
///
/// Scoping (used by SubTree, following BehaviorTree.CPP v4): a blackboard may have a parent. A key can be
/// remapped to a key of the parent (AddRemapping), or all keys not present locally can fall through to the
/// parent (EnableAutoRemapping), except private keys (starting with '_'), which auto-remapping never passes
/// to the parent (BehaviorTree.CPP 4.10). A key written "@name" always means "name" in the top-most ancestor.
///
/// Each call is atomic; sequences of calls are not. Create instances with Create().
class Blackboard {
 public:
  /// Creates an empty blackboard, optionally scoped under `parent` (may be null).
  static std::shared_ptr<Blackboard> Create(std::shared_ptr<Blackboard> parent = nullptr);

  Blackboard(const Blackboard&) = delete;
  Blackboard& operator=(const Blackboard&) = delete;
  ~Blackboard() = default;

  /// Stores `value` under `key` (replacing any previous value of any type). A C string is stored as
  /// std::string. The key is resolved through remappings (see class comment).
  template <class T>
  void Set(const std::string& key, T value) {
    if constexpr (std::is_same_v<std::decay_t<T>, const char*> || std::is_same_v<std::decay_t<T>, char*>) {
      SetAny(key, std::any(std::string(value)));
    } else {
      SetAny(key, std::any(std::move(value)));
    }
  }

  /// Reads `key` as a T (with the conversions of the class comment). nullopt if the key is absent or its
  /// value does not convert to T.
  template <class T>
  std::optional<T> Get(const std::string& key) const {
    std::optional<std::any> value = GetAny(key);
    if (!value) return std::nullopt;
    return detail::AnyTo<T>(*value);
  }

  /// True if `key` (resolved through remappings) holds a value.
  bool Has(const std::string& key) const;

  /// The raw stored value of `key` (resolved through remappings), or nullopt if absent.
  std::optional<std::any> GetAny(const std::string& key) const;

  /// Stores a raw value under `key` (resolved through remappings).
  void SetAny(const std::string& key, std::any value);

  /// Removes `key` (resolved through remappings); no-op if absent.
  void Erase(const std::string& key);

  /// Keys stored in this blackboard itself (not its parent), sorted.
  std::vector<std::string> Keys() const;

  /// Makes `key` of this blackboard an alias of `parent_key` in the parent.
  /// Throws std::logic_error if this blackboard has no parent or `key` is empty.
  void AddRemapping(const std::string& key, const std::string& parent_key);

  /// When enabled, keys not stored locally, not remapped and not starting with '_' resolve in the parent
  /// under the same name.
  void EnableAutoRemapping(bool enable);

  /// The parent blackboard, or null.
  const std::shared_ptr<Blackboard>& parent() const { return parent_; }

 private:
  explicit Blackboard(std::shared_ptr<Blackboard> parent) : parent_(std::move(parent)) {}

  // Follows "@", remappings and auto-remapping to the blackboard that owns `key`, and the key's name there.
  template <class Self>
  static std::pair<Self*, std::string> Resolve(Self* self, std::string key);

  const std::shared_ptr<Blackboard> parent_;
  mutable std::mutex mutex_;
  std::map<std::string, std::any> entries_;
  std::map<std::string, std::string> remappings_;
  bool auto_remapping_ = false;
};

}  // namespace cairn::bt
