# The portable core on a Cortex-M4 under QEMU (board mps2-an386; docs/m4.md,
# and its Instruction counts section). Included once from the top-level CMakeLists.txt.
#   cross build (m4-core preset): the port (firmware/ports/qemu_mps2) and the
#     bench/m4 programs as .elf images: golden vectors, instruction counts
#     (fixed point, and the single-precision float reference);
#   host builds: the host build of the same golden-vector program and, in
#     tests/m4, the bit-exactness test (which builds its own Cortex-M4 image
#     of the golden program, see tests/m4/CMakeLists.txt) and the test of the
#     float reference.
option(SP_M4_QEMU "Build the Cortex-M4 (QEMU mps2-an386) golden vectors, instruction counts and their tests" ON)
if(NOT SP_M4_QEMU)
  return()
endif()

if(CMAKE_CROSSCOMPILING)
  if(NOT CMAKE_SYSTEM_PROCESSOR STREQUAL "arm")
    return()
  endif()
  set(SP_MPS2_DIR ${PROJECT_SOURCE_DIR}/firmware/ports/qemu_mps2)

  # sp_mps2_add_executable(<name> [HARD_FLOAT] SOURCES <src...> [LIBS <lib...>])
  # A bare-metal program for mps2-an386: <name>.elf with the port's startup
  # and semihosting, its map file <name>.map, no C start files, no heap.
  # HARD_FLOAT compiles every source of the program (the port included) for
  # the FPU with the hard-float ABI; it cannot link the soft-float core.
  function(sp_mps2_add_executable name)
    cmake_parse_arguments(ARG "HARD_FLOAT" "" "SOURCES;LIBS" ${ARGN})
    add_executable(${name} ${ARG_SOURCES} ${SP_MPS2_DIR}/startup.c ${SP_MPS2_DIR}/mps2.c)
    set_target_properties(${name} PROPERTIES SUFFIX ".elf")
    target_include_directories(${name} PRIVATE ${SP_MPS2_DIR})
    target_compile_options(${name} PRIVATE ${SP_WARNINGS})
    if(ARG_HARD_FLOAT)
      target_compile_options(${name} PRIVATE -mfloat-abi=hard -mfpu=fpv4-sp-d16)
      target_link_options(${name} PRIVATE -mfloat-abi=hard -mfpu=fpv4-sp-d16)
    endif()
    target_link_options(${name} PRIVATE
      -nostartfiles --specs=nano.specs
      -T${SP_MPS2_DIR}/mps2_an386.ld
      -Wl,--gc-sections
      -Wl,-Map=$<TARGET_FILE_DIR:${name}>/${name}.map)
    set_property(TARGET ${name} APPEND PROPERTY LINK_DEPENDS ${SP_MPS2_DIR}/mps2_an386.ld)
    if(ARG_LIBS)
      target_link_libraries(${name} PRIVATE ${ARG_LIBS})
    endif()
    # No heap may be linked in (the port provides no _sbrk: a reference to an
    # allocator would not even link, this names the culprit if one appears).
    add_custom_command(TARGET ${name} POST_BUILD
      COMMAND ${CMAKE_COMMAND} -DNM=${CMAKE_NM} -DFILE=$<TARGET_FILE:${name}>
        "-DREGEX=malloc|_malloc_r|calloc|realloc|free|_free_r|_sbrk|_sbrk_r"
        -DDEFINED_SYMBOLS=1 -P ${PROJECT_SOURCE_DIR}/cmake/check_symbols.cmake
      COMMENT "Checking ${name} for heap code"
      VERBATIM)
  endfunction()

  add_subdirectory(bench/m4)
else()
  add_subdirectory(bench/m4)
  add_subdirectory(tests/m4)
endif()
