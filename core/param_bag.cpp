#include "core/param_bag.h"

#include <cmath>

#include "core/error.h"
#include "core/text.h"

namespace radlab {

ParamBag ParamBag::from_assignments(const std::vector<std::string>& items, std::string context) {
  ParamBag bag(std::move(context));
  for (const std::string& item : items) {
    auto eq = item.find('=');
    if (eq == std::string::npos || eq == 0)
      throw UsageError(bag.context_ + ": expected key=value, got '" + item + "'");
    std::string key(text::trim(std::string_view(item).substr(0, eq)));
    std::string value(text::trim(std::string_view(item).substr(eq + 1)));
    if (bag.has(key)) throw UsageError(bag.context_ + ": key '" + key + "' given twice");
    bag.set(key, value);
  }
  return bag;
}

ParamBag ParamBag::from_list(const std::string& list, std::string context) {
  std::vector<std::string> items;
  if (!text::trim(list).empty()) items = text::split(list, ',');
  return from_assignments(items, std::move(context));
}

void ParamBag::set(const std::string& key, const std::string& value) {
  values_[key] = value;
}

const std::string* ParamBag::lookup(const std::string& key) {
  known_.insert(key);
  auto it = values_.find(key);
  return it == values_.end() ? nullptr : &it->second;
}

double ParamBag::get_double(const std::string& key, double fallback) {
  defaults_.emplace(key, text::format_double(fallback));
  const std::string* v = lookup(key);
  if (!v) return fallback;
  auto parsed = text::parse_double(*v);
  if (!parsed || !std::isfinite(*parsed))
    throw UsageError(context_ + ": key '" + key + "' needs a finite number, got '" + *v + "'");
  return *parsed;
}

long long ParamBag::get_int(const std::string& key, long long fallback) {
  defaults_.emplace(key, std::to_string(fallback));
  const std::string* v = lookup(key);
  if (!v) return fallback;
  auto parsed = text::parse_int(*v);
  if (!parsed)
    throw UsageError(context_ + ": key '" + key + "' needs an integer, got '" + *v + "'");
  return *parsed;
}

long long ParamBag::get_int(const std::string& key, long long fallback, long long min,
                            long long max) {
  const long long value = get_int(key, fallback);
  if (value < min || value > max)
    throw UsageError(context_ + ": key '" + key + "' must lie in [" + std::to_string(min) + ", " +
                     std::to_string(max) + "], got " + std::to_string(value));
  return value;
}

bool ParamBag::get_bool(const std::string& key, bool fallback) {
  defaults_.emplace(key, fallback ? "true" : "false");
  const std::string* v = lookup(key);
  if (!v) return fallback;
  auto parsed = text::parse_bool(*v);
  if (!parsed)
    throw UsageError(context_ + ": key '" + key + "' needs true or false, got '" + *v + "'");
  return *parsed;
}

std::string ParamBag::get_string(const std::string& key, const std::string& fallback) {
  defaults_.emplace(key, fallback);
  const std::string* v = lookup(key);
  return v ? *v : fallback;
}

std::string ParamBag::get_choice(const std::string& key, const std::string& fallback,
                                 const std::vector<std::string>& choices) {
  std::string value = get_string(key, fallback);
  for (const auto& c : choices)
    if (c == value) return value;
  throw UsageError(context_ + ": key '" + key + "' must be one of " + text::join(choices, ", ") +
                   "; got '" + value + "'");
}

void ParamBag::finish() const {
  std::vector<std::string> unknown;
  for (const auto& [key, value] : values_)
    if (!known_.count(key)) unknown.push_back(key);
  if (unknown.empty()) return;
  std::vector<std::string> valid(known_.begin(), known_.end());
  throw UsageError(context_ + ": unknown key" + (unknown.size() > 1 ? "s " : " ") + "'" +
                   text::join(unknown, "', '") + "'; valid keys: " +
                   (valid.empty() ? std::string("(none)") : text::join(valid, ", ")));
}

std::string ParamBag::canonical() const {
  std::string out;
  for (const auto& [key, value] : values_) {
    if (!out.empty()) out += ',';
    out += key + '=' + value;
  }
  return out;
}

std::string fill_parameter_defaults(std::vector<ParameterInfo>& parameters,
                                    const std::map<std::string, std::string>& defaults) {
  std::string problems;
  const auto add = [&](const std::string& problem) {
    problems += (problems.empty() ? "" : "; ") + problem;
  };
  for (ParameterInfo& p : parameters) {
    auto it = defaults.find(p.name);
    if (it == defaults.end())
      add("parameter '" + p.name + "' is listed but its options never read it");
    else
      p.default_value = it->second;
  }
  for (const auto& [key, value] : defaults) {
    bool listed = false;
    for (const ParameterInfo& p : parameters) listed = listed || p.name == key;
    if (!listed) add("key '" + key + "' is read but not listed in its parameters");
  }
  return problems;
}

}  // namespace radlab
