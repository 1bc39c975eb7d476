# The installed package as another project uses it (issue 18): `cmake --install` of this build
# into a fresh prefix, tests/consumer configured with find_package(dsmplan CONFIG REQUIRED)
# against it and built (with this build's compiler flags, so sanitizer builds link), then run
# on the DSM sample. Its counts are checked against the grid: an XY-3 mesh of a w x h grid
# without nodata has w*h vertices and 2(w-1)(h-1) triangles, never more than half a --zstep
# (0.05 m, and float32 rounding) above the DSM.
#   cmake -DBUILD=... -DSOURCE=... -DWORK=... -DFLAGS=... -DTYPE=... -DDSM=... -P run.cmake
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${ARGN}\n${out}\n${err}")
  endif()
  set(out "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK})
run(${CMAKE_COMMAND} --install ${BUILD} --prefix ${WORK}/prefix)
if(NOT EXISTS ${WORK}/prefix/lib/cmake/dsmplan/dsmplanConfigVersion.cmake
   OR NOT EXISTS ${WORK}/prefix/include/dsmplan/plan.hpp OR NOT EXISTS ${WORK}/prefix/bin/dsmplan)
  message(FATAL_ERROR "the install lacks the package files, the headers or the binary")
endif()
run(${CMAKE_COMMAND} -S ${SOURCE} -B ${WORK}/build -DCMAKE_PREFIX_PATH=${WORK}/prefix
    -DCMAKE_BUILD_TYPE=${TYPE} "-DCMAKE_CXX_FLAGS=${FLAGS}")
run(${CMAKE_COMMAND} --build ${WORK}/build)
run(${WORK}/build/consumer ${DSM})
string(STRIP "${out}" out)
separate_arguments(got UNIX_COMMAND "${out}")
list(GET got 0 w)
list(GET got 1 h)
list(GET got 2 vertices)
list(GET got 3 triangles)
list(GET got 4 above)
math(EXPR want_vertices "${w} * ${h}")
math(EXPR want_triangles "2 * (${w} - 1) * (${h} - 1)")
if(NOT w GREATER 0 OR NOT vertices EQUAL want_vertices OR NOT triangles EQUAL want_triangles OR above GREATER 0.051)
  message(FATAL_ERROR "the consumer printed '${out}': expected ${want_vertices} vertices, ${want_triangles} triangles, at most 0.05 m above")
endif()
message(STATUS "consumer: ${out}")
file(REMOVE_RECURSE ${WORK})
