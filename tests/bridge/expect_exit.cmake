# Runs a program and checks its exit status and that stderr matches a
# regular expression: -DSTATUS=<n> -DPATTERN=<regex> -DCOMMAND=<a;b;c>.
execute_process(COMMAND ${COMMAND} RESULT_VARIABLE status ERROR_VARIABLE err OUTPUT_VARIABLE out
                TIMEOUT 20)
if(NOT status EQUAL STATUS)
  message(FATAL_ERROR "expected exit status ${STATUS}, got '${status}' (stderr: ${err})")
endif()
if(NOT err MATCHES "${PATTERN}")
  message(FATAL_ERROR "stderr does not match '${PATTERN}': ${err}")
endif()
message(STATUS "as expected: ${err}")
