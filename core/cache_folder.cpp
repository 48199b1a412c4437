#include "core/cache_folder.h"

#include <cstdio>
#include <exception>

#include "core/log.h"

namespace radlab {

std::string CacheKey::hex() const {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%016llx%016llx", static_cast<unsigned long long>(hash[0]),
                static_cast<unsigned long long>(hash[1]));
  return buffer;
}

CacheFolder::CacheFolder(std::filesystem::path folder, std::string kind, std::string artifact,
                         std::string redo)
    : folder_(std::move(folder)),
      kind_(std::move(kind)),
      artifact_(std::move(artifact)),
      redo_(std::move(redo)) {}

std::unique_ptr<FileLock> CacheFolder::lock(const CacheKey& key, const std::string& what) const {
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  const std::filesystem::path file = this->file(key, ".lock");
  return FileLock::acquire(file.string(), what + " (" + file.string() + ")");
}

bool CacheFolder::write(const std::filesystem::path& file,
                        const std::function<void(OutputFile&)>& body) const {
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  if (ec) {
    log::warning(kind_ + ": cannot create " + folder_.string() + " (" + ec.message() + "); the " +
                 artifact_ + " is not cached");
    return false;
  }
  remove_stale_temporaries(folder_);
  try {
    OutputFile out(file.string(), /*binary=*/true, /*sync=*/true);
    body(out);
    out.commit();
  } catch (const std::exception& e) {
    log::warning(kind_ + ": " + e.what() + "; the " + artifact_ + " is not cached");
    return false;
  }
  return true;
}

void CacheFolder::distrust(const std::filesystem::path& file, const std::string& why) const {
  log::warning(kind_ + ": " + file.string() + ": " + why + "; the file is not trusted, deleted, " +
               "and the " + artifact_ + " " + redo_);
  std::error_code ignored;
  std::filesystem::remove(file, ignored);
}

}  // namespace radlab
