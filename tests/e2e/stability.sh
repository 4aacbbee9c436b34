# `photonbench stability` on a tiny suite: the generated run, every class and its reason in
# stability.csv, a technique and a scenario that wait for a plugin (skipped), the matrix in the
# report, and bad stability files refused with file:line:col and key (exit 2).
source "$(dirname "$0")/lib.bash"
suite="$WORK/suite.yaml"
write_suite() {  # the tiny suite
  cat > "$suite" <<YAML
name: tiny-stress
resolution: [32, 18]
frames: {warmup: 0, count: 2, metrics_every: 2}
reference: {samples: 4}
limits: {cell_seconds: 120}
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: direct
  - technique: nan_output
    params: {nan_frame: 1}
  - technique: crash_on_frame
    params: {crash_frame: 1}
  - {technique: not-landed-yet, when_built: true}
stability:
  degraded_factor: 2
  no_gi_technique: direct
  baseline: cornell-box
scenarios:
  - {name: as-baseline, aims_at: the baseline itself, scene: cornell-box}
  - {name: light-inside, aims_at: a light inside a box, scene: $SRC/scenes/stress/light-inside.yaml}
  - {name: waits, aims_at: a technique not built yet, needs: [not-landed-yet], scene: cornell-box}
YAML
}
write_suite
out="$WORK/out"
expect_exit 0 "stability runs the suite (failed cells are results)" -- "$PB" stability "$suite" --out "$out"
expect_match "the matrix is printed" "^light-inside +ok|^light-inside +degraded|^light-inside +unrated" "$OUT"
[ -f "$out/benchmark.yaml" ] && pass "the generated benchmark config is kept" || fail "no benchmark.yaml"
[ -f "$out/summary.csv" ] && pass "the run's summary is written" || fail "no summary.csv"
csv="$out/stability.csv"
row() {  # row SCENARIO TECHNIQUE: "class|reason|ratio" of that row
  /usr/bin/python3 - "$csv" "$1" "$2" <<'PY'
import csv, sys
for r in csv.DictReader(open(sys.argv[1])):
    if r["scenario"] == sys.argv[2] and r["technique"] == sys.argv[3]:
        print(f'{r["class"]}|{r["reason"]}|{r["ratio"]}')
PY
}
expect_match "direct on its baseline: ok" "^ok\|FLIP [0-9.e-]+\|$" "$(row baseline direct)"
expect_match "direct on a scenario equal to the baseline: ok at 1x" "^ok\|.*= 1.00x.*\|1$" "$(row as-baseline direct)"
expect_match "a NaN output fails its cell, with the reason" "^failed\|.*NaN or Inf" "$(row as-baseline nan_output)"
expect_match "a crash fails its cell, with the signal" "^failed\|.*(SIGSEGV|signal)" "$(row light-inside crash_on_frame)"
expect_match "a technique failing on its baseline too: failed" "^failed" "$(row baseline crash_on_frame)"
expect_match "a scenario waiting for a technique is skipped" "^skipped\|needs technique 'not-landed-yet', not built" "$(row waits direct)"
expect_match "a technique not built is skipped" "^skipped\|technique not built" "$(row light-inside not-landed-yet)"
# Every rated row follows the rule: degraded iff FLIP >= 4 x its floor and > 2 x the baseline's or
# > 2 x direct's on the same scenario.
expect_exit 0 "ok and degraded rows follow the factor and floor rule" -- /usr/bin/python3 - "$csv" <<'PY'
import csv, sys
rows = list(csv.DictReader(open(sys.argv[1])))
direct = {r["scenario"]: float(r["flip"]) for r in rows if r["technique"] == "direct" and r["flip"]}
rated = 0
for r in rows:
    if r["class"] not in ("ok", "degraded") or not r["baseline_flip"]:
        continue
    flip, base, floor = float(r["flip"]), float(r["baseline_flip"]), float(r["flip_floor"] or 0)
    no_gi = direct[r["scenario"]] if r["technique"] != "direct" else float("inf")
    expect = "degraded" if flip >= 4 * floor and (flip > 2 * base or flip > 2 * no_gi) else "ok"
    if r["class"] != expect:
        sys.exit(f"{r['scenario']} x {r['technique']}: {r['class']}, the rule says {expect}")
    rated += 1
sys.exit(0 if rated >= 2 else f"only {rated} rated rows")
PY

expect_exit 0 "the report shows the robustness matrix" -- "$PB" report "$out"
[ -f "$out/report/figures/robustness.svg" ] && pass "robustness figure written" || fail "no robustness.svg"
expect_match "the page has the section and the failures' reasons" "NaN or Inf" "$(grep -A200 'id="robustness"' "$out/report/index.html")"

expect_exit 2 "a second stability run into the same folder is refused" -- "$PB" stability "$suite" --out "$out"
# Bad stability files: exit 2, the file, line and key. rejected NAME SED_EDIT REGEX: the tiny suite
# edited by SED_EDIT is refused, with REGEX in the message.
rejected() {
  write_suite
  sed -i "$2" "$suite"
  expect_exit 2 "$1" -- "$PB" stability "$suite" --out "$WORK/bad"
  expect_match "  ... $1: the message" "$3" "$OUT"
}
rejected "scenes instead of scenarios" '$a scenes: [cornell-box]' "suite.yaml:[0-9]+:[0-9]+: scenes: .*scenarios"
rejected "a misspelt rule" 's/degraded_factor: 2/degraded_factr: 2/' \
  "suite.yaml:[0-9]+:[0-9]+: stability.*degraded_factor"
rejected "a scenario named twice" 's/name: light-inside,/name: as-baseline,/' \
  "suite.yaml:[0-9]+:[0-9]+: scenarios\[1\].name: .*named twice"
rejected "a no-GI technique not in the suite" 's/no_gi_technique: direct/no_gi_technique: drect/' \
  "suite.yaml:[0-9]+:[0-9]+: stability.no_gi_technique: 'drect' is not one of"
rejected "a suite without metric frames" 's/metrics_every: 2/metrics_every: 0/' "metrics_every is 0"
rejected "a scenario naming a missing scene" 's|scene: cornell-box}|scene: no-such-scene}|' \
  "suite.yaml:[0-9]+:[0-9]+: scenarios\[0\].scene"

# --technique: one technique of the suite, with the no-GI one; a scenario parameter that only a
# technique left out has (crash_on_frame's crash_frame) is dropped, not refused.
write_suite
sed -i 's|{name: as-baseline, aims_at: the baseline itself, scene: cornell-box}|{name: as-baseline, aims_at: the baseline itself, scene: {scene: cornell-box, params: {crash_frame: 1}}}|' "$suite"
chosen="$WORK/chosen"
expect_exit 0 "--technique runs one technique of the suite" -- \
  "$PB" stability "$suite" --out "$chosen" --technique nan_output
techniques=$(/usr/bin/python3 -c 'import csv,sys; print(" ".join(sorted({r["technique"] for r in csv.DictReader(open(sys.argv[1]))})))' "$chosen/stability.csv")
expect_match "... only it and the no-GI technique have rows (a waiting one is still named)" \
  "^direct nan_output not-landed-yet$" "$techniques"
grep -q crash_frame "$chosen/benchmark.yaml" && fail "the left-out technique's parameter is kept" ||
  pass "the left-out technique's parameter is dropped"
expect_exit 2 "--technique naming no technique of the suite" -- \
  "$PB" stability "$suite" --out "$WORK/none" --technique tiledd
expect_match "  ... the message names it and the suite's techniques" \
  "--technique tiledd: not one of the suite's techniques \(direct, nan_output, crash_on_frame" "$OUT"
finish
