// Camera frames from ROS 2 messages to grey: raw encodings with row padding, JPEG, bad input, and the optical
// frame's rotation.
#include "cairn/ros2/image.h"

#include <gtest/gtest.h>

#include "cairn/perception/jpeg.h"

namespace cairn::ros2 {
namespace {

namespace sm = sensor_msgs::msg::dds_;

sm::Image_ Image(const std::string& encoding, std::uint32_t width, std::uint32_t height, std::uint32_t step,
                 const std::vector<std::uint8_t>& data) {
  sm::Image_ m;
  m.encoding(encoding);
  m.width(width);
  m.height(height);
  m.step(step);
  m.data(data);
  return m;
}

TEST(Ros2Image, RawEncodingsToGreyWithRowPadding) {
  GrayImage gray;
  // 2 x 2 mono8, rows padded to 4 bytes.
  ASSERT_EQ(ImageToGray(Image("mono8", 2, 2, 4, {10, 20, 0, 0, 30, 40, 0, 0}), &gray), "");
  EXPECT_EQ(gray.pixels, (std::vector<std::uint8_t>{10, 20, 30, 40}));
  // One red, one green pixel as rgb8 and as bgr8: BT.601 luma 76 and 150 (of 255).
  ASSERT_EQ(ImageToGray(Image("rgb8", 2, 1, 6, {255, 0, 0, 0, 255, 0}), &gray), "");
  EXPECT_NEAR(gray.pixels[0], 76, 1);
  EXPECT_NEAR(gray.pixels[1], 150, 1);
  ASSERT_EQ(ImageToGray(Image("bgr8", 2, 1, 6, {0, 0, 255, 0, 255, 0}), &gray), "");
  EXPECT_NEAR(gray.pixels[0], 76, 1);
  ASSERT_EQ(ImageToGray(Image("bgra8", 1, 1, 4, {255, 255, 255, 0}), &gray), "");
  EXPECT_EQ(gray.pixels[0], 255);
  EXPECT_EQ(gray.width_px, 1);
}

TEST(Ros2Image, BadImagesAreRefusedNamingTheFieldAndValue) {
  GrayImage gray;
  EXPECT_EQ(ImageToGray(Image("16UC1", 2, 2, 4, std::vector<std::uint8_t>(8)), &gray),
            "encoding '16UC1' is not read (mono8, rgb8, bgr8, rgba8, bgra8)");
  EXPECT_EQ(ImageToGray(Image("rgb8", 64, 1, 100, std::vector<std::uint8_t>(100)), &gray),
            "step 100 is less than width 64 x 3 bytes");
  EXPECT_EQ(ImageToGray(Image("mono8", 64, 8, 64, std::vector<std::uint8_t>(10)), &gray),
            "data holds 10 bytes, height 8 x step 64 needs 512");
  EXPECT_NE(ImageToGray(Image("mono8", 100000, 1, 100000, {}), &gray).find("outside 1..16384"),
            std::string::npos);
  sm::CompressedImage_ png;
  png.format("png");
  EXPECT_EQ(CompressedImageToGray(png, &gray), "format 'png' is not read (jpeg)");
  sm::CompressedImage_ junk;
  junk.format("jpeg");
  junk.data({1, 2, 3});
  EXPECT_NE(CompressedImageToGray(junk, &gray).find("JPEG not decoded"), std::string::npos);
}

TEST(Ros2Image, JpegAsImageTransportSendsIt) {
  perception::GrayFrame frame;
  frame.width_px = 32;
  frame.height_px = 16;
  for (int i = 0; i < 32 * 16; ++i) frame.pixels.push_back(static_cast<std::uint8_t>(i % 32 * 8));
  sm::CompressedImage_ m;
  m.format("rgb8; jpeg compressed bgr8");  // image_transport's compressed plugin
  m.data(perception::EncodeGrayJpeg(frame, 95));
  GrayImage gray;
  ASSERT_EQ(CompressedImageToGray(m, &gray), "");
  EXPECT_EQ(gray.width_px, 32);
  EXPECT_EQ(gray.height_px, 16);
  EXPECT_NEAR(gray.pixels[5], 40, 6);
}

TEST(Ros2Image, OpticalFrameRotation) {
  // Cairn's x (forward) is the optical z; its y (left) the optical -x; its z (up) the optical -y.
  const Eigen::Isometry3d T = OpticalFromCameraC();
  EXPECT_TRUE((T.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE((T.linear() * Eigen::Vector3d::UnitY()).isApprox(-Eigen::Vector3d::UnitX()));
  EXPECT_TRUE((T.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitY()));
  EXPECT_NEAR(T.linear().determinant(), 1.0, 1e-12);
}

}  // namespace
}  // namespace cairn::ros2
