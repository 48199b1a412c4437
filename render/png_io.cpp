// libpng behind two functions. libpng reports errors by longjmp, so the writer keeps every
// object with a destructor outside the setjmp region and records libpng's message in a plain
// char buffer, which the InputError then quotes.
#include "render/png_io.h"

#include <png.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "core/error.h"

namespace radlab {
namespace {

// IEC 61966-2-1 sRGB encoding of a linear value in [0,1].
double srgb_encode(double linear) {
  return linear <= 0.0031308 ? 12.92 * linear : 1.055 * std::pow(linear, 1.0 / 2.4) - 0.055;
}

// Clamps to [0,1] with NaN -> 0, then rounds to 8 bits.
unsigned char to_byte(double display) {
  if (!(display > 0.0)) return 0;  // also NaN
  return static_cast<unsigned char>(std::lround(255.0 * std::min(display, 1.0)));
}

void check_image(const std::string& path, const Image& image) {
  if (!image.well_formed())
    throw std::invalid_argument(path + ": write_png got an image whose pixel data (" +
                                std::to_string(image.rgb.size()) + " floats) does not match " +
                                std::to_string(image.width) + "x" + std::to_string(image.height));
  if (image.width == 0 || image.height == 0)
    throw InputError(path + ": cannot write an empty " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " PNG image");
}

// libpng's message, kept where the error handler can write it without allocating.
struct PngErrorState {
  char message[256] = "unknown libpng error";
};

[[noreturn]] void on_png_error(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  std::snprintf(state->message, sizeof state->message, "%s", message);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}  // nothing we write can warrant one

// The libpng calls, alone in a function that holds no object with a destructor, so a longjmp
// back to its setjmp skips nothing. `error` lives in the caller: objects local to the function
// that calls setjmp and changed before the jump would be indeterminate afterwards. Returns false
// after a libpng error.
bool encode_rgb8(FILE* file, int width, int height, const unsigned char* bytes,
                 PngErrorState* error) {
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, error, &on_png_error, &on_png_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    std::snprintf(error->message, sizeof error->message, "libpng could not start");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y) png_write_row(png, bytes + 3 * size_t(y) * size_t(width));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

// Writes 8-bit RGB rows (top row first); on failure removes the partial file and throws.
void write_rgb8(const std::string& path, int width, int height,
                const std::vector<unsigned char>& bytes) {
  FILE* file = std::fopen(path.c_str(), "wb");
  if (!file) throw InputError(path + ": cannot write PNG (" + std::strerror(errno) + ")");
  PngErrorState error;
  const bool encoded = encode_rgb8(file, width, height, bytes.data(), &error);
  const bool closed = std::fclose(file) == 0;
  if (encoded && closed) return;
  if (encoded) std::snprintf(error.message, sizeof error.message, "%s", std::strerror(errno));
  std::error_code ignored;
  std::filesystem::remove(path, ignored);  // no truncated file left behind
  throw InputError(path + ": cannot write PNG (" + error.message + ")");
}

}  // namespace

void write_png(const std::string& path, const Image& image, double exposure) {
  check_image(path, image);
  if (!std::isfinite(exposure) || exposure <= 0.0)
    throw InputError(path + ": PNG exposure must be finite and positive, got " +
                     std::to_string(exposure));
  std::vector<unsigned char> bytes(image.rgb.size());
  for (size_t k = 0; k < bytes.size(); ++k) {
    const double v = exposure * double(image.rgb[k]);
    bytes[k] = to_byte(v >= 1.0 ? 1.0 : srgb_encode(v));  // also +inf -> 1; NaN falls through
  }
  write_rgb8(path, image.width, image.height, bytes);
}

void write_png_ldr(const std::string& path, const Image& image) {
  check_image(path, image);
  std::vector<unsigned char> bytes(image.rgb.size());
  for (size_t k = 0; k < bytes.size(); ++k) bytes[k] = to_byte(double(image.rgb[k]));
  write_rgb8(path, image.width, image.height, bytes);
}

double auto_exposure(const Image& image) {
  std::vector<double> luminance;
  for (size_t k = 0; k + 2 < image.rgb.size(); k += 3) {
    const double y = 0.2126 * double(image.rgb[k]) + 0.7152 * double(image.rgb[k + 1]) +
                     0.0722 * double(image.rgb[k + 2]);
    if (y > 0 && std::isfinite(y)) luminance.push_back(y);
  }
  if (luminance.empty()) return 1.0;
  const auto at = std::ptrdiff_t(0.97 * double(luminance.size() - 1));
  std::nth_element(luminance.begin(), luminance.begin() + at, luminance.end());
  return 0.85 / luminance[size_t(at)];
}

}  // namespace radlab
