# SPDX-License-Identifier: Apache-2.0
# sp_forbid_symbols(<target> <regex>)
# After <target> (a static library) is built, list the symbols its objects
# reference but do not define; if any matches <regex>, the build fails.
# Used to keep heap allocation and (on the soft-float Cortex-M4 build) any
# floating-point arithmetic out of the firmware.
function(sp_forbid_symbols target regex)
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND ${CMAKE_COMMAND}
      -DNM=${CMAKE_NM}
      -DFILE=$<TARGET_FILE:${target}>
      "-DREGEX=${regex}"
      -P ${PROJECT_SOURCE_DIR}/cmake/check_symbols.cmake
    COMMENT "Checking ${target} for forbidden symbols"
    VERBATIM)
endfunction()

# sp_forbid_code(<target> <regex> <what>)
# After <target> (an executable) is linked, list the symbols it defines; if
# any matches <regex>, the build fails. Used to keep code that a library
# would pull in (heap, soft-float helpers) out of a firmware image.
function(sp_forbid_code target regex what)
  add_custom_command(TARGET ${target} POST_BUILD
    COMMAND ${CMAKE_COMMAND}
      -DNM=${CMAKE_NM}
      -DFILE=$<TARGET_FILE:${target}>
      "-DREGEX=${regex}"
      -DDEFINED_SYMBOLS=1
      -P ${PROJECT_SOURCE_DIR}/cmake/check_symbols.cmake
    COMMENT "Checking ${target} for ${what}"
    VERBATIM)
endfunction()

# sp_find_programs(<missing-var> <var> <program> [<var> <program>...])
# find_program for each pair, without REQUIRED: tools that only some tests
# need (the Cortex-M4 cross compiler, QEMU). <missing-var> receives
# "<program>, <program> not found" for those absent, or "" when all are
# there. A cached path that does not exist counts as absent, so
# -D<var>=<none> hides a tool that is installed.
function(sp_find_programs missing_var)
  set(args ${ARGN})
  set(missing "")
  while(args)
    list(POP_FRONT args var program)
    find_program(${var} ${program})
    if(NOT EXISTS "${${var}}")
      list(APPEND missing ${program})
    endif()
  endwhile()
  if(missing)
    list(JOIN missing ", " missing)
    set(missing "${missing} not found")
  endif()
  set(${missing_var} "${missing}" PARENT_SCOPE)
endfunction()

# sp_add_skipped_test(<name> <reason>)
# Stands in for a test that cannot run on this machine: it prints
# "SKIPPED: <reason>" and ctest reports it as skipped (never as passed);
# the configure step warns once per test.
function(sp_add_skipped_test name reason)
  message(WARNING "${name} is skipped: ${reason}")
  add_test(NAME ${name} COMMAND sh -c "echo \"SKIPPED: $1\"; exit 77" sp_skip "${reason}")
  set_tests_properties(${name} PROPERTIES SKIP_RETURN_CODE 77)
endfunction()
