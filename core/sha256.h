// SHA-256 (OpenSSL's EVP interface): the digests radlab writes where a file's identity matters
// and must be checkable with any tool (`sha256sum`, Python's hashlib): the scene files a sweep
// read (its identity), the files of a sweep folder (its manifest), the plugins a run loaded.
#pragma once

#include <memory>
#include <string>
#include <string_view>

namespace radlab {

// Incremental: update() with the bytes in order, then hex() once.
class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(Sha256&&) noexcept;
  Sha256& operator=(Sha256&&) noexcept;
  void update(std::string_view bytes);
  // The digest as 64 lower-case hex digits; the hasher is spent afterwards.
  std::string hex();

 private:
  struct Context;
  std::unique_ptr<Context> context_;
};

std::string sha256_hex(std::string_view bytes);

// SHA-256 of a file's bytes, lower-case hex. InputError naming the file if it cannot be read.
std::string file_sha256(const std::string& path);

}  // namespace radlab
