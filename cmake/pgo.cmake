# SPDX-License-Identifier: BSD-3-Clause
# EHPT_PGO: profile-guided optimisation with GCC (docs/packaging.md "Profile-guided
# optimisation"). `generate` builds an instrumented ehpt that writes .gcda profiles into
# EHPT_PGO_DIR when it exits; `use` builds with the profiles found there. tools/pgo_build.sh
# does the three steps (generate build, training run, use build). Included before the first
# target, so that every object and link gets the flags, and before the build's provenance is
# collected, so that `ehpt --version` and summary.json say the build is a PGO one.
set(EHPT_PGO OFF CACHE STRING "Profile-guided optimisation (GCC): OFF, generate, use")
set_property(CACHE EHPT_PGO PROPERTY STRINGS OFF generate use)
set(EHPT_PGO_DIR "" CACHE PATH "The .gcda profiles: where EHPT_PGO=generate writes them (default <build>/pgo-profile), where EHPT_PGO=use reads them (required)")
string(TOLOWER "${EHPT_PGO}" ehpt_pgo)
if(ehpt_pgo STREQUAL "off")
  return()
elseif(NOT ehpt_pgo MATCHES "^(generate|use)$")
  message(FATAL_ERROR "EHPT_PGO='${EHPT_PGO}': allowed values are OFF (the default), generate, use")
endif()
# -fprofile-partial-training is GCC's (10 and newer). clang's profiles are another format
# (.profraw, merged by llvm-profdata): not wired.
if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "GNU" OR CMAKE_CXX_COMPILER_VERSION VERSION_LESS 10)
  message(FATAL_ERROR "EHPT_PGO=${EHPT_PGO} needs GCC 10 or newer; this build's compiler is "
                      "${CMAKE_CXX_COMPILER_ID} ${CMAKE_CXX_COMPILER_VERSION} (configure without EHPT_PGO, or with g++)")
endif()
if(ehpt_pgo STREQUAL "generate" AND EHPT_PGO_DIR STREQUAL "")
  set(EHPT_PGO_DIR ${CMAKE_BINARY_DIR}/pgo-profile CACHE PATH "" FORCE)
endif()
get_filename_component(ehpt_pgo_dir "${EHPT_PGO_DIR}" ABSOLUTE BASE_DIR "${CMAKE_BINARY_DIR}")
if(ehpt_pgo STREQUAL "generate")
  # atomic counters: the real-time loop's writer thread and the sweep's workers run
  # instrumented code beside the main thread (plain increments would lose counts)
  add_compile_options(-fprofile-generate=${ehpt_pgo_dir} -fprofile-update=atomic)
  add_link_options(-fprofile-generate=${ehpt_pgo_dir})  # links libgcov, which writes the files
else()
  if(EHPT_PGO_DIR STREQUAL "")
    message(FATAL_ERROR "EHPT_PGO=use needs EHPT_PGO_DIR, the folder of the training's .gcda profiles "
                        "(tools/pgo_build.sh makes them)")
  endif()
  file(GLOB_RECURSE ehpt_pgo_profiles "${ehpt_pgo_dir}/*.gcda")
  if(NOT IS_DIRECTORY "${ehpt_pgo_dir}")
    message(FATAL_ERROR "EHPT_PGO=use: EHPT_PGO_DIR=${ehpt_pgo_dir} does not exist "
                        "(the folder of the training's .gcda profiles; tools/pgo_build.sh makes them)")
  elseif(NOT ehpt_pgo_profiles)
    message(FATAL_ERROR "EHPT_PGO=use: EHPT_PGO_DIR=${ehpt_pgo_dir} holds no .gcda profile "
                        "(run an EHPT_PGO=generate build's ehpt first; tools/pgo_build.sh does)")
  endif()
  # A profile is found by its object's path, in which GCC writes each '/' as '#', and it
  # matches only if the source's path is the same: the generated sources (build_info.cpp, the
  # LCM types) are in the build folder, so a use build must be in the generate build's folder.
  string(REPLACE "/" "#" ehpt_pgo_mangled "${CMAKE_BINARY_DIR}/CMakeFiles/ehpt.dir/")
  file(GLOB ehpt_pgo_own "${ehpt_pgo_dir}/${ehpt_pgo_mangled}*.gcda")
  if(NOT ehpt_pgo_own)
    message(FATAL_ERROR "EHPT_PGO=use: EHPT_PGO_DIR=${ehpt_pgo_dir} holds no profile of this build folder's "
                        "ehpt (${ehpt_pgo_mangled}*.gcda): configure EHPT_PGO=use in the folder of the "
                        "EHPT_PGO=generate build that made them")
  endif()
  # -fprofile-partial-training: code the training never ran (other kinds, the bus, the FMUs)
  # keeps the plain -O2 optimisation instead of being optimised for size as never executed.
  # -Wno-missing-profile: a file with no profile (never linked into the trained ehpt: the
  # FMU-only objects, the tests) is expected. -Wcoverage-mismatch stays an error: a profile
  # of other sources stops the build instead of optimising for the wrong code.
  add_compile_options(-fprofile-use=${ehpt_pgo_dir} -fprofile-partial-training -Wno-missing-profile)
endif()
