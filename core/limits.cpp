#include "core/limits.h"

#include <cmath>
#include <cstdio>

#include "core/error.h"
#include "core/param_bag.h"

namespace radlab {
namespace {

struct Key {
  const char* name;
  double Limits::*field;
  bool bytes;  // a size in GB (printed as bytes)
  const char* meaning;
};

constexpr Key kKeys[] = {
    {"elements", &Limits::elements, false, "mesh elements"},
    {"memory_gb", &Limits::memory_gb, true,
     "GB for preparing a dense problem (matrix, its float copy, reference LU, method buffers)"},
    {"pairs", &Limits::pairs, false, "element pairs of a dense form-factor build"},
    {"polygons", &Limits::polygons, false, "input polygons after MGF includes and arrays"},
    {"runs", &Limits::runs, false, "planned runs of one experiment"},
    {"images_gb", &Limits::images_gb, true, "GB of images one sweep writes"},
    {"rays", &Limits::rays, false, "rays per step of a Monte Carlo solver"},
};

const Key& key_named(const std::string& name) {
  for (const Key& k : kKeys)
    if (name == k.name) return k;
  throw UsageError("--limits: unknown key '" + name + "'");
}

}  // namespace

Limits& limits() {
  static Limits instance;
  return instance;
}

void set_limits(const std::string& list) {
  ParamBag bag = ParamBag::from_list(list, "--limits");
  for (const Key& k : kKeys) {
    const double value = bag.get_double(k.name, limits().*k.field);
    if (!(value > 0)) throw UsageError(std::string("--limits: '") + k.name + "' must be > 0");
    limits().*k.field = value;
  }
  bag.finish();
}

std::string limits_help() {
  const Limits defaults;
  std::string out;
  for (const Key& k : kKeys) {
    if (!out.empty()) out += "; ";
    out += std::string(k.name) + "=" + format_count(defaults.*k.field) + " " + k.meaning;
  }
  return out;
}

std::string format_count(double count) {
  char buffer[32];
  if (count < 1e6)
    std::snprintf(buffer, sizeof buffer, "%.0f", count);
  else
    std::snprintf(buffer, sizeof buffer, "%.3g", count);
  return buffer;
}

std::string format_bytes(double bytes) {
  char buffer[32];
  if (bytes < 1e6)
    std::snprintf(buffer, sizeof buffer, "%.0f bytes", bytes);
  else if (bytes < 1e9)
    std::snprintf(buffer, sizeof buffer, "%.3g MB", bytes / 1e6);
  else
    std::snprintf(buffer, sizeof buffer, "%.3g GB", bytes / 1e9);
  return buffer;
}

void check_limit(const std::string& key, double estimate, const std::string& what) {
  const Key& k = key_named(key);
  const double limit = limits().*k.field;
  const double scaled = k.bytes ? estimate / 1e9 : estimate;  // estimates of sizes are in bytes
  if (!std::isnan(scaled) && scaled <= limit) return;
  // "elements", "pairs", ...: the unit of a count; sizes print as bytes.
  const std::string unit = k.bytes ? std::string() : " " + std::string(k.name);
  const std::string shown = k.bytes ? format_bytes(estimate) : format_count(estimate) + unit;
  const std::string allowed = k.bytes ? format_bytes(limit * 1e9) : format_count(limit) + unit;
  throw InputError(what + ": " + shown + ", above the limit of " + allowed +
                   " (estimated before allocating; raise it with --limits " + k.name +
                   "=N if this machine can afford it)");
}

}  // namespace radlab
