# Writes OUTPUT, the definition of clothbench::harness::git_revision(): the revision of the
# source tree SOURCE_DIR when the binary is built - 12 hex digits of HEAD, "-dirty" appended when
# tracked files differ from HEAD, "unknown" outside a git checkout. The clothbench_git_revision
# target runs this script at every build; OUTPUT is rewritten only when its text changes, so a
# build of an unchanged tree recompiles nothing.
execute_process(COMMAND git -C "${SOURCE_DIR}" rev-parse --short=12 HEAD
  OUTPUT_VARIABLE revision OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE status)
if(NOT status EQUAL 0 OR revision STREQUAL "")
  set(revision "unknown")
else()
  execute_process(COMMAND git -C "${SOURCE_DIR}" diff --quiet HEAD --
    RESULT_VARIABLE differs OUTPUT_QUIET ERROR_QUIET)
  if(NOT differs EQUAL 0)
    string(APPEND revision "-dirty")
  endif()
endif()
set(text "// Generated at build time by harness/cmake/git_revision.cmake; do not edit.
#include \"harness/machine/git_revision.hpp\"

namespace clothbench::harness {

const char* git_revision() { return \"${revision}\"; }

}  // namespace clothbench::harness
")
set(old "")
if(EXISTS "${OUTPUT}")
  file(READ "${OUTPUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUTPUT}" "${text}")
endif()
