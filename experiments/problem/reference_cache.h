// The on-disk cache of certified references (DESIGN §5), beside the form-factor cache.
//
// A file holds B and the per-channel bounds on ||(I-J)^-1||_inf under a key naming everything the
// solution depends on: the form-factor matrix's own cache key (mesh, method, parameters,
// precision, code), whether it was symmetrised, every element's reflectance and emission, and the
// reference options. A loaded reference is not trusted: recertify_reference() recomputes its
// residual against the matrix in memory (or the rows the method computes, when rows are on the
// fly), so the certificate printed is always of this run. A
// corrupt, stale or uncertifiable file is reported, deleted and the reference recomputed.
// File names, writes, locks and the removal of stale temporaries are the cache folder's
// (core/cache_folder.h), shared with the form-factor cache.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "formfactor/matrix/matrix_cache.h"
#include "solvers/reference/reference.h"

namespace radlab {

struct ReferenceCacheKey : CacheKey {
  std::string file_name() const { return hex() + ".ref"; }
};

ReferenceCacheKey reference_cache_key(const MatrixCacheKey& matrix_key, bool symmetrised,
                                      const System& system, const ReferenceOptions& options);

class ReferenceCache {
 public:
  // 2: references are of the method's double-precision matrix, whatever the storage.
  static constexpr uint32_t kFormatVersion = 2;

  explicit ReferenceCache(std::filesystem::path folder)
      : folder_(std::move(folder), "reference cache", "reference", "recomputed") {}
  std::filesystem::path path(const ReferenceCacheKey& key) const {
    return folder_.file(key, ".ref");
  }

  // The stored reference, certified anew against `matrix`; nullopt when missing (quietly) or
  // bad (with a warning, the file deleted).
  std::optional<Reference> load(const ReferenceCacheKey& key, const System& system,
                                const FormFactorMatrix& matrix,
                                const ReferenceOptions& options) const;
  // The same, certified with rows computed by `method` (one pass, O(n) memory: rows on the fly
  // need no dense matrix); `check` receives that pass's row sums for the physical checks (only
  // filled when a stored file was read).
  std::optional<Reference> load(const ReferenceCacheKey& key, const System& system,
                                const FormFactorMethod& method, const ReferenceOptions& options,
                                StreamedCheck& check) const;

  // As MatrixCache::lock: held while computing and storing the reference of `key`.
  std::unique_ptr<FileLock> lock(const ReferenceCacheKey& key) const;

  // Stores atomically (CacheFolder::write); failures are warnings. Returns success.
  bool store(const ReferenceCacheKey& key, const Reference& reference) const;

 private:
  std::optional<Reference> load(const ReferenceCacheKey& key, const System& system,
                                const std::function<void(Reference&)>& recertify) const;
  CacheFolder folder_;
};

}  // namespace radlab
