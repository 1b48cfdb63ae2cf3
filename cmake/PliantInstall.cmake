# `cmake --install build --prefix P`: the engine (and raster/ when built) as a CMake package, so a
# host outside this tree can write find_package(pliant CONFIG REQUIRED) and link pliant::engine
# (or pliant::raster). Installed: the public headers (include/pliant/...), the static libraries
# (lib/), and lib/cmake/pliant/ with pliantConfig.cmake, its version file and the exported
# targets. Nothing of perf/, apps/ or tests/ is installed: they measure the engine, a host does
# not link them.
#
# Generic over the engine's libraries: engine/CMakeLists.txt lists them in
# PLIANT_ENGINE_LIBRARIES and the packages their link interface needs in PLIANT_ENGINE_PACKAGES;
# adding a library there is all it takes. Each library's headers are found from its build-tree
# include directories, exported names drop the `pliant_` prefix (pliant_core -> pliant::core).
# tests/package/ checks the result: it installs into a prefix under the build tree and builds and
# runs the embedding example against it.
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(PLIANT_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/pliant)

# Install TARGETS under export set EXPORT with their headers: every directory a target names in
# $<BUILD_INTERFACE:...> of its include directories is copied to include/ (once).
function(pliant_install_libraries export)
  foreach(target IN LISTS ARGN)
    if(NOT TARGET ${target})
      message(FATAL_ERROR "PliantInstall: ${target} (listed for the ${export} package) is not a target")
    endif()
    string(REGEX REPLACE "^pliant_" "" export_name ${target})
    set_target_properties(${target} PROPERTIES EXPORT_NAME ${export_name})
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(dirs)
      foreach(dir IN LISTS dirs)
        if(dir MATCHES "^\\$<BUILD_INTERFACE:(.*)>$")
          set(dir ${CMAKE_MATCH_1})
          get_property(done GLOBAL PROPERTY PLIANT_INSTALLED_INCLUDE_DIRS)
          if(NOT dir IN_LIST done)
            set_property(GLOBAL APPEND PROPERTY PLIANT_INSTALLED_INCLUDE_DIRS ${dir})
            install(DIRECTORY ${dir}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} FILES_MATCHING PATTERN "*.hpp")
          endif()
        elseif(IS_ABSOLUTE "${dir}")
          message(FATAL_ERROR "PliantInstall: ${target} exports the include directory ${dir}; "
                              "wrap it in $<BUILD_INTERFACE:...> so that no build path is installed")
        endif()
      endforeach()
    endif()
  endforeach()
  install(TARGETS ${ARGN} EXPORT ${export}
          ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
          LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
          INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  install(EXPORT ${export} NAMESPACE pliant:: DESTINATION ${PLIANT_INSTALL_CMAKEDIR}
          FILE pliant-${export}-targets.cmake)
endfunction()

# pliant_options (warnings, -ffp-contract=off, -march=native when PLIANT_NATIVE) is linked
# privately everywhere; a static library's private links are part of what it exports, so it is
# exported too (as pliant::options). Its compile options do not reach a host that links
# pliant::engine: they are link-only there.
pliant_install_libraries(engine pliant_options ${PLIANT_ENGINE_LIBRARIES})
if(TARGET pliant_raster)
  pliant_install_libraries(raster pliant_raster)
endif()

# find_dependency() lines for pliantConfig.cmake, one per entry of PLIANT_ENGINE_PACKAGES.
set(PLIANT_FIND_ENGINE_DEPENDENCIES "")
foreach(package IN LISTS PLIANT_ENGINE_PACKAGES)
  string(APPEND PLIANT_FIND_ENGINE_DEPENDENCIES "find_dependency(${package})\n")
endforeach()

configure_package_config_file(${CMAKE_CURRENT_LIST_DIR}/pliantConfig.cmake.in
  ${CMAKE_CURRENT_BINARY_DIR}/pliantConfig.cmake INSTALL_DESTINATION ${PLIANT_INSTALL_CMAKEDIR})
# 0.x: a minor version may change the interface.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/pliantConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/pliantConfig.cmake ${CMAKE_CURRENT_BINARY_DIR}/pliantConfigVersion.cmake
        DESTINATION ${PLIANT_INSTALL_CMAKEDIR})
