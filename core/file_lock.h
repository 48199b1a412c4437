// An exclusive advisory lock (flock) on a lock file, released when the object is destroyed or
// the process dies (so a killed holder never leaves a stale lock). Used by the caches, so that
// concurrent processes needing the same matrix build it once: the first builds, the others wait
// and then load it.
#pragma once

#include <memory>
#include <string>

namespace radlab {

class FileLock {
 public:
  // Blocks until the lock on `path` (created if missing) is held. Returns nullptr when the lock
  // file cannot be created (e.g. a read-only folder): the caller goes on without the lock.
  // `what` names the work waited for in the log message printed while waiting.
  static std::unique_ptr<FileLock> acquire(const std::string& path, const std::string& what);
  // Does not wait: nullptr if another process holds it (or it cannot be created).
  static std::unique_ptr<FileLock> try_acquire(const std::string& path);
  ~FileLock();
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  explicit FileLock(int fd) : fd_(fd) {}
  int fd_;
};

}  // namespace radlab
