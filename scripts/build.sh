#!/usr/bin/env bash
# Configures and builds photonbench into build/ (Release, Ninja). Safe to re-run: it only rebuilds
# what changed.
#
#   scripts/build.sh          everything: photonbench, the plugins, the tests, the bench programs
#   scripts/build.sh --main   what the main job runs: photonbench and the plugins (scripts/bench.sh)
#
# Both share build/, so a later full build reuses what --main compiled.
set -euo pipefail
cd "$(dirname "$0")/.."
case "${1:-}" in
  --main) options=(-DBUILD_TESTING=OFF -DPB_BUILD_BENCH=OFF) ;;
  "") options=(-DBUILD_TESTING=ON -DPB_BUILD_BENCH=ON) ;;
  *) echo "usage: scripts/build.sh [--main]" >&2; exit 2 ;;
esac
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release "${options[@]}" > build.log 2>&1 ||
  { cat build.log; exit 1; }
cmake --build build -j "$(nproc)"
