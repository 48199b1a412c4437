// A plugin that claims another plugin ABI: radlab must refuse it before calling it
// (tests/solvers/plugin_loader_test.cpp).
#include "solvers/plugin.h"

extern "C" __attribute__((visibility("default"))) const radlab::PluginAbi* radlab_plugin_abi() {
  static radlab::PluginAbi abi = radlab::this_build_plugin_abi();
  abi.abi = RADLAB_PLUGIN_ABI + 1000;
  return &abi;
}

extern "C" __attribute__((visibility("default"))) void radlab_plugin_register() {
  radlab::register_solver({});  // never reached: the loader refuses the ABI first
}
