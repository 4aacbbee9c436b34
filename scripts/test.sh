#!/usr/bin/env bash
# The tests: installs what is missing (scripts/setup.sh --tests), builds, runs the unit and
# end-to-end tests with CTest (Vulkan validation layers on, except in the sanitized pass: any
# validation error fails the test that caused it). Extra arguments go to ctest, e.g. -L unit (a
# label: tests/CMakeLists.txt, README "Testing") or -R REGEX.
#
#   scripts/test.sh [CTEST ARGS...]              build/, Release: every test
#   scripts/test.sh --sanitize [CTEST ARGS...]   build-asan/, AddressSanitizer and
#                                                UndefinedBehaviorSanitizer (.ci/run runs both)
#
# --sanitize builds everything of ours (harness, plugins, tests) with
# -fsanitize=address,undefined -fno-sanitize-recover=undefined, so any memory error or undefined
# behaviour fails the test that hit it. Mesa (lavapipe), Embree, TBB and the other Debian libraries
# are not instrumented; what they do wrong is not ours to fix, and scripts/sanitizers/ lists the few
# reports of theirs that are suppressed, each with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
bash scripts/setup.sh --tests
if [[ "${1:-}" == "--sanitize" ]]; then
  shift
  source scripts/sanitizers/env.bash
  flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g1"
  # Clang (Debian's clang-14, which the fuzz targets use too), while the Release build is GCC's:
  # so two compilers check the code; Clang builds the sanitized tree in less than half GCC's time,
  # and its sanitized shared library carries an eighth of GCC's relocations, which every process
  # applies at its start (README "CI time and its phases": 82 thousand against 695 thousand).
  # -O1, as AddressSanitizer's documentation advises (and a third less compile time than Release on
  # 2 cores); -g1, line tables only: enough for the reports' file:line stack traces, without full
  # debug info of every header (the sanitized build's compile and link time). The test program's
  # options (-O0, no bench programs, a process per unit suite, no validation layers) are in
  # scripts/sanitizers/tests.cmake, with their reasons, shared with select_by_coverage.py.
  # Executables not position-independent (-no-pie): the sanitizers' metadata made the test program's
  # 1.36 million relative relocations, applied by the loader at every start of every test process.
  # UndefinedBehaviorSanitizer's vptr check stays on: without it (-fno-sanitize=vptr) the core
  # library's largest unity file compiled in 68.9 CPU-s instead of 80.0, but it is the check that
  # catches a member call or downcast on an object of the wrong dynamic type, which our plugin and
  # technique class hierarchies could do.
  # End-to-end scripts see the sanitized build (tests/e2e/lib.bash: SANITIZED) and may take a
  # smaller size where their checks do not depend on it (e2e.shard_merge's reference samples, with
  # the measurement in the script).
  # Every executable links the lavapipe driver, so that it stays mapped after the Vulkan loader
  # closes it in vkDestroyInstance: LeakSanitizer then sees the memory the driver's static data
  # still points to (scripts/sanitizers/env.bash) and reports only real leaks.
  lavapipe=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' /usr/share/vulkan/icd.d/lvp_icd.*.json | head -1)
  [[ -f "$lavapipe" ]] || { echo "test.sh: the lavapipe driver (mesa-vulkan-drivers) is not installed" >&2; exit 1; }
  cmake -S . -B build-asan -G Ninja -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -C scripts/sanitizers/tests.cmake -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
    -DCMAKE_CXX_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined -no-pie -Wl,--no-as-needed $lavapipe -Wl,--as-needed" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > build-asan.log 2>&1 ||
    { cat build-asan.log; exit 1; }
  cmake --build build-asan -j "$(nproc)"
  cd build-asan
  # Left out under the sanitizers, by label: `python`, the tests that run no C++ of ours (the report
  # tools' Python unit tests; the HTML report in Chromium, whose `photonbench report` only execs
  # Python), and `statistical`, the studies (convergence over photon counts, the estimators'
  # agreement on every shipped scene, 60 area-light configurations, AAPS's energy over four modes),
  # whose passes and code the unit and slow tests run too at one configuration each.
  # Also left out: the tests of scripts/sanitizers/covered_elsewhere.txt, each of whose executed
  # regions of our code a kept test executes too (measured with Clang's source-based coverage by
  # scripts/sanitizers/select_by_coverage.py, which says how and what that misses). A test not
  # in that file, any test added since, runs.
  covered_elsewhere=$(grep -v '^#' "$root/scripts/sanitizers/covered_elsewhere.txt" |
    sed 's/[][\\.*^$()+?{}|]/\\&/g' | paste -sd '|')
  set -- -LE 'statistical|python' ${covered_elsewhere:+-E "^($covered_elsewhere)\$"} "$@"
else
  bash scripts/build.sh
  cd build
fi
ctest --output-on-failure -j "$(nproc)" --timeout 900 "$@"
