// Loading plugins (solvers/plugin.h: solvers, form-factor methods) into the running program with
// dlopen.
//
// Errors are radlab Errors naming the file: a path that does not exist is a UsageError (exit 2;
// the option is wrong), a file that is not a loadable library, lacks the plugin symbols, was
// built against another radlab or plugin ABI, or registers a solver or method that is refused
// (duplicate name, parameters that differ from its options) is an InputError (exit 3). A library
// is never unloaded (its solvers' and methods' code must outlive them); loading the same file
// twice does nothing.
//
// Plugins are requested when the command line is parsed and loaded on the first use of the solver
// or method table (solver_registry(), form_factor_method_registry()), so a command that runs no
// solver (`radlab scenes`) loads none and a bad .so cannot break it. RADLAB_PLUGIN_PATH entries
// must be absolute (a relative one would depend on the folder radlab was started in); a folder
// entry loads the regular *.so files in it, and a symbolic link only when it resolves inside that
// folder. Every loaded file is recorded with its canonical path and SHA-256, for the run's
// provenance.
#pragma once

#include <string>
#include <vector>

#include "core/sha256.h"  // file_sha256

namespace radlab {

// Loads one plugin file.
void load_plugin(const std::string& path);

// The plugins named by RADLAB_PLUGIN_PATH: a ':'-separated list of absolute paths of files and
// folders (a folder contributes its regular *.so files, and links to *.so files inside it, in
// name order; a link elsewhere is skipped with a warning). Empty entries are ignored; a relative
// entry is a UsageError. Returns the files loaded.
std::vector<std::string> load_plugins_from_environment();

// Records the plugins to load on the first use of the solver or method table: RADLAB_PLUGIN_PATH's,
// then `files` (--plugin). Nothing is opened yet.
void request_plugins(const std::vector<std::string>& files);

// Loads what request_plugins recorded, once (the solver table calls it; later calls do nothing,
// also after an error, which the first call threw).
void load_requested_plugins();

// The files loaded so far, in order (canonical paths).
const std::vector<std::string>& loaded_plugins();

// Where each loaded plugin came from: what a run's provenance (run.json) should record.
struct PluginProvenance {
  std::string path;    // canonical
  std::string sha256;  // of the file's bytes when it was loaded, lower-case hex
  std::vector<std::string> solvers, methods;  // the names its registration added
};
const std::vector<PluginProvenance>& loaded_plugin_provenance();

// The loaded plugins whose code a run of `solver` with form-factor method `method` executes:
// those that registered either (run.json's "plugins").
std::vector<PluginProvenance> plugins_providing(const std::string& solver,
                                                const std::string& method);

}  // namespace radlab
