#include "core/output_file.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>

#include "core/error.h"

namespace radlab {

std::string temporary_sibling(const std::string& path) {
  static std::atomic<unsigned long long> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(++counter);
}

void commit_temporary(const std::string& temp, const std::string& path) {
  std::error_code ec;
  std::filesystem::rename(temp, path, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(temp, ignored);
    throw InputError(path + ": cannot write file (" + ec.message() + ")");
  }
}

void check_writable(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path target(path);
  std::error_code ec;
  if (fs::exists(target, ec) && !fs::is_regular_file(target, ec)) {
    if (fs::is_directory(target, ec)) throw InputError(path + ": is a folder, not a file");
    return;  // a device or FIFO: opened when written
  }
  const fs::path parent = target.parent_path();
  if (!parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) throw InputError(parent.string() + ": cannot create folder (" + ec.message() + ")");
  }
  const std::string probe = temporary_sibling(path);
  std::FILE* f = std::fopen(probe.c_str(), "wb");
  if (!f) throw InputError(path + ": cannot write file (" + std::strerror(errno) + ")");
  std::fclose(f);
  fs::remove(probe, ec);
}

size_t remove_stale_temporaries(const std::filesystem::path& folder, double min_age_seconds,
                                double max_age_seconds) {
  namespace fs = std::filesystem;
  size_t removed = 0;
  std::error_code ec;
  fs::directory_iterator it(folder, ec), end;
  const auto now = fs::file_time_type::clock::now();
  for (; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    const size_t tmp = name.rfind(".tmp.");
    if (tmp == std::string::npos) continue;
    // "<stem>.tmp.<pid>.<n>": both numbers, nothing else.
    const std::string tail = name.substr(tmp + 5);
    const size_t dot = tail.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == tail.size() ||
        tail.find_first_not_of("0123456789.") != std::string::npos ||
        tail.find('.', dot + 1) != std::string::npos)
      continue;
    std::error_code file_ec;
    if (!it->is_regular_file(file_ec)) continue;
    const auto modified = fs::last_write_time(it->path(), file_ec);
    if (file_ec) continue;
    const double age = std::chrono::duration<double>(now - modified).count();
    const long pid = std::stol(tail.substr(0, dot));
    // kill(pid, 0) fails with ESRCH only when no such process exists (EPERM: it exists).
    const bool owner_gone = pid <= 0 || (::kill(pid_t(pid), 0) != 0 && errno == ESRCH);
    const bool own = pid == long(::getpid());
    if ((!own && owner_gone && age > min_age_seconds) || age > max_age_seconds)
      if (fs::remove(it->path(), file_ec)) ++removed;
  }
  return removed;
}

OutputFile::OutputFile(std::string path, bool binary, bool sync)
    : path_(std::move(path)), sync_(sync) {
  std::error_code ec;
  const std::filesystem::path target(path_);
  direct_ = std::filesystem::exists(target, ec) && !std::filesystem::is_regular_file(target, ec);
  if (direct_ && std::filesystem::is_directory(target, ec))
    throw InputError(path_ + ": is a folder, not a file");
  temp_ = direct_ ? path_ : temporary_sibling(path_);
  file_ = std::fopen(temp_.c_str(), binary ? "wb" : "w");
  if (!file_) throw InputError(path_ + ": cannot write file (" + std::strerror(errno) + ")");
}

OutputFile::~OutputFile() {
  if (file_) std::fclose(file_);
  if (!committed_ && !direct_) {
    std::error_code ignored;
    std::filesystem::remove(temp_, ignored);
  }
}

void OutputFile::write(std::string_view bytes) {
  if (error_ || !file_ || bytes.empty()) return;
  if (std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size())
    error_ = errno ? errno : EIO;
}

void OutputFile::fail(const std::string& what, int error) {
  if (file_) std::fclose(file_);
  file_ = nullptr;
  if (!direct_) {
    std::error_code ignored;
    std::filesystem::remove(temp_, ignored);
  }
  throw InputError(path_ + ": " + what + " (" + std::strerror(error ? error : EIO) + ")");
}

void OutputFile::flush() {
  if (committed_) return;
  if (!file_ || error_) fail("write failed", error_);
  if (std::fflush(file_) != 0) fail("write failed", errno);
}

void OutputFile::commit() {
  if (committed_) return;
  if (!file_) fail("write failed", error_);
  errno = 0;
  if (error_) fail("write failed", error_);
  if (std::fflush(file_) != 0) fail("write failed", errno);
  if (sync_ && !direct_ && ::fsync(::fileno(file_)) != 0) fail("cannot sync to disk", errno);
  std::FILE* f = file_;
  file_ = nullptr;
  if (std::fclose(f) != 0) fail("write failed on close", errno);
  if (!direct_) commit_temporary(temp_, path_);
  committed_ = true;
}

}  // namespace radlab
