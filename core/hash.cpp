#include "core/hash.h"

#include <cstring>

#include "core/random.h"

namespace radlab {

uint64_t hash_bytes(const void* data, size_t size, uint64_t seed) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  uint64_t lane[4] = {mix64(seed ^ 0x243f6a8885a308d3ULL), mix64(seed ^ 0x13198a2e03707344ULL),
                      mix64(seed ^ 0xa4093822299f31d0ULL), mix64(seed ^ 0x082efa98ec4e6c89ULL)};
  size_t k = 0;
  // Four independent lanes keep the multipliers busy: ~several GB/s on one core.
  for (; k + 32 <= size; k += 32)
    for (int l = 0; l < 4; ++l) {
      uint64_t word;
      std::memcpy(&word, bytes + k + 8 * size_t(l), 8);
      lane[l] = mix64(lane[l] ^ word) + word;
    }
  uint64_t h = mix64(seed + size);
  for (int l = 0; l < 4; ++l) h = mix64(h ^ lane[l]);
  for (; k < size; ++k) h = mix64(h ^ (uint64_t(bytes[k]) << 8) ^ k);
  return h;
}

}  // namespace radlab
