// Deterministic random numbers. Every random choice in radlab derives from a user seed and the
// identity of what it is for (an element pair, a sample index), never from a thread or a clock, so
// the same seed gives the same numbers however the work is scheduled.
#pragma once

#include <cstdint>

namespace radlab {

// SplitMix64 finaliser: a strong 64-bit mixer, used to derive independent stream seeds.
constexpr uint64_t mix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

constexpr uint64_t hash_combine(uint64_t seed, uint64_t value) {
  return mix64(seed ^ mix64(value));
}

// PCG32 (O'Neill): small state, good statistics, fast.
class Pcg32 {
 public:
  explicit Pcg32(uint64_t seed, uint64_t stream = 0x14057b7ef767814fULL) {
    inc_ = (stream << 1u) | 1u;
    state_ = 0;
    next_u32();
    state_ += seed;
    next_u32();
  }
  uint32_t next_u32() {
    uint64_t old = state_;
    state_ = old * 6364136223846793005ULL + inc_;
    auto xorshifted = static_cast<uint32_t>(((old >> 18u) ^ old) >> 27u);
    auto rot = static_cast<uint32_t>(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((-rot) & 31));
  }
  // Uniform in [0, 1), 32 random bits.
  double next_double() { return next_u32() * 0x1p-32; }
  // Uniform integer in [0, bound).
  uint32_t next_below(uint32_t bound) {
    return static_cast<uint32_t>((uint64_t(next_u32()) * bound) >> 32);
  }

 private:
  uint64_t state_ = 0;
  uint64_t inc_ = 0;
};

}  // namespace radlab
