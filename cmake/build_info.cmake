# SPDX-License-Identifier: BSD-3-Clause
# Writes hil's generated build_info.cpp (cmake -P, at every build): the version, the git
# description of the source tree and the compiler and flags, for `ehpt --version` and every
# summary.json. configure_file rewrites the file only when its text changes, so an unchanged
# build does not relink.
# In: SRC (source dir), IN (template), OUT, VERSION, COMPILER, FLAGS, BUILD_TYPE.

set(git "")
find_program(GIT git)
if(GIT)
  # only ehpt's own repository: a source tree unpacked inside another git work tree (a
  # packaging repository) must not be described by that repository's commits
  execute_process(COMMAND ${GIT} -C ${SRC} rev-parse --show-toplevel
                  OUTPUT_VARIABLE top RESULT_VARIABLE rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(rc EQUAL 0)
    file(REAL_PATH "${top}" top)
    file(REAL_PATH "${SRC}" src)
    if(top STREQUAL src)
      # --no-optional-locks: no index refresh written, so a build never holds the work tree's
      # index lock against the developer's own git commands
      execute_process(COMMAND ${GIT} --no-optional-locks -C ${SRC} describe --always --dirty --abbrev=12
                      OUTPUT_VARIABLE git RESULT_VARIABLE rc ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
      if(NOT rc EQUAL 0)
        set(git "")
      endif()
    endif()
  endif()
endif()

# into C++ string literals
foreach(v VERSION git COMPILER FLAGS BUILD_TYPE)
  string(REPLACE "\\" "\\\\" ${v} "${${v}}")
  string(REPLACE "\"" "\\\"" ${v} "${${v}}")
endforeach()
configure_file(${IN} ${OUT} @ONLY)
