# Killing a run midway and running again with --resume finishes without redoing complete cells.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/resume.yaml"
cat > "$cfg" <<YAML
name: resume
resolution: [64, 36]
frames: {warmup: 1, count: 6, metrics_every: 0}
scenes: [cornell-box]
plugin_dirs: [$TEST_PLUGINS]
techniques:
  - technique: direct
    params: {shadow_map_size: [64, 128]}
  - technique: sleeps
    params: {sleep_ms: 300}
YAML
run="$WORK/run"
setsid "$PB" run "$cfg" --out "$run" > "$WORK/first.log" 2>&1 &
leader=$!
# Wait until the two direct cells are complete and the slow cell has started, then kill everything.
for _ in $(seq 1 600); do
  done_cells=$(ls "$run"/cells/*/cell.json 2>/dev/null | wc -l)
  [ "$done_cells" -ge 2 ] && ls -d "$run"/cells/.partial-* >/dev/null 2>&1 && break
  sleep 0.1
done
kill -9 -- -"$leader" 2>/dev/null
wait "$leader" 2>/dev/null
complete_before=$(ls "$run"/cells/*/cell.json | wc -l)
[ "$complete_before" -eq 2 ] && pass "killed with 2 of 3 cells complete" || fail "killed with $complete_before cells complete"
stamps_before=$(stat -c '%n %Y %i' "$run"/cells/*/cell.json)

expect_exit 2 "--resume with another config is refused" -- "$PB" run "$cfg" --out "$run" --resume --set seed=7
expect_exit 0 "--resume finishes the run" -- "$PB" run "$cfg" --out "$run" --resume
expect_match "complete cells are skipped" "complete already, skipped.*" "$OUT"
[ "$(printf '%s' "$OUT" | grep -c 'complete already, skipped')" -eq 2 ] && pass "exactly two cells skipped" || fail "skip count: $OUT"
stamps_after=$(stat -c '%n %Y %i' $(echo "$stamps_before" | cut -d' ' -f1))
[ "$stamps_before" = "$stamps_after" ] && pass "complete cells untouched" || fail "complete cells were rewritten"
[ "$(ls "$run"/cells/*/cell.json | wc -l)" -eq 3 ] && pass "all 3 cells complete" || fail "cells after resume"
[ -z "$(ls -d "$run"/cells/.partial-* 2>/dev/null)" ] && pass "no partial folder left" || fail "partial folder left"
expect_match "summary has 3 ok rows" "^3$" "$(grep -c ',ok,' "$run/summary.csv")"
finish
