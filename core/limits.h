// Resource limits: how much work or memory one command may ask for before radlab refuses it.
//
// Small inputs can ask for unbounded work (an MGF array of a million instances, a mesh of 10^24
// elements from `--element-size 1e-12`, a sweep of 10^9 runs). Every such quantity is estimated
// in 64-bit or double arithmetic *before* anything is allocated and compared with a limit here;
// above it, the command fails (exit 3) with the estimate and the `--limits KEY=VALUE` that
// raises it. The defaults are generous for this machine class (tens of GB of RAM): every shipped
// experiment and RenderPark scene fits with a wide margin. docs/reliability_input.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace radlab {

struct Limits {
  double elements = 2e6;   // mesh elements (the unknowns)
  double memory_gb = 4.0;  // preparing a dense problem (experiments/problem/preparation_estimate.h)
  double pairs = 2.5e8;    // element pairs a dense form-factor build evaluates (n^2)
  double polygons = 5e6;   // input polygons after MGF includes and array instances
  double runs = 1e5;       // planned runs of one experiment
  double images_gb = 20.0;  // bytes of images a sweep writes (EXR + PNG, every step and run)
  double rays = 1e9;        // rays one step of a Monte Carlo solver casts (or walks it starts)
};

// The process-wide limits (the command line sets them once, tests may change them).
Limits& limits();

// Parses "key=value,..." (keys as in Limits, values finite numbers > 0) into limits().
// Throws UsageError naming the key.
void set_limits(const std::string& list);

// The keys and defaults, for --help.
std::string limits_help();

// "12.3 GB", "4.56e+09": estimates as printed in refusals.
std::string format_count(double count);
std::string format_bytes(double bytes);

// Throws InputError "<what>: <estimate> <key>, above the limit of <limit> (... --limits key=N
// ...)" when estimate (a count, or bytes for the *_gb keys) exceeds the limit named by `key`.
void check_limit(const std::string& key, double estimate, const std::string& what);

}  // namespace radlab
