#include "formfactor/matrix/matrix_cache.h"

#include <unistd.h>

#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <memory>

#include "core/log.h"
#include "core/output_file.h"
#include "core/random.h"

namespace radlab {

MatrixCacheKey matrix_cache_key(const Mesh& mesh, const std::string& method,
                                const std::string& parameters, Precision precision) {
  // The mesh: exact bytes of everything that determines F.
  auto mesh_hash = [&](uint64_t seed) {
    uint64_t h = hash_bytes(mesh.vertices.data(), mesh.vertices.size() * sizeof(Vec3), seed);
    h = hash_bytes(mesh.vertex_index.data(), mesh.vertex_index.size() * sizeof(uint32_t), h);
    h = hash_bytes(mesh.first_vertex.data(), mesh.first_vertex.size() * sizeof(uint32_t), h);
    h = hash_bytes(mesh.polygon.data(), mesh.polygon.size() * sizeof(uint32_t), h);
    return h;
  };
  char mesh_text[40];
  std::snprintf(mesh_text, sizeof mesh_text, "%016llx%016llx",
                static_cast<unsigned long long>(mesh_hash(1)),
                static_cast<unsigned long long>(mesh_hash(2)));
  MatrixCacheKey key;
  key.text = "format=" + std::to_string(MatrixCache::kFormatVersion) +
             ";code=" + formfactor_code_version() + ";method=" + method +
             ";parameters=" + parameters +
             ";precision=" + (precision == Precision::kFloat ? "float" : "double") +
             ";elements=" + std::to_string(mesh.size()) + ";mesh=" + mesh_text;
  key.hash[0] = hash_bytes(key.text.data(), key.text.size(), 0x5eed0001);
  key.hash[1] = hash_bytes(key.text.data(), key.text.size(), 0x5eed0002);
  return key;
}

std::filesystem::path default_cache_dir() {
  if (const char* dir = std::getenv("RADLAB_CACHE_DIR"); dir && *dir) return dir;
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg)
    return std::filesystem::path(xdg) / "radlab";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::filesystem::path(home) / ".cache" / "radlab";
  return {};
}

namespace {

constexpr char kMagic[8] = {'R', 'A', 'D', 'L', 'A', 'B', 'F', 'F'};
constexpr uint32_t kByteOrderMark = 0x01020304u;

// Fixed-size, fixed-layout header (all fields naturally aligned, no padding).
struct Header {
  char magic[8];
  uint32_t version;
  uint32_t byte_order;
  uint64_t n;
  uint32_t precision;  // 0 float, 1 double; plus 256 for the sparse layout
  uint32_t key_text_bytes;
  uint64_t key_hash[2];
  uint64_t payload_bytes;
  uint64_t payload_checksum;
  uint64_t rays, kernel_evaluations, pairs_culled, pairs_unoccluded, pairs_traced;
  double build_seconds;
  int64_t build_threads;
  uint64_t header_checksum;  // of every byte above, and of the key text
};
static_assert(sizeof(Header) == 128, "the cache header layout must not change silently");

uint64_t header_checksum(const Header& h, const std::string& key_text) {
  const uint64_t partial = hash_bytes(&h, offsetof(Header, header_checksum), 0xc0ffee);
  return hash_bytes(key_text.data(), key_text.size(), partial);
}

// The matrix file's header and key text, checked (magic, byte order, header checksum); empty
// when the file is missing or not a valid cache file.
std::string matrix_identity(const std::filesystem::path& matrix_file) {
  std::ifstream in(matrix_file, std::ios::binary);
  Header h{};
  if (!in.read(reinterpret_cast<char*>(&h), sizeof h)) return {};
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0 || h.byte_order != kByteOrderMark ||
      h.key_text_bytes > (1u << 20))
    return {};
  std::string key_text(h.key_text_bytes, '\0');
  if (!in.read(key_text.data(), std::streamsize(key_text.size()))) return {};
  if (h.header_checksum != header_checksum(h, key_text)) return {};
  return std::string(reinterpret_cast<const char*>(&h), sizeof h) + key_text;
}

constexpr char kSideMagic[8] = {'R', 'A', 'D', 'L', 'A', 'B', 'S', 'D'};
constexpr uint64_t kSideSeed = 0x51de0f11e5ull;

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

constexpr uint64_t kPayloadSeed = 0xfeedface;
constexpr uint32_t kSparseFlag = 256;
constexpr uint32_t kWholeRow = UINT32_MAX;  // a sparse-layout row stored as all n values

