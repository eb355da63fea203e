# The Debian package hyq-servo (docs/packaging.md), made by CPack's DEB generator from this build
# tree, so that the package holds the binaries the tests ran:
#   cmake --build --preset ci --target package    ->  build/ci/hyq-servo_<version>_<arch>.deb
# It holds the runtime component (the executables with their manual pages, the configuration as
# conffiles, the unit, the LCM jar and definitions, hyq-viewer's page, the documentation); the
# libraries, headers and CMake package (the dev component) stay with `cmake --install`.
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME hyq-servo)
set(CPACK_PACKAGE_VENDOR "HyQ servo team")
set(CPACK_PACKAGE_CONTACT "HyQ servo team <dev@hyq.invalid>")
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_DEBIAN_PACKAGE_RELEASE 1)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "HyQ hydraulic quadruped servo daemon and tools")
set(CPACK_PACKAGE_DESCRIPTION
  "hyq-servod reads the IIT HyQ robot's joint encoders, load cells and IMU over
CAN every millisecond, estimates the trunk's state, computes contact-aware
inverse dynamics (the two-stage QP of Zapolsky and Drumwright) and writes the
joint torques, with graded fault stops and LCM telemetry. The package also
holds hyq-sim (a MuJoCo model of HyQ behind virtual CAN), hyq-command,
hyq-teleop, hyq-viewer, hyq-spy and the other tools, the default configuration
in /etc/hyq and a systemd unit that is not enabled.")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
# the configuration's place (/etc/hyq for the prefix /usr) is chosen by the install script from
# the prefix, which it sees only when CPack installs with DESTDIR
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_COMPONENTS_ALL runtime)
set(CPACK_COMPONENTS_GROUPING ALL_COMPONENTS_IN_ONE)
set(CPACK_STRIP_FILES ON)
# the shared libraries' packages, found by dpkg-shlibdeps; adduser for the maintainer scripts
# (deb-systemd-invoke's init-system-helpers is essential), python3 for the plotting scripts
# (their matplotlib is recommended)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_DEPENDS "adduser, python3")
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS
  "liblcm-bin, liblcm-java, libjchart2d-java, default-jre | java-runtime, python3-matplotlib, python3-numpy, can-utils")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "linux-image-rt-amd64, rt-tests, xvfb")
set(hyq_deb ${PROJECT_SOURCE_DIR}/packaging/debian)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA
  ${hyq_deb}/postinst ${hyq_deb}/prerm ${hyq_deb}/postrm ${hyq_deb}/conffiles)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)
# Debian's place for a package's copyright and changelog (the changelog names this version)
install(FILES ${hyq_deb}/copyright DESTINATION ${HYQ_INSTALL_DOCDIR} COMPONENT runtime)
# the lintian tags this package keeps, each with its reason (docs/packaging.md)
install(FILES ${hyq_deb}/lintian-overrides DESTINATION ${CMAKE_INSTALL_DATADIR}/lintian/overrides
  RENAME hyq-servo COMPONENT runtime)
file(READ ${hyq_deb}/changelog changelog)
if(NOT changelog MATCHES "^hyq-servo \\(${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE}\\)")
  message(FATAL_ERROR "packaging/debian/changelog: expected its first entry to be hyq-servo "
                      "(${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE}), the package's version")
endif()
set(changelog_gz ${PROJECT_BINARY_DIR}/packaging/changelog.Debian.gz)
add_custom_command(OUTPUT ${changelog_gz}
  COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/packaging
  COMMAND sh -c "gzip -9nc '${hyq_deb}/changelog' > '${changelog_gz}'"
  DEPENDS ${hyq_deb}/changelog
  VERBATIM)
add_custom_target(hyq-deb-changelog ALL DEPENDS ${changelog_gz})
install(FILES ${changelog_gz} DESTINATION ${HYQ_INSTALL_DOCDIR} COMPONENT runtime)
include(CPack)
execute_process(COMMAND dpkg --print-architecture OUTPUT_VARIABLE arch OUTPUT_STRIP_TRAILING_WHITESPACE
  ERROR_QUIET)
set(HYQ_DEB_FILE
  ${PROJECT_BINARY_DIR}/hyq-servo_${PROJECT_VERSION}-${CPACK_DEBIAN_PACKAGE_RELEASE}_${arch}.deb)
