// PNG encoding of camera frames with libpng, for operators who save a snapshot as .png (lossless copy of the
// decoded JPEG frame; the wire format stays JPEG).
#pragma once

#include <cstdint>
#include <vector>

#include "cairn/perception/jpeg.h"

namespace cairn::perception {

/// Encodes `frame` (8-bit grayscale, width and height in [1, 16384], pixels.size() == width*height) as a PNG
/// file's bytes. Throws JpegError (the image-codec error) naming the field and value otherwise, or libpng's
/// reason.
std::vector<std::uint8_t> EncodeGrayPng(const GrayFrame& frame);

}  // namespace cairn::perception
