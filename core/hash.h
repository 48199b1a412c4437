// A fast 64-bit hash of a byte range, for cache keys and file checksums (not cryptographic: the
// caches also compare the key's readable text, so a collision cannot hand back the wrong file).
#pragma once

#include <cstddef>
#include <cstdint>

namespace radlab {

// Four independent lanes of a SplitMix64-style mixer, then folded. Different seeds give
// independent hashes.
uint64_t hash_bytes(const void* data, size_t size, uint64_t seed);

}  // namespace radlab
