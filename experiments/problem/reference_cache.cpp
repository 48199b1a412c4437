#include "experiments/problem/reference_cache.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "core/error.h"
#include "core/log.h"
#include "core/output_file.h"

namespace radlab {
namespace {

constexpr char kMagic[8] = {'R', 'A', 'D', 'L', 'A', 'B', 'R', 'F'};
constexpr uint64_t kChecksumSeed = 0xbadc0ffee;

// Fixed layout, naturally aligned; followed by the key text, the method name, the per-channel
// inverse-norm bounds, B (channel-major) and a checksum of everything before it.
struct Header {
  char magic[8];
  uint32_t version;
  uint32_t channels;
  uint64_t n;
  uint32_t key_text_bytes;
  uint32_t method_bytes;
  int32_t refinements;
  int32_t reserved;
  double seconds, q, spectral_radius_upper;
};
static_assert(sizeof(Header) == 64, "the reference cache header layout must not change silently");

template <class T>
void append(std::string& out, const T* data, size_t count) {
  out.append(reinterpret_cast<const char*>(data), count * sizeof(T));
}

// A cache file's bytes without their trailing checksum, once its magic (the first 8 bytes), its
// format version (the 4 after) and that checksum are verified; nullopt when it is missing or
// unreadable (`why` empty: a miss) or fails (`why` says how: to be distrusted).
std::optional<std::string> read_verified(const std::filesystem::path& file, const char* magic,
                                         uint32_t version, size_t header_bytes, std::string& why) {
  why.clear();
  std::error_code ec;
  if (!std::filesystem::exists(file, ec)) return std::nullopt;
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;  // vanished or unreadable: a miss
  std::ostringstream buffer;
  buffer << in.rdbuf();
  std::string bytes = buffer.str();
  uint32_t stored_version = 0;
  if (bytes.size() < header_bytes + sizeof(uint64_t)) {
    why = "truncated";
  } else if (std::memcmp(bytes.data(), magic, 8) != 0) {
    why = "not a radlab cache file of this kind";
  } else if (std::memcpy(&stored_version, bytes.data() + 8, sizeof stored_version),
             stored_version != version) {
    why = "stale format version";
  } else {
    const size_t body = bytes.size() - sizeof(uint64_t);
    uint64_t checksum = 0;
    std::memcpy(&checksum, bytes.data() + body, sizeof checksum);
    if (hash_bytes(bytes.data(), body, kChecksumSeed) != checksum)
      why = "checksum mismatch (corrupt)";
    bytes.resize(body);
  }
  if (!why.empty()) return std::nullopt;
  return bytes;
}

}  // namespace

ReferenceCacheKey reference_cache_key(const MatrixCacheKey& matrix_key, bool symmetrised,
                                      const System& system, const ReferenceOptions& options) {
  // The materials as exact bytes: rho and E per channel and element.
  uint64_t materials = 0x6d617473;
  for (int c = 0; c < system.channels(); ++c) {
    const auto rho = system.reflectance().channel(c);
    const auto E = system.emission().channel(c);
    materials = hash_bytes(rho.data(), rho.size_bytes(), materials);
    materials = hash_bytes(E.data(), E.size_bytes(), materials);
  }
  char text[300];
  std::snprintf(text, sizeof text,
                ";symmetrised=%d;channels=%d;materials=%016llx;target=%.17g;acceptable=%.17g;"
                "refinements=%d;dense_limit=%zu;gmres_tolerance=%.17g",
                symmetrised ? 1 : 0, system.channels(), static_cast<unsigned long long>(materials),
                options.target, options.acceptable, options.max_refinements, options.dense_limit,
                options.gmres_tolerance);
  ReferenceCacheKey key;
  key.text =
      "reference=" + std::to_string(ReferenceCache::kFormatVersion) + ";" + matrix_key.text + text;
  key.hash[0] = hash_bytes(key.text.data(), key.text.size(), 0x5eed0011);
  key.hash[1] = hash_bytes(key.text.data(), key.text.size(), 0x5eed0012);
  return key;
}

std::optional<Reference> ReferenceCache::load(const ReferenceCacheKey& key, const System& system,
                                              const FormFactorMatrix& matrix,
                                              const ReferenceOptions& options) const {
  return load(key, system,
              [&](Reference& ref) { recertify_reference(system, matrix, ref, options); });
}

std::optional<Reference> ReferenceCache::load(const ReferenceCacheKey& key, const System& system,
                                              const FormFactorMethod& method,
                                              const ReferenceOptions& options, StreamedCheck& check,
                                              bool use_stored_check, bool& check_was_stored) const {
  check_was_stored = false;
  bool computed = false;
  auto reference = load(key, system, [&](Reference& ref) {
    std::optional<StreamedCheck> stored;
    if (use_stored_check) stored = load_check(key, ref.B);
    if (stored && stored->row_sum.size() == system.size()) {
      check = std::move(*stored);
      check_was_stored = true;
    } else {
      check = streamed_check(system, method, ref.B);
      computed = true;
    }
    recertify_reference(system, check.residual, ref, options);
  });
  // Stored only once it certified: a check that did not is never kept.
  if (reference && computed) store_check(key, reference->B, check);
  return reference;
}

namespace {

constexpr char kCheckMagic[8] = {'R', 'A', 'D', 'L', 'A', 'B', 'C', 'K'};
constexpr uint32_t kCheckFormatVersion = 1;

// Fixed layout; followed by the key text, the residual per channel, the row sums and the
// emission-weighted row sums (n each) and a checksum of everything before it.
struct CheckHeader {
  char magic[8];
  uint32_t version;
  uint32_t channels;
  uint64_t n;
  uint64_t solution_hash;  // of B's bytes: the check is of this solution only
  uint32_t key_text_bytes;
  uint32_t reserved;
};
static_assert(sizeof(CheckHeader) == 40, "the check file header layout must not change silently");

uint64_t solution_hash(const Radiosity& B) {
  uint64_t h = 0x50107104;
  for (int c = 0; c < B.channels(); ++c)
    h = hash_bytes(B.channel(c).data(), B.channel(c).size_bytes(), h);
  return h;
}

}  // namespace

std::optional<StreamedCheck> ReferenceCache::load_check(const ReferenceCacheKey& key,
                                                        const Radiosity& B) const {
  const std::filesystem::path file = check_path(key);
  auto reject = [&](const std::string& why) -> std::optional<StreamedCheck> {
    folder_.distrust(file, "its stored residual pass: " + why);
    return std::nullopt;
  };
  std::string why;
  const std::optional<std::string> file_bytes =
      read_verified(file, kCheckMagic, kCheckFormatVersion, sizeof(CheckHeader), why);
  if (!file_bytes) return why.empty() ? std::nullopt : reject(why);
  const std::string& bytes = *file_bytes;
  const size_t body = bytes.size();
  CheckHeader h{};
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.channels != uint32_t(B.channels()) || h.n != B.size())
    return reject("stored for another system");
  if (body != sizeof h + h.key_text_bytes + (h.channels + 2 * h.n) * sizeof(double))
    return reject("corrupt sizes");
  const char* p = bytes.data() + sizeof h;
  if (std::string(p, h.key_text_bytes) != key.text) return reject("stale: stored for another key");
  if (h.solution_hash != solution_hash(B)) return reject("stored for another solution");
  p += h.key_text_bytes;
  StreamedCheck check;
  auto read = [&](std::vector<double>& v, size_t count) {
    v.resize(count);
    std::memcpy(v.data(), p, count * sizeof(double));
    p += count * sizeof(double);
  };
  read(check.residual, h.channels);
  read(check.row_sum, h.n);
  read(check.emitter_sum, h.n);
  for (double v : check.residual)
    if (!(v >= 0.0) || !std::isfinite(v)) return reject("a residual that is not finite");
  return check;
}

