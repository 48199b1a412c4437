// Loading plugins (solvers/plugin.h: solvers, form-factor methods) into the running program with
// dlopen.
//
// Errors are radlab Errors naming the file: a path that does not exist is a UsageError (exit 2;
// the option is wrong), a file that is not a loadable library, lacks the plugin symbols, was
// built against another radlab or plugin ABI, or registers a solver or method that is refused
// (duplicate name, parameters that differ from its options) is an InputError (exit 3). A library
// is never unloaded (its solvers' and methods' code must outlive them); loading the same file
// twice does nothing.
#pragma once

#include <string>
#include <vector>

namespace radlab {

// Loads one plugin file.
void load_plugin(const std::string& path);

// The plugins named by RADLAB_PLUGIN_PATH: a ':'-separated list of files and folders (a folder
// contributes its *.so files, in name order). Empty entries are ignored. Returns the files loaded.
std::vector<std::string> load_plugins_from_environment();

// The files loaded so far, in order.
const std::vector<std::string>& loaded_plugins();

}  // namespace radlab
