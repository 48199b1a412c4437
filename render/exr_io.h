// OpenEXR output and input; exr_io.cpp is the only file in radlab that includes OpenEXR.
//
// Images are stored as three 32-bit FLOAT channels R, G, B (not HALF) with lossless ZIP
// compression, so every value reads back bit for bit: tests compare renders exactly, and
// radiosities and signed errors need more than half's 11-bit mantissa and 65504 range.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "render/image.h"

namespace radlab {

// Writes a scanline EXR with channels R, G, B (FLOAT). Throws InputError naming the path if the
// image is empty or the file cannot be written; std::invalid_argument if `image` is not
// well_formed() (a programming error).
// `attributes` are written as string attributes of the header: the provenance of the image (run
// id, scene, solver, step, rows, git revision), as pbrt and Mitsuba record theirs, so a file
// separated from its run folder still says where it came from.
using ExrAttributes = std::vector<std::pair<std::string, std::string>>;
void write_exr(const std::string& path, const Image& image, const ExrAttributes& attributes = {});

// Reads the R, G, B channels of any scanline or tiled EXR (HALF and UINT channels are converted
// to float). Throws InputError naming the path if the file cannot be read or lacks R, G or B.
Image read_exr(const std::string& path);

// The string attributes of an EXR header, in the header's (name) order.
ExrAttributes read_exr_attributes(const std::string& path);

}  // namespace radlab
