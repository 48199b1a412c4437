// 8-bit sRGB PNG output (libpng). write_png tone-maps linear radiance-like values: multiply by
// the exposure, clamp to [0,1], apply the sRGB transfer curve. write_png_ldr writes images that
// already hold display values in [0,1] (false-colour maps) unchanged.
#pragma once

#include <string>

#include "render/image.h"

namespace radlab {

void write_png(const std::string& path, const Image& image, double exposure);
void write_png_ldr(const std::string& path, const Image& image);

// An exposure that maps the 97th percentile of the luminance of lit pixels to 0.85: bright light
// sources (a few per cent of the pixels) saturate, the walls they light stay in range. 1 for a
// black image.
double auto_exposure(const Image& image);

}  // namespace radlab
