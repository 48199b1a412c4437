#include "render/exr_io.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>

#include <exception>

#include "core/error.h"

namespace radlab {

void write_exr(const std::string& path, const Image& image) {
  try {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer frame;
    const size_t xstride = 3 * sizeof(float);
    const size_t ystride = xstride * size_t(image.width);
    char* base = const_cast<char*>(reinterpret_cast<const char*>(image.rgb.data()));
    frame.insert("R", Imf::Slice(Imf::FLOAT, base, xstride, ystride));
    frame.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xstride, ystride));
    frame.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xstride, ystride));
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot write EXR (" + e.what() + ")");
  }
}

Image read_exr(const std::string& path) {
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i window = file.header().dataWindow();
    const int width = window.max.x - window.min.x + 1;
    const int height = window.max.y - window.min.y + 1;
    for (const char* c : {"R", "G", "B"})
      if (!file.header().channels().findChannel(c))
        throw InputError(path + ": EXR has no channel " + c);
    Image image(width, height);
    Imf::FrameBuffer frame;
    const size_t xstride = 3 * sizeof(float);
    const size_t ystride = xstride * size_t(width);
    // The slice base is offset so that pixel (min.x, min.y) lands at the start of the buffer.
    char* base = reinterpret_cast<char*>(image.rgb.data()) -
                 ptrdiff_t(window.min.x) * ptrdiff_t(xstride) -
                 ptrdiff_t(window.min.y) * ptrdiff_t(ystride);
    frame.insert("R", Imf::Slice(Imf::FLOAT, base, xstride, ystride));
    frame.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xstride, ystride));
    frame.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xstride, ystride));
    file.setFrameBuffer(frame);
    file.readPixels(window.min.y, window.max.y);
    return image;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path + ": cannot read EXR (" + e.what() + ")");
  }
}

}  // namespace radlab