// The sparse payload: for each row two uint32_t, its run count (kWholeRow for a whole row) and
// value count, then each row's runs (FormFactorMatrix::SparseRow) and values. The checksum
// chains over the pieces in file order.
template <class T>
uint64_t sparse_payload(const FormFactorMatrix& m,
                        const std::vector<T> FormFactorMatrix::SparseRow::*values,
                        const std::function<void(const void*, size_t)>& write) {
  const size_t n = m.size();
  std::vector<uint32_t> counts(2 * n);
  for (size_t i = 0; i < n; ++i) {
    const auto& row = m.sparse_row(i);
    counts[2 * i] = m.whole_row(i) ? kWholeRow : uint32_t(row.run.size() / 2);
    counts[2 * i + 1] = uint32_t((row.*values).size());
  }
  uint64_t checksum = hash_bytes(counts.data(), counts.size() * sizeof(uint32_t), kPayloadSeed);
  if (write) write(counts.data(), counts.size() * sizeof(uint32_t));
  for (size_t i = 0; i < n; ++i) {
    const auto& row = m.sparse_row(i);
    const size_t run_bytes = row.run.size() * sizeof(uint32_t);
    const size_t value_bytes = (row.*values).size() * sizeof(T);
    checksum = hash_bytes(row.run.data(), run_bytes, checksum);
    checksum = hash_bytes((row.*values).data(), value_bytes, checksum);
    if (write) {
      write(row.run.data(), run_bytes);
      write((row.*values).data(), value_bytes);
    }
  }
  return checksum;
}

uint64_t sparse_payload_bytes(const FormFactorMatrix& m) {
  size_t bytes = 2 * m.size() * sizeof(uint32_t);
  for (size_t i = 0; i < m.size(); ++i) {
    const auto& row = m.sparse_row(i);
    bytes += row.run.size() * sizeof(uint32_t) + row.f32.size() * sizeof(float) +
             row.f64.size() * sizeof(double);
  }
  return bytes;
}

// Reads the sparse payload of an n x n matrix; an error message, or empty on success. Sizes are
// checked against the payload's (which matches the file's) before any allocation, and every
// row's runs by set_sparse_row.
template <class T>
std::string read_sparse(std::FILE* f, uint64_t payload_bytes, uint64_t expected_checksum,
                        std::vector<T> FormFactorMatrix::SparseRow::*values, FormFactorMatrix& m) {
  const size_t n = m.size();
  std::vector<uint32_t> counts(2 * n);
  if (n && std::fread(counts.data(), sizeof(uint32_t), counts.size(), f) != counts.size())
    return "truncated payload";
  uint64_t bytes = counts.size() * sizeof(uint32_t);
  for (size_t i = 0; i < n; ++i) {
    const uint32_t runs = counts[2 * i], count = counts[2 * i + 1];
    if (runs == kWholeRow ? count != n : (count > n || runs > count))
      return "corrupt payload (row " + std::to_string(i) + "'s counts)";
    bytes += (runs == kWholeRow ? 0 : 2 * uint64_t(runs) * sizeof(uint32_t)) +
             uint64_t(count) * sizeof(T);
  }
  if (bytes != payload_bytes) return "corrupt payload (row counts do not match its size)";
  uint64_t checksum = hash_bytes(counts.data(), counts.size() * sizeof(uint32_t), kPayloadSeed);
  for (size_t i = 0; i < n; ++i) {
    FormFactorMatrix::SparseRow row;
    const uint32_t runs = counts[2 * i], count = counts[2 * i + 1];
    if (runs != kWholeRow) row.run.resize(2 * size_t(runs));
    (row.*values).resize(count);
    if (std::fread(row.run.data(), sizeof(uint32_t), row.run.size(), f) != row.run.size() ||
        std::fread((row.*values).data(), sizeof(T), count, f) != count)
      return "truncated payload";
    checksum = hash_bytes(row.run.data(), row.run.size() * sizeof(uint32_t), checksum);
    checksum = hash_bytes((row.*values).data(), count * sizeof(T), checksum);
    try {
      m.set_sparse_row(i, std::move(row));
    } catch (const std::invalid_argument& e) {
      return std::string("corrupt payload (") + e.what() + ")";
    }
  }
  if (checksum != expected_checksum) return "payload checksum mismatch (corrupt)";
  return {};
}

}  // namespace

std::optional<FormFactorMatrix> MatrixCache::load(const MatrixCacheKey& key,
                                                  BuildReport* report) const {
  std::string why;
  std::optional<FormFactorMatrix> matrix = read(path(key), key, report, why);
  if (!matrix && !why.empty()) folder_.distrust(path(key), why);
  return matrix;
}

