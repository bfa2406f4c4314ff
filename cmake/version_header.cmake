# Writes OUT, a header defining PENUMBRA_GIT_DESCRIBE as `git describe --always --dirty` of the
# checkout SRC ("unknown" without git). Run by the penumbra_version target at every build (not only at
# configure time), so the commit a binary reports is the one it was built from; the file is rewritten
# only when the text changes, so an unchanged commit recompiles nothing.
execute_process(COMMAND git describe --always --dirty
                WORKING_DIRECTORY "${SRC}"
                OUTPUT_VARIABLE describe
                OUTPUT_STRIP_TRAILING_WHITESPACE
                ERROR_QUIET
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR describe STREQUAL "")
  set(describe "unknown")
endif()
set(text "// Generated at build time by cmake/version_header.cmake: do not edit.\n#pragma once\n#define PENUMBRA_GIT_DESCRIBE \"${describe}\"\n")
set(old "")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUT}" "${text}")
endif()
