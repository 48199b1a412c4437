#include "solvers/kernels/kernels.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "core/error.h"

// The vector versions use GCC/Clang vector extensions inside functions compiled for AVX2 or
// AVX-512 only; their 32- and 64-byte vector values never cross a call boundary (every helper is
// always_inline), so GCC's note about the AVX calling convention does not apply.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define RADLAB_HAVE_VECTOR_KERNELS 1
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif
#include <immintrin.h>
#endif

namespace radlab::kernels {
namespace {

constexpr size_t kLanes = 16;  // sums are kept in 16 lanes: lane = j mod 16
constexpr size_t kBlock = 64;  // shots find the maximum per block of 64, then inside the block
// The vector loops prefetch the row twice: kPrefetchL2 elements ahead into L2 only (4 KB of
// floats; PREFETCHT2), kPrefetchL1 ahead into L1 (512 bytes). With one prefetch into L1 from 2 KB
// ahead (before), a cold row cost the hot row's time plus the raw read's, nearly without overlap;
// the likely cause (not measured with counters) is that L1 prefetches that far ahead hold L1's
// few miss buffers for a whole memory latency, which the shots' loads of their L2-resident state
// (dB, 1/A, A) need too. In A/B runs the two distances took 5-35% off most gathers and shots
// (docs/performance.md, session avx512).
constexpr size_t kPrefetchL2 = 1024;
constexpr size_t kPrefetchL1 = 128;
constexpr size_t kAlignDoubles = 4;  // shots align their dB stores to 32 bytes

// The one way 16 lane sums become a total, shared by both versions.
inline double combine(double* s) {
  for (size_t w = kLanes / 2; w >= 1; w /= 2)
    for (size_t q = 0; q < w; ++q) s[q] += s[q + w];
  return s[0];
}

// The column origin of a run: origin[j] is the run's value for column j (first <= j). Formed by
// integer arithmetic, as the pointer itself may lie before the values' array; only columns of the
// run are read through it.
template <class T>
const T* column_origin(const T* values, size_t first) {
  return reinterpret_cast<const T*>(reinterpret_cast<uintptr_t>(values) - first * sizeof(T));
}

template <bool kClamp>
inline double clamped(double v) {
  if constexpr (kClamp) return v > 0.0 ? v : 0.0;
  return v;
}

// ------------------------------------------------------------------------------------------
// Scalar versions: the definition of the arithmetic.

// Adds F[j] x_c[j] to lane j mod 16 of s[c] for j in [lo, hi): a row's gather is this over
// [0, n) (or over each stored run of a sparse row) followed by combine().
template <class T, int C, bool kClamp>
void gather_lanes_scalar(const T* F, size_t lo, size_t hi, const double* const* x,
                         double (*s)[kLanes]) {
  for (size_t j = lo; j < hi; ++j) {
    const double f = double(F[j]);
    for (int c = 0; c < C; ++c) s[c][j % kLanes] += f * clamped<kClamp>(x[c][j]);
  }
}

template <class T, int C>
void gather_scatter_scalar(const T* F, size_t n, const double* const* x, double* out,
                           double* const* z, const double* a) {
  double s[C][kLanes] = {};
  for (size_t j = 0; j < n; ++j) {
    const double f = double(F[j]);
    for (int c = 0; c < C; ++c) {
      s[c][j % kLanes] += f * x[c][j];
      z[c][j] += a[c] * f;
    }
  }
  for (int c = 0; c < C; ++c) out[c] = combine(s[c]);
}

// The priority of element j after its update, in the order both versions use:
// (0 + |dB_0j (+ o_0j)| + |dB_1j (+ o_1j)| + ...) * A_j.
template <int C, bool kOffset>
inline double priority(const ShotTargets& t, size_t j) {
  double p = 0.0;
  for (int c = 0; c < C; ++c) {
    if constexpr (kOffset)
      p += std::fabs(t.unshot[c][j] + t.offset[c][j]);
    else
      p += std::fabs(t.unshot[c][j]);
  }
  return p * t.area[j];
}

// The run holding element j.
inline const ReflectanceRun* first_run(const ShotTargets& t, size_t j) {
  return std::upper_bound(t.runs, t.runs + t.run_count, j,
                          [](size_t e, const ReflectanceRun& r) { return e < r.end; });
}

// Calls fn(a, b, rho) for the pieces of [lo, hi) that share one source of reflectance: with
// runs, the part of each run inside [lo, hi) and the run's reflectance; without, [lo, hi) itself
// and null (the reflectance is then read per element).
template <bool kRuns, class Fn>
inline void for_each_segment(const ShotTargets& t, size_t lo, size_t hi, Fn&& fn) {
  if constexpr (kRuns) {
    for (const ReflectanceRun* run = first_run(t, lo); lo < hi; ++run) {
      const size_t b = std::min(hi, run->end);
      fn(lo, b, static_cast<const double*>(run->rho));
      lo = b;
    }
  } else {
    fn(lo, hi, static_cast<const double*>(nullptr));
  }
}

// The update of one receiver j: the definition of a shot's arithmetic,
//   g = F_ij * (1/A_j),  dB_cj += g * (k_c * rho_cj),  coverage_j += g * coverage_scale.
// kr[c] = k[c] * rho_c when the segment is one run (the same product, formed once), else null and
// the product is formed here from the reflectance arrays.
template <class T, int C, bool kCoverage, bool kRuns>
inline void shoot1(const T* F, size_t j, const double* k, const double* kr, double coverage_scale,
                   const ShotTargets& t) {
  const double g = double(F[j]) * t.inverse_area[j];
  for (int c = 0; c < C; ++c) {
    double k_rho;
    if constexpr (kRuns)
      k_rho = kr[c];
    else
      k_rho = k[c] * t.reflectance[c][j];
    t.unshot[c][j] += g * k_rho;
  }
  if constexpr (kCoverage) t.coverage[j] += g * coverage_scale;
}

template <class T, int C, bool kSelect, bool kOffset, bool kCoverage, bool kRuns>
Argmax shoot_scalar(const T* F, size_t lo, size_t hi, const double* k, double coverage_scale,
                    const ShotTargets& t) {
  Argmax best;
  for_each_segment<kRuns>(t, lo, hi, [&](size_t a, size_t b, const double* rho) {
    double kr[3] = {0.0, 0.0, 0.0};
    if constexpr (kRuns)
      for (int c = 0; c < C; ++c) kr[c] = k[c] * rho[c];
    for (size_t j = a; j < b; ++j) {
      shoot1<T, C, kCoverage, kRuns>(F, j, k, kr, coverage_scale, t);
      if constexpr (kSelect) {
        const double p = priority<C, kOffset>(t, j);
        if (p > best.value) best = {p, j};
      }
    }
  });
  return best;
}

// ------------------------------------------------------------------------------------------
// Vector versions: kernels_simd.inc, once for AVX2 (4 doubles a vector) and once for AVX-512
// (8 doubles), on the primitives below.

#ifdef RADLAB_HAVE_VECTOR_KERNELS
// The arrays of one shot, copied out of ShotTargets: the vector stores (memcpy) may alias any
// memory, so pointers read through a reference would be reloaded after every store.
template <int C>
struct Lanes {
  double* u[C];
  const double* rho[C];
  const double* o[C];  // offsets (null without)
  const double* area;
  double* coverage;
  const double* inverse_area;
  explicit Lanes(const ShotTargets& t)
      : area(t.area), coverage(t.coverage), inverse_area(t.inverse_area) {
    for (int c = 0; c < C; ++c) {
      u[c] = t.unshot[c];
      rho[c] = t.reflectance[c];
      o[c] = t.offset[c];
    }
  }
};

// The largest priority seen so far and the first block [start, end) that holds it.
struct BlockBest {
  double value = -1.0;
  size_t start = kNone, end = kNone;
};

// The first element of the block holding the largest priority (block.value): the selection's
// index, found once at the end of a pass rather than per block.
template <int C, bool kOffset>
Argmax first_in_block(const BlockBest& block, const ShotTargets& t) {
  if (block.start != kNone)
    for (size_t j = block.start; j < block.end; ++j)
      if (priority<C, kOffset>(t, j) == block.value) return {block.value, j};
  return {};
}

namespace avx2 {

typedef double V __attribute__((vector_size(32)));
constexpr size_t kWidth = 4;

#define RADLAB_SIMD __attribute__((target("avx2")))
#define RADLAB_SIMD_INLINE __attribute__((target("avx2"), always_inline)) inline

RADLAB_SIMD_INLINE V load(const float* p) {
  return _mm256_cvtps_pd(_mm_loadu_ps(p));
}
// max(a, b) as MAXPD computes it: a if a > b, else b; a NaN in a is ignored, like the scalar
// selection's `p > best`.
RADLAB_SIMD_INLINE V vmax(V a, V b) {
  return _mm256_max_pd(a, b);
}
// The largest of a block maximum's 4 lanes, without the libm call that std::fmax is on baseline
// x86-64 (the three calls per block of 64 receivers were ~15% of the RGB shot's time in perf, and
// the vector registers were spilled around them). On these lanes it is std::fmax's result exactly:
// they start at -1 and vmax keeps them when a priority is NaN, so none is NaN, and priorities
// (sums of |.| times an area >= 0) are never -0, so no tie between +0 and -0 can pick a sign.
RADLAB_SIMD_INLINE double hmax(V v) {
  const __m128d m = _mm_max_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_max_sd(m, _mm_unpackhi_pd(m, m)));
}

#include "solvers/kernels/kernels_simd.inc"

#undef RADLAB_SIMD
#undef RADLAB_SIMD_INLINE
}  // namespace avx2

namespace avx512 {

typedef double V __attribute__((vector_size(64)));
constexpr size_t kWidth = 8;

// AVX-512 F for the 512-bit arithmetic; VL, DQ and BW (every AVX-512 CPU since Skylake-X has
// them) let the compiler use the 32 vector registers and masks on the 256- and 128-bit code too.
#define RADLAB_SIMD __attribute__((target("avx512f,avx512vl,avx512dq,avx512bw")))
#define RADLAB_SIMD_INLINE \
  __attribute__((target("avx512f,avx512vl,avx512dq,avx512bw"), always_inline)) inline

// The zero-masked intrinsics with every lane selected, here and in hmax: the plain ones pass an
// undefined source operand that GCC 12 warns "may be used uninitialized" (and
// __builtin_convertvector converted in two halves).
constexpr __mmask8 kAll = 0xff;
RADLAB_SIMD_INLINE V load(const float* p) {
  return _mm512_maskz_cvtps_pd(kAll, _mm256_loadu_ps(p));
}
// MAXPD's rule, as avx2::vmax: a if a > b, else b (so a NaN in a is ignored).
RADLAB_SIMD_INLINE V vmax(V a, V b) {
  return a > b ? a : b;
}
// The largest of 8 lanes: the two halves' maximum, then avx2::hmax's reduction (the same
// argument: no lane is NaN or -0, so any order gives std::fmax's result).
RADLAB_SIMD_INLINE double hmax(V v) {
  const __m256d h = _mm256_max_pd(_mm512_maskz_extractf64x4_pd(kAll, v, 0),
                                  _mm512_maskz_extractf64x4_pd(kAll, v, 1));
  const __m128d m = _mm_max_pd(_mm256_castpd256_pd128(h), _mm256_extractf128_pd(h, 1));
  return _mm_cvtsd_f64(_mm_max_sd(m, _mm_unpackhi_pd(m, m)));
}

#include "solvers/kernels/kernels_simd.inc"

#undef RADLAB_SIMD
#undef RADLAB_SIMD_INLINE
}  // namespace avx512
#endif  // RADLAB_HAVE_VECTOR_KERNELS

// What the CPU runs (the build targets baseline x86-64; the choice is made at run time).
bool cpu_has(KernelSet set) {
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  __builtin_cpu_init();
  switch (set) {
    case KernelSet::kScalar:
      return true;
    case KernelSet::kAvx2:
      return __builtin_cpu_supports("avx2");
    case KernelSet::kAvx512:
      return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
             __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512bw");
  }
  return false;
#else
  return set == KernelSet::kScalar;
#endif
}

// The widest set the CPU runs, no wider than `limit`.
KernelSet best_up_to(KernelSet limit) {
  for (KernelSet set : {KernelSet::kAvx512, KernelSet::kAvx2})
    if (set <= limit && cpu_has(set)) return set;
  return KernelSet::kScalar;
}

// RADLAB_KERNELS: "scalar" forces the scalar versions, "avx512" asks for AVX-512 where the CPU
// has it, "avx2" for AVX2; unset, empty or "auto" is AVX2 where the CPU has it. Anything else is
// refused (check_kernel_environment) rather than ignored.
const char* kernel_environment() {
  const char* value = std::getenv("RADLAB_KERNELS");
  return value ? value : "";
}

// The vector set used by default: AVX2 even where AVX-512 is there. On the AMD EPYC (Zen 4) these
// kernels were measured on, the AVX-512 versions were nowhere clearly faster and up to 17% slower
// (the grey shots, the RGB gather; docs/performance.md, session avx512): Zen 4 executes a 512-bit
// operation as two 256-bit halves, and these loops are bound by the L2-resident state they move,
// not by their instruction count. RADLAB_KERNELS=avx512 selects them (for CPUs with full-width
// AVX-512 units, where that may differ: not measured).
KernelSet default_vector_set() {
  return best_up_to(std::string(kernel_environment()) == "avx512" ? KernelSet::kAvx512
                                                                  : KernelSet::kAvx2);
}

std::atomic<KernelSet>& active_set() {
  static std::atomic<KernelSet> set{
      std::string(kernel_environment()) == "scalar" ? KernelSet::kScalar : default_vector_set()};
  return set;
}

// The widest set a kernel may use where the active set is the slower choice for it (the paired
// RGB gather): AVX-512 where the CPU has it, unless RADLAB_KERNELS or use_kernels() asked for a
// narrower set.
KernelSet widest_permitted() {
  const std::string value = kernel_environment();
  if (value == "scalar") return KernelSet::kScalar;
  return best_up_to(value == "avx2" ? KernelSet::kAvx2 : KernelSet::kAvx512);
}
std::atomic<KernelSet>& widest_set() {
  static std::atomic<KernelSet> set{widest_permitted()};
  return set;
}

KernelSet active() {
  return active_set().load(std::memory_order_relaxed);
}

// ------------------------------------------------------------------------------------------
// Dispatch on channels and instruction set.

// Calls lanes(F, lo, hi) over the row's columns: [0, n) of a dense row, each stored run of a
// sparse one (with F the run's column origin).
template <class T, class Fn>
void for_each_stored(const T* F, size_t n, Fn&& lanes) {
  lanes(F, size_t(0), n);
}
template <class T, class Fn>
void for_each_stored(const RunRow<T>& F, size_t, Fn&& lanes) {
  for (size_t k = 0; k < F.runs; ++k) {
    const size_t first = F.first(k);
    lanes(column_origin(F.value + F.begin(k), first), first, first + F.count(k));
  }
}

template <int C, bool kClamp, class Row>
void gather_channels(const Row& F, size_t n, const double* const* x, double* out) {
  double s[C][kLanes] = {};
  const KernelSet set = active();
  for_each_stored(F, n, [&](const auto* row, size_t lo, size_t hi) {
    using T = std::remove_cvref_t<decltype(*row)>;
#ifdef RADLAB_HAVE_VECTOR_KERNELS
    if (set == KernelSet::kAvx512) return avx512::gather_lanes<T, C, kClamp>(row, lo, hi, x, s);
    if (set == KernelSet::kAvx2) return avx2::gather_lanes<T, C, kClamp>(row, lo, hi, x, s);
#endif
    gather_lanes_scalar<T, C, kClamp>(row, lo, hi, x, s);
  });
  for (int c = 0; c < C; ++c) out[c] = combine(s[c]);
}

template <bool kClamp, class Row>
void gather_dispatch(const Row& F, const Radiosity& x, double* out) {
  const size_t n = x.size();
  const double* ptr[3] = {x.channel(0).data(), nullptr, nullptr};
  if (x.channels() == 3) {
    ptr[1] = x.channel(1).data();
    ptr[2] = x.channel(2).data();
  }
  if (x.channels() == 1) return gather_channels<1, kClamp>(F, n, ptr, out);
  gather_channels<3, kClamp>(F, n, ptr, out);
}

// The set a paired gather of C channels runs on, or nullopt for two single gathers. RGB pairs keep
// 2 x 3 x 16 lane sums: 24 AVX2 registers' worth, more than the 16 there are, and with them
// spilled the AVX2 pair was slower than two single gathers (2.2 against 1.9 us a row on a hot
// row, Zen 4). In AVX-512's 32 registers they fit and the pair takes a quarter off (docs/
// performance.md, "Stop 29: two rows a pass"), so RGB pairs run on AVX-512 wherever it is
// permitted, the default included, where every other kernel stays on AVX2. Grey pairs (8 sums) fit
// either set.
std::optional<KernelSet> pair_set(int channels) {
  const KernelSet set = active();
  if (channels == 1 || set == KernelSet::kScalar || set == KernelSet::kAvx512) return set;
  if (widest_set().load(std::memory_order_relaxed) == KernelSet::kAvx512) return KernelSet::kAvx512;
  return std::nullopt;
}

template <class T, int C>
void gather_pair_channels(const T* F0, const T* F1, size_t n, const double* const* x, double* out0,
                          double* out1) {
  const std::optional<KernelSet> set = pair_set(C);
  if (!set) {
    gather_channels<C, false>(F0, n, x, out0);
    gather_channels<C, false>(F1, n, x, out1);
    return;
  }
  double s[2][C][kLanes] = {};
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  if (*set == KernelSet::kAvx512)
    avx512::gather_pair_lanes<T, C>(F0, F1, n, x, s);
  else if (*set == KernelSet::kAvx2)
    avx2::gather_pair_lanes<T, C>(F0, F1, n, x, s);
  else
#endif
  {
    gather_lanes_scalar<T, C, false>(F0, 0, n, x, s[0]);
    gather_lanes_scalar<T, C, false>(F1, 0, n, x, s[1]);
  }
  for (int c = 0; c < C; ++c) {
    out0[c] = combine(s[0][c]);
    out1[c] = combine(s[1][c]);
  }
}

template <class T>
void gather_pair_dispatch(const T* F0, const T* F1, const Radiosity& x, double* out0,
                          double* out1) {
  const size_t n = x.size();
  const double* ptr[3] = {x.channel(0).data(), nullptr, nullptr};
  if (x.channels() == 1) return gather_pair_channels<T, 1>(F0, F1, n, ptr, out0, out1);
  ptr[1] = x.channel(1).data();
  ptr[2] = x.channel(2).data();
  gather_pair_channels<T, 3>(F0, F1, n, ptr, out0, out1);
}

template <class T>
void gather_scatter_dispatch(const T* F, const Radiosity& x, double* out, Radiosity& z,
                             const double* a) {
  const size_t n = x.size();
  const double* xp[3] = {x.channel(0).data(), nullptr, nullptr};
  double* zp[3] = {z.channel(0).data(), nullptr, nullptr};
  if (x.channels() == 3)
    for (int c = 1; c < 3; ++c) {
      xp[c] = x.channel(c).data();
      zp[c] = z.channel(c).data();
    }
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  switch (active()) {
    case KernelSet::kAvx512:
      if (x.channels() == 1) return avx512::gather_scatter<T, 1>(F, n, xp, out, zp, a);
      return avx512::gather_scatter<T, 3>(F, n, xp, out, zp, a);
    case KernelSet::kAvx2:
      if (x.channels() == 1) return avx2::gather_scatter<T, 1>(F, n, xp, out, zp, a);
      return avx2::gather_scatter<T, 3>(F, n, xp, out, zp, a);
    case KernelSet::kScalar:
      break;
  }
#endif
  if (x.channels() == 1) return gather_scatter_scalar<T, 1>(F, n, xp, out, zp, a);
  return gather_scatter_scalar<T, 3>(F, n, xp, out, zp, a);
}

template <class T, int C, bool kSelect, bool kOffset, bool kCoverage, bool kRuns>
Argmax shoot_isa(const T* F, size_t lo, size_t hi, const double* k, double cs,
                 const ShotTargets& t) {
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  switch (active()) {
    case KernelSet::kAvx512:
      return avx512::shoot<T, C, kSelect, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
    case KernelSet::kAvx2:
      return avx2::shoot<T, C, kSelect, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
    case KernelSet::kScalar:
      break;
  }
#endif
  return shoot_scalar<T, C, kSelect, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
}

template <class T, int C, bool kSelect, bool kOffset, bool kCoverage>
Argmax shoot_runs(const T* F, size_t lo, size_t hi, const double* k, double cs,
                  const ShotTargets& t) {
  if (t.runs) return shoot_isa<T, C, kSelect, kOffset, kCoverage, true>(F, lo, hi, k, cs, t);
  return shoot_isa<T, C, kSelect, kOffset, kCoverage, false>(F, lo, hi, k, cs, t);
}

template <class T, int C>
Argmax shoot_flags(const T* F, size_t lo, size_t hi, const double* k, double cs,
                   const ShotTargets& t, bool select) {
  const bool coverage = t.coverage != nullptr;
  if (select && t.offset[0])
    return coverage ? shoot_runs<T, C, true, true, true>(F, lo, hi, k, cs, t)
                    : shoot_runs<T, C, true, true, false>(F, lo, hi, k, cs, t);
  if (select)
    return coverage ? shoot_runs<T, C, true, false, true>(F, lo, hi, k, cs, t)
                    : shoot_runs<T, C, true, false, false>(F, lo, hi, k, cs, t);
  return coverage ? shoot_runs<T, C, false, false, true>(F, lo, hi, k, cs, t)
                  : shoot_runs<T, C, false, false, false>(F, lo, hi, k, cs, t);
}

template <class T>
Argmax shoot_serial(const T* F, size_t lo, size_t hi, const double* k, double cs,
                    const ShotTargets& t, bool select) {
  if (lo >= hi) return {};
  if (t.channels == 1) return shoot_flags<T, 1>(F, lo, hi, k, cs, t, select);
  return shoot_flags<T, 3>(F, lo, hi, k, cs, t, select);
}

std::atomic<size_t>& parallel_minimum() {
  static std::atomic<size_t> minimum{kDefaultParallelShotMinimum};
  return minimum;
}

// A long shot split over threads at fixed receiver boundaries (multiples of kShotChunk from 0,
// whatever the thread count): every receiver's update is the same arithmetic wherever it runs,
// and the pieces' maxima are combined in index order with a strict `>`, which keeps the lowest
// index of the largest priority, as the serial pass does. So the same bits on any thread count.
template <class T>
Argmax shoot_dispatch(const T* F, size_t lo, size_t hi, const double* k, double cs,
                      const ShotTargets& t, bool select) {
  if (hi <= lo || hi - lo < parallel_minimum().load(std::memory_order_relaxed) ||
      tbb::this_task_arena::max_concurrency() < 2)
    return shoot_serial(F, lo, hi, k, cs, t, select);
  const size_t first = lo / kShotChunk, last = (hi - 1) / kShotChunk;
  std::vector<Argmax> best(last - first + 1);
  tbb::this_task_arena::isolate([&] {
    tbb::parallel_for(tbb::blocked_range<size_t>(first, last + 1, 1),
                      [&](const tbb::blocked_range<size_t>& r) {
                        for (size_t c = r.begin(); c != r.end(); ++c) {
                          const size_t a = std::max(lo, c * kShotChunk);
                          const size_t b = std::min(hi, (c + 1) * kShotChunk);
                          best[c - first] = shoot_serial(F, a, b, k, cs, t, select);
                        }
                      });
  });
  Argmax result;
  for (const Argmax& b : best)
    if (b.value > result.value) result = b;
  return result;
}

// The scalar form of kernels_simd.inc's shoot_sparse_select: the gaps' priorities scanned, the runs
// shot with their selection fused, the pieces' maxima combined in column order with a strict `>`
// (the lowest index of the largest priority, as one scan of [lo, hi) would find it).
template <class T, int C, bool kOffset, bool kCoverage, bool kRuns>
Argmax shoot_sparse_select_scalar(const RunRow<T>& F, size_t lo, size_t hi, const double* k,
                                  double cs, const ShotTargets& t) {
  Argmax best;
  const auto scan = [&](size_t a, size_t b) {
    for (size_t j = a; j < b; ++j) {
      const double p = priority<C, kOffset>(t, j);
      if (p > best.value) best = {p, j};
    }
  };
  size_t cursor = lo;
  for (size_t r = 0; r < F.runs; ++r) {
    const size_t first = F.first(r);
    if (first >= hi) break;
    const size_t a = std::max(first, lo), b = std::min(first + F.count(r), hi);
    if (a >= b) continue;
    scan(cursor, a);
    const Argmax run = shoot_scalar<T, C, true, kOffset, kCoverage, kRuns>(
        column_origin(F.value + F.begin(r), first), a, b, k, cs, t);
    if (run.value > best.value) best = run;
    cursor = b;
  }
  scan(cursor, hi);
  return best;
}

template <class T, int C, bool kOffset, bool kCoverage, bool kRuns>
Argmax shoot_sparse_select_isa(const RunRow<T>& F, size_t lo, size_t hi, const double* k, double cs,
                               const ShotTargets& t) {
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  switch (active()) {
    case KernelSet::kAvx512:
      return avx512::shoot_sparse_select<T, C, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
    case KernelSet::kAvx2:
      return avx2::shoot_sparse_select<T, C, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
    case KernelSet::kScalar:
      break;
  }
#endif
  return shoot_sparse_select_scalar<T, C, kOffset, kCoverage, kRuns>(F, lo, hi, k, cs, t);
}

template <class T, int C, bool kOffset>
Argmax shoot_sparse_select_flags(const RunRow<T>& F, size_t lo, size_t hi, const double* k,
                                 double cs, const ShotTargets& t) {
  if (t.coverage)
    return t.runs ? shoot_sparse_select_isa<T, C, kOffset, true, true>(F, lo, hi, k, cs, t)
                  : shoot_sparse_select_isa<T, C, kOffset, true, false>(F, lo, hi, k, cs, t);
  return t.runs ? shoot_sparse_select_isa<T, C, kOffset, false, true>(F, lo, hi, k, cs, t)
                : shoot_sparse_select_isa<T, C, kOffset, false, false>(F, lo, hi, k, cs, t);
}

// A shot on a sparse row's stored runs: each run's receivers get the dense kernel's arithmetic
// (so the same bits); the receivers in the gaps would get exactly nothing (kernels_row.h) and are
// not touched. With select, the selection is fused into the same pass
// (kernels_simd.inc's shoot_sparse_select): the runs' receivers are ranked while they are updated
// and only the gaps are read again. (The version before this one shot the runs and then scanned all
// of [lo, hi): on rows of 64-column runs, 7% slower than shooting the expanded dense row.) Rows
// long enough for the parallel split (set_parallel_shot_minimum) shoot each run through it and scan
// afterwards: the same result.
template <class T>
Argmax shoot_sparse(const RunRow<T>& F, size_t lo, size_t hi, const double* k, double cs,
                    const ShotTargets& t, bool select) {
  if (lo >= hi) return {};
  if (select && hi - lo < parallel_minimum().load(std::memory_order_relaxed)) {
    if (t.channels == 1)
      return t.offset[0] ? shoot_sparse_select_flags<T, 1, true>(F, lo, hi, k, cs, t)
                         : shoot_sparse_select_flags<T, 1, false>(F, lo, hi, k, cs, t);
    return t.offset[0] ? shoot_sparse_select_flags<T, 3, true>(F, lo, hi, k, cs, t)
                       : shoot_sparse_select_flags<T, 3, false>(F, lo, hi, k, cs, t);
  }
  for (size_t r = 0; r < F.runs; ++r) {
    const size_t first = F.first(r);
    if (first >= hi) break;
    const size_t a = std::max(first, lo), b = std::min(first + F.count(r), hi);
    if (a < b) shoot_dispatch(column_origin(F.value + F.begin(r), first), a, b, k, cs, t, false);
  }
  return select ? max_priority(lo, hi, t) : Argmax{};
}

}  // namespace

