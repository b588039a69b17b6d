// Camera frames from ROS 2 as the grey frames Cairn's autonomy and operators use: sensor_msgs/Image (mono8,
// rgb8, bgr8, rgba8, bgra8: any row padding) and sensor_msgs/CompressedImage (JPEG). Other encodings are
// refused naming the encoding.
//
// Message definitions: ros2/common_interfaces, sensor_msgs/msg/Image.msg and CompressedImage.msg; encodings
// as sensor_msgs/image_encodings.hpp names them.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "ros2_msgs.h"

namespace cairn::ros2 {

/// An 8-bit grey frame, row-major, top row first.
struct GrayImage {
  int width_px = 0;
  int height_px = 0;
  std::vector<std::uint8_t> pixels;  ///< width_px * height_px
};

/// Largest side accepted, pixels (a bad header must not allocate gigabytes).
constexpr std::uint32_t kMaxImageSidePx = 16384;

/// `image` as grey (ITU-R BT.601 luma for colour encodings) into `*gray`. @return "" or the problem naming
/// the field and value ("encoding '16UC1' is not read (mono8, rgb8, bgr8, rgba8, bgra8)", "step 100 is less
/// than width 64 x 3 bytes", "data holds 10 bytes, height 8 x step 64 needs 512").
std::string ImageToGray(const sensor_msgs::msg::dds_::Image_& image, GrayImage* gray);

/// A JPEG `image` as grey. @return "" or the problem ("format 'png' is not read (jpeg)", the decoder's
/// error).
std::string CompressedImageToGray(const sensor_msgs::msg::dds_::CompressedImage_& image, GrayImage* gray);

/// The rotation from Cairn's camera frame C (x along the optical axis, y left, z up) to a ROS optical frame
/// (z along the optical axis, x right, y down; REP-103): T_M_C = T_M_optical * OpticalFromCameraC().
Eigen::Isometry3d OpticalFromCameraC();

}  // namespace cairn::ros2
