# SPDX-License-Identifier: Apache-2.0
# Script mode. Compiles SRC the way the firmware core is compiled (the
# forced-include rules header, the project's warnings) and checks the
# outcome: EXPECT=ok must compile, EXPECT=fail must be rejected.
# With NM set, the object's undefined symbols are checked as the firmware
# build checks them (REGEX), and a match counts as a rejection.
separate_arguments(flags UNIX_COMMAND "${FLAGS}")
execute_process(
  COMMAND ${CC} ${flags} -include ${RULES} -c ${SRC} -o ${OBJ}
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
set(rejected FALSE)
if(NOT rc EQUAL 0)
  set(rejected TRUE)
elseif(NM)
  execute_process(COMMAND ${CMAKE_COMMAND} -DNM=${NM} -DFILE=${OBJ} "-DREGEX=${REGEX}"
    -P ${CHECK} RESULT_VARIABLE rc2 OUTPUT_VARIABLE out2 ERROR_VARIABLE err2)
  if(NOT rc2 EQUAL 0)
    set(rejected TRUE)
    set(err "${err2}")
  endif()
endif()
if(EXPECT STREQUAL "ok" AND rejected)
  message(FATAL_ERROR "${SRC} should compile under the core rules but did not:\n${err}")
elseif(EXPECT STREQUAL "fail" AND NOT rejected)
  message(FATAL_ERROR "${SRC} should be rejected by the core rules but was accepted")
endif()
message(STATUS "${SRC}: ${EXPECT} as expected\n${err}")
