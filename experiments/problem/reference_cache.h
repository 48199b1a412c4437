// The on-disk cache of certified references (DESIGN §5), beside the form-factor cache.
//
// A file holds B and the per-channel bounds on ||(I-J)^-1||_inf under a key naming everything the
// solution depends on: the form-factor matrix's own cache key (mesh, method, parameters,
// precision, code), whether it was symmetrised, every element's reflectance and emission, and the
// reference options. A loaded reference is not trusted: recertify_reference() recomputes its
// residual against the matrix in memory, so the certificate printed is always of this run. With
// rows on the fly there is no matrix in memory and recomputing the residual costs every row again
// (the whole matrix's work: 18 min on hosp.mgf), which would defeat the matrix-free solvers; so the
// residual pass (StreamedCheck: per-channel residual, row sums) is stored once beside the reference
// (`<key>.check`, bound to the key and to B's bytes, checksummed) and a run with rows on the fly
// certifies the reference from it. It is as trustworthy as a cached matrix (same key, same
// verification), and it is computed from the same rows: the one pass a first streamed run makes,
// or the dense matrix when a run holds it. A corrupt, stale or uncertifiable file is reported,
// deleted and the reference (or the check) recomputed.
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
  // need no dense matrix), or with the stored check of that pass when there is one and
  // `use_stored_check`; `check` receives the pass's residuals and row sums for the physical
  // checks (only filled when a stored file was read), `check_was_stored` whether they were read
  // from the stored check. A pass computed here is stored for the next run.
  std::optional<Reference> load(const ReferenceCacheKey& key, const System& system,
                                const FormFactorMethod& method, const ReferenceOptions& options,
                                StreamedCheck& check, bool use_stored_check,
                                bool& check_was_stored) const;

  // The stored residual pass of the reference of `key` with solution `B`; nullopt when missing
  // (quietly) or bad (with a warning, the file deleted).
  std::filesystem::path check_path(const ReferenceCacheKey& key) const {
    return folder_.file(key, ".check");
  }
  std::optional<StreamedCheck> load_check(const ReferenceCacheKey& key, const Radiosity& B) const;
  bool store_check(const ReferenceCacheKey& key, const Radiosity& B,
                   const StreamedCheck& check) const;

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
