# Deferred from sdk/src/backends/gl/CMakeLists.txt to the end of the top-level directory, when the library targets exist:
# the GL tests (cmocka, ctest), linked with pleat_static as the other tests are. The timing program is a benchmark:
# bench/gl_step_timing.c, built by bench/.
get_filename_component(_pleat_root "${PLEAT_GL_DIR}/../../../.." ABSOLUTE)

if(NOT PLEAT_BUILD_TESTS AND DEFINED PLEAT_BUILD_TESTS)
  return()
endif()
pkg_check_modules(PLEAT_GL_CMOCKA IMPORTED_TARGET cmocka)
if(NOT PLEAT_GL_CMOCKA_FOUND)
  message(STATUS "Pleat GL: cmocka not found; GL tests not built")
  return()
endif()
file(GLOB _pleat_gl_tests CONFIGURE_DEPENDS "${_pleat_root}/tests/c/test_gl_*.c")
list(FILTER _pleat_gl_tests EXCLUDE REGEX "test_gl_support\\.c$")
foreach(_test_source IN LISTS _pleat_gl_tests)
  get_filename_component(_test_name "${_test_source}" NAME_WE)
  add_executable(${_test_name} "${_test_source}" "${_pleat_root}/tests/c/test_gl_support.c")
  target_include_directories(${_test_name} PRIVATE ${PLEAT_INTERNAL_INCLUDE_DIRS} "${_pleat_root}/sdk/include"
                             "${_pleat_root}/tests/c")
  target_link_libraries(${_test_name} PRIVATE pleat_static ${PLEAT_GL_LIBRARIES} PkgConfig::PLEAT_GL_CMOCKA m)
  # These build their assets with the core's C test asset builder.
  if(_test_name MATCHES "^test_gl_(instance|headless_reports_platform|batch_matches_single|networks|scene_two_devices)$")
    if(NOT TARGET pleat_test_support)
      message(STATUS "Pleat GL: tests/c has no pleat_test_support (asset builder); ${_test_name} not built")
      set_target_properties(${_test_name} PROPERTIES EXCLUDE_FROM_ALL ON)
      continue()
    endif()
    target_link_libraries(${_test_name} PRIVATE pleat_test_support)
  endif()
  if(COMMAND pleat_set_warnings)
    pleat_set_warnings(${_test_name})
  endif()
  add_test(NAME ${_test_name} COMMAND ${_test_name})
  # llvmpipe threads: keep the GL tests from taking both cores from everything else ctest runs beside them.
  set_tests_properties(${_test_name} PROPERTIES ENVIRONMENT "LP_NUM_THREADS=2" LABELS gl TIMEOUT 300)
endforeach()
