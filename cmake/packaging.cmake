# SPDX-License-Identifier: BSD-3-Clause
# Install and Debian packages (docs/packaging.md), included from the top-level CMakeLists.txt
# after the targets. Components: runtime, dev, python; each is its own Debian package:
#   ehpt          the CLI, the plot tool, the data, the bus contract, the man page, the examples
#   ehpt-dev      the headers, the static libraries and the CMake package (find_package(ehpt):
#                 ehpt::plant, ehpt::solvers, ehpt::io, ehpt::hil, and the ones they use)
#   python3-ehpt  the Python module (its install rule: python/CMakeLists.txt)
# Each carries /usr/share/doc/<package>/copyright (packaging/copyright, DEP-5) and
# changelog.Debian.gz (packaging/changelog).

# The static libraries and the CMake package go to Debian's multiarch folder, lib/<triplet>
# (lib/x86_64-linux-gnu), whatever the prefix: GNUInstallDirs gives lib/<triplet> only for the
# prefix /usr, and the packages are made from a build configured for /usr/local. Any other
# -DCMAKE_INSTALL_LIBDIR than GNUInstallDirs' "lib" is taken as given.
if(CMAKE_LIBRARY_ARCHITECTURE AND CMAKE_INSTALL_LIBDIR STREQUAL "lib")
  set(EHPT_LIB_INSTALL_DIR lib/${CMAKE_LIBRARY_ARCHITECTURE})
else()
  set(EHPT_LIB_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR})
endif()

install(TARGETS ehpt RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
# the library every FMU carries (ehpt fmu finds it at <bin>/../<libdir>/ehpt/fmu/). Two levels
# below lib/: cpack's DEB generator adds an ldconfig call (lintian: maintscript-calls-ldconfig)
# for a shared object in lib/ or one folder below it, and nothing links against this one.
install(TARGETS ehpt_fmu3 ehpt_fmu2 LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/ehpt/fmu COMPONENT runtime)
install(PROGRAMS tools/plot.py tools/plot_expect.py DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/ehpt COMPONENT runtime)
# The installed data: its place is known to the installed code (hil/config/scenario.cpp) and to
# the CMake package (ehpt_DATA_DIR), relative to the prefix.
set(EHPT_DATA_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/ehpt)
# scenarios name their vehicle and cycle relative to themselves (../vehicles, ../data): the
# four folders keep their places side by side
install(DIRECTORY scenarios vehicles data campaigns DESTINATION ${EHPT_DATA_INSTALL_DIR} COMPONENT runtime)
install(FILES io/can/ehpt.dbc io/can/ehpt-psd.binding.toml io/can/ehpt-ev.binding.toml io/can/ehpt-shev.binding.toml DESTINATION ${EHPT_DATA_INSTALL_DIR}/can COMPONENT runtime)
install(FILES ${EHPT_LCM_SOURCES} DESTINATION ${EHPT_DATA_INSTALL_DIR}/lcm COMPONENT runtime)

# The ECUs of one's own to start from, as documentation (not executable: one copies them):
# on CAN with python-can (and the DBC reader it imports), in process in Python, on LCM in C++,
# and a C++ harness against the installed CMake package.
set(EHPT_EXAMPLES_INSTALL_DIR ${CMAKE_INSTALL_DOCDIR}/examples)
install(FILES tools/pycan_ecu.py tools/ehpt_dbc.py python/examples/mbecu2_ecu.py python/examples/shev_ems.py
              examples/lcm_ecu.cpp
        DESTINATION ${EHPT_EXAMPLES_INSTALL_DIR} COMPONENT runtime)
install(FILES packaging/examples-README.md DESTINATION ${EHPT_EXAMPLES_INSTALL_DIR} RENAME README.md COMPONENT runtime)
install(FILES examples/embed/CMakeLists.txt examples/embed/main.cpp
        DESTINATION ${EHPT_EXAMPLES_INSTALL_DIR}/embed COMPONENT runtime)
# a VCU with its own DBC and its binding; its strategy is mbecu2_ecu.py, one folder up
install(FILES examples/own_dbc/vcu.dbc examples/own_dbc/vcu.binding.toml examples/own_dbc/vcu_ecu.py
        DESTINATION ${EHPT_EXAMPLES_INSTALL_DIR}/own_dbc COMPONENT runtime)

foreach(dir msgs plant solvers io hil ecu)
  install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ehpt/${dir} COMPONENT dev
          FILES_MATCHING PATTERN "*.hpp")
endforeach()
install(FILES ${EHPT_LCM_HEADERS} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/ehpt/ehpt_lcm COMPONENT dev)
set_target_properties(ehpt_msgs PROPERTIES EXPORT_NAME msgs)
set_target_properties(ehpt_plant PROPERTIES EXPORT_NAME plant)
set_target_properties(ehpt_ecu PROPERTIES EXPORT_NAME ecu)
set_target_properties(ehpt_solvers PROPERTIES EXPORT_NAME solvers)
set_target_properties(ehpt_lcm_types PROPERTIES EXPORT_NAME lcm_types)
set_target_properties(ehpt_io PROPERTIES EXPORT_NAME io)
set_target_properties(ehpt_hil PROPERTIES EXPORT_NAME hil)
install(TARGETS ehpt_msgs ehpt_plant ehpt_ecu ehpt_solvers ehpt_lcm_types ehpt_io ehpt_hil
        EXPORT ehptTargets
        ARCHIVE DESTINATION ${EHPT_LIB_INSTALL_DIR} COMPONENT dev)
