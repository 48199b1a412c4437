# radlab_target_defaults(<target>): the compile settings every radlab target shares.
# Warnings are on and are errors in CI builds (RADLAB_WERROR), never in users' builds.
option(RADLAB_WERROR "Treat compiler warnings as errors" OFF)

function(radlab_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
    -Woverloaded-virtual -Wnull-dereference -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
    # GCC 12 reports impossible overlaps in inlined std::string concatenation (GCC PR 105329).
    $<$<CXX_COMPILER_ID:GNU>:-Wno-restrict>)
  if(RADLAB_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()