bool ReferenceCache::store_check(const ReferenceCacheKey& key, const Radiosity& B,
                                 const StreamedCheck& check) const {
  if (check.residual.size() != size_t(B.channels()) || check.row_sum.size() != B.size() ||
      check.emitter_sum.size() != B.size())
    return false;
  CheckHeader h{};
  std::memcpy(h.magic, kCheckMagic, sizeof kCheckMagic);
  h.version = kCheckFormatVersion;
  h.channels = uint32_t(B.channels());
  h.n = B.size();
  h.solution_hash = solution_hash(B);
  h.key_text_bytes = uint32_t(key.text.size());
  std::string bytes;
  append(bytes, &h, 1);
  bytes += key.text;
  append(bytes, check.residual.data(), check.residual.size());
  append(bytes, check.row_sum.data(), check.row_sum.size());
  append(bytes, check.emitter_sum.data(), check.emitter_sum.size());
  const uint64_t checksum = hash_bytes(bytes.data(), bytes.size(), kChecksumSeed);
  append(bytes, &checksum, 1);
  return folder_.write(check_path(key), [&](OutputFile& out) { out.write(bytes); });
}

std::optional<Reference> ReferenceCache::load(
    const ReferenceCacheKey& key, const System& system,
    const std::function<void(Reference&)>& recertify) const {
  const std::filesystem::path file = path(key);
  auto reject = [&](const std::string& why) -> std::optional<Reference> {
    folder_.distrust(file, why);
    return std::nullopt;
  };
  std::string why;
  const std::optional<std::string> file_bytes =
      read_verified(file, kMagic, kFormatVersion, sizeof(Header), why);
  if (!file_bytes) return why.empty() ? std::nullopt : reject(why);
  const std::string& bytes = *file_bytes;
  const size_t body = bytes.size();
  Header h{};
  std::memcpy(&h, bytes.data(), sizeof h);
  if ((h.channels != 1 && h.channels != 3) || h.n != system.size() ||
      int(h.channels) != system.channels())
    return reject("stored for another system");
  const size_t doubles = size_t(h.channels) * (1 + h.n);
  if (body != sizeof h + h.key_text_bytes + h.method_bytes + doubles * sizeof(double))
    return reject("corrupt sizes");
  const char* p = bytes.data() + sizeof h;
  if (std::string(p, h.key_text_bytes) != key.text) return reject("stale: stored for another key");
  p += h.key_text_bytes;

  Reference ref;
  ref.method = std::string(p, h.method_bytes) + ", cached";
  p += h.method_bytes;
  ref.channel_inverse_norm.resize(h.channels);
  std::memcpy(ref.channel_inverse_norm.data(), p, h.channels * sizeof(double));
  p += h.channels * sizeof(double);
  ref.B = Radiosity(int(h.channels), size_t(h.n));
  for (int c = 0; c < int(h.channels); ++c) {
    std::memcpy(ref.B.channel(c).data(), p, h.n * sizeof(double));
    p += h.n * sizeof(double);
  }
  ref.refinements = h.refinements;
  ref.seconds = h.seconds;
  ref.q = h.q;
  ref.spectral_radius_upper = h.spectral_radius_upper;
  for (double v : ref.channel_inverse_norm)
    ref.inverse_norm_bound = std::max(ref.inverse_norm_bound, v);
  try {
    recertify(ref);
  } catch (const NumericalError& e) {
    return reject(std::string("does not certify against this matrix (") + e.what() + ")");
  }
  return ref;
}

