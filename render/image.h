// An RGB float image, row-major, top row first: what the renderer produces and the EXR and PNG
// writers consume.
#pragma once

#include <cstddef>
#include <vector>

namespace radlab {

struct Image {
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  // 3 floats per pixel

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgb(size_t(w) * size_t(h) * 3, 0.0f) {}
  float* pixel(int x, int y) { return rgb.data() + 3 * (size_t(y) * size_t(width) + size_t(x)); }
  const float* pixel(int x, int y) const {
    return rgb.data() + 3 * (size_t(y) * size_t(width) + size_t(x));
  }
};

}  // namespace radlab
