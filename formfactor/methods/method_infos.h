// The built-in form-factor methods' registry entries, one per method file; formfactor/registry.cpp
// lists them. A new method adds its file and one line here and one in registry.cpp (a plugin's
// method: its file and its RADLAB_PLUGIN line; docs/library.md).
#pragma once

#include "formfactor/registry.h"

namespace radlab {

FormFactorMethodInfo raycast_method_info();   // raycast.cpp
FormFactorMethodInfo hemicube_method_info();  // hemicube.cpp
FormFactorMethodInfo exact_method_info();     // exact.cpp

}  // namespace radlab
