# MANUAL, not run by CTest: on a shared 2-core machine run-to-run spread (25-35 %) exceeds the
# 25 % slowdown it must detect, so it is flaky (see the session note on issue 6). Run it by hand:
#   bash tests/manual/compare_real.sh build/photonbench .
# `photonbench compare` on real runs (the unit tests use synthetic fixtures): two runs of the same build
# (A/A) are not a regression; a run with one pass made 25% slower by the test-only delay injection
# (testing.slow_pass / testing.slow_factor, harness/src/run/cell_runner.cpp) is, and the table names it.
# Known limit (measured with tools/aa_check.sh): with another build or test job on the 2 cores, two
# back-to-back runs' pass medians differ by up to 2-3x in wall time, so this test then fails on the A/A or
# the SLOW verdict; that is the measurement's between-run drift, not this script. PB_COMPARE_FRAMES sets
# the frame count (more frames do not help: the drift is between runs, not between frames).
source "$(dirname "$0")/../e2e/lib.bash"
cfg="$WORK/compare.yaml"
# Small enough for ~2 s a run on lavapipe, with enough measured frames per pass for the Mann-Whitney U
# test (>= 5 a side; more narrow the noise estimate). No metric frames: no references to render.
cat > "$cfg" <<YAML
name: compare-real
resolution: [160, 90]
frames: {warmup: 2, count: ${PB_COMPARE_FRAMES:-24}, metrics_every: 0}
seed: 1
scenes: [cornell-box]
techniques:
  - technique: direct
YAML
# Timings of a perf run are taken without validation layers (ctest sets PB_VALIDATION for correctness).
run() { env -u PB_VALIDATION "$PB" run "$cfg" --out "$@"; }
slow=(--set testing.slow_pass=gbuffer --set testing.slow_factor=1.25)

expect_exit 0 "run A" -- run "$WORK/A"
expect_exit 0 "run A2 (same build, same config)" -- run "$WORK/A2"
expect_exit 0 "run SLOW (gbuffer x1.25)" -- run "$WORK/SLOW" "${slow[@]}"
expect_match "SLOW records the testing hook in run.json" "testing.slow_pass=gbuffer" "$(cat "$WORK/SLOW/run.json")"

# A run against itself: identical samples, every pass tested and unchanged (deterministic).
expect_exit 0 "compare A A" -- "$PB" compare "$WORK/A" "$WORK/A" --json "$WORK/self.json"
expect_match "A vs A: every pass the same" "^ok$" "$(/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
rows = d["passes"]
names = {r["pass_name"] for r in rows}
need = {"frame", "gbuffer", "direct-light", "shade"}
print("ok" if rows and need <= names and all(r["verdict"] == "same" for r in rows) and d["regressions"] == 0
      else "bad: %s" % [(r["pass_name"], r["verdict"]) for r in rows])' "$WORK/self.json")"

# A/A: two real runs of the same build.
expect_exit 0 "compare A A2: no regression" -- "$PB" compare "$WORK/A" "$WORK/A2"
expect_match "A/A verdict" "no significant regression" "$OUT"

# One pass 25% slower: a regression, and the table's Slower section names that pass.
expect_exit 1 "compare A SLOW: regression" -- "$PB" compare "$WORK/A" "$WORK/SLOW" --json "$WORK/slow.json"
expect_match "SLOW verdict" "\*\*REGRESSION\*\*" "$OUT"
expect_match "the table warns that SLOW was made with a testing hook" \
  'Testing hooks\*\* in the new run.*testing\.slow_pass=gbuffer' "$OUT"
expect_match "the Slower table names gbuffer" '^\| [^|]+ \| `gbuffer` \|.*\*\*SLOWER\*\*' \
  "$(printf '%s\n' "$OUT" | awk '/^### Slower/ {on = 1; next} /^(###|<details>)/ {on = 0} on')"
expect_match "gbuffer's change is about the injected 25% or more" "^ok" "$(/usr/bin/python3 -c '
import json, sys
rows = [r for r in json.load(open(sys.argv[1]))["passes"] if r["pass_name"] == "gbuffer"]
print("ok" if rows and rows[0]["verdict"] == "slower" and rows[0]["change_pct"] > 15 else "bad: %s" % rows)' \
  "$WORK/slow.json")"
finish
