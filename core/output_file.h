// Output files that are either complete or absent: every file radlab writes (CSV, JSON, images,
// cache files) goes to a temporary sibling `<name>.tmp.<pid>.<n>`, is closed and checked, and
// only then renamed over `<name>`. A kill, a full disk or a file-size limit therefore never
// leaves a truncated file under the real name, and a failed write is an InputError (exit 3)
// naming the file and the system's reason — never a silent exit 0.
//
// A target that exists and is not a regular file (/dev/stdout, /dev/full, a FIFO) is written
// directly: there is nothing to rename; the close is still checked.
//
// Temporary names carry the writer's pid, so stale ones left by a killed process can be found
// and removed safely (remove_stale_temporaries).
#pragma once

#include <cstdio>
#include <filesystem>
#include <string>
#include <string_view>

namespace radlab {

// A fresh temporary sibling of `path` (unique within this process, and across processes by pid).
std::string temporary_sibling(const std::string& path);

// Renames a finished temporary file over `path`; throws InputError (and removes `temp`) if not.
void commit_temporary(const std::string& temp, const std::string& path);

// Creates `path`'s parent folder and checks a file can be created there (by creating and
// removing a temporary sibling), before any long computation. Throws InputError naming the
// folder and the reason (read-only, missing permission, no space, name too long).
void check_writable(const std::string& path);

// Removes `<stem>.tmp.<pid>.<n>` files in `folder` (optionally only those whose name starts with
// `prefix`) left by a killed writer: those whose process no longer exists and are older than
// `min_age_seconds`, and any older than `max_age_seconds` whatever their pid says (the pid may
// have been reused, or the file may come from another machine sharing the folder). Returns how
// many were removed. Errors are ignored (housekeeping must never fail a command).
size_t remove_stale_temporaries(const std::filesystem::path& folder, double min_age_seconds = 60,
                                double max_age_seconds = 24 * 3600);

// For writers that take a path (EXR, PNG): `write(temp)` writes a temporary sibling, which is
// then renamed over `path`; on an exception the temporary is removed and the exception passes.
template <class Write>
void write_via_temporary(const std::string& path, Write write) {
  const std::string temp = temporary_sibling(path);
  try {
    write(temp);
  } catch (...) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw;
  }
  commit_temporary(temp, path);
}

class OutputFile {
 public:
  // Opens the temporary sibling of `path` (or `path` itself for a non-regular target). `sync`:
  // fsync before the rename, so the renamed file's bytes are on disk even after a power cut
  // (the caches use it; a result file can be recomputed). Throws InputError if it cannot.
  explicit OutputFile(std::string path, bool binary = false, bool sync = false);
  ~OutputFile();  // an uncommitted temporary is removed
  OutputFile(const OutputFile&) = delete;
  OutputFile& operator=(const OutputFile&) = delete;

  // Buffered; an error is remembered and reported by commit().
  void write(std::string_view bytes);
  // Hands the buffer to the system; throws InputError if a write failed.
  void flush();
  // Close, check, (fsync), rename. Throws InputError naming the file and the reason.
  void commit();
  bool committed() const { return committed_; }
  const std::string& path() const { return path_; }

 private:
  void fail(const std::string& what, int error);
  std::string path_, temp_;
  std::FILE* file_ = nullptr;
  bool direct_ = false, sync_ = false, committed_ = false;
  int error_ = 0;  // first errno seen while writing
};

}  // namespace radlab
