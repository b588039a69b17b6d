// Fuzz harness: ROS 2 messages as the ROS 2 driver (cairn_agent --driver ros2) decodes them from a robot's
// own ROS 2 stack. The first byte picks the type; the rest is its CDR payload, deserialized by the fastddsgen
// type (what Fast DDS does with every sample), then read as the driver reads it: a PointCloud2 by its field
// layout (ReadPointCloud2), a TFMessage into the transform tree and looked up (TfBuffer), an Odometry's pose
// (ToIsometry), an Image or CompressedImage to grey (ImageToGray, CompressedImageToGray). Every input must
// decode or be refused; no crash, no allocation beyond what the input holds.
#include <fastdds/rtps/common/SerializedPayload.h>

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "cairn/ros2/image.h"
#include "cairn/ros2/point_cloud2.h"
#include "cairn/ros2/tf_buffer.h"
#include "cairn/ros2/wire.h"
#include "fuzz_input.h"
#include "ros2_msgsPubSubTypes.h"

namespace {

namespace sm = sensor_msgs::msg::dds_;

using cairn::fuzz::DeserializeCdr;

void Cloud(const sm::PointCloud2_& m) {
  std::vector<Eigen::Vector3f> points;
  cairn::ros2::CloudReadCounts counts;
  (void)cairn::ros2::ReadPointCloud2(m, cairn::ros2::CloudRangeFilter{0.3, 100.0}, &points, &counts);
}

void Transforms(const tf2_msgs::msg::dds_::TFMessage_& m) {
  cairn::ros2::TfBuffer tf;
  for (const auto& t : m.transforms()) {
    const auto& r = t.transform().rotation();
    const auto& p = t.transform().translation();
    const Eigen::Isometry3d T = cairn::ros2::ToIsometry({p.x(), p.y(), p.z()}, r.x(), r.y(), r.z(), r.w());
    (void)tf.Set(t.header().frame_id(), t.child_frame_id(), T, cairn::ros2::StampS(t.header().stamp()),
                 t.header().frame_id().size() % 2 == 0);
  }
  std::string why;
  for (const auto& t : m.transforms()) {
    (void)tf.Lookup("map", t.child_frame_id(), cairn::ros2::StampS(t.header().stamp()), &why);
  }
}

void Odometry(const nav_msgs::msg::dds_::Odometry_& m) {
  const auto& p = m.pose().pose();
  cairn::ros2::TfBuffer tf;
  const Eigen::Isometry3d T =
      cairn::ros2::ToIsometry({p.position().x(), p.position().y(), p.position().z()}, p.orientation().x(),
                              p.orientation().y(), p.orientation().z(), p.orientation().w());
  (void)tf.Set(m.header().frame_id(), m.child_frame_id(), T, cairn::ros2::StampS(m.header().stamp()), false);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::uint8_t kind = data[0] % 5;
  ++data;
  --size;
  switch (kind) {
    case 0: {
      sm::PointCloud2_ m;
      if (DeserializeCdr<sm::PointCloud2_PubSubType>(data, size, &m)) Cloud(m);
      break;
    }
    case 1: {
      tf2_msgs::msg::dds_::TFMessage_ m;
      if (DeserializeCdr<tf2_msgs::msg::dds_::TFMessage_PubSubType>(data, size, &m)) Transforms(m);
      break;
    }
    case 2: {
      nav_msgs::msg::dds_::Odometry_ m;
      if (DeserializeCdr<nav_msgs::msg::dds_::Odometry_PubSubType>(data, size, &m)) Odometry(m);
      break;
    }
    case 3: {
      sm::Image_ m;
      cairn::ros2::GrayImage gray;
      if (DeserializeCdr<sm::Image_PubSubType>(data, size, &m)) (void)cairn::ros2::ImageToGray(m, &gray);
      break;
    }
    case 4: {
      sm::CompressedImage_ m;
      cairn::ros2::GrayImage gray;
      if (DeserializeCdr<sm::CompressedImage_PubSubType>(data, size, &m))
        (void)cairn::ros2::CompressedImageToGray(m, &gray);
      break;
    }
  }
  return 0;
}
