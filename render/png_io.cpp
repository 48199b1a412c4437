#include "render/png_io.h"

#include <png.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "core/error.h"

namespace radlab {
namespace {

double srgb(double linear) {
  linear = std::clamp(linear, 0.0, 1.0);
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

void write_bytes(const std::string& path, int width, int height,
                 const std::vector<unsigned char>& bytes) {
  std::unique_ptr<FILE, int (*)(FILE*)> file(std::fopen(path.c_str(), "wb"), &std::fclose);
  if (!file) throw InputError(path + ": cannot write PNG");
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    throw InputError(path + ": libpng could not start");
  }
  // libpng reports errors by longjmp; nothing with a destructor lives between here and the end.
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw InputError(path + ": libpng failed while writing");
  }
  png_init_io(png, file.get());
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y)
    png_write_row(png, bytes.data() + size_t(y) * size_t(width) * 3);
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
}

}  // namespace

void write_png(const std::string& path, const Image& image, double exposure) {
  std::vector<unsigned char> bytes(image.rgb.size());
  for (size_t k = 0; k < bytes.size(); ++k)
    bytes[k] = static_cast<unsigned char>(std::lround(255.0 * srgb(exposure * double(image.rgb[k]))));
  write_bytes(path, image.width, image.height, bytes);
}

void write_png_ldr(const std::string& path, const Image& image) {
  std::vector<unsigned char> bytes(image.rgb.size());
  for (size_t k = 0; k < bytes.size(); ++k)
    bytes[k] = static_cast<unsigned char>(std::lround(255.0 * std::clamp(double(image.rgb[k]), 0.0, 1.0)));
  write_bytes(path, image.width, image.height, bytes);
}

double auto_exposure(const Image& image) {
  std::vector<double> luminance;
  for (size_t k = 0; k + 2 < image.rgb.size(); k += 3) {
    const double y = 0.2126 * double(image.rgb[k]) + 0.7152 * double(image.rgb[k + 1]) +
                     0.0722 * double(image.rgb[k + 2]);
    if (y > 0 && std::isfinite(y)) luminance.push_back(y);
  }
  if (luminance.empty()) return 1.0;
  const size_t at = size_t(0.97 * double(luminance.size() - 1));
  std::nth_element(luminance.begin(), luminance.begin() + long(at), luminance.end());
  return 0.85 / luminance[at];
}

}  // namespace radlab