set(EHPT_CMAKE_INSTALL_DIR ${EHPT_LIB_INSTALL_DIR}/cmake/ehpt)
install(EXPORT ehptTargets NAMESPACE ehpt:: DESTINATION ${EHPT_CMAKE_INSTALL_DIR} COMPONENT dev)
include(CMakePackageConfigHelpers)
configure_package_config_file(cmake/ehptConfig.cmake.in ${CMAKE_CURRENT_BINARY_DIR}/ehptConfig.cmake
  INSTALL_DESTINATION ${EHPT_CMAKE_INSTALL_DIR}
  PATH_VARS EHPT_DATA_INSTALL_DIR)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/ehptConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/ehptConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/ehptConfigVersion.cmake
        DESTINATION ${EHPT_CMAKE_INSTALL_DIR} COMPONENT dev)

# The Debian changelog: packaging/changelog, whose newest entry must be this version (else the
# package would say one version and its changelog another), compressed as Debian's tools do
# (gzip -9n: no name, no time stamp, so the same file every build).
# The packages' version is the project's with a Debian revision (0.1.0-1): packages made from
# upstream sources, not native ones (whose changelog would be changelog.gz).
set(EHPT_DEB_RELEASE 1)
set(EHPT_DEB_VERSION ${PROJECT_VERSION}-${EHPT_DEB_RELEASE})
file(STRINGS packaging/changelog ehpt_changelog_head LIMIT_COUNT 1)
if(NOT ehpt_changelog_head MATCHES "^ehpt \\(([^)]+)\\) ")
  message(FATAL_ERROR "packaging/changelog:1: '${ehpt_changelog_head}': expected 'ehpt (VERSION) unstable; urgency=...'")
elseif(NOT CMAKE_MATCH_1 STREQUAL EHPT_DEB_VERSION)
  message(FATAL_ERROR "packaging/changelog:1: version ${CMAKE_MATCH_1}, the project's is ${EHPT_DEB_VERSION}: "
                      "add an entry for ${EHPT_DEB_VERSION} on top")
endif()
find_program(EHPT_GZIP gzip REQUIRED)
set(EHPT_PACKAGING_BINARY_DIR ${CMAKE_CURRENT_BINARY_DIR}/packaging)
add_custom_command(OUTPUT ${EHPT_PACKAGING_BINARY_DIR}/changelog.Debian.gz
  COMMAND ${CMAKE_COMMAND} -E make_directory ${EHPT_PACKAGING_BINARY_DIR}
  COMMAND ${EHPT_GZIP} -9n -c ${CMAKE_CURRENT_SOURCE_DIR}/packaging/changelog > ${EHPT_PACKAGING_BINARY_DIR}/changelog.Debian.gz
  DEPENDS packaging/changelog
  COMMENT "changelog.Debian.gz")
set(ehpt_packaging_outputs ${EHPT_PACKAGING_BINARY_DIR}/changelog.Debian.gz)

# The man page ehpt(1): help2man runs the built `ehpt --help` (the build fails if it fails) and
# writes the page's frame (name, version, date); the text is packaging/ehpt.h2m's: help2man's
# own reading of the help ran the commands' list into one paragraph, so the include replaces
# the description and adds the commands, exit status, files, environment and examples. The
# install test checks that the page names exactly the commands `ehpt --help` lists. The version
# is the project's, not --version's first line, which names the git commit (the page would
# change with every commit).
find_program(EHPT_HELP2MAN help2man)
if(EHPT_HELP2MAN)
  add_custom_command(OUTPUT ${EHPT_PACKAGING_BINARY_DIR}/ehpt.1.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${EHPT_PACKAGING_BINARY_DIR}
    COMMAND ${EHPT_HELP2MAN} --no-info --section=1 --version-string=${PROJECT_VERSION}
            --include=${CMAKE_CURRENT_SOURCE_DIR}/packaging/ehpt.h2m
            --output=${EHPT_PACKAGING_BINARY_DIR}/ehpt.1 $<TARGET_FILE:ehpt>
    COMMAND ${EHPT_GZIP} -9n -f ${EHPT_PACKAGING_BINARY_DIR}/ehpt.1
    DEPENDS ehpt packaging/ehpt.h2m
    COMMENT "man page ehpt(1) (help2man)")
  list(APPEND ehpt_packaging_outputs ${EHPT_PACKAGING_BINARY_DIR}/ehpt.1.gz)
  install(FILES ${EHPT_PACKAGING_BINARY_DIR}/ehpt.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT runtime)
else()
  message(WARNING "help2man not found: no man page ehpt(1) (Debian: apt install help2man; tools/setup.sh does)")
endif()
add_custom_target(ehpt_packaging_docs ALL DEPENDS ${ehpt_packaging_outputs})

