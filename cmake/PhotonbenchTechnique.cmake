# pb_add_technique(NAME name SOURCES ... [SHADERS ...])
# A technique is a shared module loaded at run time from the build's plugin directory. It links the
# public API library (photonbench::core) and the photon-technique toolkit (photonbench::toolkit, a
# static library: harness/toolkit/README.md) and embeds its shaders, so it is one file in
# build/plugins/.
function(pb_add_technique)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;SHADERS" ${ARGN})
  set(target technique_${ARG_NAME})
  add_library(${target} MODULE ${ARG_SOURCES})
  set_target_properties(${target} PROPERTIES
    OUTPUT_NAME ${ARG_NAME} PREFIX "" LIBRARY_OUTPUT_DIRECTORY ${PB_PLUGIN_DIR}
    CXX_VISIBILITY_PRESET hidden)
  target_link_libraries(${target} PRIVATE photonbench::core photonbench::toolkit)
  if(ARG_SHADERS)
    pb_embed_shaders(TARGET ${target} HEADER ${ARG_NAME}_shaders.h SHADERS ${ARG_SHADERS})
  endif()
  add_dependencies(photonbench ${target})
endfunction()
