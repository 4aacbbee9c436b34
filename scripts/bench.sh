#!/usr/bin/env bash
# The default benchmark: installs what is missing, builds, runs configs/quick.yaml (a few minutes on
# 2 cores) and writes the report. Extra arguments go to `photonbench run` (e.g. --set frames.count=8).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh
out="results/quick-$(date +%Y%m%d-%H%M%S)"
status=0
./build/photonbench run configs/quick.yaml --out "$out" "$@" || status=$?
./build/photonbench report "$out" || true
echo "summary: $out/summary.csv   report: $out/report/index.html"
exit $status
