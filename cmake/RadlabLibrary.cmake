# radlab_library(<target> <sources...>): one of radlab's libraries, one per top-level folder.
#
# Every file includes the others by their path from the repository root ("core/error.h",
# "solvers/flat/interleaved.h"): the folder's headers form a CMake header file set whose base
# directory is the root, so that path works in the tree, and `cmake --install` puts the same
# path under <prefix>/include/radlab/, which the installed targets add to a plugin's include
# path. One spelling everywhere, and nothing copied that could go stale (docs/library.md).
function(radlab_library target)
  add_library(${target} ${ARGN})
  file(GLOB_RECURSE headers CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  target_sources(${target} PUBLIC FILE_SET HEADERS BASE_DIRS ${PROJECT_SOURCE_DIR}
                 FILES ${headers})
  radlab_target_defaults(${target})
endfunction()
