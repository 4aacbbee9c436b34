#!/usr/bin/env bash
# The tests: installs what is missing, builds, runs every unit and end-to-end test with CTest
# (Vulkan validation layers on: any validation error fails the test that caused it).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
cd build
ctest --output-on-failure -j 2 --timeout 900 "$@"
