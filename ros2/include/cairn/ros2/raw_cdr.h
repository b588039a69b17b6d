// A sample that is already CDR (its 4-byte encapsulation header included), written and read under a type name
// given at compile time: how the basestation forwards Cairn's own messages to ROS 2 tools unchanged. ROS 2's
// cairn_msgs/msg/X (ros2/cairn_msgs_ros2, generated from idl/cairn_msgs.idl by tools/gen_ros2_msgs.py) has
// the same fields in the same order as Cairn's cairn_msgs::X, so the CDR Cairn's type writes is what a ROS 2
// reader of cairn_msgs::msg::dds_::X_ expects; only the type name (and the keys, which ROS 2 topics do not
// have) differ.
#pragma once

#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <fastdds/dds/topic/TopicDataType.hpp>
#include <functional>
#include <vector>

namespace cairn::ros2 {

/// A CDR payload, encapsulation header first.
struct RawCdrSample {
  std::vector<std::uint8_t> payload;
  /// The payload's size less its 4-byte header, bytes (as fastddsgen types report theirs: core::Writer counts
  /// what it writes with it).
  static std::size_t getCdrSerializedSize(const RawCdrSample& sample, std::size_t = 0) {
    return sample.payload.size() >= 4 ? sample.payload.size() - 4 : 0;
  }
};

/// The CDR of `message` as fastddsgen type support `PubSubT` writes it. Empty when it cannot be serialized.
template <class PubSubT>
RawCdrSample ToCdr(const typename PubSubT::type& message) {
  PubSubT type;
  void* data = const_cast<typename PubSubT::type*>(&message);
  eprosima::fastrtps::rtps::SerializedPayload_t payload(type.getSerializedSizeProvider(data)());
  RawCdrSample sample;
  if (type.serialize(data, &payload)) sample.payload.assign(payload.data, payload.data + payload.length);
  return sample;
}

/// Type support for RawCdrSample under `Name::kTypeName` (keyless), usable with core::Writer and
/// core::Reader.
template <class Name>
class RawCdrPubSubType : public eprosima::fastdds::dds::TopicDataType {
 public:
  using type = RawCdrSample;

  RawCdrPubSubType() {
    setName(Name::kTypeName);
    m_typeSize = 4096;  // the initial payload size; larger samples grow it
    m_isGetKeyDefined = false;
  }

  bool serialize(void* data, eprosima::fastrtps::rtps::SerializedPayload_t* payload) override {
    const std::vector<std::uint8_t>& bytes = static_cast<RawCdrSample*>(data)->payload;
    if (bytes.size() < 4 || bytes.size() > payload->max_size) return false;
    std::memcpy(payload->data, bytes.data(), bytes.size());
    payload->length = static_cast<std::uint32_t>(bytes.size());
    payload->encapsulation = bytes[1] == 0 ? CDR_BE : CDR_LE;  // the header's second byte: 0 BE, 1 LE
    return true;
  }

  bool deserialize(eprosima::fastrtps::rtps::SerializedPayload_t* payload, void* data) override {
    static_cast<RawCdrSample*>(data)->payload.assign(payload->data, payload->data + payload->length);
    return true;
  }

  std::function<std::uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] { return static_cast<std::uint32_t>(static_cast<RawCdrSample*>(data)->payload.size()); };
  }

  void* createData() override { return new RawCdrSample(); }
  void deleteData(void* data) override { delete static_cast<RawCdrSample*>(data); }

  bool getKey(void*, eprosima::fastrtps::rtps::InstanceHandle_t*, bool) override { return false; }
};

/// ROS 2's names of the Cairn types the basestation forwards (ros2/cairn_msgs_ros2): the Name parameter of
/// RawCdrPubSubType, what a ROS 2 reader of the forwarded topics matches.
struct RobotStateName {
  static constexpr const char* kTypeName = "cairn_msgs::msg::dds_::RobotState_";
};
struct BehaviorTreeStateName {
  static constexpr const char* kTypeName = "cairn_msgs::msg::dds_::BehaviorTreeState_";
};
struct GlobalPathName {
  static constexpr const char* kTypeName = "cairn_msgs::msg::dds_::GlobalPath_";
};
struct AgentHealthName {
  static constexpr const char* kTypeName = "cairn_msgs::msg::dds_::AgentHealth_";
};

}  // namespace cairn::ros2
