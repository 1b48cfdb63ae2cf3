# The force passes' small matrix helpers (tet_local.hpp: hooke, mul_tn, corner_gradient,
# quat_to_matrix ...) must be inlined into the vector passes of the kernels library: when GCC 12
# runs out of inlining budget in a translation unit it leaves them out of line, and every pass
# slows by 13-17 % (docs/performance.md, "Rayleigh damping as one Hooke law": a third damping
# variant instantiated beside the others did it). A build property, not a speed: it fails when the
# library defines any of them for a vector type, naming them. Release GCC builds only (tests/CMakeLists.txt).
#   cmake -DNM=<nm> -DLIB=<libpliant_kernels.a> -P check_helpers_inlined.cmake
execute_process(COMMAND ${NM} -C --defined-only ${LIB} OUTPUT_VARIABLE symbols RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR symbols STREQUAL "")
  message(FATAL_ERROR "could not list the symbols of ${LIB} with ${NM} (exit ${rc})")
endif()
string(REGEX MATCHALL "[^\n]*pliant::detail::[A-Za-z_0-9]+<[a-z]+ __vector\\([0-9]+\\)>\\([^\n]*" out_of_line "${symbols}")
list(LENGTH out_of_line count)
# The library must be the one with the passes (a renamed helper would make this pass vacuously).
string(FIND "${symbols}" "pliant::detail::range_pass<" passes)
if(passes EQUAL -1)
  message(FATAL_ERROR "${LIB} has no pliant::detail::range_pass: not the kernels library, or the passes were renamed")
endif()
if(count GREATER 0)
  list(JOIN out_of_line "\n" listed)
  message(FATAL_ERROR "${count} vector helper(s) left out of line in ${LIB}:\n${listed}\n"
                      "Split the translation unit that instantiates them (kernels/src/element_batches.hpp).")
endif()
message(STATUS "no vector helper out of line in ${LIB}")
