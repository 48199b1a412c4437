// An RGB float image: what the renderer produces and the EXR and PNG writers consume. Linear
// values, 3 floats per pixel, row-major, top row first (the order EXR and PNG store rows in), so
// pixel (x, y) with y = 0 is the top-left corner of the view.
#pragma once

#include <cstddef>
#include <vector>

namespace radlab {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // 3 floats per pixel: R, G, B of pixel (0,0), then (1,0), ...

  Image() = default;
  // A black width x height image (both must be >= 0).
  Image(int w, int h) : width(w), height(h), rgb(3 * size_t(w) * size_t(h), 0.0f) {}

  size_t pixel_count() const { return size_t(width) * size_t(height); }
  // True when the sizes are non-negative and `rgb` holds exactly 3 floats per pixel; the writers
  // refuse anything else rather than read past the end.
  bool well_formed() const { return width >= 0 && height >= 0 && rgb.size() == 3 * pixel_count(); }

  // The first of the pixel's three floats.
  float* pixel(int x, int y) { return rgb.data() + 3 * (size_t(y) * size_t(width) + size_t(x)); }
  const float* pixel(int x, int y) const {
    return rgb.data() + 3 * (size_t(y) * size_t(width) + size_t(x));
  }
};

}  // namespace radlab
