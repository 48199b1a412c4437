// 8-bit sRGB PNG output (libpng) for looking at results; EXR keeps the numbers.
//
// write_png tone-maps linear values: multiply by the exposure, clamp to [0,1], apply the sRGB
// transfer curve (IEC 61966-2-1), round to 8 bits; the file carries an sRGB chunk. write_png_ldr
// writes images that already hold display values in [0,1] (the false-colour maps) with no curve:
// clamp and round only. Non-finite values become 0 (NaN) or 1 (+inf), never undefined bytes.
#pragma once

#include <string>

#include "render/image.h"

namespace radlab {

// Throws InputError naming the path if the file cannot be written, the image is empty or the
// exposure is not finite and positive; std::invalid_argument if `image` is not well_formed().
void write_png(const std::string& path, const Image& image, double exposure);
void write_png_ldr(const std::string& path, const Image& image);

// An exposure for write_png that maps the 97th percentile of the luminance (Rec. 709 weights)
// of the lit pixels (luminance > 0; misses and black surfaces are left out) to 0.85. Why not the
// maximum or the 99th percentile: light sources are bright and cover about 1% of a typical view,
// so they saturate while the walls they light stay in range, and 0.85 leaves headroom for the
// brightest walls. Returns 1 for an image with no lit pixel.
double auto_exposure(const Image& image);

}  // namespace radlab
