// Copyright Cairn authors.
#include "cairn/perception/jpeg.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "cairn/perception/png.h"

namespace cairn::perception {
namespace {

GrayFrame Gradient(int width, int height) {
  GrayFrame frame{width, height, std::vector<std::uint8_t>(static_cast<std::size_t>(width) * height)};
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) frame.pixels[static_cast<std::size_t>(y) * width + x] = (x + y) & 0xff;
  }
  return frame;
}

TEST(JpegTest, RoundTripKeepsSizeAndPixelsClose) {
  const GrayFrame frame = Gradient(320, 240);
  const std::vector<std::uint8_t> jpeg = EncodeGrayJpeg(frame, 90);
  EXPECT_LT(jpeg.size(), frame.pixels.size() / 3);
  int width = 0;
  int height = 0;
  ReadJpegSize(jpeg, &width, &height);
  EXPECT_EQ(width, 320);
  EXPECT_EQ(height, 240);
  const GrayFrame decoded = DecodeGrayJpeg(jpeg);
  ASSERT_EQ(decoded.pixels.size(), frame.pixels.size());
  double error = 0;
  for (std::size_t i = 0; i < frame.pixels.size(); ++i)
    error += std::abs(decoded.pixels[i] - frame.pixels[i]);
  EXPECT_LT(error / frame.pixels.size(), 3.0);
}

TEST(JpegTest, BadInputNamesTheField) {
  GrayFrame frame = Gradient(4, 4);
  try {
    EncodeGrayJpeg(frame, 0);
    FAIL();
  } catch (const JpegError& e) {
    EXPECT_NE(std::string(e.what()).find("quality 0"), std::string::npos) << e.what();
  }
  frame.pixels.pop_back();
  EXPECT_THROW(EncodeGrayJpeg(frame), JpegError);
  EXPECT_THROW(EncodeGrayJpeg(GrayFrame{0, 4, {}}), JpegError);
  int w = 0;
  int h = 0;
  EXPECT_THROW(ReadJpegSize({}, &w, &h), JpegError);
  EXPECT_THROW(ReadJpegSize({1, 2, 3, 4, 5}, &w, &h), JpegError);
  std::vector<std::uint8_t> truncated = EncodeGrayJpeg(Gradient(64, 64));
  truncated.resize(truncated.size() / 2);
  EXPECT_THROW(DecodeGrayJpeg(truncated), JpegError);
}

// A snapshot saved as .png: a real PNG (signature, IHDR size and 8-bit grayscale), lossless against the
// decoded frame's size; bad frames are refused naming the field.
TEST(Png, EncodesAGrayFrameAsPng) {
  const GrayFrame frame = Gradient(320, 240);
  const std::vector<std::uint8_t> png = EncodeGrayPng(frame);
  ASSERT_GT(png.size(), 33u);
  const std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  EXPECT_TRUE(std::equal(kSignature, kSignature + 8, png.begin()));
  auto be32 = [&](std::size_t at) {
    return (static_cast<uint32_t>(png[at]) << 24) | (static_cast<uint32_t>(png[at + 1]) << 16) |
           (static_cast<uint32_t>(png[at + 2]) << 8) | png[at + 3];
  };
  EXPECT_EQ(std::string(png.begin() + 12, png.begin() + 16), "IHDR");
  EXPECT_EQ(be32(16), 320u);
  EXPECT_EQ(be32(20), 240u);
  EXPECT_EQ(png[24], 8) << "bit depth";
  EXPECT_EQ(png[25], 0) << "grayscale";
  EXPECT_EQ(std::string(png.end() - 8, png.end() - 4), "IEND");
  GrayFrame bad = frame;
  bad.pixels.pop_back();
  EXPECT_THROW(EncodeGrayPng(bad), JpegError);
  EXPECT_THROW(EncodeGrayPng(GrayFrame{0, 4, {}}), JpegError);
}

}  // namespace
}  // namespace cairn::perception
