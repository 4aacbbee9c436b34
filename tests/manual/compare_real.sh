# MANUAL, not run by CTest: timings on a shared machine are not deterministic, so neither is this
# test's outcome (tools/aa_check.sh measures how often compare is right there). Run it by hand:
#   bash tests/manual/compare_real.sh build/photonbench .
# `photonbench compare` on real runs (the unit tests use synthetic fixtures): two folders of replicate
# runs of the same build (A/A) are not a regression; runs with one pass made 25% slower by the
# test-only delay injection (testing.slow_pass / testing.slow_factor, harness/src/cell/profiler.h) are,
# and the table names it. Replicates (PB_COMPARE_RUNS, default 8 per side) are interleaved in time, as
# compare's docstring asks; on lavapipe compare reads process CPU time (frames.csv process_cpu_ms).
# PB_COMPARE_FRAMES sets the frame count.
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

for j in $(seq 1 "${PB_COMPARE_RUNS:-8}"); do
  expect_exit 0 "run A/$j" -- run "$WORK/A/$j"
  expect_exit 0 "run A2/$j (same build, same config)" -- run "$WORK/A2/$j"
  expect_exit 0 "run SLOW/$j (gbuffer x1.25)" -- run "$WORK/SLOW/$j" "${slow[@]}"
done
expect_match "SLOW records the testing hook in run.json" "testing.slow_pass=gbuffer" "$(cat "$WORK/SLOW/1/run.json")"
expect_match "frames.csv has the process CPU time column" "^frame,pass,gpu_ms,cpu_ms,process_cpu_ms$" \
  "$(head -1 "$WORK"/A/1/cells/*/frames.csv)"

# A set against itself: identical samples, every pass tested and unchanged (deterministic).
expect_exit 0 "compare A A" -- "$PB" compare "$WORK/A" "$WORK/A" --json "$WORK/self.json"
expect_match "A vs A: every pass the same" "^ok$" "$(/usr/bin/python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
rows = d["passes"]
names = {r["pass_name"] for r in rows}
need = {"frame", "gbuffer", "direct-light", "shade"}
print("ok" if rows and need <= names and all(r["verdict"] == "same" for r in rows) and d["regressions"] == 0
      and {r["clock"] for r in rows} == {"process"}
      else "bad: %s" % [(r["pass_name"], r["verdict"], r["clock"]) for r in rows])' "$WORK/self.json")"

# A/A: two sets of real runs of the same build.
expect_exit 0 "compare A A2: no regression" -- "$PB" compare "$WORK/A" "$WORK/A2"
expect_match "A/A verdict" "no significant regression" "$OUT"

# One pass 25% slower (in process CPU time, what compare reads): a regression, and the table's
# Slower section names that pass.
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
