# Ctrl-C (SIGINT to the run's process group) or SIGTERM (to the run alone) stops a run cleanly: the
# running cell is not recorded as failed and leaves no partial folder, summary.csv lists the cells
# not run, run.json says interrupted, the lock is gone, and the printed command resumes the run
# from the recorded invocation (config and --set) with nothing retyped.
source "$(dirname "$0")/lib.bash"
cfg="$WORK/interrupt.yaml"
cat > "$cfg" <<YAML
name: interrupt
plugin_dirs: [$TEST_PLUGINS]
resolution: [48, 27]
scenes: [cornell-box]
frames: {warmup: 0, count: 4, metrics_every: 0}
techniques:
  - {technique: direct, params: {shadow_map_size: [64, 256]}}
  - {technique: sleeps, params: {sleep_ms: 250}}
YAML
# start_run DIR: the run in its own process group (as a shell job is), until one cell is complete
# and the next has started.
start_run() {
  setsid "$PB" run "$cfg" --out "$1" --set frames.count=6 > "$1.log" 2>&1 &
  leader=$!
  for _ in $(seq 1 600); do
    [ "$(ls "$1"/cells/*/cell.json 2>/dev/null | wc -l)" -ge 1 ] &&
      ls -d "$1"/cells/.partial-* > /dev/null 2>&1 && break
    sleep 0.1
  done
}
# stopped_cleanly DIR SIGNAL CODE: what a clean stop leaves.
stopped_cleanly() {
  wait "$leader"
  local code=$?
  local log
  log=$(cat "$1.log")
  [ "$code" -eq "$3" ] && pass "$2: exit $code" || fail "$2: exit $code, expected $3; log: $log"
  expect_match "$2: says it was interrupted" "interrupted \($2\)" "$log"
  expect_match "$2: prints the resume command" "^  .*photonbench run --resume --out $1( --validation)?$" "$log"
  expect_no_match "$2: the stopped cell is not recorded failed" "FAILED" "$log"
  [ ! -e "$1/.lock" ] && pass "$2: no .lock left" || fail "$2: .lock left"
  [ -z "$(ls -d "$1"/cells/.partial-* 2>/dev/null)" ] && pass "$2: no partial folder left" ||
    fail "$2: partial folder left"
  expect_match "$2: summary.csv lists the cells not run" "^[1-2]$" \
    "$(grep -c ',not_run,' "$1/summary.csv")"
  expect_match "$2: summary.csv has a row per planned cell" "^3$" "$(($(wc -l < "$1/summary.csv") - 1))"
  expect_match "$2: run.json says interrupted" "'signal': '$2'" "$(json_field "$1/run.json" interrupted)"
}

run="$WORK/run"
start_run "$run"
kill -INT -- -"$leader"
stopped_cleanly "$run" SIGINT 130

expect_exit 0 "the interrupted run's report is written" -- "$PB" report "$run"
expect_match "the report says the run is incomplete and how to resume it" \
  "Incomplete: the run was interrupted \(SIGINT" "$(cat "$run/report/index.html")"

resume=$(grep -E '^  .*photonbench run --resume --out' "$run.log" | sed 's/^  //')
expect_exit 0 "the printed command alone resumes the run" -- $resume
expect_match "complete cells are skipped" "complete already, skipped" "$OUT"
expect_match "summary has 3 ok rows" "^3$" "$(grep -c ',ok,' "$run/summary.csv")"
expect_match "the recorded --set was reused (6 frames measured)" "^6$" \
  "$(json_field "$(ls "$run"/cells/*/cell.json | head -1)" frames_measured)"
[ ! -e "$run/.lock" ] && pass "no .lock after the resumed run" || fail ".lock left after the resumed run"
expect_exit 2 "--resume alone with --set is refused" -- "$PB" run --resume --out "$run" --set seed=2
expect_match "saying why" "reuses the recorded --set" "$OUT"
expect_exit 2 "run without a config or --resume is refused" -- "$PB" run --out "$run"

term="$WORK/term"
start_run "$term"
kill -TERM "$leader"
stopped_cleanly "$term" SIGTERM 143
finish
