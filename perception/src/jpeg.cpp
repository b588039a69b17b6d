// Copyright Cairn authors.
#include "cairn/perception/jpeg.h"

#include <turbojpeg.h>

#include <memory>

namespace cairn::perception {
namespace {

constexpr int kMaxSidePx = 16384;

// Owns a TurboJPEG handle.
struct Handle {
  explicit Handle(bool compress) : h(compress ? tjInitCompress() : tjInitDecompress()) {
    if (h == nullptr) throw JpegError(std::string("TurboJPEG init failed: ") + tjGetErrorStr2(nullptr));
  }
  ~Handle() { tjDestroy(h); }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  tjhandle h;
};

}  // namespace

std::vector<std::uint8_t> EncodeGrayJpeg(const GrayFrame& frame, int quality) {
  if (quality < 1 || quality > 100) {
    throw JpegError("JPEG quality " + std::to_string(quality) + " is outside [1, 100]");
  }
  if (frame.width_px < 1 || frame.width_px > kMaxSidePx || frame.height_px < 1 ||
      frame.height_px > kMaxSidePx) {
    throw JpegError("image size " + std::to_string(frame.width_px) + "x" + std::to_string(frame.height_px) +
                    " is outside [1, " + std::to_string(kMaxSidePx) + "] a side");
  }
  const std::size_t expected = static_cast<std::size_t>(frame.width_px) * frame.height_px;
  if (frame.pixels.size() != expected) {
    throw JpegError("image pixels " + std::to_string(frame.pixels.size()) + " != width * height " +
                    std::to_string(expected));
  }
  Handle compressor(/*compress=*/true);
  unsigned char* out = nullptr;
  unsigned long out_size = 0;  // NOLINT(runtime/int): TurboJPEG's type.
  const int rc = tjCompress2(compressor.h, frame.pixels.data(), frame.width_px, /*pitch=*/0, frame.height_px,
                             TJPF_GRAY, &out, &out_size, TJSAMP_GRAY, quality, TJFLAG_FASTDCT);
  std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(out, tjFree);
  if (rc != 0) throw JpegError(std::string("JPEG compression failed: ") + tjGetErrorStr2(compressor.h));
  return std::vector<std::uint8_t>(out, out + out_size);
}

void ReadJpegSize(const std::vector<std::uint8_t>& jpeg, int* width_px, int* height_px) {
  if (jpeg.empty()) throw JpegError("not a JPEG: 0 bytes");
  Handle decompressor(/*compress=*/false);
  int subsampling = 0;
  int colorspace = 0;
  if (tjDecompressHeader3(decompressor.h, jpeg.data(), static_cast<unsigned long>(jpeg.size()),  // NOLINT
                          width_px, height_px, &subsampling, &colorspace) != 0) {
    throw JpegError("not a JPEG (" + std::to_string(jpeg.size()) +
                    " bytes): " + tjGetErrorStr2(decompressor.h));
  }
}

GrayFrame DecodeGrayJpeg(const std::vector<std::uint8_t>& jpeg) {
  GrayFrame frame;
  ReadJpegSize(jpeg, &frame.width_px, &frame.height_px);
  if (frame.width_px < 1 || frame.width_px > kMaxSidePx || frame.height_px < 1 ||
      frame.height_px > kMaxSidePx) {
    throw JpegError("JPEG size " + std::to_string(frame.width_px) + "x" + std::to_string(frame.height_px) +
                    " is outside [1, " + std::to_string(kMaxSidePx) + "] a side");
  }
  frame.pixels.resize(static_cast<std::size_t>(frame.width_px) * frame.height_px);
  Handle decompressor(/*compress=*/false);
  if (tjDecompress2(decompressor.h, jpeg.data(), static_cast<unsigned long>(jpeg.size()),  // NOLINT
                    frame.pixels.data(), frame.width_px, /*pitch=*/0, frame.height_px, TJPF_GRAY, 0) != 0) {
    throw JpegError("JPEG decoding failed: " + std::string(tjGetErrorStr2(decompressor.h)));
  }
  return frame;
}

}  // namespace cairn::perception
