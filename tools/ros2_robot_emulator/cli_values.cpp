// Copyright Cairn authors.
#include "cli_values.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

namespace ros2_emulator {
namespace {

constexpr unsigned long long kMaxDomainId = 232;
constexpr std::size_t kMaxInterfaceNameLength = 15;  // IFNAMSIZ - 1 (linux/if.h)

}  // namespace

std::string Quote(const std::string& value) { return "'" + value + "'"; }

std::optional<double> ToDouble(const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(value)) {
    return std::nullopt;
  }
  return value;
}

std::optional<unsigned long long> ToUnsigned(const std::string& text, unsigned long long max) {
  if (text.empty() || !std::all_of(text.begin(), text.end(), [](char c) { return std::isdigit(c) != 0; })) {
    return std::nullopt;
  }
  errno = 0;
  const unsigned long long value = std::strtoull(text.c_str(), nullptr, 10);
  if (errno == ERANGE || value > max) return std::nullopt;
  return value;
}

std::uint32_t ParseDomain(const std::string& source, const std::string& text) {
  const std::optional<unsigned long long> domain = ToUnsigned(text, kMaxDomainId);
  if (!domain) {
    throw UsageError(source + " " + Quote(text) + " is not a DDS domain id (an integer 0.." +
                     std::to_string(kMaxDomainId) + ")");
  }
  return static_cast<std::uint32_t>(*domain);
}

std::string RosTopicToDds(const std::string& flag, const std::string& ros_name) {
  const auto bad = [&](const std::string& why) {
    return UsageError(flag + " " + Quote(ros_name) + " is not a valid ROS 2 topic name: " + why);
  };
  if (ros_name.empty() || ros_name == "/") throw bad("it is empty");
  for (char c : ros_name) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/')) {
      throw bad(std::string("character '") + c + "' (allowed: letters, digits, '_' and '/')");
    }
  }
  if (ros_name.back() == '/') throw bad("it ends with '/'");
  if (ros_name.find("//") != std::string::npos) throw bad("it contains '//'");
  const std::string relative = ros_name.front() == '/' ? ros_name.substr(1) : ros_name;
  std::stringstream tokens(relative);
  for (std::string token; std::getline(tokens, token, '/');) {
    if (std::isdigit(static_cast<unsigned char>(token.front())))
      throw bad(Quote(token) + " starts with a digit");
  }
  return "rt/" + relative;
}

std::string ParseInterfaceName(const std::string& flag, const std::string& text) {
  const bool ok = !text.empty() && text.size() <= kMaxInterfaceNameLength &&
                  std::none_of(text.begin(), text.end(), [](char c) {
                    return c == '/' || std::isspace(static_cast<unsigned char>(c)) != 0 ||
                           std::iscntrl(static_cast<unsigned char>(c)) != 0;
                  });
  if (!ok) {
    throw UsageError(flag + " " + Quote(text) +
                     " is not a network interface name (1-15 characters, no '/' or spaces), e.g. eth1");
  }
  return text;
}

}  // namespace ros2_emulator
