# SPDX-License-Identifier: BSD-3-Clause
# Install (README "Install"): the CLI, the plot tool, the data, the bus contract, and for C++
# users the headers, the static libraries and a CMake package (find_package(ehpt):
# ehpt::plant, ehpt::solvers, ehpt::io, ehpt::hil). Components: runtime, dev (and python,
# python/CMakeLists.txt); each is its own Debian package (below).
install(TARGETS ehpt RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
install(PROGRAMS tools/plot.py DESTINATION ${CMAKE_INSTALL_LIBEXECDIR}/ehpt COMPONENT runtime)
set(EHPT_DATA_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/ehpt)
# scenarios name their vehicle and cycle relative to themselves (../vehicles, ../data): the
# four folders keep their places side by side
install(DIRECTORY scenarios vehicles data campaigns DESTINATION ${EHPT_DATA_INSTALL_DIR} COMPONENT runtime)
install(FILES io/can/ehpt.dbc DESTINATION ${EHPT_DATA_INSTALL_DIR}/can COMPONENT runtime)
install(FILES ${EHPT_LCM_SOURCES} DESTINATION ${EHPT_DATA_INSTALL_DIR}/lcm COMPONENT runtime)

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
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
set(EHPT_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/ehpt)
install(EXPORT ehptTargets NAMESPACE ehpt:: DESTINATION ${EHPT_CMAKE_INSTALL_DIR} COMPONENT dev)
include(CMakePackageConfigHelpers)
configure_package_config_file(cmake/ehptConfig.cmake.in ${CMAKE_CURRENT_BINARY_DIR}/ehptConfig.cmake
  INSTALL_DESTINATION ${EHPT_CMAKE_INSTALL_DIR}
  PATH_VARS EHPT_DATA_INSTALL_DIR)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/ehptConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/ehptConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/ehptConfigVersion.cmake
        DESTINATION ${EHPT_CMAKE_INSTALL_DIR} COMPONENT dev)

# Debian packages (cpack -G DEB in the build folder): ehpt_<version>_amd64.deb (the CLI and
# its data), ehpt-dev (headers, libraries, CMake package) and python3-ehpt (the module).
# Run-time library dependencies come from dpkg-shlibdeps (Debian's dpkg-dev).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME ehpt)
set(CPACK_PACKAGE_VENDOR "ehpt")
set(CPACK_PACKAGE_CONTACT "ehpt maintainers <maintainers@ehpt.invalid>")
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "plant models of electric and hybrid power trains for SIL/HIL")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime dev)
if(EHPT_BUILD_PYTHON)
  list(APPEND CPACK_COMPONENTS_ALL python)
endif()
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME ehpt)
# the plot tool runs on Debian's python3 with matplotlib and numpy
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "python3, python3-matplotlib, python3-numpy")
set(CPACK_DEBIAN_DEV_PACKAGE_NAME ehpt-dev)
set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
    "ehpt (= ${PROJECT_VERSION}), libeigen3-dev (>= 3.4), libtomlplusplus-dev, liblcm-dev, libglib2.0-dev, pkg-config")
# (libglib2.0-dev: lcm.pc requires glib-2.0 and gthread-2.0, which liblcm-dev does not pull in)
set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-ehpt)
set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
set(CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS "ehpt (= ${PROJECT_VERSION}), python3 (>= 3.11), python3 (<< 3.12), python3-numpy")
include(CPack)