std::optional<FormFactorMatrix> MatrixCache::read(const std::filesystem::path& file,
                                                  const CacheKey& key, BuildReport* report,
                                                  std::string& why) {
  const auto start = std::chrono::steady_clock::now();
  why.clear();
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  const uint64_t file_size = std::filesystem::file_size(file, ec);

  auto reject = [&](const std::string& reason) -> std::optional<FormFactorMatrix> {
    why = reason;
    return std::nullopt;
  };
  if (ec) return reject("cannot read its size (" + ec.message() + ")");

  File f(std::fopen(file.c_str(), "rb"));
  if (!f) return std::nullopt;  // vanished or unreadable: just a miss
  Header h{};
  if (file_size < sizeof(Header) || std::fread(&h, sizeof h, 1, f.get()) != 1)
    return reject("truncated header");
  if (std::memcmp(h.magic, kMagic, sizeof kMagic) != 0) return reject("not a radlab cache file");
  if (h.byte_order != kByteOrderMark) return reject("written on a machine of another byte order");
  if (h.version != kFormatVersion)
    return reject("stale format version " + std::to_string(h.version) + " (this radlab writes " +
                  std::to_string(kFormatVersion) + ")");
  if (h.key_text_bytes > (1u << 20)) return reject("corrupt header (key text length)");
  std::string key_text(h.key_text_bytes, '\0');
  if (h.key_text_bytes &&
      std::fread(key_text.data(), 1, key_text.size(), f.get()) != key_text.size())
    return reject("truncated key");
  if (h.header_checksum != header_checksum(h, key_text)) return reject("header checksum mismatch");
  if (key_text != key.text || h.key_hash[0] != key.hash[0] || h.key_hash[1] != key.hash[1])
    return reject("stale: stored for a different key (" + key_text + ")");
  const bool sparse = (h.precision & kSparseFlag) != 0;
  const uint32_t precision_code = h.precision & ~kSparseFlag;
  const Precision precision = precision_code == 1 ? Precision::kDouble : Precision::kFloat;
  const uint64_t element_bytes = precision == Precision::kFloat ? sizeof(float) : sizeof(double);
  if (precision_code > 1 || h.n > (uint64_t(1) << 24) ||
      (!sparse && h.payload_bytes != h.n * h.n * element_bytes) ||
      (sparse && h.payload_bytes > h.n * (8 + h.n * (8 + element_bytes))))
    return reject("corrupt header (size fields)");
  if (file_size != sizeof(Header) + h.key_text_bytes + h.payload_bytes)
    return reject("size " + std::to_string(file_size) + " bytes, expected " +
                  std::to_string(sizeof(Header) + h.key_text_bytes + h.payload_bytes) +
                  " (truncated or padded)");

  FormFactorMatrix matrix(size_t(h.n), precision, sparse ? Layout::kSparse : Layout::kDense);
  if (sparse) {
    const std::string error = precision == Precision::kFloat
                                  ? read_sparse(f.get(), h.payload_bytes, h.payload_checksum,
                                                &FormFactorMatrix::SparseRow::f32, matrix)
                                  : read_sparse(f.get(), h.payload_bytes, h.payload_checksum,
                                                &FormFactorMatrix::SparseRow::f64, matrix);
    if (!error.empty()) return reject(error);
  } else {
    if (h.payload_bytes &&
        std::fread(matrix.data(), 1, h.payload_bytes, f.get()) != h.payload_bytes)
      return reject("truncated payload");
    if (hash_bytes(matrix.data(), h.payload_bytes, kPayloadSeed) != h.payload_checksum)
      return reject("payload checksum mismatch (corrupt)");
  }

  if (report) {
    report->cost.rays = h.rays;
    report->cost.kernel_evaluations = h.kernel_evaluations;
    report->cost.pairs_culled = h.pairs_culled;
    report->cost.pairs_unoccluded = h.pairs_unoccluded;
    report->cost.pairs_traced = h.pairs_traced;
    report->seconds = h.build_seconds;
    report->threads = int(h.build_threads);
    report->cached = true;
    report->cache_file = file.string();
    report->load_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return matrix;
}

bool MatrixCache::store(const MatrixCacheKey& key, const FormFactorMatrix& matrix,
                        const BuildReport& report) const {
  return write(path(key), key, matrix, report);
}

bool MatrixCache::write(const std::filesystem::path& file, const CacheKey& key,
                        const FormFactorMatrix& matrix, const BuildReport& report) const {
  const size_t n = matrix.size();
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kFormatVersion;
  h.byte_order = kByteOrderMark;
  h.n = n;
  h.precision =
      (matrix.precision() == Precision::kDouble ? 1 : 0) | (matrix.sparse() ? kSparseFlag : 0);
  h.key_text_bytes = uint32_t(key.text.size());
  h.key_hash[0] = key.hash[0];
  h.key_hash[1] = key.hash[1];
  auto payload = [&](const std::function<void(const void*, size_t)>& write) {
    return matrix.precision() == Precision::kFloat
               ? sparse_payload(matrix, &FormFactorMatrix::SparseRow::f32, write)
               : sparse_payload(matrix, &FormFactorMatrix::SparseRow::f64, write);
  };
  h.payload_bytes = matrix.sparse() ? sparse_payload_bytes(matrix) : matrix.bytes();
  h.payload_checksum =
      matrix.sparse() ? payload({}) : hash_bytes(matrix.data(), matrix.bytes(), kPayloadSeed);
  h.rays = report.cost.rays;
  h.kernel_evaluations = report.cost.kernel_evaluations;
  h.pairs_culled = report.cost.pairs_culled;
  h.pairs_unoccluded = report.cost.pairs_unoccluded;
  h.pairs_traced = report.cost.pairs_traced;
  h.build_seconds = report.seconds;
  h.build_threads = report.threads;
  h.header_checksum = header_checksum(h, key.text);

  return folder_.write(file, [&](OutputFile& out) {
    out.write({reinterpret_cast<const char*>(&h), sizeof h});
    out.write(key.text);
    if (matrix.sparse())
      payload([&](const void* bytes, size_t size) {
        out.write({static_cast<const char*>(bytes), size});
      });
    else
      out.write({reinterpret_cast<const char*>(matrix.data()), matrix.bytes()});
  });
}

std::unique_ptr<FileLock> MatrixCache::lock(const MatrixCacheKey& key) const {
  return folder_.lock(key, "the same form-factor matrix");
}

bool write_matrix_side_file(const std::filesystem::path& matrix_file, const std::string& suffix,
                            const void* payload, size_t bytes) {
  const std::string identity = matrix_identity(matrix_file);
  if (identity.empty()) return false;
  const uint64_t size = bytes;
  std::string data(kSideMagic, sizeof kSideMagic);
  data.append(reinterpret_cast<const char*>(&size), sizeof size);
  data += identity;
  data.append(static_cast<const char*>(payload), bytes);
  const uint64_t checksum = hash_bytes(data.data(), data.size(), kSideSeed);
  data.append(reinterpret_cast<const char*>(&checksum), sizeof checksum);
  const std::filesystem::path target = matrix_file.string() + suffix;
  const std::filesystem::path temporary = target.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    out.write(data.data(), std::streamsize(data.size()));
    if (!out) return false;
  }
  std::error_code ec;
  std::filesystem::rename(temporary, target, ec);
  return !ec;
}

