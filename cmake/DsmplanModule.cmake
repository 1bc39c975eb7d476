# dsmplan_module(NAME SOURCES ... [PUBLIC deps ...] [PRIVATE deps ...]): one stage of the pipeline
# as its own static library dsmplan_NAME. Its public headers are the folder's include/dsmplan/
# (installed together as <prefix>/include/dsmplan); only the modules it links see them, so a
# header of a stage it does not depend on fails to build. `src/` is a private include path for
# the shared internals (core/text.hpp, core/atomic_file.hpp, ...).
function(dsmplan_module name)
  cmake_parse_arguments(M "" "" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  set(target dsmplan_${name})
  add_library(${target} STATIC ${M_SOURCES})
  target_include_directories(${target}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${PROJECT_SOURCE_DIR}/src)
  target_link_libraries(${target} PUBLIC ${M_PUBLIC} PRIVATE ${M_PRIVATE})
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  install(DIRECTORY include/dsmplan DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  set_property(GLOBAL APPEND PROPERTY DSMPLAN_MODULES ${target})
endfunction()
