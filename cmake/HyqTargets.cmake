# Helpers that give every project target the same warnings, sanitizers and install rules.

set(HYQ_WARNINGS
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough
  -Wmissing-declarations)

# Apply warnings, sanitizers and project-wide definitions to TARGET.
function(hyq_target_defaults target)
  target_compile_options(${target} PRIVATE ${HYQ_WARNINGS})
  target_compile_features(${target} PUBLIC cxx_std_20)
  # Debian's hardening (dpkg-buildflags): checked libc calls where sizes are known, and the
  # relocations resolved and made read-only at start-up, which also keeps the dynamic linker's
  # lazy binding out of the servo's first cycles
  target_compile_definitions(${target} PRIVATE $<$<NOT:$<CONFIG:Debug>>:_FORTIFY_SOURCE=2>)
  target_link_options(${target} PRIVATE LINKER:-z,relro,-z,now)
  if(HYQ_NAN_INIT)
    target_compile_definitions(${target} PUBLIC HYQ_NAN_INIT=1 EIGEN_INITIALIZE_MATRICES_BY_NAN)
  endif()
  if(HYQ_EIGEN_NO_MALLOC)
    target_compile_definitions(${target} PUBLIC EIGEN_RUNTIME_NO_MALLOC=1)
  endif()
  if(HYQ_SANITIZE)
    target_compile_options(${target} PRIVATE -fsanitize=${HYQ_SANITIZE} -fno-omit-frame-pointer
                                             -fno-sanitize-recover=all)
    target_link_options(${target} PUBLIC -fsanitize=${HYQ_SANITIZE})
    target_compile_definitions(${target} PUBLIC HYQ_SANITIZED=1)
  endif()
endfunction()

# hyq_add_library(NAME SOURCES ... [PUBLIC_DEPS ...] [PRIVATE_DEPS ...] [HEADER_DIR DIR])
# Creates hyq_NAME with alias hyq::NAME. Headers are included as "DIR/header.h" (DIR defaults to
# NAME; e.g. servo/control for hyq::servo_control) from the source root when building and from
# include/hyq when installed.
function(hyq_add_library name)
  cmake_parse_arguments(ARG "" "HEADER_DIR" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  if(NOT ARG_HEADER_DIR)
    set(ARG_HEADER_DIR ${name})
  endif()
  add_library(hyq_${name} ${ARG_SOURCES})
  add_library(hyq::${name} ALIAS hyq_${name})
  set_target_properties(hyq_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME hyq_${name})
  target_include_directories(hyq_${name} PUBLIC
    $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}>
    $<BUILD_INTERFACE:${PROJECT_BINARY_DIR}/generated>
    $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/hyq>)
  target_link_libraries(hyq_${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  hyq_target_defaults(hyq_${name})
  install(TARGETS hyq_${name} EXPORT hyqTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
  file(GLOB headers ${CMAKE_CURRENT_SOURCE_DIR}/*.h)
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/hyq/${ARG_HEADER_DIR} COMPONENT dev)
endfunction()

# hyq_add_executable(NAME SUMMARY "what it is" SOURCES ... [DEPS ...]) for tools/: installed to bin/
# with a manual page made from its --help (help2man), both in the runtime component (the Debian
# package); SUMMARY is the page's NAME line.
function(hyq_add_executable name)
  cmake_parse_arguments(ARG "" "SUMMARY" "SOURCES;DEPS" ${ARGN})
  if(NOT ARG_SUMMARY)
    message(FATAL_ERROR "hyq_add_executable(${name}): expected SUMMARY \"what it is\", found none")
  endif()
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  hyq_target_defaults(${name})
  install(TARGETS ${name} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
  hyq_add_manual_page(${name} "${ARG_SUMMARY}" $<TARGET_FILE:${name}> ${name})
endfunction()

# hyq_add_manual_page(NAME SUMMARY PROGRAM DEPENDS): man1/NAME.1.gz from `PROGRAM --help`, made at build time
# when help2man is installed (scripts/bootstrap.sh installs it), installed with the program. The
# pages describe the Debian package: the configuration in /etc/hyq.
find_program(HYQ_HELP2MAN help2man)
function(hyq_add_manual_page name summary program depends)
  if(NOT HYQ_HELP2MAN)
    return()
  endif()
  set(page ${PROJECT_BINARY_DIR}/man/${name}.1)
  add_custom_command(OUTPUT ${page}.gz
    COMMAND ${CMAKE_COMMAND} -E make_directory ${PROJECT_BINARY_DIR}/man
    COMMAND ${CMAKE_COMMAND} -E env HYQ_HELP_CONFIG_DIR=/etc/hyq
            ${HYQ_HELP2MAN} --no-info --no-discard-stderr --version-string=${PROJECT_VERSION}
            --name=${summary} --section=1 --output=${page} ${program}
    COMMAND gzip -9nf ${page}
    DEPENDS ${depends}
    COMMENT "help2man: ${name}.1"
    VERBATIM)
  add_custom_target(${name}-man ALL DEPENDS ${page}.gz)
  install(FILES ${page}.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT runtime)
endfunction()

# Exported CMake package (find_package(hyq) gives hyq::dynamics, ...) and a pkg-config file.
function(hyq_install_package)
  include(CMakePackageConfigHelpers)
  install(EXPORT hyqTargets NAMESPACE hyq:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hyq COMPONENT dev)
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/hyqConfig.cmake.in
    ${PROJECT_BINARY_DIR}/hyqConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hyq)
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/hyqConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/hyqConfig.cmake ${PROJECT_BINARY_DIR}/hyqConfigVersion.cmake
    DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/hyq COMPONENT dev)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/hyq.pc.in ${PROJECT_BINARY_DIR}/hyq.pc @ONLY)
  install(FILES ${PROJECT_BINARY_DIR}/hyq.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)
endfunction()
