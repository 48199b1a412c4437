#include "solvers/plugin_loader.h"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <system_error>

#include "core/error.h"
#include "core/log.h"
#include "core/paths.h"
#include "core/text.h"
#include "formfactor/registry.h"
#include "solvers/plugin.h"

namespace radlab {
namespace {

namespace fs = std::filesystem;

std::vector<std::string>& loaded() {
  static std::vector<std::string> files;
  return files;
}

std::vector<PluginProvenance>& provenance() {
  static std::vector<PluginProvenance> files;
  return files;
}

struct Requested {
  std::vector<std::string> files;
  bool pending = false;
};
Requested& requested() {
  static Requested r;
  return r;
}

std::string version_text(int major, int minor, int patch) {
  return std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
}

// Empty when `theirs` can be loaded by this radlab; otherwise what differs.
std::string abi_mismatch(const PluginAbi& theirs) {
  const PluginAbi ours = this_build_plugin_abi();
  if (theirs.abi != ours.abi)
    return "it was built for plugin ABI " + std::to_string(theirs.abi) + ", this radlab has ABI " +
           std::to_string(ours.abi);
  if (theirs.version_major != ours.version_major || theirs.version_minor != ours.version_minor ||
      theirs.version_patch != ours.version_patch)
    return "it was built against radlab " +
           version_text(theirs.version_major, theirs.version_minor, theirs.version_patch) +
           ", this is radlab " + kVersion;
  if (theirs.cxx11_string_abi != ours.cxx11_string_abi)
    return "it was built with _GLIBCXX_USE_CXX11_ABI=" + std::to_string(theirs.cxx11_string_abi) +
           ", radlab with " + std::to_string(ours.cxx11_string_abi);
  if (theirs.solver_info_size != ours.solver_info_size)
    return "its SolverInfo has " + std::to_string(theirs.solver_info_size) + " bytes, radlab's " +
           std::to_string(ours.solver_info_size) + " (headers of another radlab?)";
  if (theirs.method_info_size != ours.method_info_size)
    return "its FormFactorMethodInfo has " + std::to_string(theirs.method_info_size) +
           " bytes, radlab's " + std::to_string(ours.method_info_size) +
           " (headers of another radlab?)";
  return "";
}

}  // namespace

void load_plugin(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw UsageError("--plugin " + path + ": no such file");
  const std::string canonical = fs::canonical(path, ec).string();
  if (std::find(loaded().begin(), loaded().end(), canonical) != loaded().end()) return;

  // RTLD_NOW: a symbol the plugin needs and radlab lacks is reported here, not mid-run.
  void* handle = dlopen(canonical.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* why = dlerror();
    throw InputError("plugin " + path + ": cannot be loaded: " + (why ? why : "unknown reason"));
  }
  using AbiFunction = const PluginAbi* (*)();
  using RegisterFunction = void (*)();
  // POSIX guarantees that a data pointer from dlsym converts to a function pointer.
  auto abi = reinterpret_cast<AbiFunction>(dlsym(handle, "radlab_plugin_abi"));
  auto registration = reinterpret_cast<RegisterFunction>(dlsym(handle, "radlab_plugin_register"));
  if (!abi || !registration)
    throw InputError("plugin " + path +
                     ": not a radlab plugin (no radlab_plugin_abi or radlab_plugin_register; "
                     "see solvers/plugin.h)");
  const PluginAbi* theirs = abi();
  if (!theirs) throw InputError("plugin " + path + ": radlab_plugin_abi() returned nothing");
  const std::string mismatch = abi_mismatch(*theirs);
  if (!mismatch.empty())
    throw InputError("plugin " + path + ": " + mismatch + "; rebuild it against this radlab");
  // Hashed before its code runs, so what is recorded is what was loaded.
  const std::string digest = file_sha256(canonical);
  // What it registers: the entries its registration appends to the two tables.
  const size_t solvers_before = solver_registry().size();
  const size_t methods_before = form_factor_methods().size();
  try {
    registration();
  } catch (const Error& e) {
    throw InputError("plugin " + path + ": " + e.what());
  }
  PluginProvenance record{canonical, digest, {}, {}};
  for (size_t k = solvers_before; k < solver_registry().size(); ++k)
    record.solvers.push_back(solver_registry()[k].name);
  for (size_t k = methods_before; k < form_factor_methods().size(); ++k)
    record.methods.push_back(form_factor_methods()[k].name);
  loaded().push_back(canonical);
  provenance().push_back(std::move(record));
}

std::vector<std::string> load_plugins_from_environment() {
  std::vector<std::string> files;
  const char* value = std::getenv("RADLAB_PLUGIN_PATH");
  if (!value) return files;
  for (const std::string& entry : text::split(value, ':')) {
    if (entry.empty()) continue;
    if (!fs::path(entry).is_absolute())
      throw UsageError("RADLAB_PLUGIN_PATH: '" + entry +
                       "' is a relative path (it would depend on the folder radlab runs in); "
                       "give absolute paths");
    std::error_code ec;
    if (fs::is_directory(entry, ec)) {
      const fs::path folder = fs::canonical(entry, ec);
      std::vector<std::string> in_folder;
      for (const fs::directory_entry& file : fs::directory_iterator(folder, ec)) {
        if (file.path().extension() != ".so") continue;
        std::error_code link_ec;
        const fs::path target = fs::canonical(file.path(), link_ec);
        if (link_ec || !path_within(target, folder) || !fs::is_regular_file(target, link_ec)) {
          log::warning("RADLAB_PLUGIN_PATH: " + file.path().string() +
                       " skipped: not a regular file in " + folder.string() +
                       " (a link to another place, or to nothing); name it by its own path");
          continue;
        }
        in_folder.push_back(file.path().string());
      }
      std::sort(in_folder.begin(), in_folder.end());
      files.insert(files.end(), in_folder.begin(), in_folder.end());
    } else if (fs::exists(entry, ec)) {
      files.push_back(entry);
    } else {
      throw UsageError("RADLAB_PLUGIN_PATH: '" + entry + "' does not exist");
    }
  }
  for (const std::string& file : files) load_plugin(file);
  return files;
}

void request_plugins(const std::vector<std::string>& files) {
  requested().files = files;
  requested().pending = true;
  set_form_factor_methods_hook(&load_requested_plugins);  // methods load where they are used too
}

void load_requested_plugins() {
  // Recursive: a plugin's registration may read the solver table, which calls this again.
  static std::recursive_mutex mutex;
  const std::lock_guard lock(mutex);
  Requested& r = requested();
  if (!r.pending) return;
  r.pending = false;  // before loading: registering a plugin's solvers reads the table again
  load_plugins_from_environment();
  for (const std::string& file : r.files) load_plugin(file);
}

const std::vector<PluginProvenance>& loaded_plugin_provenance() {
  return provenance();
}

std::vector<PluginProvenance> plugins_providing(const std::string& solver,
                                                const std::string& method) {
  std::vector<PluginProvenance> used;
  for (const PluginProvenance& p : provenance()) {
    const bool runs_solver =
        std::find(p.solvers.begin(), p.solvers.end(), solver) != p.solvers.end();
    const bool runs_method =
        std::find(p.methods.begin(), p.methods.end(), method) != p.methods.end();
    if (runs_solver || runs_method) used.push_back(p);
  }
  return used;
}

const std::vector<std::string>& loaded_plugins() {
  return loaded();
}

}  // namespace radlab
