# SPDX-License-Identifier: Apache-2.0
# The portable core on a Cortex-M4 under QEMU (board mps2-an386; docs/explanation/m4.md,
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
  # The port (firmware/ports/qemu_mps2: sp_mps2_add_executable), then the
  # programs that run on it.
  add_subdirectory(firmware/ports/qemu_mps2)
  add_subdirectory(bench/m4)
else()
  add_subdirectory(bench/m4)
  add_subdirectory(tests/m4)
endif()
