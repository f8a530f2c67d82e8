# Script mode: fails if an undefined symbol of FILE matches REGEX in full.
execute_process(COMMAND ${NM} -u ${FILE}
  OUTPUT_VARIABLE undefined RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} -u ${FILE} failed (${rc})")
endif()
string(REPLACE "\n" ";" lines "${undefined}")
set(hits "")
foreach(line IN LISTS lines)
  if(line MATCHES "^ *U (${REGEX})$")
    list(APPEND hits "${CMAKE_MATCH_1}")
  endif()
endforeach()
if(hits)
  list(REMOVE_DUPLICATES hits)
  string(REPLACE ";" " " hits "${hits}")
  message(FATAL_ERROR
    "${FILE} references forbidden symbols (heap or floating point): ${hits}")
endif()
