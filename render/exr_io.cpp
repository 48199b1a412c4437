// OpenEXR 3 behind two functions: FrameBuffer slices point straight into Image::rgb (interleaved
// R, G, B floats), so there is no copy, and every OpenEXR exception becomes an InputError that
// names the file.
#include "render/exr_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStringAttribute.h>

#include <exception>
#include <stdexcept>

#include "core/error.h"

namespace radlab {
namespace {

constexpr const char* kChannels[3] = {"R", "G", "B"};

// Slices for the three interleaved channels of `pixels`, whose first float is the data window's
// top-left pixel.
Imf::FrameBuffer interleaved_frame(const float* pixels, const Imath::Box2i& window) {
  const size_t x_stride = 3 * sizeof(float);
  const size_t y_stride = x_stride * size_t(window.max.x - window.min.x + 1);
  Imf::FrameBuffer frame;
  for (int c = 0; c < 3; ++c)
    frame.insert(kChannels[c],
                 Imf::Slice::Make(Imf::FLOAT, pixels + c, window, x_stride, y_stride));
  return frame;
}

}  // namespace

void write_exr(const std::string& path, const Image& image, const ExrAttributes& attributes) {
  if (!image.well_formed())
    throw std::invalid_argument(path + ": write_exr got an image whose pixel data (" +
                                std::to_string(image.rgb.size()) + " floats) does not match " +
                                std::to_string(image.width) + "x" + std::to_string(image.height));
  if (image.width == 0 || image.height == 0)
    throw InputError(path + ": cannot write an empty " + std::to_string(image.width) + "x" +
                     std::to_string(image.height) + " EXR image");
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* c : kChannels) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    for (const auto& [name, value] : attributes) header.insert(name, Imf::StringAttribute(value));
    Imf::OutputFile file(path.c_str(), header);
    file.setFrameBuffer(interleaved_frame(image.rgb.data(), header.dataWindow()));
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot write EXR (" + e.what() + ")");
  }
}

Image read_exr(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    for (const char* c : kChannels)
      if (!file.header().channels().findChannel(c))
        throw InputError(path + ": EXR has no channel " + c);
    const Imath::Box2i window = file.header().dataWindow();
    Image image(window.max.x - window.min.x + 1, window.max.y - window.min.y + 1);
    file.setFrameBuffer(interleaved_frame(image.rgb.data(), window));
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot read EXR (" + e.what() + ")");
  }
}

ExrAttributes read_exr_attributes(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    ExrAttributes out;
    for (auto it = file.header().begin(); it != file.header().end(); ++it)
      if (const auto* text = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
        out.emplace_back(it.name(), text->value());
    return out;
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot read EXR (" + e.what() + ")");
  }
}

}  // namespace radlab
