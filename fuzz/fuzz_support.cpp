#include "fuzz/fuzz_support.h"

#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "core/limits.h"

namespace radlab::fuzz {

void set_fuzz_limits() {
  Limits& l = limits();
  l.elements = 2e4;
  l.memory_gb = 0.1;
  l.pairs = 2e6;
  l.polygons = 2e4;
  l.runs = 1e3;
  l.images_gb = 0.1;
}

std::vector<std::string> split_parts(const uint8_t* data, size_t size, size_t parts) {
  static constexpr std::string_view kMarker = "#--8<--\n";
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  std::vector<std::string> out;
  size_t start = 0;
  while (out.size() + 1 < parts) {
    const size_t at = text.find(kMarker, start);
    if (at == std::string_view::npos) break;
    out.emplace_back(text.substr(start, at - start));
    start = at + kMarker.size();
  }
  out.emplace_back(text.substr(start));
  out.resize(parts);
  return out;
}

const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base ? base : "/tmp") + "/radlab-fuzz-XXXXXX";
    if (!mkdtemp(pattern.data())) std::abort();
    return std::filesystem::path(pattern);
  }();
  return dir;
}

void clear_scratch() {
  for (const auto& entry : std::filesystem::directory_iterator(scratch()))
    std::filesystem::remove_all(entry.path());
}

void write_file(const std::filesystem::path& path, std::string_view text) {
  std::ofstream out(path, std::ios::binary);
  out.write(text.data(), std::streamsize(text.size()));
}

}  // namespace radlab::fuzz
