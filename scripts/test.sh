#!/usr/bin/env bash
# The tests: installs what is missing, builds, runs every unit and end-to-end test with CTest
# (Vulkan validation layers on: any validation error fails the test that caused it).
#
#   scripts/test.sh [CTEST ARGS...]              build/, Release
#   scripts/test.sh --sanitize [CTEST ARGS...]   build-asan/, AddressSanitizer and
#                                                UndefinedBehaviorSanitizer (.ci/run runs both)
#
# --sanitize builds everything of ours (harness, plugins, tests, bench) with
# -fsanitize=address,undefined -fno-sanitize-recover=undefined, so any memory error or undefined
# behaviour fails the test that hit it. Mesa (lavapipe), Embree, TBB and the other Debian libraries
# are not instrumented; what they do wrong is not ours to fix, and scripts/sanitizers/ lists the few
# reports of theirs that are suppressed, each with its reason.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
bash scripts/setup.sh
if [[ "${1:-}" == "--sanitize" ]]; then
  shift
  source scripts/sanitizers/env.bash
  flags="-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer -g"
  # -O1, as AddressSanitizer's documentation advises (and a third less compile time than Release on
  # 2 cores); no bench programs (they are not tests).
  # Every executable links the lavapipe driver, so that it stays mapped after the Vulkan loader
  # closes it in vkDestroyInstance: LeakSanitizer then sees the memory the driver's static data
  # still points to (scripts/sanitizers/env.bash) and reports only real leaks.
  lavapipe=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' /usr/share/vulkan/icd.d/lvp_icd.*.json | head -1)
  [[ -f "$lavapipe" ]] || { echo "test.sh: the lavapipe driver (mesa-vulkan-drivers) is not installed" >&2; exit 1; }
  cmake -S . -B build-asan -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g -DNDEBUG" -DPB_BUILD_BENCH=OFF -DCMAKE_CXX_FLAGS="$flags" \
    -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=address,undefined -Wl,--no-as-needed $lavapipe -Wl,--as-needed" \
    -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address,undefined" > build-asan.log 2>&1 ||
    { cat build-asan.log; exit 1; }
  cmake --build build-asan -j "$(nproc)"
  cd build-asan
  # Left out under the sanitizers: the tests that run no C++ of ours (the report tools' Python
  # unit tests; the HTML report in Chromium, whose `photonbench report` only execs Python) and the
  # convergence studies, which render the passes the shorter technique tests render, at several
  # photon counts, and take about 90 s each unsanitized; and the reference renderer's statistical
  # studies over every shipped scene and 60 area-light configurations, whose code the shorter
  # reference, bidirectional and area-light tests run too (30-56 s each under the sanitizers); and
  # AAPS's energy study (four msaa modes, 8 scored frames at 256x192 and their references: 65 s
  # unsanitized), whose passes the shorter AAPS tests run at 128x96 (none and all_per_sample).
  set -- -E '^(e2e[.]report_unit|e2e[.]report_html|Techniques/Paper1Convergence[.].*|ShippedScenes/EstimatorsAgree[.].*|AreaLight[.]DirectLightFromAQuadMatchesTheClosedFormWithinOnePercent|Aaps[.]ScreenEnergyMatchesTheCausticsReference)$' "$@"
else
  bash scripts/build.sh
  cd build
fi
ctest --output-on-failure -j 2 --timeout 900 "$@"
