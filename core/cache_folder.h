// One folder of cached artifacts: what every kind of cache shares (the form-factor matrices of
// formfactor/matrix/matrix_cache.h, the certified references of
// experiments/problem/reference_cache.h), written once. A kind owns its file format and what
// verifying a file means; the folder owns
//   - file names from a 128-bit key (32 hex digits and the kind's extension),
//   - the per-key lock (`<32 hex digits>.lock`, flock) that lets concurrent processes compute an
//     artifact once: the first computes and stores it, the others wait, then load it,
//   - atomic writes: the folder created, stale temporaries removed (core/output_file.h), the file
//     written to a temporary, synced and renamed, failures reported as warnings,
//   - the one treatment of a file that fails verification: reported, deleted, recomputed.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "core/file_lock.h"
#include "core/output_file.h"

namespace radlab {

// A cache key: the readable text naming everything the artifact depends on (stored in the file
// and compared on load) and its 128-bit hash (the file name).
struct CacheKey {
  std::string text;
  std::array<uint64_t, 2> hash{};
  std::string hex() const;  // 32 hex digits
};

class CacheFolder {
 public:
  // `kind`: how messages name the cache ("form-factor cache"); `artifact`: what a file holds
  // ("matrix"); `redo`: what happens without it ("rebuilt").
  CacheFolder(std::filesystem::path folder, std::string kind, std::string artifact,
              std::string redo);
  const std::filesystem::path& folder() const { return folder_; }
  std::filesystem::path file(const CacheKey& key, const std::string& extension) const {
    return folder_ / (key.hex() + extension);
  }
  // Blocks while another process holds the key's lock, then holds it; nullptr when the folder
  // cannot hold a lock file (then nothing is locked). `what` names the artifact in the message
  // printed while waiting.
  std::unique_ptr<FileLock> lock(const CacheKey& key, const std::string& what) const;
  // Writes `file` atomically with `body`; returns success (failures are warnings: the artifact
  // is then not cached).
  bool write(const std::filesystem::path& file, const std::function<void(OutputFile&)>& body) const;
  // A file that failed verification (`why`): reported and deleted, never trusted.
  void distrust(const std::filesystem::path& file, const std::string& why) const;

 private:
  std::filesystem::path folder_;
  std::string kind_, artifact_, redo_;
};

}  // namespace radlab
