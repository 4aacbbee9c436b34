# Precompiled third-party headers, built once and shared (target_precompile_headers REUSE_FROM).
#
# Why: measured per translation unit (.ninja_log, gcc -ftime-report), most of the harness's compile
# time was spent parsing the same few headers again in every file: Vulkan-Hpp's vulkan_raii.hpp
# (4.2 s alone; every file that reaches photonbench/gpu.h, which plan/plan.h does), nlohmann/json
# (1.8 s, and more to instantiate its parser), yaml-cpp, fmt, the standard library. A run/ file
# spent 40-60% of its compile in the parser.
#
# GCC uses a precompiled header only when it was made with the same code-model flags as the file
# that includes it (-fPIC against -fPIE is refused; -Winvalid-pch, which CMake adds, says so) and
# when every macro defined at its making is defined alike at its use. So the libraries and plugins
# (position-independent code, no definitions of their own that these headers read) share one,
# made by `pb_precompiled_pic`, an object library of one empty file; the one test program makes its
# own with GoogleTest added (tests/CMakeLists.txt). The executables (the command line in two unity
# files, the bench programs) have none: a third header would cost as much to make as it saves them.
#
# Clang also refuses a precompiled header made with another default visibility (-fvisibility,
# -fvisibility-inlines-hidden: "differs in PCH file vs. current file"), which GCC accepts. Under
# Clang (the sanitized build, scripts/test.sh --sanitize) the hidden-visibility targets (the toolkit
# and the plugins) share a second one, `pb_precompiled_hidden`.
#
# -DPB_PRECOMPILE_HEADERS=OFF builds without them (each file then has to include what it uses, which
# the CI's build with them does not check: build once without before adding an include-heavy file).
option(PB_PRECOMPILE_HEADERS "precompile the heavy third-party headers once, shared by all targets" ON)

set(PB_PRECOMPILED_HEADERS
  <vulkan/vulkan_raii.hpp> <nlohmann/json.hpp> <yaml-cpp/yaml.h> <fmt/format.h> <glm/glm.hpp>
  <algorithm> <array> <chrono> <cmath> <cstdint> <filesystem> <fstream> <functional> <map>
  <memory> <optional> <set> <span> <sstream> <string> <string_view> <unordered_map> <variant>
  <vector>)

if(PB_PRECOMPILE_HEADERS)
  set(pb_precompiled_source ${CMAKE_BINARY_DIR}/generated/precompiled_holder.cpp)
  file(WRITE ${pb_precompiled_source} "// the holder of the shared precompiled headers\n")
  # A holder: an object library of the empty file that makes the headers with PROPERTIES (besides
  # position independence). FMT_SHARED comes with fmt::fmt (every target of ours has it); the
  # include paths are the system's, so the holder links nothing else.
  function(pb_add_precompiled_holder name)
    add_library(${name} OBJECT ${pb_precompiled_source})
    set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON ${ARGN})
    target_link_libraries(${name} PRIVATE fmt::fmt)
    target_precompile_headers(${name} PRIVATE ${PB_PRECOMPILED_HEADERS})
  endfunction()
  pb_add_precompiled_holder(pb_precompiled_pic)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    pb_add_precompiled_holder(pb_precompiled_hidden CXX_VISIBILITY_PRESET hidden
                              VISIBILITY_INLINES_HIDDEN ON)
  endif()
endif()

# pb_use_precompiled_headers(TARGET...): each (a library or plugin) includes the shared headers
# first; call it after the target's visibility is set.
function(pb_use_precompiled_headers)
  if(NOT PB_PRECOMPILE_HEADERS)
    return()
  endif()
  foreach(target IN LISTS ARGN)
    get_target_property(visibility ${target} CXX_VISIBILITY_PRESET)
    if(TARGET pb_precompiled_hidden AND visibility STREQUAL "hidden")
      get_target_property(inlines ${target} VISIBILITY_INLINES_HIDDEN)
      if(NOT inlines)
        message(FATAL_ERROR "${target}: hidden visibility without VISIBILITY_INLINES_HIDDEN has no "
                            "precompiled header under Clang; set both")
      endif()
      target_precompile_headers(${target} REUSE_FROM pb_precompiled_hidden)
    else()
      target_precompile_headers(${target} REUSE_FROM pb_precompiled_pic)
    endif()
  endforeach()
endfunction()
