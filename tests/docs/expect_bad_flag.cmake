# Runs PROGRAM with a bad --peis-* flag and checks it exits 2 naming the flag,
# without starting a PEIS. Run with -DPROGRAM=<path>.
execute_process(COMMAND ${PROGRAM} --peis-id 0 RESULT_VARIABLE status ERROR_VARIABLE err
                OUTPUT_VARIABLE out TIMEOUT 20)
if(NOT status EQUAL 2)
  message(FATAL_ERROR "expected exit status 2, got '${status}' (stderr: ${err})")
endif()
if(NOT err MATCHES "--peis-id: '0' is not an id")
  message(FATAL_ERROR "stderr does not name the bad flag: ${err}")
endif()
message(STATUS "bad flag rejected: ${err}")
