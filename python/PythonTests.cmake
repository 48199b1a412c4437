# The Python module's tests (included by tests/CMakeLists.txt when RADLAB_PYTHON is on), label
# `python`: each pytest file of python/tests/ and each notebook of examples/notebooks/ (executed
# with nbconvert) is one ctest, against the build tree's package (PYTHONPATH=build/python), the
# command line and the suite's cache; and the package installed by `cmake --install` imports.
set(python_test_environment
    "PYTHONPATH=${PROJECT_BINARY_DIR}/python"
    "RADLAB_BINARY=$<TARGET_FILE:radlab>"
    "RADLAB_CACHE_DIR=${RADLAB_TEST_CACHE_DIR}"
    "${RADLAB_TEST_ENVIRONMENT}"
    # No __pycache__ or .pytest_cache in the source tree.
    "PYTHONDONTWRITEBYTECODE=1")
# A plugin for radlab.load_plugin (python/tests/test_plugins.py), where the test plugins are built.
if(TARGET radlab_test_plugin_contract_breaker)
  list(APPEND python_test_environment
       "CONTRACT_BREAKER_PLUGIN=$<TARGET_FILE:radlab_test_plugin_contract_breaker>")
endif()

file(GLOB python_test_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/python/tests/test_*.py)
foreach(file ${python_test_files})
  get_filename_component(stem ${file} NAME_WE)
  add_test(NAME python.${stem}
           COMMAND ${Python_EXECUTABLE} -m pytest -q -p no:cacheprovider ${file}
           WORKING_DIRECTORY ${PROJECT_BINARY_DIR})
  set_tests_properties(python.${stem} PROPERTIES ENVIRONMENT "${python_test_environment}"
                                                 LABELS python)
endforeach()

file(GLOB notebooks CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/examples/notebooks/*.ipynb)
foreach(notebook ${notebooks})
  get_filename_component(stem ${notebook} NAME_WE)
  # The executed copy goes to the build tree; the committed notebook is left as it is.
  add_test(NAME python.notebook.${stem}
           COMMAND ${Python_EXECUTABLE} -m nbconvert --to notebook --execute
                   --ExecutePreprocessor.timeout=300
                   --output-dir ${PROJECT_BINARY_DIR}/notebooks ${notebook})
  set_tests_properties(python.notebook.${stem}
                       PROPERTIES ENVIRONMENT "${python_test_environment};MPLBACKEND=Agg"
                                  LABELS python)
endforeach()

# `cmake --install --component python` into a prefix of the build tree, then import from there
# (not from the build tree: PYTHONPATH names the prefix only).
set(python_prefix ${PROJECT_BINARY_DIR}/python_install_test/prefix)
add_test(NAME python.installed_package
         COMMAND ${CMAKE_COMMAND} -DBUILD_DIR=${PROJECT_BINARY_DIR} -DPREFIX=${python_prefix}
                 -DPYTHON=${Python_EXECUTABLE} -DINSTALL_DIR=${RADLAB_PYTHON_INSTALL_DIR}
                 -P ${PROJECT_SOURCE_DIR}/python/InstalledPackageTest.cmake)
set_tests_properties(python.installed_package PROPERTIES LABELS python ENVIRONMENT
                     "RADLAB_CACHE_DIR=${RADLAB_TEST_CACHE_DIR}")
