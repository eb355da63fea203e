# Runs at install time (`cmake --install`, CPack), when the prefix is known:
#   - the configuration and the robot model to <prefix>/etc/hyq, or to /etc/hyq for the prefix
#     /usr (GNUInstallDirs' rule; tools/cli/install_paths.h finds them by the same rule);
#   - the systemd unit, naming the installed executables and configuration, to
#     <prefix>/lib/systemd/system (/usr/lib/systemd/system in the Debian package).
# HYQ_SOURCE_DIR, HYQ_BINARY_DIR and HYQ_DOC_DIR_REL are set by the install(CODE) before it.
if(CMAKE_INSTALL_PREFIX STREQUAL "/usr")
  set(HYQ_CONFIG_DIR /etc/hyq)
else()
  set(HYQ_CONFIG_DIR ${CMAKE_INSTALL_PREFIX}/etc/hyq)
endif()
set(HYQ_BIN_DIR ${CMAKE_INSTALL_PREFIX}/bin)
set(HYQ_DOC_DIR ${CMAKE_INSTALL_PREFIX}/${HYQ_DOC_DIR_REL})

file(INSTALL
  ${HYQ_SOURCE_DIR}/config/hyq_servo.yaml
  ${HYQ_SOURCE_DIR}/config/hyq_servo_sim.yaml
  ${HYQ_SOURCE_DIR}/config/hyq_hal.yaml
  ${HYQ_SOURCE_DIR}/config/robots
  DESTINATION ${HYQ_CONFIG_DIR}
  FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)

set(unit ${HYQ_BINARY_DIR}/install/hyq-servod.service)
configure_file(${HYQ_SOURCE_DIR}/config/systemd/hyq-servod.service.in ${unit} @ONLY)
file(INSTALL ${unit} DESTINATION ${CMAKE_INSTALL_PREFIX}/lib/systemd/system
  FILE_PERMISSIONS OWNER_READ OWNER_WRITE GROUP_READ WORLD_READ)
