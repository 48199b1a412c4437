# The out-of-tree path end to end (ctest plugin.installed_package): install radlab into a
# temporary prefix inside the build folder, build examples/southwell_plugin (a solver) and
# examples/nusselt_plugin (a form-factor method) against the installed package, each with its own
# CMakeLists.txt, and run them through the installed radlab (`solvers`, `solve`, `formfactors`)
# and through the conformance tests (solvers; form-factor methods).
#   -DBUILD_DIR -DSOURCE_DIR -DCXX_COMPILER -DCONFORMANCE_TEST=<solvers_tests binary>
#   -DMETHOD_CONFORMANCE_TEST=<formfactor_tests binary>
set(work ${BUILD_DIR}/plugin_package_test)
set(prefix ${work}/prefix)
file(REMOVE_RECURSE ${work})

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "failed (${code}): ${ARGN}\n${out}\n${err}")
  endif()
  set(output "${out}${err}" PARENT_SCOPE)
endfunction()

run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
foreach(file include/radlab/solvers/plugin.h include/radlab/solvers/solver.h
             include/radlab/formfactor/registry.h include/radlab/formfactor/form_factor_method.h
             include/radlab/core/version.h lib/cmake/radlab/radlabConfig.cmake bin/radlab)
  if(NOT EXISTS ${prefix}/${file})
    message(FATAL_ERROR "the install has no ${file}")
  endif()
endforeach()
# Installed headers include each other by their path under include/radlab/, as in the tree.
file(READ ${prefix}/include/radlab/solvers/solver.h text)
if(NOT text MATCHES "#include \"core/radiosity.h\"")
  message(FATAL_ERROR "installed solver.h does not include core/radiosity.h")
endif()

run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/southwell_plugin -B ${work}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${work}/build)
set(plugin ${work}/build/libsouthwell_plugin.so)

# Named twice (--plugin and RADLAB_PLUGIN_PATH): loaded once, or its name would be a duplicate.
run(${CMAKE_COMMAND} -E env RADLAB_PLUGIN_PATH=${plugin} ${prefix}/bin/radlab --plugin ${plugin} solvers)
if(NOT output MATCHES "southwell +plugin example" OR NOT output MATCHES "omega +default 1 ")
  message(FATAL_ERROR "radlab solvers does not list the plugin's solver:\n${output}")
endif()
run(${CMAKE_COMMAND} -E env RADLAB_CACHE_DIR=${work}/cache
    ${prefix}/bin/radlab -q --plugin ${plugin} solve builtin:cube:rho=0.5 --subdiv 2
    --solver southwell --tol 1e-6)
if(NOT output MATCHES "run +southwell/")
  message(FATAL_ERROR "radlab solve with the plugin's solver:\n${output}")
endif()
# The conformance tests, with the plugin's solver among the registered ones.
run(${CMAKE_COMMAND} -E env RADLAB_PLUGIN_PATH=${plugin} RADLAB_CACHE_DIR=${work}/cache
    ${CONFORMANCE_TEST} --gtest_filter=*southwell*)
if(NOT output MATCHES "EverySolver.ReachesTheReference/southwell" OR NOT output MATCHES "PASSED")
  message(FATAL_ERROR "the conformance tests did not run the plugin's solver:\n${output}")
endif()
message(STATUS "${output}")

# The form-factor method plugin: one file (nusselt.cpp) and its registration line.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/examples/nusselt_plugin -B ${work}/nusselt
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${work}/nusselt)
set(method ${work}/nusselt/libnusselt_plugin.so)
# One RADLAB_PLUGIN_PATH for both: a solver plugin and a method plugin side by side.
run(${CMAKE_COMMAND} -E env RADLAB_PLUGIN_PATH=${plugin}:${method} ${prefix}/bin/radlab solvers)
if(NOT output MATCHES "nusselt-mc +plugin example" OR NOT output MATCHES "strata +default 32 "
   OR NOT output MATCHES "southwell +plugin example")
  message(FATAL_ERROR "radlab solvers does not list the plugins' method and solver:\n${output}")
endif()
# Its matrix on the closed cube: rows sum to 1 (every ray meets an inward face).
run(${CMAKE_COMMAND} -E env RADLAB_CACHE_DIR=${work}/cache
    ${prefix}/bin/radlab --plugin ${method} formfactors builtin:cube --subdiv 2 --ff nusselt-mc)
if(NOT output MATCHES "nusselt-mc")
  message(FATAL_ERROR "radlab formfactors with the plugin's method:\n${output}")
endif()
# The plugin's solver on the plugin's form factors; then two levels with the method's row at each
# patch's centre (rows_at_points).
run(${CMAKE_COMMAND} -E env RADLAB_CACHE_DIR=${work}/cache
    ${prefix}/bin/radlab -q --plugin ${method} --plugin ${plugin} solve builtin:cube:rho=0.5
    --subdiv 2 --ff nusselt-mc --solver southwell --tol 1e-6)
if(NOT output MATCHES "run +southwell/")
  message(FATAL_ERROR "radlab solve with the plugins' method and solver:\n${output}")
endif()
run(${CMAKE_COMMAND} -E env RADLAB_CACHE_DIR=${work}/cache
    ${prefix}/bin/radlab -q --plugin ${method} solve builtin:cube:rho=0.5 --subdiv 2
    --ff nusselt-mc --patches polygons --patch-rows centre --solver sorted-shooting --rows 100)
if(NOT output MATCHES "run +sorted-shooting/")
  message(FATAL_ERROR "radlab solve, two levels on the plugin's method:\n${output}")
endif()
# The method conformance tests, with the plugin's method among the registered ones.
run(${CMAKE_COMMAND} -E env RADLAB_PLUGIN_PATH=${method} RADLAB_CACHE_DIR=${work}/cache
    ${METHOD_CONFORMANCE_TEST} --gtest_filter=*nusselt*)
if(NOT output MATCHES "EveryMethod.RowsOfAClosedSceneSumToOneWithinTheStatedError/nusselt_mc"
   OR NOT output MATCHES "PASSED")
  message(FATAL_ERROR "the method conformance tests did not run the plugin's method:\n${output}")
endif()
message(STATUS "${output}")
