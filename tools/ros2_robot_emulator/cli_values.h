// Copyright Cairn authors.
//
// Command-line values shared by the emulator and the echo tool, parsed strictly: a bad value is a UsageError
// naming the flag and the value and saying what was expected (the processes exit with code 2).
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace ros2_emulator {

/// A command-line error: what() names the flag and the value and says what was expected.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// `value` in single quotes, as every message prints a value.
std::string Quote(const std::string& value);

/// The whole string as a finite double; nullopt otherwise.
std::optional<double> ToDouble(const std::string& text);

/// The whole string as a non-negative decimal integer no greater than `max`; nullopt otherwise.
std::optional<unsigned long long> ToUnsigned(const std::string& text, unsigned long long max);

/// A DDS domain id, 0..232 (the highest whose RTPS ports 7400 + 250 * domain + ... fit in 16 bits). Throws
/// UsageError naming `source` (a flag or "ROS_DOMAIN_ID") and `text` otherwise.
std::uint32_t ParseDomain(const std::string& source, const std::string& text);

/// Maps a ROS 2 topic name to its DDS topic as rmw does: "/points" and "points" -> "rt/points" (a relative
/// name resolves in the root namespace). Throws UsageError naming `flag` when `ros_name` is not a valid ROS 2
/// name (empty, "//", a trailing "/", a character outside [A-Za-z0-9_/], or a name token starting with a
/// digit).
std::string RosTopicToDds(const std::string& flag, const std::string& ros_name);

/// A network interface name for --interface: 1-15 characters (IFNAMSIZ - 1), none of them '/', whitespace or
/// a control character. Whether this host has it is for Cyclone DDS to say when the domain is created.
/// Throws UsageError naming the flag and the value otherwise.
std::string ParseInterfaceName(const std::string& flag, const std::string& text);

}  // namespace ros2_emulator