std::optional<std::vector<char>> read_matrix_side_file(const std::filesystem::path& matrix_file,
                                                       const std::string& suffix,
                                                       size_t expected_bytes) {
  const std::string identity = matrix_identity(matrix_file);
  if (identity.empty()) return std::nullopt;
  const std::filesystem::path side = matrix_file.string() + suffix;
  std::error_code ec;
  const uint64_t file_size = std::filesystem::file_size(side, ec);
  const uint64_t expected_size =
      sizeof kSideMagic + sizeof(uint64_t) + identity.size() + expected_bytes + sizeof(uint64_t);
  if (ec || file_size != expected_size) return std::nullopt;  // missing, or not for this size
  std::string data(size_t(file_size), '\0');
  std::ifstream in(side, std::ios::binary);
  if (!in.read(data.data(), std::streamsize(data.size()))) return std::nullopt;
  uint64_t size = 0, checksum = 0;
  std::memcpy(&size, data.data() + sizeof kSideMagic, sizeof size);
  std::memcpy(&checksum, data.data() + data.size() - sizeof checksum, sizeof checksum);
  const size_t body = data.size() - sizeof checksum;
  if (std::memcmp(data.data(), kSideMagic, sizeof kSideMagic) != 0 || size != expected_bytes ||
      data.compare(sizeof kSideMagic + sizeof size, identity.size(), identity) != 0 ||
      hash_bytes(data.data(), body, kSideSeed) != checksum)
    return std::nullopt;
  const size_t start = sizeof kSideMagic + sizeof size + identity.size();
  return std::vector<char>(data.begin() + std::ptrdiff_t(start),
                           data.begin() + std::ptrdiff_t(start + expected_bytes));
}

}  // namespace radlab
