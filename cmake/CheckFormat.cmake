# Fails when any C++ source under SOURCE_DIR differs from what CLANG_FORMAT makes of it.
# Run by the test `style.clang_format`; fix with: clang-format -i $(git ls-files '*.cpp' '*.h')
file(GLOB_RECURSE sources RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/*.cpp ${SOURCE_DIR}/*.h)
list(FILTER sources EXCLUDE REGEX "^(build|out|\\.)")
execute_process(COMMAND ${CLANG_FORMAT} --dry-run --Werror ${sources}
                WORKING_DIRECTORY ${SOURCE_DIR} RESULT_VARIABLE result ERROR_VARIABLE diff)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "clang-format differs (run clang-format -i on these):\n${diff}")
endif()
