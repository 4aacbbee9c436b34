# photonbench_add_technique(NAME name SOURCES ... [SHADERS ...]
#                           [TESTS ...] [LABELS label pattern... [label pattern...]] [LIBS ...])
# A technique is a shared module loaded at run time. It links the public API library
# (photonbench::core) and the photon-technique toolkit (photonbench::toolkit, a static library:
# harness/toolkit/README.md) and embeds its shaders (pb_embed_shaders: the generated header
# <name>_shaders.h), so it is one file, plugins/<name>.so, that `cmake --install` puts with the
# installed plugins. The same function builds the in-tree techniques and, through the installed
# package (find_package(photonbench)), techniques in other repositories.
#
# The rest registers the technique's tests with the in-tree test program (tests/CMakeLists.txt), so
# that a technique's folder is the one place that lists them:
#   TESTS   its GoogleTest files (tests/<name>_test.cpp), compiled into build/tests/photonbench_tests
#   LABELS  a label (slow or statistical) followed by the GoogleTest filter patterns (Suite.Name,
#           * and ?) of the tests it labels, e.g. `LABELS slow "Tiled.*"`; every other test of the
#           program is a unit test (tests/CMakeLists.txt says what each label promises)
#   LIBS    libraries of the technique's own, linked into the plugin and into the test program (a
#           kernel library that the tests drive as the plugin does)
# Out of tree there is no such program: TESTS and LABELS are kept in global properties that nothing
# reads.
function(photonbench_add_technique)
  cmake_parse_arguments(ARG "" "NAME" "SOURCES;SHADERS;TESTS;LABELS;LIBS" ${ARGN})
  if(NOT ARG_NAME OR NOT ARG_SOURCES)
    message(FATAL_ERROR "photonbench_add_technique: NAME and SOURCES are required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "photonbench_add_technique(${ARG_NAME}): unknown arguments "
                        "'${ARG_UNPARSED_ARGUMENTS}' (keywords: NAME SOURCES SHADERS TESTS LABELS LIBS)")
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
  target_link_libraries(${target} PRIVATE photonbench::core photonbench::toolkit ${ARG_LIBS})
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

  foreach(test_file IN LISTS ARG_TESTS)
    get_filename_component(test_file ${test_file} ABSOLUTE BASE_DIR ${CMAKE_CURRENT_SOURCE_DIR})
    set_property(GLOBAL APPEND PROPERTY PB_TECHNIQUE_TESTS ${test_file})
  endforeach()
  set_property(GLOBAL APPEND PROPERTY PB_TECHNIQUE_TEST_LIBS ${ARG_LIBS})
  set(label "")
  foreach(word IN LISTS ARG_LABELS)
    if(word STREQUAL "slow" OR word STREQUAL "statistical")
      set(label ${word})
    elseif(NOT label)
      message(FATAL_ERROR "photonbench_add_technique(${ARG_NAME}): LABELS starts with '${word}'; "
                          "it takes a label (slow or statistical) before its test patterns")
    else()
      set_property(GLOBAL APPEND PROPERTY PB_TECHNIQUE_TESTS_${label} ${word})
    endif()
  endforeach()
endfunction()
