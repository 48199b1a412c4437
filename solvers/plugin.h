// Writing a solver or a form-factor method outside radlab's source tree: a plugin is a shared
// library that `radlab` loads at run time (`--plugin PATH`, or the files and folders listed in
// RADLAB_PLUGIN_PATH; solvers/plugin_loader.h). Once loaded, its solvers and methods are in the
// registries like the built-in ones: `radlab solvers` lists them, `solve --solver`, `--ff`,
// experiment files and the conformance tests (solvers and methods) use them.
//
// A plugin implements radlab::Solver (solvers/solver.h) and describes it with a SolverInfo
// (solvers/registry.h), or implements radlab::FormFactorMethod (formfactor/form_factor_method.h)
// and describes it with a FormFactorMethodInfo (formfactor/registry.h), or both, and exports its
// registration with one macro:
//
//   #include <solvers/plugin.h>
//   static void register_mine() {
//     radlab::register_solver(my_solver_info());
//     radlab::register_form_factor_method(my_method_info());
//   }
//   RADLAB_PLUGIN(register_mine)
//
// It is built against the headers of the radlab that will load it (CMake: find_package(radlab),
// target radlab::plugin; examples/southwell_plugin, examples/nusselt_plugin) and links none of
// radlab's libraries: the symbols it uses (register_solver, ParamBag, System, ...) are the radlab
// executable's own (radlab exports them), so there is one registry and one copy of every class. C++
// has no stable ABI, so the loader refuses a plugin built against another radlab version, another
// plugin ABI or another C++ library ABI, with a message saying which.
#pragma once

#include <cstddef>

#include "core/version.h"
#include "formfactor/registry.h"
#include "solvers/registry.h"

// Raised whenever the plugin interface (this file, SolverInfo, Solver, System,
// FormFactorMethodInfo, FormFactorMethod) changes incompatibly; checked with the radlab version
// on loading. 2: form-factor methods (issue 37). 3: FormFactorMethod's blocks of pairs (issue 33).
// 4: FormFactorMethod::pair_work, blocks of pairs of equal estimated work (issue 33).
#define RADLAB_PLUGIN_ABI 4

namespace radlab {

// What a plugin was built against. Plain integers, the ABI number first, so that any radlab can
// read at least that much of any plugin's.
struct PluginAbi {
  int abi;
  int version_major, version_minor, version_patch;
  int cxx11_string_abi;     // libstdc++'s _GLIBCXX_USE_CXX11_ABI (std::string's layout)
  size_t solver_info_size;  // sizeof(SolverInfo), a cheap guard against mixed headers
  size_t method_info_size;  // sizeof(FormFactorMethodInfo), the same guard (ABI 2 on)
};

// The values of the including translation unit: the plugin's when compiled in the plugin, the
// loader's when compiled in radlab.
inline PluginAbi this_build_plugin_abi() {
#ifdef _GLIBCXX_USE_CXX11_ABI
  constexpr int cxx11 = _GLIBCXX_USE_CXX11_ABI;
#else
  constexpr int cxx11 = -1;
#endif
  return {RADLAB_PLUGIN_ABI,
          RADLAB_VERSION_MAJOR,
          RADLAB_VERSION_MINOR,
          RADLAB_VERSION_PATCH,
          cxx11,
          sizeof(SolverInfo),
          sizeof(FormFactorMethodInfo)};
}

}  // namespace radlab

// The two C symbols the loader looks for. radlab_plugin_abi() is called first, and
// radlab_plugin_register() only when it matches; exceptions from register_solver() and
// register_form_factor_method() (a duplicate name, parameters that differ from the options
// struct) reach the loader, which names the file.
#define RADLAB_PLUGIN(register_function)                                                           \
  extern "C" __attribute__((visibility("default"))) const radlab::PluginAbi* radlab_plugin_abi() { \
    static const radlab::PluginAbi abi = radlab::this_build_plugin_abi();                          \
    return &abi;                                                                                   \
  }                                                                                                \
  extern "C" __attribute__((visibility("default"))) void radlab_plugin_register() {                \
    register_function();                                                                           \
  }
