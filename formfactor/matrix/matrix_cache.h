// On-disk cache of dense form-factor matrices (DESIGN §3), so a matrix is built once and reused
// by every later command on the same mesh, method and parameters.
//
// Key: a 128-bit hash of the exact bytes of the mesh (vertex coordinates, element corner
// indices and offsets, element-to-polygon map), the method's name, its canonical parameters,
// the stored precision and the file format version. The key's readable text is stored in the
// file too and compared on load, so even a hash collision cannot hand back the wrong matrix.
//
// File `<dir>/<32 hex digits>.ffm`:
//   header  magic "RADLABFF", format version, byte-order mark, n, precision, key hash, key text
//           length, payload bytes, payload checksum (64-bit), the cost of the original build
//           (BuildReport), header checksum
//   key text, then the payload, native byte order: dense, n*n floats or doubles, row-major;
//   sparse (precision field + 256), per row two uint32 (its run count, 2^32-1 for a whole row,
//   and its value count), then each row's runs and values (formfactor/matrix/matrix.h), the
//   checksum chained over the pieces. A load validates counts, sizes and runs before anything is
//   used.
// A file that is truncated, has the wrong size, a different version or byte order, a different
// key, or a checksum mismatch is reported (log::warning), deleted and rebuilt; it is never
// trusted. File names, the per-key lock, atomic writes and the removal of temporaries left by a
// killed writer are the cache folder's (core/cache_folder.h), shared with the reference cache:
// readers see either the old file, the new one, or none, and concurrent processes build one
// matrix once (the first builds, the others wait, then load it).
//
// Folder: `$RADLAB_CACHE_DIR` if set, else `$XDG_CACHE_HOME/radlab`, else `~/.cache/radlab`.
// Nothing evicts old files: delete the folder to reclaim the space.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/cache_folder.h"
#include "core/file_lock.h"
#include "core/hash.h"
#include "formfactor/matrix/matrix.h"

namespace radlab {

// text: "format=...;code=...;method=...;parameters=...;precision=...;elements=...;mesh=..."
struct MatrixCacheKey : CacheKey {
  std::string file_name() const { return hex() + ".ffm"; }
};

// A hash of the form-factor and scene sources this binary was built from (cmake/SourceHash.cmake);
// part of every key, so a fix to a method never meets a matrix its old code computed.
const char* formfactor_code_version();

MatrixCacheKey matrix_cache_key(const Mesh& mesh, const std::string& method,
                                const std::string& parameters, Precision precision);

// $RADLAB_CACHE_DIR, else $XDG_CACHE_HOME/radlab, else $HOME/.cache/radlab; empty when none of
// these is set (then nothing is cached).
std::filesystem::path default_cache_dir();

// Side files beside a cached matrix (`<matrix file><suffix>`: raycast's ".sigma", the rows'
// sampling errors and quadrature excesses; the hemicube's ".emitters"; exact's ".excess"): a magic,
// the payload size, the matrix file's own 128-byte header and key text as they are when the side
// file is written, the payload, and a checksum of all of it. A side file is read back only when
// that header and key are the matrix file's current ones (the same key and the same build, whose
// payload checksum the header holds), its size is the one expected and the checksum matches: a
// zeroed file, edited values, or a file from another key or an earlier build of this one is not
// used (the caller recomputes what it held). Written to a temporary and renamed; failures are
// silent (best effort).
bool write_matrix_side_file(const std::filesystem::path& matrix_file, const std::string& suffix,
                            const void* payload, size_t bytes);
std::optional<std::vector<char>> read_matrix_side_file(const std::filesystem::path& matrix_file,
                                                       const std::string& suffix,
                                                       size_t expected_bytes);

class MatrixCache {
 public:
  // 2: the sparse layout (FormFactorMatrix::sparse()) is stored as such. 3: exact's ".excess"
  // is a side file as below (it was raw doubles without a checksum).
  static constexpr uint32_t kFormatVersion = 3;

  explicit MatrixCache(std::filesystem::path folder)
      : folder_(std::move(folder), "form-factor cache", "matrix", "rebuilt") {}
  const std::filesystem::path& folder() const { return folder_.folder(); }
  std::filesystem::path path(const MatrixCacheKey& key) const { return folder_.file(key, ".ffm"); }

  // The matrix stored under `key`, with the cost of its original build in `report` (if given;
  // report->cached is set). A missing file returns nullopt quietly; a bad file is reported,
  // deleted, and nullopt returned.
  std::optional<FormFactorMatrix> load(const MatrixCacheKey& key, BuildReport* report) const;

  // The matrix in `file` (of this folder or any), verified against `key` as load() verifies:
  // nullopt when the file is missing (`why` empty) or fails verification (`why` says how; the
  // file is left alone). Blocked builds read their block files with it
  // (formfactor/matrix/matrix_blocks.h).
  static std::optional<FormFactorMatrix> read(const std::filesystem::path& file,
                                              const CacheKey& key, BuildReport* report,
                                              std::string& why);

  // Blocks while another process holds the lock of `key`, then holds it: take it after a miss,
  // load again (the other process may have stored it meanwhile), build, store, release.
  // nullptr when the folder cannot hold a lock file (then nothing is locked).
  std::unique_ptr<FileLock> lock(const MatrixCacheKey& key) const;

  // Stores atomically (CacheFolder::write). Failures (unwritable folder, full disk) are
  // warnings; returns success.
  bool store(const MatrixCacheKey& key, const FormFactorMatrix& matrix,
             const BuildReport& report) const;
  // The same into `file` of this folder under `key` (a block file of a blocked build).
  bool write(const std::filesystem::path& file, const CacheKey& key, const FormFactorMatrix& matrix,
             const BuildReport& report) const;
  // Takes `file`'s lock (the folder's per-key lock, for any key).
  std::unique_ptr<FileLock> lock(const CacheKey& key, const std::string& what) const {
    return folder_.lock(key, what);
  }

 private:
  CacheFolder folder_;
};

}  // namespace radlab
