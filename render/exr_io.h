// OpenEXR output and input; exr_io.cpp is the only file in radlab that includes OpenEXR.
//
// Images are stored as three 32-bit FLOAT channels R, G, B (not HALF) with lossless ZIP
// compression, so every value reads back bit for bit: tests compare renders exactly, and
// radiosities and signed errors need more than half's 11-bit mantissa and 65504 range.
#pragma once

#include <string>

#include "render/image.h"

namespace radlab {

// Writes a scanline EXR with channels R, G, B (FLOAT). Throws InputError naming the path if the
// image is empty or the file cannot be written; std::invalid_argument if `image` is not
// well_formed() (a programming error).
void write_exr(const std::string& path, const Image& image);

// Reads the R, G, B channels of any scanline or tiled EXR (HALF and UINT channels are converted
// to float). Throws InputError naming the path if the file cannot be read or lacks R, G or B.
Image read_exr(const std::string& path);

}  // namespace radlab