void gather(const float* F, const Radiosity& x, double* out, bool clamp_negative) {
  if (clamp_negative) return gather_dispatch<true>(F, x, out);
  gather_dispatch<false>(F, x, out);
}
void gather(const double* F, const Radiosity& x, double* out, bool clamp_negative) {
  if (clamp_negative) return gather_dispatch<true>(F, x, out);
  gather_dispatch<false>(F, x, out);
}
void gather_pair(const float* F0, const float* F1, const Radiosity& x, double* out0, double* out1) {
  gather_pair_dispatch(F0, F1, x, out0, out1);
}
void gather_pair(const double* F0, const double* F1, const Radiosity& x, double* out0,
                 double* out1) {
  gather_pair_dispatch(F0, F1, x, out0, out1);
}
void gather(const RunRow<float>& F, const Radiosity& x, double* out, bool clamp_negative) {
  if (clamp_negative) return gather_dispatch<true>(F, x, out);
  gather_dispatch<false>(F, x, out);
}
void gather(const RunRow<double>& F, const Radiosity& x, double* out, bool clamp_negative) {
  if (clamp_negative) return gather_dispatch<true>(F, x, out);
  gather_dispatch<false>(F, x, out);
}

void gather_scatter(const float* F, const Radiosity& x, double* out, Radiosity& z,
                    const double* a) {
  gather_scatter_dispatch(F, x, out, z, a);
}
void gather_scatter(const double* F, const Radiosity& x, double* out, Radiosity& z,
                    const double* a) {
  gather_scatter_dispatch(F, x, out, z, a);
}

