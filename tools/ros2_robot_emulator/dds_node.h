// Copyright Cairn authors.
//
// A thin RAII layer over Cyclone DDS's C API (dds/dds.h) for the emulator: a domain configured for loopback
// only, one participant, and writers/readers with the QoS ROS 2 uses. Every failure throws DdsError naming
// the entity, topic and Cyclone's return code.
#pragma once

#include <dds/dds.h>

#include <cstdint>
#include <stdexcept>
#include <string>

namespace ros2_emulator {

/// A Cyclone DDS call failed; what() says which and why.
class DdsError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The Cyclone DDS configuration of every emulator process. With `interface_name` "" (network safety: nothing
/// may leave the host): the loopback interface only, no multicast, unicast discovery to 127.0.0.1
/// (participant indices 0..59, ports 7400 + 250 * domain + 10 + 2 * index, as Fast DDS's initial peers use).
/// With an interface: that interface only, discovery by SPDP multicast on it (239.255.0.1, port 7400 + 250 *
/// domain, as every ROS 2 middleware announces by default), data unicast. Either way a 4 MiB socket receive
/// buffer for ~0.5 MB clouds (the kernel's net.core.rmem_max must allow it).
std::string CycloneConfig(const std::string& interface_name);

/// The QoS of one endpoint, as ROS 2 profiles set it (KEEP_LAST history of `depth`).
struct EndpointQos {
  bool reliable = true;          // RELIABLE, else BEST_EFFORT
  bool transient_local = false;  // TRANSIENT_LOCAL durability, else VOLATILE
  std::int32_t depth = 10;       // history depth, samples (> 0)
};

/// A domain (created with CycloneConfig(), never from CYCLONEDDS_URI) and a participant in it.
/// Deleting it deletes every writer, reader and topic created through it.
class DdsNode {
 public:
  /// On `interface_name` ("" = loopback only; see CycloneConfig). Throws DdsError if the domain or the
  /// participant cannot be created (the socket buffer refused, no such interface).
  DdsNode(std::uint32_t domain_id, const std::string& interface_name);
  ~DdsNode();
  DdsNode(const DdsNode&) = delete;
  DdsNode& operator=(const DdsNode&) = delete;

  /// A writer on topic `topic_name` of type `type` (an idlc descriptor) with `qos`.
  dds_entity_t CreateWriter(const std::string& topic_name, const dds_topic_descriptor_t& type,
                            const EndpointQos& qos);
  /// A reader on topic `topic_name` of type `type` with `qos`.
  dds_entity_t CreateReader(const std::string& topic_name, const dds_topic_descriptor_t& type,
                            const EndpointQos& qos);

 private:
  dds_entity_t CreateTopic(const std::string& topic_name, const dds_topic_descriptor_t& type);

  dds_entity_t domain_ = 0;
  dds_entity_t participant_ = 0;
};

}  // namespace ros2_emulator