bool ReferenceCache::store(const ReferenceCacheKey& key, const Reference& ref) const {
  Header h{};
  std::memcpy(h.magic, kMagic, sizeof kMagic);
  h.version = kFormatVersion;
  h.channels = uint32_t(ref.B.channels());
  h.n = ref.B.size();
  h.key_text_bytes = uint32_t(key.text.size());
  h.method_bytes = uint32_t(ref.method.size());
  h.refinements = ref.refinements;
  h.seconds = ref.seconds;
  h.q = ref.q;
  h.spectral_radius_upper = ref.spectral_radius_upper;
  std::string bytes;
  append(bytes, &h, 1);
  bytes += key.text;
  bytes += ref.method;
  append(bytes, ref.channel_inverse_norm.data(), ref.channel_inverse_norm.size());
  for (int c = 0; c < ref.B.channels(); ++c) append(bytes, ref.B.channel(c).data(), ref.B.size());
  const uint64_t checksum = hash_bytes(bytes.data(), bytes.size(), kChecksumSeed);
  append(bytes, &checksum, 1);

  return folder_.write(path(key), [&](OutputFile& out) { out.write(bytes); });
}

std::unique_ptr<FileLock> ReferenceCache::lock(const ReferenceCacheKey& key) const {
  return folder_.lock(key, "the same reference");
}

}  // namespace radlab