Argmax shoot(const float* F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select) {
  return shoot_dispatch(F, lo, hi, k, coverage_scale, targets, select);
}
Argmax shoot(const double* F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select) {
  return shoot_dispatch(F, lo, hi, k, coverage_scale, targets, select);
}

Argmax shoot(const RunRow<float>& F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select) {
  return shoot_sparse(F, lo, hi, k, coverage_scale, targets, select);
}
Argmax shoot(const RunRow<double>& F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select) {
  return shoot_sparse(F, lo, hi, k, coverage_scale, targets, select);
}

namespace {

template <int C, bool kOffset>
Argmax max_priority_scan(size_t lo, size_t hi, const ShotTargets& t) {
  Argmax best;
  for (size_t j = lo; j < hi; ++j) {
    const double p = priority<C, kOffset>(t, j);
    if (p > best.value) best = {p, j};
  }
  return best;
}

}  // namespace

Argmax max_priority(size_t lo, size_t hi, const ShotTargets& t) {
#ifdef RADLAB_HAVE_VECTOR_KERNELS
  switch (active()) {
    case KernelSet::kAvx512:
      if (t.offset[0])
        return t.channels == 1 ? avx512::max_priority<1, true>(lo, hi, t)
                               : avx512::max_priority<3, true>(lo, hi, t);
      return t.channels == 1 ? avx512::max_priority<1, false>(lo, hi, t)
                             : avx512::max_priority<3, false>(lo, hi, t);
    case KernelSet::kAvx2:
      if (t.offset[0])
        return t.channels == 1 ? avx2::max_priority<1, true>(lo, hi, t)
                               : avx2::max_priority<3, true>(lo, hi, t);
      return t.channels == 1 ? avx2::max_priority<1, false>(lo, hi, t)
                             : avx2::max_priority<3, false>(lo, hi, t);
    case KernelSet::kScalar:
      break;
  }
#endif
  if (t.offset[0])
    return t.channels == 1 ? max_priority_scan<1, true>(lo, hi, t)
                           : max_priority_scan<3, true>(lo, hi, t);
  return t.channels == 1 ? max_priority_scan<1, false>(lo, hi, t)
                         : max_priority_scan<3, false>(lo, hi, t);
}

