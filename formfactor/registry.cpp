// The table of form-factor methods (see registry.h).
#include "formfactor/registry.h"

#include <stdexcept>

#include "core/error.h"
#include "core/text.h"
#include "formfactor/methods/method_infos.h"

namespace radlab {

void FormFactorMethod::upper_row(size_t /*i*/, std::span<double> /*row*/, RowCost& /*cost*/) const {
  // Reached only when a method says integrates_pairs_once() without giving its pairs: a
  // programming error in that method, which the method conformance tests catch.
  throw std::logic_error("form-factor method '" + name() +
                         "' integrates pairs once but has no upper_row()");
}

void FormFactorMethod::pair_entries(size_t /*i*/, std::span<double> /*upper*/,
                                    std::span<double> /*lower*/, RowCost& /*cost*/) const {
  // Reached only when a method says builds_in_pair_blocks() without giving its pairs.
  throw std::logic_error("form-factor method '" + name() +
                         "' builds in blocks of pairs but has no pair_entries()");
}

std::map<std::string, std::string> read_parameter_defaults(const FormFactorMethodInfo& info) {
  ParamBag bag("form factors '" + info.name + "'");
  info.configure(bag);  // reads every key with its fallback; configuring builds nothing
  return bag.defaults();
}

namespace {

// Fills in the defaults; returns what is wrong ("" when nothing is).
std::string complete_parameters(FormFactorMethodInfo& info) {
  return fill_parameter_defaults(info.parameters, read_parameter_defaults(info));
}

std::vector<FormFactorMethodInfo> builtin_methods() {
  std::vector<FormFactorMethodInfo> table = {
      raycast_method_info(),
      hemicube_method_info(),
      exact_method_info(),
  };
  for (FormFactorMethodInfo& info : table) {
    const std::string problems = complete_parameters(info);
    // A programming error in radlab itself; the method conformance tests would fail first.
    if (!problems.empty())
      throw std::logic_error("form-factor method '" + info.name + "': " + problems);
  }
  return table;
}

std::vector<FormFactorMethodInfo>& table() {
  static std::vector<FormFactorMethodInfo> methods = builtin_methods();
  return methods;
}

void (*methods_hook)() = nullptr;

}  // namespace

void set_form_factor_methods_hook(void (*before_use)()) {
  methods_hook = before_use;
}

const std::vector<FormFactorMethodInfo>& form_factor_methods() {
  if (methods_hook) methods_hook();
  return table();
}

void register_form_factor_method(FormFactorMethodInfo info) {
  if (info.name.empty()) throw InputError("a form-factor method to register has no name");
  for (const FormFactorMethodInfo& existing : table())
    if (existing.name == info.name)
      throw InputError("a form-factor method named '" + info.name + "' is registered already");
  if (!info.configure)
    throw InputError("form-factor method '" + info.name + "' has no configure function");
  std::string problems;
  try {
    problems = complete_parameters(info);
  } catch (const Error& e) {
    throw InputError("form-factor method '" + info.name +
                     "' cannot be configured with its defaults: " + e.what());
  }
  if (!problems.empty()) throw InputError("form-factor method '" + info.name + "': " + problems);
  table().push_back(std::move(info));
}

const FormFactorMethodInfo& form_factor_method_info(const std::string& name) {
  for (const FormFactorMethodInfo& info : form_factor_methods())
    if (info.name == name) return info;
  std::vector<std::string> names;
  for (const FormFactorMethodInfo& info : form_factor_methods()) names.push_back(info.name);
  throw UsageError("unknown form-factor method '" + name +
                   "'; methods: " + text::join(names, ", "));
}

std::unique_ptr<FormFactorMethod> make_form_factor_method(const std::string& name, ParamBag& bag,
                                                          const Scene& scene, const Mesh& mesh) {
  const FormFactorMethodBuilder build = form_factor_method_info(name).configure(bag);
  bag.finish();
  return build(scene, mesh);
}

}  // namespace radlab
