# ctest python.installed_package: installs the Python component into PREFIX and imports radlab
# from there alone (a scene load and a short run), as a user of an installed radlab would.
file(REMOVE_RECURSE ${PREFIX})
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --component python --prefix
                        ${PREFIX} RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "cmake --install --component python failed")
endif()
set(package ${PREFIX}/${INSTALL_DIR})
execute_process(
  COMMAND ${CMAKE_COMMAND} -E env PYTHONPATH=${package} PYTHONDONTWRITEBYTECODE=1 ${PYTHON} -c
          "import radlab, os; assert radlab.__file__.startswith(os.environ['PYTHONPATH']), radlab.__file__; s = radlab.load('builtin:cube', subdiv=2); r = radlab.solve(s, solver='jacobi', steps=24); assert r.B.shape == (s.size, 3) and len(r.trace) > 0; print('imported', radlab.__file__)"
  RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "import radlab from ${package} failed")
endif()
