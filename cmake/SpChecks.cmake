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
