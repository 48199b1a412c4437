// A key/value bag of options, e.g. from `--set omega=1.5` or `builtin:cube:rho=0.9`.
//
// Options structs read their fields from a bag with typed getters; every getter records the key as
// valid. finish() then rejects any key that was given but never read, listing the valid ones
// (DESIGN §8: no silently accepted keys). Values that do not parse name the key and the value.
#pragma once

#include <map>
#include <set>
#include <string>
#include <vector>

namespace radlab {

// Bounds for ParamBag::get_int(key, fallback, min, max) of values that become int or uint64.
inline constexpr long long kIntMin = -2147483648LL;
inline constexpr long long kIntMax = 2147483647;
inline constexpr long long kInt64Max = 9223372036854775807;

class ParamBag {
 public:
  // `context` names the owner in error messages, e.g. "solver 'gauss-seidel'".
  explicit ParamBag(std::string context = "options") : context_(std::move(context)) {}

  // Parses "k=v" items (one per entry); a repeated key or an item without '=' is a usage error.
  static ParamBag from_assignments(const std::vector<std::string>& items, std::string context);
  // Parses "k=v,k=v".
  static ParamBag from_list(const std::string& list, std::string context);

  void set(const std::string& key, const std::string& value);
  bool has(const std::string& key) const { return values_.count(key) != 0; }
  bool empty() const { return values_.empty(); }
  const std::string& context() const { return context_; }
  const std::map<std::string, std::string>& values() const { return values_; }

  double get_double(const std::string& key, double fallback);
  long long get_int(const std::string& key, long long fallback);
  // An integer that must lie in [min, max], checked in 64 bits before the caller narrows it
  // (rays=4294967297 is refused, not taken as 1 ray).
  long long get_int(const std::string& key, long long fallback, long long min, long long max);
  bool get_bool(const std::string& key, bool fallback);
  std::string get_string(const std::string& key, const std::string& fallback);
  // A string that must be one of `choices`.
  std::string get_choice(const std::string& key, const std::string& fallback,
                         const std::vector<std::string>& choices);

  // Throws UsageError if a key was given that no getter asked for.
  void finish() const;

  // "k=v,k=v" in key order: stable, for run ids and cache keys.
  std::string canonical() const;

  // Every key a getter asked for, with the fallback it was given as text (the first one if asked
  // twice). Reading an options struct from an empty bag thus lists its parameters and their
  // defaults from the struct itself (solvers/registry.cpp: `radlab solvers` prints
  // these).
  const std::map<std::string, std::string>& defaults() const { return defaults_; }

 private:
  const std::string* lookup(const std::string& key);

  std::string context_;
  std::map<std::string, std::string> values_;
  std::set<std::string> known_;
  std::map<std::string, std::string> defaults_;
};

// One parameter of a registered component (a solver, a form-factor method): its name, its
// default as text and its help. The default is not typed by hand: the registries read it from
// the component's options struct (ParamBag::defaults() of an empty bag; fill_parameter_defaults).
struct ParameterInfo {
  std::string name;
  // Filled in by the registry from the options struct (any value given here is replaced).
  std::string default_value;
  std::string help;
};

// Sets each listed parameter's default_value from `defaults` (the keys an options struct read
// from an empty bag, with their fallbacks). Returns what is wrong, "" when nothing is: a
// parameter listed that the options never read, or a key read that is not listed.
std::string fill_parameter_defaults(std::vector<ParameterInfo>& parameters,
                                    const std::map<std::string, std::string>& defaults);

}  // namespace radlab
