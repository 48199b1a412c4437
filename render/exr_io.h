// OpenEXR output and input (the only code that includes OpenEXR). Images are stored as three
// 32-bit FLOAT channels R, G, B (not half), so values read back exactly — tests rely on it and
// radiosities span more range than half's 11 bits keep.
#pragma once

#include <string>

#include "render/image.h"

namespace radlab {

// Throws InputError naming the path if the file cannot be written.
void write_exr(const std::string& path, const Image& image);
// Throws InputError naming the path if the file cannot be read or lacks R, G, B.
Image read_exr(const std::string& path);

}  // namespace radlab
