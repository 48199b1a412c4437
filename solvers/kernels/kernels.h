// Inner loops shared by the solvers, for rows of F stored as float or double. Accumulation is
// always in double (DESIGN §2: all-float shooting stalls at rho near 1).
//
// Every kernel has a portable scalar version and, on x86-64, an AVX2 and an AVX-512 version, one
// of the three chosen at run time (the build targets baseline x86-64, where the scalar loops run
// 2-4x slower than the vector ones; bench/bench_solvers.cpp measures all three). The vector
// versions (kernels_simd.inc, written once for both widths) reproduce the scalar arithmetic
// exactly: the same operations in the same order, sums kept in the same 16 lanes and combined by
// the same tree, no fused multiply-adds. Results are therefore bit-identical on every x86-64
// machine whatever it runs, and tests check it.
#pragma once

#include <cstddef>
#include <limits>

#include "core/radiosity.h"
#include "solvers/kernels/kernels_row.h"

namespace radlab::kernels {

// out[c] = sum_j F[j] * x_c[j] for each channel c of x. With clamp_negative, negative x values
// count as zero (the clamped regather of overshooting).
void gather(const float* F, const Radiosity& x, double* out, bool clamp_negative = false);
void gather(const double* F, const Radiosity& x, double* out, bool clamp_negative = false);
// The same on a sparse row's stored runs (kernels_row.h): the same bits as on its dense form.
void gather(const RunRow<float>& F, const Radiosity& x, double* out, bool clamp_negative = false);
void gather(const RunRow<double>& F, const Radiosity& x, double* out, bool clamp_negative = false);

// gather(F0, x, out0) and gather(F1, x, out1), the same bits each, in one pass that loads x once
// for both rows: the RGB gathers read 24 bytes of x from L2 per 4-byte entry of a float row, and
// that traffic, not the row's, bounded them (docs/performance.md, "Stop 29: two rows a pass").
void gather_pair(const float* F0, const float* F1, const Radiosity& x, double* out0, double* out1);
void gather_pair(const double* F0, const double* F1, const Radiosity& x, double* out0,
                 double* out1);

// out[c] = sum_j F[j] * x_c[j] (as gather) and, in the same pass, z_c[j] += a[c] * F[j] for every
// j: the row's contribution to F^T z. One streaming pass gives both A F p and (A F)^T p, the
// symmetric part that conjugate gradients needs when F itself is not reciprocal.
void gather_scatter(const float* F, const Radiosity& x, double* out, Radiosity& z, const double* a);
void gather_scatter(const double* F, const Radiosity& x, double* out, Radiosity& z,
                    const double* a);

// A run of consecutive elements with the same reflectance (elements follow input polygon order,
// and a polygon has one material, so a scene has few runs).
struct ReflectanceRun {
  size_t end = 0;                   // one past the run's last element
  double rho[3] = {0.0, 0.0, 0.0};  // the reflectance of every element of the run, per channel
};

// The receivers of one shot (all arrays have one entry per element).
struct ShotTargets {
  int channels = 1;
  double* unshot[3] = {nullptr, nullptr, nullptr};             // dB_c, updated
  const double* reflectance[3] = {nullptr, nullptr, nullptr};  // rho_c[j] (read without runs)
  const double* inverse_area = nullptr;                        // 1 / A[j]
  const double* area = nullptr;                                // A[j], for the priority
  double* coverage = nullptr;                                  // Wu & Wang's dff (optional)
  // Optional offsets o_c[j] in the priority, A_j sum_c |dB_cj + o_cj| (overshooting: each
  // element's overshoot of its last shot). Read only; all channels set, or none (null).
  const double* offset[3] = {nullptr, nullptr, nullptr};
  // Optional runs of equal reflectance covering every element, in order. With runs, k_c * rho_c
  // is formed once per run instead of once per receiver and channel, and the reflectance arrays
  // are not read; the results are the same bits either way.
  const ReflectanceRun* runs = nullptr;
  size_t run_count = 0;
};

inline constexpr size_t kNone = std::numeric_limits<size_t>::max();

// The largest priority A_j * sum_c |dB_cj| (A_j * sum_c |dB_cj + o_cj| with offsets) in a range
// and the lowest index holding it.
struct Argmax {
  double value = -1.0;
  size_t index = kNone;
};

// For every j in [lo, hi): dB_c[j] += (F[j] * inverse_area[j]) * (k[c] * rho_c[j]), i.e. the shot
// delivers rho_j F_ij (A_i / A_j) s_c when k[c] = A_i s_c. (This association needs one multiply
// per receiver for F_ij / A_j and one per channel, against three per channel for
// (F k) (rho / A): the RGB shot was limited by its multiplies as much as by its bytes.) With
// coverage set, also coverage[j] += (F[j] * inverse_area[j]) * coverage_scale (F_ji =
// F_ij A_i / A_j for coverage_scale = A_i). With select, returns the largest priority among the
// updated elements (fused into the same pass: a shot changes every receiver's priority, so any heap
// or tree would pay at least this much to learn the new maximum), with the targets' offsets if
// set: the same bits as max_priority over [lo, hi) after the shot.
Argmax shoot(const float* F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select);
Argmax shoot(const double* F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select);
// The same on a sparse row's stored runs (kernels_row.h): only stored receivers are updated (the
// others would receive exactly nothing); with select, max_priority over [lo, hi) after the shot,
// found in the same pass (the runs' receivers ranked as they are updated, the gaps' priorities
// read). The same bits and index as on the dense form.
Argmax shoot(const RunRow<float>& F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select);
Argmax shoot(const RunRow<double>& F, size_t lo, size_t hi, const double* k, double coverage_scale,
             const ShotTargets& targets, bool select);

// Shots over at least set_parallel_shot_minimum() receivers are split over threads in pieces of
// kShotChunk receivers at fixed boundaries: the same bits on any number of threads. Off by default
// (kDefaultParallelShotMinimum = SIZE_MAX): on the 2-core machine it was measured on (shared,
// load ~19) the split gained no wall time at 4,096-262,144 receivers and cost up to 1.3x the CPU
// (docs/performance.md, bench/bench_threads.cpp). Returns the previous minimum.
inline constexpr size_t kShotChunk = 4096;
inline constexpr size_t kDefaultParallelShotMinimum = std::numeric_limits<size_t>::max();
size_t set_parallel_shot_minimum(size_t receivers);

// The largest priority over [lo, hi) without changing anything (after gathers, or at init).
Argmax max_priority(size_t lo, size_t hi, const ShotTargets& targets);

// out[c] = sum_j A[j] * dB_c[j] (the unshot power); with clamp_negative only positive dB counts.
void unshot_power(const ShotTargets& targets, size_t n, bool clamp_negative, double* out);

// The instruction sets the kernels come in, narrowest first. The default is AVX2 where the CPU
// has it (__builtin_cpu_supports, at start-up), even where AVX-512 is there: on the Zen 4 CPU
// they were measured on, the AVX-512 versions were nowhere clearly faster (docs/performance.md).
// The environment variable RADLAB_KERNELS chooses otherwise: "scalar" forces the scalar
// versions, "avx512" asks for AVX-512 (where the CPU has it), "avx2", "auto" or nothing the
// default. Every set gives the same bits. One kernel departs from the active set: the RGB
// gather_pair runs on AVX-512 wherever it is permitted (not under "avx2" or use_kernels(kAvx2)),
// because its 24 vectors of sums do not fit AVX2's 16 registers (kernels.cpp, pair_set).
enum class KernelSet { kScalar, kAvx2, kAvx512 };
// Whether this build and CPU can run `set` (kScalar: always).
bool kernels_available(KernelSet set);
// Uses `set` from now on, in the whole process; false (nothing changed) where the CPU lacks it.
// For tests and benchmarks.
bool use_kernels(KernelSet set);
KernelSet kernels_in_use();
// "scalar", "avx2", "avx512".
const char* kernel_set_name(KernelSet set);
// Chooses the default vector set (above: AVX2, or AVX-512 with RADLAB_KERNELS=avx512), or with
// false the scalar ones (`radlab --scalar-kernels`); returns whether vector versions are now in
// use.
bool use_vector_kernels(bool enable);
// Whether a vector set (AVX2 or AVX-512) is in use.
bool vector_kernels();
// The set gather_pair runs on now for `channels` channels: the active set, except RGB pairs on
// AVX-512 where it is permitted (for labels: which instructions a paired gather used).
KernelSet gather_pair_kernels(int channels);
// Throws UsageError when RADLAB_KERNELS holds anything but "scalar", "avx2", "avx512", "auto" or
// nothing.
void check_kernel_environment();

}  // namespace radlab::kernels
