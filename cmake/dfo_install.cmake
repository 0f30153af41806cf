# `cmake --install build [--prefix DIR]`: the libraries with their public headers, the default
# model and the tools, and a package configuration so that another CMake project gets the
# modules' targets with
#
#   find_package(dfo 0.1 REQUIRED)
#   target_link_libraries(my_program PRIVATE dfo::backend dfo::learned)
#
# Layout under the prefix:
#   include/dfo/dfo_core/*.h, dfo_frontend/*.h, dfo_frontend/learned/*.h, dfo_backend/*.h,
#     dfo_io/*.h (dfo_io/lcm/*.h and the generated message types in include/dfo/lcm_types/ with
#     DFO_WITH_LCM); the internal/ folders are not installed
#   lib/libdfo_*.a, lib/cmake/dfo/ (dfoConfig.cmake, its version file, the exported targets)
#   share/dfo/models/default.dfo (found by dfo::DefaultModelPath())
#   bin/dfo_* (the tools, with DFO_BUILD_APPS)
# The targets are split in three export sets so that the package's consumers only need what they
# use: dfo::core, frontend, backend, io (Eigen, Ceres, OpenCV, yaml-cpp, FFmpeg's libraries),
# dfo::learned (LibTorch's libraries; loaded when Torch is found or asked for as a component) and
# dfo::io_lcm (liblcm; the same). tests/apps/example_test.cc builds apps/example against it.
include(CMakePackageConfigHelpers)

install(TARGETS dfo_core dfo_frontend dfo_backend dfo_io EXPORT dfoTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT dfoTargets NAMESPACE dfo:: DESTINATION ${DFO_INSTALL_CMAKEDIR})
install(TARGETS dfo_learned EXPORT dfoLearnedTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
install(EXPORT dfoLearnedTargets NAMESPACE dfo:: DESTINATION ${DFO_INSTALL_CMAKEDIR})

# Public headers: every module's *.h except the internal/ folders (and dfo_io/lcm/ without LCM).
set(DFO_HEADER_EXCLUDES PATTERN "internal" EXCLUDE)
if(NOT DFO_WITH_LCM)
  list(APPEND DFO_HEADER_EXCLUDES PATTERN "lcm" EXCLUDE)
endif()
install(DIRECTORY dfo_core dfo_frontend dfo_backend dfo_io DESTINATION ${DFO_INSTALL_INCLUDEDIR}
        FILES_MATCHING PATTERN "*.h" ${DFO_HEADER_EXCLUDES})

if(DFO_WITH_LCM)
  install(TARGETS dfo_io_lcm EXPORT dfoLcmTargets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(EXPORT dfoLcmTargets NAMESPACE dfo:: DESTINATION ${DFO_INSTALL_CMAKEDIR})
  install(DIRECTORY ${CMAKE_BINARY_DIR}/dfo_io/lcm/generated/
          DESTINATION ${DFO_INSTALL_INCLUDEDIR}/lcm_types FILES_MATCHING PATTERN "*.hpp")
endif()

install(FILES ${PROJECT_SOURCE_DIR}/models/default.dfo DESTINATION ${DFO_INSTALL_MODELDIR})

if(DFO_BUILD_APPS)
  set(DFO_INSTALLED_TOOLS "")
  foreach(tool dfo_run dfo_eval dfo_synth dfo_train dfo_bench dfo_bench_backend dfo_sweep
          dfo_lcm_listen)
    if(TARGET ${tool})
      list(APPEND DFO_INSTALLED_TOOLS ${tool})
    endif()
  endforeach()
  install(TARGETS ${DFO_INSTALLED_TOOLS} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
endif()

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/dfoConfig.cmake.in
                              ${CMAKE_BINARY_DIR}/dfoConfig.cmake
                              INSTALL_DESTINATION ${DFO_INSTALL_CMAKEDIR})
# 0.x: a minor version may change the interface.
write_basic_package_version_file(${CMAKE_BINARY_DIR}/dfoConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_BINARY_DIR}/dfoConfig.cmake ${CMAKE_BINARY_DIR}/dfoConfigVersion.cmake
        DESTINATION ${DFO_INSTALL_CMAKEDIR})
