# Whether the Python module (python/) is built: RADLAB_PYTHON, ON when pybind11 and a python3
# with numpy are found (python/CMakeLists.txt builds it).
#
# The interpreter is the first python3 that imports numpy: the first `python3` on some machines'
# PATH (a pyenv shim) lacks Debian's numpy, which the module's tests and notebooks need. Pass
# -DPython_EXECUTABLE=... to choose another.
if(NOT DEFINED Python_EXECUTABLE)
  find_program(radlab_python_on_path NAMES python3 NO_CACHE)
  foreach(candidate ${radlab_python_on_path} /usr/bin/python3)
    if(EXISTS "${candidate}")
      execute_process(COMMAND "${candidate}" -c "import numpy" RESULT_VARIABLE no_numpy
                      OUTPUT_QUIET ERROR_QUIET)
      if(no_numpy EQUAL 0)
        set(Python_EXECUTABLE "${candidate}" CACHE FILEPATH "python3 with numpy (python/)")
        break()
      endif()
    endif()
  endforeach()
endif()
find_package(Python 3 QUIET COMPONENTS Interpreter Development.Module)
if(Python_FOUND)
  find_package(pybind11 2.10 CONFIG QUIET)
endif()
set(radlab_python_default OFF)
# Not in sanitizer or fuzzing builds: an instrumented extension would need the sanitizer's
# runtime preloaded into python3.
if(Python_FOUND AND pybind11_FOUND AND NOT RADLAB_SANITIZE AND NOT RADLAB_FUZZ)
  set(radlab_python_default ON)
endif()
option(RADLAB_PYTHON "Build the Python module radlab (python/; needs pybind11-dev)"
       ${radlab_python_default})
if(RADLAB_PYTHON)
  if(NOT pybind11_FOUND)
    message(FATAL_ERROR "RADLAB_PYTHON needs pybind11 (apt-get install pybind11-dev python3-dev)")
  endif()
  message(STATUS "Python module: ${Python_EXECUTABLE} (pybind11 ${pybind11_VERSION})")
endif()
