# photonbench_add_technique(NAME name SOURCES ... [SHADERS ...])
# A technique is a shared module loaded at run time. It links the public API library
# (photonbench::core) and the photon-technique toolkit (photonbench::toolkit, a static library:
# harness/toolkit/README.md) and embeds its shaders (pb_embed_shaders: the generated header
# <name>_shaders.h), so it is one file, plugins/<name>.so, that `cmake --install` puts with the
# installed plugins. The same function builds the in-tree techniques and, through the installed
# package (find_package(photonbench)), techniques in other repositories.
function(photonbench_add_technique)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;SHADERS" ${ARGN})
  if(NOT ARG_NAME OR NOT ARG_SOURCES)
    message(FATAL_ERROR "photonbench_add_technique: NAME and SOURCES are required")
  endif()
  set(target technique_${ARG_NAME})
  # In tree the build's plugin folder (beside the executable); out of tree the project's plugins/.
  set(plugin_dir ${CMAKE_BINARY_DIR}/plugins)
  if(DEFINED PB_PLUGIN_DIR)
    set(plugin_dir ${PB_PLUGIN_DIR})
  endif()
  add_library(${target} MODULE ${ARG_SOURCES})
  set_target_properties(${target} PROPERTIES
    OUTPUT_NAME ${ARG_NAME} PREFIX "" LIBRARY_OUTPUT_DIRECTORY ${plugin_dir}
    CXX_VISIBILITY_PRESET hidden VISIBILITY_INLINES_HIDDEN ON
    # Installed as <prefix>/lib/photonbench/plugins/<name>.so, beside <prefix>/lib/libphotonbench.so.
    INSTALL_RPATH "$ORIGIN/../..")
  target_link_libraries(${target} PRIVATE photonbench::core photonbench::toolkit)
  if(ARG_SHADERS)
    pb_embed_shaders(TARGET ${target} HEADER ${ARG_NAME}_shaders.h SHADERS ${ARG_SHADERS})
  endif()
  if(COMMAND pb_use_precompiled_headers)  # in tree: the shared precompiled headers
    pb_use_precompiled_headers(${target})
  endif()
  if(TARGET photonbench)  # in tree: building the executable builds its plugins
    add_dependencies(photonbench ${target})
  endif()
  include(GNUInstallDirs)
  install(TARGETS ${target} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/photonbench/plugins)
endfunction()
