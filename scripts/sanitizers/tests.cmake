# The sanitized pass's test configuration, loaded with `cmake -C` by scripts/test.sh --sanitize and
# by select_by_coverage.py, whose coverage build must hold the same tests under the same names and
# run them as the pass does. Compiler and sanitizer flags are each script's own.
#
# The test program at -O0: its files are assertions around calls into the library; its largest
# unity file took 60 CPU-s at -O1, 33 at -O0 even without its precompiled header.
set(PB_TEST_COMPILE_OPTIONS -O0 CACHE STRING "" FORCE)
# No bench programs: they are not tests.
set(PB_BUILD_BENCH OFF CACHE BOOL "" FORCE)
# The unit tests one process per GoogleTest suite (tests/CMakeLists.txt): a sanitized process takes
# about half a second to start.
set(PB_UNIT_TEST_PROCESS suite CACHE STRING "" FORCE)
set(PB_IMAGE_CODEC_MODULE ON CACHE BOOL "" FORCE)
# No Vulkan validation layers: every test of this pass runs in the Release pass too, whose layers
# check the same Vulkan calls; the sanitizers instrument our code, not the layers.
set(PB_TEST_VALIDATION OFF CACHE BOOL "" FORCE)
