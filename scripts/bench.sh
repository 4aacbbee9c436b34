#!/usr/bin/env bash
# The default benchmark: installs what the main job needs (scripts/setup.sh, no test packages),
# builds photonbench and its plugins (not the tests or bench programs), runs configs/quick.yaml and
# writes the report. Extra arguments go to `photonbench run` (e.g. --set frames.count=8).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
bash scripts/build.sh --main
out="results/quick-$(date +%Y%m%d-%H%M%S)"
status=0
./build/photonbench run configs/quick.yaml --out "$out" "$@" || status=$?
./build/photonbench report "$out" || true
echo "summary: $out/summary.csv   report: $out/report/index.html"
exit $status
