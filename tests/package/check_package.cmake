# ctest package: install pliant from BUILD into a fresh prefix under WORK, check that the installed
# CMake files name no path of the build or source tree, then configure, build and run the host
# project of tests/package/ against that prefix (find_package(pliant CONFIG REQUIRED)).
#   cmake -DBUILD=<build dir> -DSOURCE=<source dir> -DWORK=<scratch dir> -DGENERATOR=<gen>
#         -DCXX=<compiler> -P check_package.cmake
foreach(var BUILD SOURCE WORK GENERATOR CXX)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "check_package.cmake: -D${var}=... is required")
  endif()
endforeach()

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${what}: ok\n${out}")
endfunction()

file(REMOVE_RECURSE ${WORK})
set(prefix ${WORK}/prefix)
run("install" ${CMAKE_COMMAND} --install ${BUILD} --prefix ${prefix})

set(config ${prefix}/lib/cmake/pliant/pliantConfig.cmake)
foreach(needed ${config} ${prefix}/lib/cmake/pliant/pliantConfigVersion.cmake
        ${prefix}/include/pliant/world.hpp ${prefix}/include/pliant/kernels/range.hpp
        ${prefix}/lib/libpliant_core.a)
  if(NOT EXISTS ${needed})
    message(FATAL_ERROR "the install has no ${needed}")
  endif()
endforeach()
# The package must stand on its own: no path of the trees it was built from.
file(GLOB_RECURSE installed_cmake ${prefix}/*.cmake)
foreach(f ${installed_cmake})
  file(READ ${f} text)
  foreach(tree ${BUILD} ${SOURCE})
    string(FIND "${text}" "${tree}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "${f} names ${tree}")
    endif()
  endforeach()
endforeach()
# Nothing of the instruments: a host gets no study code.
file(GLOB_RECURSE instruments ${prefix}/lib/libpliant_study* ${prefix}/include/pliant/perf/*)
if(instruments)
  message(FATAL_ERROR "the install carries the instruments: ${instruments}")
endif()

# The host: found only through the prefix (no package registry, no build tree).
run("configure host" ${CMAKE_COMMAND} -S ${SOURCE}/tests/package -B ${WORK}/host -G ${GENERATOR}
    -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
run("build host" ${CMAKE_COMMAND} --build ${WORK}/host)
run("run embed_host" ${WORK}/host/embed_host)
if(EXISTS ${prefix}/lib/cmake/pliant/pliant-raster-targets.cmake)
  if(NOT EXISTS ${WORK}/host/raster_host)
    message(FATAL_ERROR "pliant::raster is installed but the host did not find it")
  endif()
  run("run raster_host" ${WORK}/host/raster_host ${WORK}/raster_host.png)
endif()
