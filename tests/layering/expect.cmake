# Builds TARGET in BUILD. With EXPECT empty the build must succeed; otherwise it must fail with
# output matching the regular expression EXPECT (the layering's refusal, not another error).
execute_process(COMMAND ${CMAKE_COMMAND} --build ${BUILD} --target ${TARGET}
                OUTPUT_VARIABLE out ERROR_VARIABLE out RESULT_VARIABLE rc)
if(EXPECT STREQUAL "")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${TARGET} should compile:\n${out}")
  endif()
  message(STATUS "${TARGET} compiles")
  return()
endif()
if(rc EQUAL 0)
  message(FATAL_ERROR "${TARGET} compiled, but it breaks the layering")
endif()
if(NOT out MATCHES "${EXPECT}")
  message(FATAL_ERROR "${TARGET} failed, but not with \"${EXPECT}\":\n${out}")
endif()
string(REGEX MATCH "[^\n]*error[^\n]*" first "${out}")
message(STATUS "${TARGET} refused: ${first}")
