// Copyright Cairn authors.
//
// cairn_ros2_echo's output: one ROS 2 message (an idlc-generated C sample, see ros2_msgs.h) as one line of
// JSON. Written by hand (no JSON library): strings escaped (invalid UTF-8 becomes U+FFFD), numbers in the
// shortest form that reads back to the same double or float (std::to_chars), non-finite numbers as null,
// stamps exact (sec.nanosec with 9 decimals).
#pragma once

#include <dds/dds.h>

#include <string>

namespace ros2_emulator {

/// A ROS 2 message type cairn_ros2_echo knows: its ROS name, its DDS type and its JSON form.
struct EchoType {
  /// "pkg/Type", e.g. "tf2_msgs/TFMessage".
  const char* ros_name;
  /// The idlc descriptor of pkg::msg::dds_::Type_.
  const dds_topic_descriptor_t* descriptor;
  /// Appends the type's own members (after "topic" and "type") to an open JSON object; `sample` points to
  /// the generated C struct.
  void (*append_members)(std::string& json, const void* sample);
};

/// The type named `ros_name` ("pkg/Type" or "pkg/msg/Type"); nullptr if cairn_ros2_echo does not know it.
const EchoType* FindEchoType(const std::string& ros_name);

/// The known types' names, comma separated (for error messages and --help).
std::string EchoTypeNames();

/// One sample as a JSON object on one line (no newline): {"topic":..., "type":..., <the type's members>}.
std::string SampleToJson(const std::string& ros_topic, const EchoType& type, const void* sample);

}  // namespace ros2_emulator
