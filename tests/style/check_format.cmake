# SPDX-License-Identifier: Apache-2.0
# ctest style_clang_format: every C source and header of the project is
# formatted as .clang-format says (clang-format --dry-run -Werror). Run with
# -DCLANG_FORMAT=<program> -DROOT=<source dir>.
file(GLOB_RECURSE sources RELATIVE ${ROOT}
  ${ROOT}/firmware/*.c ${ROOT}/firmware/*.h
  ${ROOT}/host_sim/*.c ${ROOT}/host_sim/*.h
  ${ROOT}/tests/*.c ${ROOT}/tests/*.h
  ${ROOT}/bench/*.c ${ROOT}/bench/*.h)
list(LENGTH sources n)
if(n LESS 50)
  message(FATAL_ERROR "style: only ${n} C files found under ${ROOT}: wrong root?")
endif()
execute_process(COMMAND ${CLANG_FORMAT} --dry-run -Werror ${sources}
  WORKING_DIRECTORY ${ROOT} RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "style: files not formatted as .clang-format says "
    "(fix with: clang-format -i <file>):\n${err}")
endif()
message(STATUS "style: ${n} C files formatted")
