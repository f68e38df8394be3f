# Install rules: headers, libraries, a CMake package (find_package(Pleat) → Pleat::pleat) and pleat.pc.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/sdk/include/pleat DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(TARGETS pleat pleat_static EXPORT PleatTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
  ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
  RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR}
  INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(EXPORT PleatTargets NAMESPACE Pleat:: DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/PleatConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/PleatConfig.cmake INSTALL_DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/PleatConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/PleatConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/PleatConfigVersion.cmake
  DESTINATION ${CMAKE_INSTALL_LIBDIR}/cmake/Pleat)

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
list(REMOVE_DUPLICATES PLEAT_LINK_LIBRARIES)
set(PLEAT_PC_REQUIRES_PRIVATE "")
if(PLEAT_GL_ENABLED)
  set(PLEAT_PC_REQUIRES_PRIVATE " epoxy")
endif()
configure_file(${CMAKE_CURRENT_LIST_DIR}/pleat.pc.in ${CMAKE_CURRENT_BINARY_DIR}/pleat.pc @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/pleat.pc DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
