// Copyright Cairn authors.
#include "dds_node.h"

#include <memory>

namespace ros2_emulator {
namespace {

std::string Failure(const std::string& what, dds_return_t rc) {
  return what + " failed: " + dds_strretcode(rc) + " (" + std::to_string(rc) + ")";
}

/// dds_qos_t owned by a unique_ptr.
struct QosDeleter {
  void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

QosPtr MakeQos(const EndpointQos& spec) {
  QosPtr qos(dds_create_qos());
  dds_qset_reliability(qos.get(), spec.reliable ? DDS_RELIABILITY_RELIABLE : DDS_RELIABILITY_BEST_EFFORT,
                       DDS_MSECS(100));
  dds_qset_durability(qos.get(),
                      spec.transient_local ? DDS_DURABILITY_TRANSIENT_LOCAL : DDS_DURABILITY_VOLATILE);
  dds_qset_history(qos.get(), DDS_HISTORY_KEEP_LAST, spec.depth);
  return qos;
}

}  // namespace

std::string CycloneConfig(const std::string& interface_name) {
  // Element names as in Cyclone DDS 0.10's configuration reference (docs/manual/options.md):
  // General/Interfaces/NetworkInterface[@name], General/AllowMulticast, Discovery/ParticipantIndex,
  // Discovery/MaxAutoParticipantIndex, Discovery/Peers/Peer[@Address],
  // Internal/SocketReceiveBufferSize[@max] (asked for, less accepted: Linux caps it at net.core.rmem_max). A
  // peer without a port is probed on the unicast discovery ports of participant indices
  // 0..MaxAutoParticipantIndex-1. AllowMulticast "spdp": multicast for participant discovery only.
  const std::string discovery = interface_name.empty()
                                    ? "<General>"
                                      "<Interfaces><NetworkInterface name=\"lo\"/></Interfaces>"
                                      "<AllowMulticast>false</AllowMulticast>"
                                      "</General>"
                                      "<Discovery>"
                                      "<ParticipantIndex>auto</ParticipantIndex>"
                                      "<MaxAutoParticipantIndex>60</MaxAutoParticipantIndex>"
                                      "<Peers><Peer Address=\"127.0.0.1\"/></Peers>"
                                      "</Discovery>"
                                    : "<General>"
                                      "<Interfaces><NetworkInterface name=\"" +
                                          interface_name +
                                          "\"/></Interfaces>"
                                          "<AllowMulticast>spdp</AllowMulticast>"
                                          "</General>";
  return "<CycloneDDS><Domain id=\"any\">" + discovery +
         "<Internal><SocketReceiveBufferSize max=\"4MiB\"/></Internal>"
         "</Domain></CycloneDDS>";
}

DdsNode::DdsNode(std::uint32_t domain_id, const std::string& interface_name) {
  // A config string given here is all Cyclone reads: CYCLONEDDS_URI in the environment is not consulted,
  // so nobody's environment can turn multicast or another interface back on.
  domain_ = dds_create_domain(domain_id, CycloneConfig(interface_name).c_str());
  if (domain_ < 0) {
    throw DdsError(
        Failure("creating DDS domain " + std::to_string(domain_id) +
                    (interface_name.empty() ? " (loopback only"
                                            : " (interface " + interface_name + ": does this host have it?") +
                    ", 4 MiB receive buffer: is net.core.rmem_max >= 4194304?)",
                domain_));
  }
  participant_ = dds_create_participant(domain_id, nullptr, nullptr);
  if (participant_ < 0) {
    const dds_return_t rc = participant_;
    dds_delete(domain_);
    throw DdsError(Failure("creating the participant in DDS domain " + std::to_string(domain_id), rc));
  }
}

DdsNode::~DdsNode() {
  dds_delete(participant_);
  dds_delete(domain_);
}

dds_entity_t DdsNode::CreateTopic(const std::string& topic_name, const dds_topic_descriptor_t& type) {
  const dds_entity_t topic = dds_create_topic(participant_, &type, topic_name.c_str(), nullptr, nullptr);
  if (topic < 0)
    throw DdsError(Failure("creating topic " + topic_name + " (" + type.m_typename + ")", topic));
  return topic;
}

dds_entity_t DdsNode::CreateWriter(const std::string& topic_name, const dds_topic_descriptor_t& type,
                                   const EndpointQos& qos) {
  const QosPtr dds_qos = MakeQos(qos);
  const dds_entity_t writer =
      dds_create_writer(participant_, CreateTopic(topic_name, type), dds_qos.get(), nullptr);
  if (writer < 0) throw DdsError(Failure("creating a writer on " + topic_name, writer));
  return writer;
}

dds_entity_t DdsNode::CreateReader(const std::string& topic_name, const dds_topic_descriptor_t& type,
                                   const EndpointQos& qos) {
  const QosPtr dds_qos = MakeQos(qos);
  const dds_entity_t reader =
      dds_create_reader(participant_, CreateTopic(topic_name, type), dds_qos.get(), nullptr);
  if (reader < 0) throw DdsError(Failure("creating a reader on " + topic_name, reader));
  return reader;
}

}  // namespace ros2_emulator