void unshot_power(const ShotTargets& t, size_t n, bool clamp_negative, double* out) {
  for (int c = 0; c < t.channels; ++c) {
    double s[kLanes] = {};
    const double* u = t.unshot[c];
    if (clamp_negative)
      for (size_t j = 0; j < n; ++j) s[j % kLanes] += t.area[j] * clamped<true>(u[j]);
    else
      for (size_t j = 0; j < n; ++j) s[j % kLanes] += t.area[j] * u[j];
    out[c] = combine(s);
  }
}

size_t set_parallel_shot_minimum(size_t receivers) {
  return parallel_minimum().exchange(receivers);
}

bool kernels_available(KernelSet set) {
  return cpu_has(set);
}

bool use_kernels(KernelSet set) {
  if (!cpu_has(set)) return false;
  active_set().store(set);
  widest_set().store(set);
  return true;
}

KernelSet kernels_in_use() {
  return active_set().load();
}

const char* kernel_set_name(KernelSet set) {
  switch (set) {
    case KernelSet::kScalar:
      return "scalar";
    case KernelSet::kAvx2:
      return "avx2";
    case KernelSet::kAvx512:
      return "avx512";
  }
  return "?";
}

KernelSet gather_pair_kernels(int channels) {
  return pair_set(channels).value_or(active());
}

bool vector_kernels() {
  return kernels_in_use() != KernelSet::kScalar;
}

void check_kernel_environment() {
  const std::string value = kernel_environment();
  if (!value.empty() && value != "auto" && value != "scalar" && value != "avx2" &&
      value != "avx512")
    throw UsageError(
        "RADLAB_KERNELS must be 'scalar', 'avx2', 'avx512' or 'auto' (or unset), got '" + value +
        "'");
}

bool use_vector_kernels(bool enable) {
  const KernelSet set = enable ? default_vector_set() : KernelSet::kScalar;
  active_set().store(set);
  widest_set().store(enable ? best_up_to(std::max(set, widest_permitted())) : set);
  return set != KernelSet::kScalar;
}

}  // namespace radlab::kernels
