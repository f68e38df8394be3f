# Install rules: headers, libraries, a CMake package and pleat.pc (docs/integrate.md, "Install and consume").
#   find_package(Pleat)                       → Pleat::pleat, the shared library: needs nothing else at build time
#   find_package(Pleat COMPONENTS static)     → also Pleat::pleat_static, which needs libepoxy's pkg-config file when
#                                               the GL path is built (a static library carries its dependencies)
# libepoxy is a private, run-time dependency of libpleat.so (its DT_NEEDED): a consumer of the shared library compiles
# against pleat.h alone (which includes no GL header) and links against libpleat.so alone, so neither the CMake
# package nor pleat.pc may ask for epoxy's development files (headers, epoxy.pc) on that path. The shared and static
# libraries are therefore exported as two sets, and only the static one's loading looks for epoxy.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/sdk/include/pleat DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS pleat EXPORT PleatTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS pleat_static EXPORT PleatStaticTargets
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT PleatTargets NAMESPACE Pleat:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)
install(EXPORT PleatStaticTargets NAMESPACE Pleat:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/PleatConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/PleatConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/PleatConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/PleatConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/PleatConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)

# pleat.pc: Libs.private lists what a static link (pkg-config --static) adds, epoxy included; there is deliberately no
# "Requires.private: epoxy": pkg-config resolves Requires.private even for a plain --cflags query, so it would fail
# for every shared-library consumer on a machine without epoxy.pc.
set(PLEAT_PC_LIBS_PRIVATE "")
set(_pleat_pc_libs ${PLEAT_LINK_LIBRARIES})
list(REMOVE_DUPLICATES _pleat_pc_libs)
foreach(lib ${_pleat_pc_libs})
  if(lib MATCHES "^/")
    get_filename_component(name ${lib} NAME_WE)
    string(REGEX REPLACE "^lib" "" name ${name})
    string(APPEND PLEAT_PC_LIBS_PRIVATE " -l${name}")
  elseif(NOT lib MATCHES "::")
    string(APPEND PLEAT_PC_LIBS_PRIVATE " -l${lib}")
  endif()
endforeach()
if(PLEAT_GL_ENABLED)
  string(APPEND PLEAT_PC_LIBS_PRIVATE " -lepoxy")
endif()
# The prefix relative to the .pc file, so an installed tree can be moved (pkg-config's ${pcfiledir}); ../.. for lib/,
# ../../.. for lib/x86_64-linux-gnu/.
if(IS_ABSOLUTE "${CMAKE_INSTALL_LIBDIR}")
  set(PLEAT_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
else()
  file(RELATIVE_PATH _pleat_pc_up "/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/")
  string(REGEX REPLACE "/$" "" _pleat_pc_up "${_pleat_pc_up}")
  set(PLEAT_PC_PREFIX "\${pcfiledir}/${_pleat_pc_up}")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/pleat.pc.in ${CMAKE_CURRENT_BINARY_DIR}/pleat.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/pleat.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
