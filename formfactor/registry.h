// The table of form-factor methods (DESIGN §3), as solvers/registry.h is of solvers: the built-in
// methods, listed explicitly in registry.cpp (no self-registration inside a static library, which
// the linker would drop), followed by those a plugin added with register_form_factor_method()
// (solvers/plugin.h). `radlab solvers`, `--ff NAME`, experiment files and the method conformance
// tests (tests/formfactor/method_conformance_test.cpp) all read this table.
//
// Each fact about a method is written once. Its FormFactorMethodInfo holds the name, a summary and
// its parameters' names and help; the defaults are not typed here: the registry calls
// configure() on an empty bag, which reads the options struct with the fallback of every key
// (core/param_bag.h records them), so the value `radlab solvers` prints is the one the code
// uses. A key listed but never read, or read but not listed, is refused. Everything else code
// outside a method asks of it (its stated error, side files, rows at a point, symmetric builds)
// is a virtual function of FormFactorMethod (form_factor_method.h).
#pragma once

#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/param_bag.h"
#include "formfactor/form_factor_method.h"

namespace radlab {

// The method used when none is named (`--ff`, ProblemSpec, experiment files): one place, so that
// the CLI, the library and a sweep cannot disagree.
inline constexpr const char* kDefaultFormFactorMethod = "raycast";

// Builds a configured method on a scene and its mesh (both must outlive it).
using FormFactorMethodBuilder =
    std::function<std::unique_ptr<FormFactorMethod>(const Scene& scene, const Mesh& mesh)>;

struct FormFactorMethodInfo {
  std::string name;
  std::string summary;  // one line
  std::vector<ParameterInfo> parameters;
  // Reads the method's options from the bag (validating them; no scene needed) and returns what
  // builds it. Called on an empty bag, it lists the parameters and their defaults.
  std::function<FormFactorMethodBuilder(ParamBag&)> configure;
  // Whether its rows can be taken at any point of a surface (FormFactorMethod::row_at_point):
  // two levels' patch rows "centre", and what `rows = "auto"` resolves to.
  bool rows_at_points = false;
};

// configure() for a method whose options struct has `static Options from(ParamBag&)` and whose
// constructor is Method(const Scene&, const Mesh&, Options).
template <class Method, class Options>
std::function<FormFactorMethodBuilder(ParamBag&)> configure_from_options() {
  return [](ParamBag& bag) -> FormFactorMethodBuilder {
    const Options options = Options::from(bag);
    return [options](const Scene& scene, const Mesh& mesh) -> std::unique_ptr<FormFactorMethod> {
      return std::make_unique<Method>(scene, mesh, options);
    };
  };
}

// The built-in methods, then the registered ones, in registration order. Register before using
// the table: registering may move its entries.
// Called before the method table is first read: the plugin loader (solvers/plugin_loader.h, a
// layer above) sets it, so that plugins named on the command line load where methods are used,
// as they do where solvers are, and a command that uses neither loads none.
void set_form_factor_methods_hook(void (*before_use)());

const std::vector<FormFactorMethodInfo>& form_factor_methods();

// Adds a method (a plugin's, solvers/plugin.h). Refused with an InputError (exit 3) when the name
// is empty or taken, configure() is missing or fails with no parameters given, or the parameters
// listed differ from the keys its options read.
void register_form_factor_method(FormFactorMethodInfo info);

// UsageError listing the methods when `name` is none of them.
const FormFactorMethodInfo& form_factor_method_info(const std::string& name);

// Creates a method by name; unknown names, unknown keys and invalid values are UsageErrors that
// list what is valid; a scene the method cannot handle is an InputError.
std::unique_ptr<FormFactorMethod> make_form_factor_method(const std::string& name,
                                                          ParamBag& parameters, const Scene& scene,
                                                          const Mesh& mesh);

// The keys configure() reads from an empty bag, with the defaults of its options as text.
std::map<std::string, std::string> read_parameter_defaults(const FormFactorMethodInfo& info);

}  // namespace radlab