# copyright and changelog in each package's documentation folder (Debian policy 12.5, 12.7)
set(ehpt_doc_packages runtime:ehpt dev:ehpt-dev)
if(EHPT_BUILD_PYTHON)
  list(APPEND ehpt_doc_packages python:python3-ehpt)
endif()
foreach(pair ${ehpt_doc_packages})
  string(REPLACE ":" ";" pair ${pair})
  list(GET pair 0 component)
  list(GET pair 1 package)
  install(FILES packaging/copyright ${EHPT_PACKAGING_BINARY_DIR}/changelog.Debian.gz
          DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${package} COMPONENT ${component})
endforeach()

# Debian packages (cpack -G DEB in the build folder): ehpt_0.1.0-1_amd64.deb, ehpt-dev_... and
# python3-ehpt_... . Run-time library dependencies come from dpkg-shlibdeps (Debian's dpkg-dev).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ehpt)
set(CPACK_PACKAGE_VENDOR "ehpt")
set(CPACK_PACKAGE_CONTACT "ehpt maintainers <maintainers@ehpt.invalid>")
# Each package's description: its synopsis line, then the extended description (empty lines
# become Debian's " ." paragraph breaks). No CPACK_PACKAGE_DESCRIPTION_SUMMARY: CPackDeb would
# put that one line on top of every package's own.
set(CPACK_PACKAGING_INSTALL_PREFIX ${EHPT_PACKAGE_PREFIX})  # CMakeLists.txt: scenario.cpp knows it too
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev)
if(EHPT_BUILD_PYTHON)
  list(APPEND CPACK_COMPONENTS_ALL python)
endif()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # <package>_<version>-<revision>_<architecture>.deb
set(CPACK_DEBIAN_PACKAGE_RELEASE ${EHPT_DEB_RELEASE})
set(CPACK_DEBIAN_PACKAGE_SOURCE ehpt)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# stripped executables and shared objects in the packages (the build tree keeps its symbols;
# static libraries are never stripped by CMake: they need their symbol tables)
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME ehpt)
# the plot tool runs on Debian's python3 with matplotlib and numpy
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "python3, python3-matplotlib, python3-numpy")
# what the documented uses need besides: cyclictest (real-time latency), candump and cansend,
# python-can (the example CAN ECU), lcm-logger and lcm-spy (LCM)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SUGGESTS "rt-tests, can-utils, python3-can, python3-canmatrix, liblcm-bin")
set(CPACK_DEBIAN_RUNTIME_DESCRIPTION "plant models of electric and hybrid power trains for SIL/HIL
ehpt simulates the power train of an electric or hybrid vehicle on a drive
cycle: battery, electric machines, power-split device, engine, body and
driver, the physics of the EHPowerTrain Modelica library written again in
C++ with fixed-step solvers. It runs as fast as possible, in real time, as
the plant of a hardware- or software-in-the-loop test on a CAN bus or LCM
(with the ECU in another process or machine), or as a timing benchmark.
Every run writes its time series and a summary with the provenance of its
inputs; runs are deterministic to the bit.

This package holds the ehpt command, the plot tool, the shipped scenarios,
vehicles, drive cycles and maps, the bus contract (DBC, LCM types), the
manual page and example ECUs in /usr/share/doc/ehpt/examples.")
set(CPACK_DEBIAN_DEV_PACKAGE_NAME ehpt-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
    "ehpt (= ${EHPT_DEB_VERSION}), libeigen3-dev (>= 3.4), libtomlplusplus-dev, liblcm-dev, libglib2.0-dev, pkg-config")
# (libglib2.0-dev: lcm.pc requires glib-2.0 and gthread-2.0, which liblcm-dev does not pull in)
set(CPACK_DEBIAN_DEV_DESCRIPTION "C++ headers, static libraries and CMake package of ehpt
ehpt simulates the power train of an electric or hybrid vehicle on a drive
cycle (the physics of the EHPowerTrain Modelica library in C++), for
software- and hardware-in-the-loop tests.

This package is for building one's own test harness or plant around the
simulation: the headers, the position-independent static libraries and the
CMake package, find_package(ehpt) with the targets ehpt::plant,
ehpt::solvers, ehpt::io and ehpt::hil, and ehpt_DATA_DIR, the installed
scenarios.")
set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-ehpt)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "ehpt (= ${EHPT_DEB_VERSION}), python3 (>= 3.11), python3 (<< 3.12), python3-numpy")
set(CPACK_DEBIAN_PYTHON_PACKAGE_SUGGESTS "python3-pandas")  # Result.to_dataframe() (docs/python.md)
set(CPACK_DEBIAN_PYTHON_DESCRIPTION "Python 3 module of ehpt, the power-train plant models
ehpt simulates the power train of an electric or hybrid vehicle on a drive
cycle (the physics of the EHPowerTrain Modelica library in C++), for
software- and hardware-in-the-loop tests.

This package holds the Python module: import ehpt, run a scenario with
overrides and get its time series as numpy arrays, or step the plant with
an ECU written in Python, in process and in lockstep.")
include(CPack)
